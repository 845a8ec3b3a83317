//! Barometric altitude: the exact ISA troposphere formula and a cheap form.
//!
//! # Exact form
//!
//! The International Standard Atmosphere troposphere law (0–11 km, standard
//! lapse rate 6.5 K/km) gives the height above the level where the pressure
//! is `P0`:
//!
//! ```text
//! h_m  = 44330 · (1 − (P/P0)^(1/5.255))          altitude_m
//! P_pa = P0 · (1 − h/44330)^5.255                 pressure_pa
//! ```
//!
//! With `P0 = 101325 Pa` ([`SEA_LEVEL_PA`]) the height is the standard
//! pressure altitude; with `P0` = the pressure measured at take-off it is the
//! height above the take-off point (the `control` convention: "up", metres).
//! Both functions call `libm::powf` (hundreds of soft-float instructions on a
//! Cortex-M3), so use them for set-up, logging and tests, not per sample.
//!
//! # Cheap form: [`CheapBaro`]
//!
//! The height is a function of the pressure *ratio* `x = P/P0` only:
//! `h(x) = 44330 · (1 − x^0.190295)`. [`CheapBaro`] tabulates `h(x)` as 32
//! quadratic segments of width 0.0175 over `x ∈ [0.52, 1.08]` (a 384-byte
//! table in flash). Each segment interpolates `h` exactly at its two ends and
//! its midpoint, so the curve is continuous. Per call ([`CheapBaro::height_m`],
//! integer pascals in) the cost is:
//!
//! * 1 int→float conversion of the pressure,
//! * 1 fmul + 1 fadd to get the segment coordinate `u = P·(1/(P0·w)) − x0/w`
//!   (the reciprocal is pre-computed when the reference is set, no division),
//! * 1 float→int (segment index, saturating) + 1 int→float + 1 fsub (the fraction `s`),
//! * Horner `c0 + s·(c1 + s·c2)`: 2 fmul + 2 fadd,
//!
//! i.e. **3 fmul + 4 fadd/fsub + 3 conversions**, no division, no `powf`.
//!
//! ## Accuracy (tested densely in `tests/baro.rs`)
//!
//! Against the exact formula evaluated in f64 at the same input pressure the
//! error is below **5 mm** (interpolation ≤ 3.3 mm plus f32 rounding) for every
//! ratio `P/P0 ∈ [0.52, 1.08]`. That covers heights from **−500 m to +5000 m
//! above the reference** (ratios 1.0607 … 0.5332) for **any reference pressure
//! `P0` in 30 000 … 120 000 Pa** (the range [`CheapBaro::new`] accepts); the
//! tests sweep P0 = 95 000 … 105 000 Pa and a few others. The requirement is
//! 2 cm. Outside the table the end segment is extrapolated: the result stays
//! finite but its error grows fast (4 cm at 5.3 km, 0.3 m at 5.5 km,
//! 3 m at 6 km above a 101 325 Pa reference).
//!
//! The 1-Pa resolution of the integer input (≈ 8.4 cm at sea level) is the
//! sensor's quantisation, not an error of the cheap form; pass
//! [`CheapBaro::height_from_f32_m`] a fractional pressure if you have one.

use crate::error::{finite, Error};

/// ISA standard sea-level pressure, Pa.
pub const SEA_LEVEL_PA: f32 = 101_325.0;

/// Scale height of the troposphere law, metres (44 330 m).
pub const SCALE_HEIGHT_M: f32 = 44_330.0;

/// Exponent of the troposphere law, 5.255 (`P/P0 = (1 − h/44330)^5.255`).
pub const EXPONENT: f32 = 5.255;

/// Smallest reference pressure [`CheapBaro`] accepts, Pa.
pub const MIN_REFERENCE_PA: f32 = 30_000.0;
/// Largest reference pressure [`CheapBaro`] accepts, Pa.
pub const MAX_REFERENCE_PA: f32 = 120_000.0;

