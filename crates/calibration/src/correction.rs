//! Correction types: plain `Copy`, `#[repr(C)]` data the firmware can store in
//! flash, each with `apply`, `identity`, `is_finite` and `validate`.

use crate::{Error, MAX_GAIN, MIN_GAIN};

/// `true` when every component is finite.
fn finite3(v: &[f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// `true` when `g` lies in the plausible gain range.
fn gain_ok(g: f32) -> bool {
    (MIN_GAIN..=MAX_GAIN).contains(&g)
}

/// Gyroscope bias measured at rest: `corrected = raw − bias`.
///
/// `bias` is in the unit of the rate samples it was estimated from (rad/s,
/// °/s or raw counts: whatever was fed to
/// [`GyroBiasEstimator`](crate::GyroBiasEstimator)).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroBias {
    /// Per-axis bias (x, y, z), input unit.
    pub bias: [f32; 3],
}

impl GyroBias {
    /// No correction (zero bias).
    pub const fn identity() -> Self {
        Self { bias: [0.0; 3] }
    }

    /// Remove the bias: `raw − bias`.
    pub fn apply(&self, raw: [f32; 3]) -> [f32; 3] {
        let [x, y, z] = raw;
        let [bx, by, bz] = self.bias;
        [x - bx, y - by, z - bz]
    }

    /// `true` when every field is finite.
    pub fn is_finite(&self) -> bool {
        finite3(&self.bias)
    }

    /// Check the record is usable: finite and each `|bias|` at most
    /// `max_abs_bias` (input unit; MPU-9250 ±5 °/s ≈ 0.09 rad/s is typical).
    pub fn validate(&self, max_abs_bias: f32) -> Result<(), Error> {
        if self.is_finite() && self.bias.iter().all(|b| b.abs() <= max_abs_bias) {
            Ok(())
        } else {
            Err(Error::OutOfRange)
        }
    }
}

impl Default for GyroBias {
    fn default() -> Self {
        Self::identity()
    }
}

/// Magnetometer hard- and soft-iron correction:
/// `corrected = soft_iron · (raw − offset)`.
///
/// `offset` (the hard-iron offset, the centre of the raw data) is in the input
/// unit (µT, gauss, counts, ...); `soft_iron` is dimensionless, row-major
/// (`soft_iron[row][col]`), and scaled so the corrected field keeps the
/// average raw field magnitude, so the output stays in the input unit.
/// [`MagMinMax`](crate::MagMinMax) produces a diagonal matrix,
/// [`EllipsoidFit`](crate::EllipsoidFit) a full symmetric positive-definite one.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagCalibration {
    /// Hard-iron offset (x, y, z), input unit.
    pub offset: [f32; 3],
    /// Soft-iron matrix, row-major, dimensionless.
    pub soft_iron: [[f32; 3]; 3],
}