/// Exact barometric height of `p_pa` above the level where the pressure is
/// `p0_pa`, metres, "up" positive.
///
/// Uses `libm::powf`: accurate but expensive on an FPU-less M3. Errors:
/// [`Error::NonFinite`] if either input is NaN/∞, [`Error::OutOfRange`] if
/// either pressure is `<= 0`.
///
/// ```
/// use control::baro::{altitude_m, SEA_LEVEL_PA};
/// let h = altitude_m(89_874.6, SEA_LEVEL_PA).unwrap();
/// assert!((h - 1000.0).abs() < 0.5); // ISA: 898.746 hPa at 1000 m
/// assert_eq!(altitude_m(SEA_LEVEL_PA, SEA_LEVEL_PA).unwrap(), 0.0);
/// ```
pub fn altitude_m(p_pa: f32, p0_pa: f32) -> Result<f32, Error> {
    finite(p_pa)?;
    finite(p0_pa)?;
    if p_pa <= 0.0 || p0_pa <= 0.0 {
        return Err(Error::OutOfRange);
    }
    let ratio = p_pa / p0_pa;
    let h = SCALE_HEIGHT_M * (1.0 - libm::powf(ratio, 1.0 / EXPONENT));
    if h.is_finite() {
        Ok(h)
    } else {
        Err(Error::Overflow)
    }
}

/// Exact inverse of [`altitude_m`]: the pressure at height `h_m` above the
/// level where the pressure is `p0_pa`, Pa.
///
/// Errors: [`Error::NonFinite`] for NaN/∞ inputs, [`Error::OutOfRange`] if
/// `p0_pa <= 0` or `h_m >= 44330 m` (outside the formula's domain).
///
/// ```
/// use control::baro::{altitude_m, pressure_pa, SEA_LEVEL_PA};
/// let p = pressure_pa(1000.0, SEA_LEVEL_PA).unwrap();
/// assert!((p - 89_874.6).abs() < 5.0);
/// let h = altitude_m(p, SEA_LEVEL_PA).unwrap();
/// assert!((h - 1000.0).abs() < 0.05);
/// ```
pub fn pressure_pa(h_m: f32, p0_pa: f32) -> Result<f32, Error> {
    finite(h_m)?;
    finite(p0_pa)?;
    if p0_pa <= 0.0 || h_m >= SCALE_HEIGHT_M {
        return Err(Error::OutOfRange);
    }
    let base = 1.0 - h_m / SCALE_HEIGHT_M;
    let p = p0_pa * libm::powf(base, EXPONENT);
    if p.is_finite() {
        Ok(p)
    } else {
        Err(Error::Overflow)
    }
}

/// Lower end of the tabulated pressure ratio `P/P0`.
pub const TABLE_RATIO_MIN: f32 = 0.52;
/// Width of one table segment in pressure ratio.
const SEGMENT_WIDTH: f32 = 0.0175;
/// Number of quadratic segments.
const SEGMENTS: usize = 32;
/// Upper end of the tabulated pressure ratio `P/P0` (`0.52 + 32 · 0.0175`).
pub const TABLE_RATIO_MAX: f32 = 1.08;

/// `[c0, c1, c2]` per segment `k`: over `x ∈ [0.52 + k·w, 0.52 + (k+1)·w]`,
/// with `s = (x − x_k)/w ∈ [0, 1]`, `h_m ≈ c0 + c1·s + c2·s²`.
/// Generated in f64 from the exact law (nodes at s = 0, ½, 1) and rounded to
/// f32; the unit tests re-derive every entry and check it.
pub(crate) const TABLE: [[f32; 3]; SEGMENTS] = [
    [5186.9556, -250.64473, 3.3142369],
    [4939.625, -244.01843, 3.1245623],
    [4698.7314, -237.77122, 2.9512243],
    [4463.911, -231.87048, 2.7923715],
    [4234.833, -226.28726, 2.6464102],
    [4011.1924, -220.9958, 2.5119617],
    [3792.7085, -215.9731, 2.3878284],
    [3579.1233, -211.19855, 2.2729654],
    [3370.1978, -206.6536, 2.1664588],
    [3165.7104, -202.32158, 2.0675051],
    [2965.4565, -198.18738, 1.9753956],
    [2769.2444, -194.23734, 1.8895041],
    [2576.8967, -190.459, 1.8092748],
    [2388.2468, -186.84106, 1.7342131],
    [2203.1401, -183.37321, 1.6638778],
    [2021.4307, -180.04597, 1.5978744],
    [1842.9825, -176.8507, 1.5358487],
    [1667.6677, -173.77943, 1.4774827],
    [1495.3658, -170.82487, 1.4224894],
    [1325.9634, -167.98027, 1.37061],
    [1159.3538, -165.2394, 1.3216102],
    [995.436, -162.5965, 1.2752774],
    [834.11475, -160.04625, 1.2314186],
    [675.29987, -157.58368, 1.189858],
    [518.90607, -155.20422, 1.1504351],
    [364.85226, -152.9036, 1.1130037],
    [213.06168, -150.67781, 1.0774299],
    [63.461296, -148.52316, 1.0435907],
    [-84.01827, -146.43617, 1.0113734],
    [-229.44308, -144.41362, 0.9806743],
    [-372.876, -142.45244, 0.9513982],
    [-514.3771, -140.5498, 0.9234569],
];

/// Cheap barometric height for a fixed reference pressure: a quadratic
/// table lookup in the pressure ratio, no `powf`, no division per call.
///
/// See the [module docs](self) for the cost (3 fmul + 4 fadd + 3 conversions)
/// and the accuracy (< 5 mm vs. the exact law for `P/P0 ∈ [0.52, 1.08]`,
/// i.e. −500 m … +5000 m above any reference in 30 000 … 120 000 Pa).
///
/// ```
/// use control::baro::{altitude_m, CheapBaro};
/// // Reference = the pressure measured on the ground before take-off.
/// let baro = CheapBaro::new(98_000.0).unwrap();
/// let h = baro.height_m(96_850); // MS5611 gives integer pascals
/// let exact = altitude_m(96_850.0, 98_000.0).unwrap();
/// assert!((h - exact).abs() < 0.02);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CheapBaro {
    reference_pa: f32,
    /// `1 / (P0 · w)`: pascals → segment coordinate.
    scale_per_pa: f32,
}

impl CheapBaro {
    /// Creates the cheap form for reference pressure `p0_pa` (height 0 m).
    ///
    /// Errors: [`Error::NonFinite`] for NaN/∞, [`Error::InvalidParameter`]
    /// outside [`MIN_REFERENCE_PA`] ..= [`MAX_REFERENCE_PA`].
    pub fn new(p0_pa: f32) -> Result<Self, Error> {
        finite(p0_pa)?;
        if !(MIN_REFERENCE_PA..=MAX_REFERENCE_PA).contains(&p0_pa) {
            return Err(Error::InvalidParameter);
        }
        Ok(Self {
            reference_pa: p0_pa,
            scale_per_pa: 1.0 / (p0_pa * SEGMENT_WIDTH),
        })
    }

    /// Standard-atmosphere form: heights are ISA pressure altitudes (P0 = 101 325 Pa).
    pub fn standard() -> Self {
        Self {
            reference_pa: SEA_LEVEL_PA,
            scale_per_pa: 1.0 / (SEA_LEVEL_PA * SEGMENT_WIDTH),
        }
    }

    /// Changes the reference pressure (e.g. re-zero on the ground). Same
    /// checks as [`CheapBaro::new`]; on error the old reference is kept.
    pub fn set_reference_pa(&mut self, p0_pa: f32) -> Result<(), Error> {
        *self = Self::new(p0_pa)?;
        Ok(())
    }

    /// The reference pressure (height 0 m), Pa.
    pub fn reference_pa(&self) -> f32 {
        self.reference_pa
    }

    /// Pressure range (Pa, inclusive) over which the stated accuracy holds for
    /// this reference: `[0.52·P0, 1.08·P0]`.
    pub fn valid_pressure_range_pa(&self) -> (f32, f32) {
        (
            TABLE_RATIO_MIN * self.reference_pa,
            TABLE_RATIO_MAX * self.reference_pa,
        )
    }