impl MagCalibration {
    /// No correction: zero offset, identity matrix.
    pub const fn identity() -> Self {
        Self {
            offset: [0.0; 3],
            soft_iron: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }

    /// Correct a raw sample: `soft_iron · (raw − offset)`. 9 multiplies,
    /// 9 additions/subtractions.
    pub fn apply(&self, raw: [f32; 3]) -> [f32; 3] {
        let [x, y, z] = raw;
        let [ox, oy, oz] = self.offset;
        let (dx, dy, dz) = (x - ox, y - oy, z - oz);
        let [r0, r1, r2] = &self.soft_iron;
        [
            r0[0] * dx + r0[1] * dy + r0[2] * dz,
            r1[0] * dx + r1[1] * dy + r1[2] * dz,
            r2[0] * dx + r2[1] * dy + r2[2] * dz,
        ]
    }

    /// `true` when every field is finite.
    pub fn is_finite(&self) -> bool {
        finite3(&self.offset) && self.soft_iron.iter().all(finite3)
    }

    /// Check the record is plausible: all finite, every diagonal gain within
    /// [`MIN_GAIN`]..=[`MAX_GAIN`], and the symmetric part of `soft_iron`
    /// positive definite (the correction never flips or collapses a
    /// direction). The offset's size is not checked (its unit is unknown
    /// here).
    pub fn validate(&self) -> Result<(), Error> {
        if !self.is_finite() {
            return Err(Error::OutOfRange);
        }
        let [r0, r1, r2] = &self.soft_iron;
        if !(gain_ok(r0[0]) && gain_ok(r1[1]) && gain_ok(r2[2])) {
            return Err(Error::OutOfRange);
        }
        // Symmetric part, Sylvester's criterion on leading principal minors.
        let a = r0[0];
        let b = 0.5 * (r0[1] + r1[0]);
        let c = 0.5 * (r0[2] + r2[0]);
        let d = r1[1];
        let e = 0.5 * (r1[2] + r2[1]);
        let g = r2[2];
        let m2 = a * d - b * b;
        let m3 = a * (d * g - e * e) - b * (b * g - e * c) + c * (b * e - d * c);
        if m2 > 0.0 && m3 > 0.0 {
            Ok(())
        } else {
            Err(Error::OutOfRange)
        }
    }
}

impl Default for MagCalibration {
    fn default() -> Self {
        Self::identity()
    }
}

/// Integer form of an affine magnetometer correction for the sample-rate
/// path: `out = M · raw − bias`, with `raw` in integer sensor counts and
/// `out` in integer output units (e.g. 1/16 µT).
///
/// Q-format: `M` is stored in Q16 (`m_q16 = round(M · 2¹⁶)`), the products
/// are summed in `i64` and shifted right 16 (floor), and `bias = round(M ·
/// offset)` in output units. For 16-bit counts every output is within 2.25
/// output units of the exact `M · (raw − offset)`: the Q16 rounding of `M`
/// contributes at most `3 · 2⁻¹⁷ · 2¹⁵ = 0.75`, the floor of the shift less
/// than 1 and the rounding of the bias 0.5 (the tests check the bound).
///
/// Build it once from the f32 [`MagCalibration`] folded together with the
/// count scale and any axis remapping
/// ([`from_affine`](Self::from_affine)); the per-sample
/// [`apply`](Self::apply) is 9 multiply-accumulates and no soft-float call.
///
/// ```
/// use calibration::{MagCalibration, MagCalibrationQ16};
/// // Hard iron 1.25 µT on x, no soft iron; counts of 0.125 µT in, 1/16 µT
/// // out: M = 0.125 · 16 · soft_iron, offset = 1.25 / 0.125 = 10 counts.
/// let cal = MagCalibration { offset: [1.25, 0.0, 0.0], ..MagCalibration::identity() };
/// let m = cal.soft_iron.map(|r| r.map(|v| v * 0.125 * 16.0));
/// let q = MagCalibrationQ16::from_affine(m, cal.offset.map(|o| o / 0.125))?;
/// assert_eq!(q.apply([110, 0, -3]), [200, 0, -6]); // 100 counts = 12.5 µT = 200/16 µT
/// # Ok::<(), calibration::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagCalibrationQ16 {
    /// `M`, row-major, Q16 (output units per count).
    pub m_q16: [[i32; 3]; 3],
    /// `M · offset`, output units.
    pub bias: [i32; 3],
}

/// Largest |element| of `M` accepted by [`MagCalibrationQ16::from_affine`]:
/// keeps `M` in Q16 within `i32` and every output of 16-bit counts below 2³¹.
pub const MAG_Q16_MAX_GAIN: f32 = 10_000.0;

impl MagCalibrationQ16 {
    /// Pass-through: `M = I`, no bias.
    pub const fn identity() -> Self {
        Self {
            m_q16: [[65_536, 0, 0], [0, 65_536, 0], [0, 0, 65_536]],
            bias: [0; 3],
        }
    }