    /// Height above the reference, metres, from an integer pressure in Pa
    /// (the MS5611's compensated output). Never fails and never panics;
    /// outside [`valid_pressure_range_pa`](Self::valid_pressure_range_pa) the
    /// end segment is extrapolated (finite, less accurate).
    #[inline]
    pub fn height_m(&self, p_pa: i32) -> f32 {
        self.eval(p_pa as f32)
    }

    /// Same as [`height_m`](Self::height_m) for a fractional pressure in Pa.
    /// Errors: [`Error::NonFinite`] for NaN/∞ input, [`Error::Overflow`] if an
    /// absurd (but finite) pressure overflows the extrapolation.
    #[inline]
    pub fn height_from_f32_m(&self, p_pa: f32) -> Result<f32, Error> {
        finite(p_pa)?;
        let h = self.eval(p_pa);
        if h.is_finite() {
            Ok(h)
        } else {
            Err(Error::Overflow)
        }
    }

    #[inline]
    fn eval(&self, p_pa: f32) -> f32 {
        // u = (P/P0 − x0)/w: segment coordinate, integer part = segment index.
        const OFFSET: f32 = -TABLE_RATIO_MIN / SEGMENT_WIDTH;
        let u = p_pa * self.scale_per_pa + OFFSET;
        // `as` saturates (NaN → 0): no overflow; then clamp to the table.
        let idx = (u as i32).clamp(0, SEGMENTS as i32 - 1);
        let s = u - idx as f32;
        // idx is clamped to the table, so the fallback is never used.
        let c = TABLE.get(idx as usize).unwrap_or(&[0.0; 3]);
        c[0] + s * (c[1] + s * c[2])
    }
}

impl Default for CheapBaro {
    fn default() -> Self {
        Self::standard()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_constants_are_consistent() {
        let top = TABLE_RATIO_MIN + SEGMENTS as f32 * SEGMENT_WIDTH;
        assert!((top - TABLE_RATIO_MAX).abs() < 1e-6);
        // Segments join: end of k == start of k+1 (within f32 rounding).
        for k in 0..SEGMENTS - 1 {
            let [c0, c1, c2] = TABLE[k];
            let end = c0 + c1 + c2;
            assert!((end - TABLE[k + 1][0]).abs() < 2e-3, "seam {k}");
        }
    }

    #[test]
    fn table_matches_exact_law_at_its_nodes() {
        let h = |x: f64| 44_330.0 * (1.0 - libm::pow(x, 1.0 / 5.255));
        let w = 0.0175_f64; // SEGMENT_WIDTH, exact decimal as in the generator
        for (k, c) in TABLE.iter().enumerate() {
            let x0 = 0.52 + k as f64 * w;
            let (f0, fm, f1) = (h(x0), h(x0 + w / 2.0), h(x0 + w));
            let want = [
                f0,
                -3.0 * f0 + 4.0 * fm - f1,
                2.0 * f0 - 4.0 * fm + 2.0 * f1,
            ];
            for j in 0..3 {
                let tol = 1e-6 * want[j].abs().max(1.0);
                assert!(
                    (f64::from(c[j]) - want[j]).abs() < tol,
                    "segment {k} coeff {j}"
                );
            }
        }
    }

    #[test]
    fn reference_pressure_reads_zero() {
        for p0 in [95_000, 98_765, 101_325, 105_000] {
            let b = CheapBaro::new(p0 as f32).unwrap();
            assert!(b.height_m(p0).abs() < 0.005, "p0 {p0}");
        }
    }

    #[test]
    fn rejects_bad_reference() {
        assert_eq!(CheapBaro::new(f32::NAN), Err(Error::NonFinite));
        assert_eq!(CheapBaro::new(0.0), Err(Error::InvalidParameter));
        assert_eq!(CheapBaro::new(200_000.0), Err(Error::InvalidParameter));
        let mut b = CheapBaro::standard();
        assert!(b.set_reference_pa(-1.0).is_err());
        assert_eq!(b.reference_pa(), SEA_LEVEL_PA);
    }

    #[test]
    fn extreme_integer_inputs_stay_finite() {
        let b = CheapBaro::standard();
        for p in [i32::MIN, -1, 0, 1, 1000, 2_000_000, i32::MAX] {
            assert!(b.height_m(p).is_finite(), "p {p}");
        }
    }
}