    /// `out = m · (raw − offset_counts)`: `m` in output units per count,
    /// `offset_counts` in counts. [`Error::OutOfRange`] when a value is
    /// not finite, an element of `m` exceeds [`MAG_Q16_MAX_GAIN`] or the
    /// bias does not fit in `i32`.
    pub fn from_affine(m: [[f32; 3]; 3], offset_counts: [f32; 3]) -> Result<Self, Error> {
        let mut out = Self::identity();
        for ((q_row, b), row) in out.m_q16.iter_mut().zip(&mut out.bias).zip(&m) {
            if !finite3(row) || row.iter().any(|v| v.abs() > MAG_Q16_MAX_GAIN) {
                return Err(Error::OutOfRange);
            }
            for (q, v) in q_row.iter_mut().zip(row) {
                *q = round_f32_to_i32(v * 65_536.0);
            }
            let bias =
                row[0] * offset_counts[0] + row[1] * offset_counts[1] + row[2] * offset_counts[2];
            if !(bias.is_finite() && bias.abs() < 2.0e9) {
                return Err(Error::OutOfRange);
            }
            *b = round_f32_to_i32(bias);
        }
        Ok(out)
    }

    /// Correct one sample of counts. Saturates instead of wrapping for
    /// inputs beyond 16 bits that would overflow.
    #[inline]
    pub fn apply(&self, raw: [i32; 3]) -> [i32; 3] {
        let mut out = [0i32; 3];
        for ((o, row), b) in out.iter_mut().zip(&self.m_q16).zip(self.bias) {
            let acc = i64::from(row[0]) * i64::from(raw[0])
                + i64::from(row[1]) * i64::from(raw[1])
                + i64::from(row[2]) * i64::from(raw[2]);
            let v = (acc >> 16) - i64::from(b);
            *o = v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        }
        out
    }
}

impl Default for MagCalibrationQ16 {
    fn default() -> Self {
        Self::identity()
    }
}

/// Round to nearest (ties away from zero); callers pass values below 2³¹.
fn round_f32_to_i32(x: f32) -> i32 {
    (if x >= 0.0 { x + 0.5 } else { x - 0.5 }) as i32
}

/// Accelerometer per-axis offset and scale:
/// `corrected = scale ⊙ (raw − offset)` (element-wise).
///
/// `offset` is in the input unit; `scale` is dimensionless and maps the raw
/// reading onto the configured gravity magnitude (1.0 when working in g,
/// 9.80665 when working in m/s², see
/// [`AccelSixPositionConfig::gravity`](crate::AccelSixPositionConfig::gravity)).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelCalibration {
    /// Per-axis offset (x, y, z), input unit.
    pub offset: [f32; 3],
    /// Per-axis scale factor, dimensionless.
    pub scale: [f32; 3],
}

impl AccelCalibration {
    /// No correction: zero offset, unit scale.
    pub const fn identity() -> Self {
        Self {
            offset: [0.0; 3],
            scale: [1.0; 3],
        }
    }

    /// Correct a raw sample: `scale ⊙ (raw − offset)`.
    pub fn apply(&self, raw: [f32; 3]) -> [f32; 3] {
        let [x, y, z] = raw;
        let [ox, oy, oz] = self.offset;
        let [sx, sy, sz] = self.scale;
        [sx * (x - ox), sy * (y - oy), sz * (z - oz)]
    }

    /// `true` when every field is finite.
    pub fn is_finite(&self) -> bool {
        finite3(&self.offset) && finite3(&self.scale)
    }

    /// Check the record is plausible: all finite and every scale within
    /// [`MIN_GAIN`]..=[`MAX_GAIN`]. The offset's size is not checked (its
    /// unit is unknown here).
    pub fn validate(&self) -> Result<(), Error> {
        if self.is_finite() && self.scale.iter().all(|&s| gain_ok(s)) {
            Ok(())
        } else {
            Err(Error::OutOfRange)
        }
    }
}

impl Default for AccelCalibration {
    fn default() -> Self {
        Self::identity()
    }
}
