//! Full hard/soft-iron ellipsoid fit from incrementally accumulated moments.
//!
//! # Method
//!
//! Samples `m` are taken relative to the first accepted sample `p₀`
//! (`x = m − p₀`) and every monomial `xᵃ yᵇ zᶜ` of degree 1..=4 is summed
//! (34 sums; f32 sums over blocks of 64 samples, folded into f64 totals).
//! Those moments determine every quantity below exactly, so nothing else
//! about the samples is kept.
//!
//! At [`EllipsoidFit::finish`] the moments are converted to means and
//! rescaled by the RMS distance `s` from `p₀` (f64), and the general quadric
//! `xᵀMx + 2bᵀx + J = 0` is fitted by linear least squares with the trace of
//! `M` fixed (Petrov's parametrisation): regressors
//! `[x²+y²−2z², x²+z²−2y², 2xy, 2xz, 2yz, 2x, 2y, 2z, 1]`, target `x²+y²+z²`.
//! Fixing the trace rather than the constant term makes the fit independent
//! of where the origin lies (it may sit on the surface, as `p₀` does). The
//! 9×9 normal equations are Jacobi-equilibrated and solved by an in-place
//! Cholesky decomposition;
//! a pivot below [`PIVOT_MIN`] means the data do not determine the quadric
//! ([`Error::Singular`]).
//!
//! Then the centre is `c = −M⁻¹b`, the shape `S = M / (cᵀMc − J)` must be
//! positive definite ([`Error::NotEllipsoid`]), `(x − c)ᵀ S (x − c) = 1` on
//! the fitted surface, and with `S = V diag(λ) Vᵀ` (symmetric
//! eigen-decomposition) the semi-axes are `aᵢ = 1/√λᵢ`. The soft-iron matrix
//! is the symmetric square root scaled to keep the mean semi-axis
//! `R = (a₁ + a₂ + a₃)/3`: `W = R · V diag(√λ) Vᵀ`, so `|W(m − c)| = R` on
//! the surface (the same normalisation as the min/max method's
//! `avg_delta / delta`). The symmetric root is the correction that maps the
//! ellipsoid to the sphere without adding a rotation; the true distortion's
//! rotation part is unobservable from magnitudes alone.
//!
//! # Coverage
//!
//! For each of 14 directions `d` (±x, ±y, ±z and the 8 cube diagonals) the
//! sample with the largest projection `d·m` (its support point) is kept —
//! six compares per sample, no multiplies. At `finish` a direction counts as
//! covered when, seen from the centre and in corrected space, its support
//! point lies within 30° of that direction (for a sphere, the support point
//! in direction `d` is the sample closest in angle to `d`). The check is made
//! twice: before the fit relative to the min/max box centre with per-axis
//! half-range scaling (so data that cannot determine an ellipsoid are
//! reported as [`Error::InsufficientCoverage`] rather than as a numerical
//! failure), and after it relative to the fitted centre and `W`. A single
//! plane through the centre covers at most 6 directions, a hemisphere 9;
//! the default requires 12 of 14.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

use crate::{check_input, Error, MagCalibration};

/// Number of coverage directions (±x, ±y, ±z and the 8 cube diagonals).
pub const COVERAGE_BINS: u8 = 14;

/// A direction counts as covered when its support point lies within this
/// angle's cosine (30°) of it, seen from the centre in corrected space.
pub const COVERAGE_COS: f64 = 0.866_025_403_784_438_6;

/// The coverage directions (not normalised).
pub(crate) const DIRECTIONS: [[i8; 3]; 14] = [
    [1, 0, 0],
    [-1, 0, 0],
    [0, 1, 0],
    [0, -1, 0],
    [0, 0, 1],
    [0, 0, -1],
    [1, 1, 1],
    [-1, -1, -1],
    [1, 1, -1],
    [-1, -1, 1],
    [1, -1, 1],
    [-1, 1, -1],
    [1, -1, -1],
    [-1, 1, 1],
];

/// Smallest accepted Cholesky pivot² of the unit-diagonal (equilibrated)
/// normal matrix: the fraction of a regressor's variance not explained by
/// the previous ones. Below this the fit is refused as [`Error::Singular`].
pub const PIVOT_MIN: f64 = 1.0e-9;

/// Samples per f32 block before folding into the f64 totals.
const BLOCK: u32 = 64;

/// Number of accumulated monomials (degrees 1..=4 in three variables).
pub(crate) const N_MOMENTS: usize = 34;

/// What the coverage check needs from the samples, shared by both fits:
/// the min/max box and, per coverage direction, the sample with the largest
/// projection on it (its support point).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Coverage {
    pub(crate) min: [f32; 3],
    pub(crate) max: [f32; 3],
    pub(crate) support: [[f32; 3]; 14],
    support_proj: [f32; 14],
}

impl Coverage {
    pub(crate) const fn new() -> Self {
        Self {
            min: [0.0; 3],
            max: [0.0; 3],
            support: [[0.0; 3]; 14],
            support_proj: [0.0; 14],
        }
    }

    /// Per-axis max − min.
    pub(crate) fn ranges(&self) -> [f32; 3] {
        let mut r = [0.0; 3];
        for ((ri, lo), hi) in r.iter_mut().zip(&self.min).zip(&self.max) {
            *ri = hi - lo;
        }
        r
    }

    /// Adds an accepted sample (`first`: the first one, which starts the box
    /// and every support point).
    pub(crate) fn push(&mut self, m: [f32; 3], first: bool) {
        if first {
            self.min = m;
            self.max = m;
        }
        for ((&v, lo), hi) in m.iter().zip(&mut self.min).zip(&mut self.max) {
            if v < *lo {
                *lo = v;
            }
            if v > *hi {
                *hi = v;
            }
        }
        let [x, y, z] = m;
        let (s, d) = (x + y, x - y);
        let (ppp, ppm, pmp, pmm) = (s + z, s - z, d + z, d - z);
        // Same order as DIRECTIONS.
        let proj = [
            x, -x, y, -y, z, -z, ppp, -ppp, ppm, -ppm, pmp, -pmp, pmm, -pmm,
        ];
        for ((p, best), sup) in proj
            .iter()
            .zip(&mut self.support_proj)
            .zip(&mut self.support)
        {
            if first || *p > *best {
                *best = *p;
                *sup = m;
            }
        }
    }
}

/// [`Error::RangeTooSmall`] for the first axis whose sweep is below
/// `min_range` (or zero, or NaN).
pub(crate) fn check_ranges(ranges: [f32; 3], min_range: f32) -> Result<(), Error> {
    let mut axis = 0u8;
    for range in ranges {
        if range.is_nan() || range < min_range || range <= 0.0 {
            return Err(Error::RangeTooSmall {
                axis,
                range,
                min: min_range,
            });
        }
        axis = axis.saturating_add(1);
    }
    Ok(())
}

/// Settings for [`EllipsoidFit`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EllipsoidFitConfig {
    /// Fewest accepted samples (at least 10 is enforced).
    pub min_samples: u32,
    /// Coverage directions (of [`COVERAGE_BINS`]) that must be covered.
    /// A plane of data covers at most 6, a hemisphere 9.
    pub bins_needed: u8,
    /// Smallest acceptable max − min on every axis, input unit.
    pub min_range: f32,
    /// Largest accepted [`EllipsoidSolution::rms_error`].
    pub max_rms_error: f32,
    /// Largest accepted [`EllipsoidSolution::offset_std_error`], input unit.
    pub max_offset_std_error: f32,
}

impl EllipsoidFitConfig {
    /// Defaults for µT: 300 samples, 12 of 14 directions, every axis spanning at
    /// least 30 µT, RMS magnitude error at most 5 %, and a centre whose
    /// standard error is at most 1/3 µT on every axis (three standard errors
    /// within 1 µT; the AK8963's 0.4 µT noise on a figure eight leaves about
    /// 0.02 µT, so only samples that leave a side of the sphere to a few
    /// points reach it).
    pub const MICROTESLA: Self = Self {
        min_samples: 300,
        bins_needed: 12,
        min_range: 30.0,
        max_rms_error: 0.05,
        max_offset_std_error: 1.0 / 3.0,
    };

    /// `Ok` when `bins_needed ≤ 14` and the thresholds are finite and
    /// non-negative.
    pub fn validate(&self) -> Result<(), Error> {
        let ok = self.bins_needed <= COVERAGE_BINS
            && self.min_range.is_finite()
            && self.min_range >= 0.0
            && self.max_rms_error >= 0.0
            && self.max_offset_std_error >= 0.0;
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidConfig)
        }
    }
}

impl Default for EllipsoidFitConfig {
    /// [`EllipsoidFitConfig::MICROTESLA`].
    fn default() -> Self {
        Self::MICROTESLA
    }
}

/// Result of [`EllipsoidFit::finish`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EllipsoidSolution {
    /// The correction: `offset` = ellipsoid centre, `soft_iron` = symmetric
    /// positive-definite `W`.
    pub calibration: MagCalibration,
    /// Field magnitude after correction (mean semi-axis `R`), input unit.
    pub radius: f32,
    /// Semi-axes of the raw ellipsoid, ascending, input unit.
    pub semi_axes: [f32; 3],
    /// Fit quality: RMS over all samples of `(|W(m − c)|² / R² − 1) / 2`,
    /// which to first order is the RMS relative deviation of the corrected
    /// magnitude from `R` (0.01 ≈ 1 % RMS). Computed exactly from the
    /// accumulated moments (no second pass).
    pub rms_error: f32,
    /// Largest per-axis standard error of the centre, input unit: the
    /// linearised least-squares covariance of `c = −M⁻¹b` from the normal
    /// matrix and the RMS regression residual (so it grows with the noise
    /// and with samples that leave a side of the ellipsoid to a few points).
    /// Noise of σ per axis on `N` samples spread over the sphere gives about
    /// `σ·√(3/N)`.
    pub offset_std_error: f32,
    /// Coverage directions covered (of [`COVERAGE_BINS`]), judged from the
    /// fitted centre.
    pub bins_hit: u8,
    /// Samples used.
    pub samples: u32,
}

/// Incremental ellipsoid fit for magnetometer hard- and soft-iron
/// calibration (see the module documentation for the method).
///
/// State is ≈ 700 bytes: 34 f32 block sums, 34 f64 totals, the reference
/// sample, the min/max box and 14 support points. Rotate the sensor through
/// as many orientations as possible while feeding it samples.
///
/// ```
/// use calibration::{EllipsoidFit, EllipsoidFitConfig};
///
/// let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA)?;
/// // 50 µT field, hard-iron offset (12, -7, 30) µT, z squeezed to 80 %.
/// for i in 0..40 {
///     let t = -0.95 + 1.9 * (i as f32 + 0.5) / 40.0;
///     let r = libm::sqrtf(1.0 - t * t);
///     for j in 0..20 {
///         let phi = j as f32 * 0.314_159_27 + i as f32 * 0.1;
///         let h = [r * libm::cosf(phi), r * libm::sinf(phi), t];
///         let m = [12.0 + 50.0 * h[0], -7.0 + 50.0 * h[1], 30.0 + 40.0 * h[2]];
///         fit.push(m)?;
///     }
/// }
/// let sol = fit.finish()?;
/// assert!((sol.calibration.offset[2] - 30.0).abs() < 0.01);
/// let c = sol.calibration.apply([12.0, -7.0, 70.0]); // +z pole
/// assert!((c[2] - sol.radius).abs() < 0.01 * sol.radius);
/// assert!(sol.rms_error < 1e-3);
/// # Ok::<(), calibration::Error>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct EllipsoidFit {
    config: EllipsoidFitConfig,
    origin: [f32; 3],
    block: [f32; N_MOMENTS],
    block_n: u32,
    total: [f64; N_MOMENTS],
    count: u32,
    rejected: u32,
    cov: Coverage,
}

impl EllipsoidFit {
    /// A fresh fit; [`Error::InvalidConfig`] if `config` is unusable.
    pub fn new(config: EllipsoidFitConfig) -> Result<Self, Error> {
        config.validate()?;
        Ok(Self::empty(config))
    }

    /// Forget all samples (keeps the configuration).
    pub fn reset(&mut self) {
        *self = Self::empty(self.config);
    }

    /// No samples yet, with an already validated `config`.
    const fn empty(config: EllipsoidFitConfig) -> Self {
        Self {
            config,
            origin: [0.0; 3],
            block: [0.0; N_MOMENTS],
            block_n: 0,
            total: [0.0; N_MOMENTS],
            count: 0,
            rejected: 0,
            cov: Coverage::new(),
        }
    }

    /// Accepted samples.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Samples skipped as non-finite or out of range.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Coverage directions covered so far (of [`COVERAGE_BINS`]), judged
    /// from the current min/max box centre; for progress display.
    pub fn bins_hit(&self) -> u8 {
        self.box_coverage()
    }

    /// Per-axis max − min so far (input unit).
    pub fn ranges(&self) -> [f32; 3] {
        self.cov.ranges()
    }

    /// Add a sample (input unit). [`Error::NonFinite`] /
    /// [`Error::InputOutOfRange`]: skipped and counted, state unchanged.
    pub fn push(&mut self, m: [f32; 3]) -> Result<(), Error> {
        if let Err(e) = check_input(&m) {
            self.rejected = self.rejected.saturating_add(1);
            return Err(e);
        }
        if self.count == 0 {
            self.origin = m;
        }
        let [ox, oy, oz] = self.origin;
        let [mx, my, mz] = m;
        // |x| ≤ 2·INPUT_LIMIT, so every 4th-degree product ≤ 1.6e25 and a
        // block sum of 64 stays far below f32::MAX.
        let (x, y, z) = (mx - ox, my - oy, mz - oz);
        let (xx, xy, xz, yy, yz, zz) = (x * x, x * y, x * z, y * y, y * z, z * z);
        let terms: [f32; N_MOMENTS] = [
            x,
            y,
            z,
            xx,
            xy,
            xz,
            yy,
            yz,
            zz,
            xx * x,
            xx * y,
            xx * z,
            xy * y,
            xy * z,
            xz * z,
            yy * y,
            yy * z,
            yz * z,
            zz * z,
            xx * xx,
            xx * xy,
            xx * xz,
            xx * yy,
            xx * yz,
            xx * zz,
            xy * yy,
            xy * yz,
            xy * zz,
            xz * zz,
            yy * yy,
            yy * yz,
            yy * zz,
            yz * zz,
            zz * zz,
        ];
        for (acc, t) in self.block.iter_mut().zip(&terms) {
            *acc += t;
        }
        self.block_n = self.block_n.saturating_add(1);
        if self.block_n >= BLOCK {
            for (tot, acc) in self.total.iter_mut().zip(&mut self.block) {
                *tot += f64::from(*acc);
                *acc = 0.0;
            }
            self.block_n = 0;
        }
        self.cov.push(m, self.count == 0);
        self.count = self.count.saturating_add(1);
        Ok(())
    }

    /// Directions covered relative to the min/max box centre, each axis
    /// scaled by its half-range.
    fn box_coverage(&self) -> u8 {
        let mut center = [0.0f64; 3];
        let mut w = Matrix3::<f64>::zeros();
        let (min, max) = (&self.cov.min, &self.cov.max);
        for (i, ((c, lo), hi)) in center.iter_mut().zip(min).zip(max).enumerate() {
            let (lo, hi) = (f64::from(*lo), f64::from(*hi));
            *c = 0.5 * (lo + hi);
            let half = 0.5 * (hi - lo);
            if half.is_nan() || half <= 0.0 {
                return 0;
            }
            if let Some(wii) = w.get_mut((i, i)) {
                *wii = 1.0 / half;
            }
        }
        if self.count == 0 {
            return 0;
        }
        self.coverage(center, &w)
    }

    /// Directions covered relative to `center` in the space corrected by `w`
    /// (`corrected = w·(m − center)`): the support point of raw direction
    /// `d` corresponds to corrected direction `w⁻ᵀd`; it is covered when the
    /// corrected support point lies within 30° of that.
    fn coverage(&self, center: [f64; 3], w: &Matrix3<f64>) -> u8 {
        let Some(w_inv_t) = w.try_inverse().map(|m| m.transpose()) else {
            return 0;
        };
        let c = Vector3::from(center);
        let mut covered = 0u8;
        for (dir, sup) in DIRECTIONS.iter().zip(&self.cov.support) {
            let d = Vector3::new(f64::from(dir[0]), f64::from(dir[1]), f64::from(dir[2]));
            let want = w_inv_t * d;
            let p = Vector3::new(f64::from(sup[0]), f64::from(sup[1]), f64::from(sup[2]));
            let got = w * (p - c);
            let denom = want.norm() * got.norm();
            if denom > 0.0 && want.dot(&got) >= COVERAGE_COS * denom {
                covered = covered.saturating_add(1);
            }
        }
        covered
    }

    /// Fit the ellipsoid.
    ///
    /// Errors, in the order checked: [`Error::TooFewSamples`],
    /// [`Error::RangeTooSmall`], [`Error::InsufficientCoverage`],
    /// [`Error::Singular`], [`Error::NotEllipsoid`], [`Error::OutOfRange`]
    /// (gains outside [`MIN_GAIN`](crate::MIN_GAIN)..=[`MAX_GAIN`](crate::MAX_GAIN),
    /// i.e. semi-axis ratio beyond ~5), [`Error::PoorFit`].
    pub fn finish(&self) -> Result<EllipsoidSolution, Error> {
        let need = self.config.min_samples.max(10);
        if self.count < need {
            return Err(Error::TooFewSamples {
                have: self.count,
                need,
            });
        }
        check_ranges(self.ranges(), self.config.min_range)?;
        let bins_needed = self.config.bins_needed;
        let bins_hit = self.box_coverage();
        if bins_hit < bins_needed {
            return Err(Error::InsufficientCoverage {
                bins_hit,
                bins_needed,
            });
        }
        let moments = self.scaled_moments()?;
        let fit = solve(&moments, self.count)?;
        let s = moments.scale;
        let [ox, oy, oz] = self.origin;
        let center = [
            f64::from(ox) + s * fit.center[0],
            f64::from(oy) + s * fit.center[1],
            f64::from(oz) + s * fit.center[2],
        ];
        let bins_hit = self.coverage(center, &fit.w);
        if bins_hit < bins_needed {
            return Err(Error::InsufficientCoverage {
                bins_hit,
                bins_needed,
            });
        }
        let offset = [center[0] as f32, center[1] as f32, center[2] as f32];
        let w = &fit.w;
        let calibration = MagCalibration {
            offset,
            soft_iron: [
                [w[(0, 0)] as f32, w[(0, 1)] as f32, w[(0, 2)] as f32],
                [w[(1, 0)] as f32, w[(1, 1)] as f32, w[(1, 2)] as f32],
                [w[(2, 0)] as f32, w[(2, 1)] as f32, w[(2, 2)] as f32],
            ],
        };
        calibration.validate()?;
        let [a0, a1, a2] = fit.semi_axes;
        let solution = EllipsoidSolution {
            calibration,
            radius: (s * fit.radius) as f32,
            semi_axes: [(s * a0) as f32, (s * a1) as f32, (s * a2) as f32],
            rms_error: fit.rms_error as f32,
            offset_std_error: (s * fit.offset_std_error) as f32,
            bins_hit,
            samples: self.count,
        };
        let finite = solution.radius.is_finite()
            && solution.semi_axes.iter().all(|a| a.is_finite())
            && solution.rms_error.is_finite()
            && solution.offset_std_error.is_finite();
        if !finite {
            return Err(Error::OutOfRange);
        }
        if solution.rms_error.is_nan() || solution.rms_error > self.config.max_rms_error {
            return Err(Error::PoorFit {
                rms_error: solution.rms_error,
                limit: self.config.max_rms_error,
            });
        }
        if solution.offset_std_error > self.config.max_offset_std_error {
            return Err(Error::UncertainOffset {
                std_error: solution.offset_std_error,
                limit: self.config.max_offset_std_error,
            });
        }
        Ok(solution)
    }

    /// Mean moments about `origin`, rescaled by the RMS distance `s`.
    fn scaled_moments(&self) -> Result<Moments, Error> {
        let n = f64::from(self.count);
        let mut mean = [0.0f64; N_MOMENTS + 1];
        mean[0] = 1.0;
        for ((dst, t), b) in mean.iter_mut().skip(1).zip(&self.total).zip(&self.block) {
            *dst = (t + f64::from(*b)) / n;
        }
        // mean[4], mean[7], mean[9] are x², y², z² (index 0 is the constant).
        let s2 = mean[4] + mean[7] + mean[9];
        if !(s2 > 0.0 && s2.is_finite()) {
            return Err(Error::Singular);
        }
        let scale = libm::sqrt(s2);
        let inv = 1.0 / scale;
        let inv_pow = [inv, inv * inv, inv * inv * inv, (inv * inv) * (inv * inv)];
        for (dst, e) in mean.iter_mut().skip(1).zip(EXPONENTS.iter()) {
            let degree = usize::from(e[0] + e[1] + e[2]);
            let p = inv_pow
                .get(degree.wrapping_sub(1))
                .copied()
                .unwrap_or(f64::NAN);
            *dst *= p;
        }
        Ok(Moments { mean, scale })
    }
}

/// Exponents (a, b, c) of the accumulated monomials, in accumulation order
/// (graded, then a descending, then b descending).
pub(crate) const EXPONENTS: [[u8; 3]; N_MOMENTS] = [
    [1, 0, 0],
    [0, 1, 0],
    [0, 0, 1],
    [2, 0, 0],
    [1, 1, 0],
    [1, 0, 1],
    [0, 2, 0],
    [0, 1, 1],
    [0, 0, 2],
    [3, 0, 0],
    [2, 1, 0],
    [2, 0, 1],
    [1, 2, 0],
    [1, 1, 1],
    [1, 0, 2],
    [0, 3, 0],
    [0, 2, 1],
    [0, 1, 2],
    [0, 0, 3],
    [4, 0, 0],
    [3, 1, 0],
    [3, 0, 1],
    [2, 2, 0],
    [2, 1, 1],
    [2, 0, 2],
    [1, 3, 0],
    [1, 2, 1],
    [1, 1, 2],
    [1, 0, 3],
    [0, 4, 0],
    [0, 3, 1],
    [0, 2, 2],
    [0, 1, 3],
    [0, 0, 4],
];

/// Index of monomial `xᵃyᵇzᶜ` in [`Moments::mean`] (0 = constant), `None`
/// above degree 4.
pub(crate) fn moment_index(a: u8, b: u8, c: u8) -> Option<usize> {
    let (a, b, c) = (usize::from(a), usize::from(b), usize::from(c));
    let d = a + b + c;
    let offset = [0usize, 1, 4, 10, 20].get(d).copied()?;
    let da = d - a;
    Some(offset + da * (da + 1) / 2 + c)
}

/// Mean scaled moments: `mean[i] = mean over samples of (x/s)ᵃ(y/s)ᵇ(z/s)ᶜ`.
struct Moments {
    mean: [f64; N_MOMENTS + 1],
    scale: f64,
}

impl Moments {
    /// Mean of the monomial with exponents `e`; NaN above degree 4 (never
    /// requested), which makes the fit fail rather than silently succeed.
    fn get(&self, e: [u8; 3]) -> f64 {
        let [a, b, c] = e;
        moment_index(a, b, c)
            .and_then(|i| self.mean.get(i).copied())
            .unwrap_or(f64::NAN)
    }

    /// Mean of `p(x)·q(x)` for sparse polynomials of degree ≤ 2.
    fn product(&self, p: &[Term], q: &[Term]) -> f64 {
        let mut acc = 0.0;
        for (ep, cp) in p {
            for (eq, cq) in q {
                let e = [
                    ep[0].saturating_add(eq[0]),
                    ep[1].saturating_add(eq[1]),
                    ep[2].saturating_add(eq[2]),
                ];
                acc += cp * cq * self.get(e);
            }
        }
        acc
    }
}

/// A polynomial term: exponents and coefficient.
pub(crate) type Term = ([u8; 3], f64);

const X2: [u8; 3] = [2, 0, 0];
const Y2: [u8; 3] = [0, 2, 0];
const Z2: [u8; 3] = [0, 0, 2];

/// Petrov regressors (trace-constrained general quadric).
pub(crate) const REGRESSORS: [&[Term]; 9] = [
    &[(X2, 1.0), (Y2, 1.0), (Z2, -2.0)],
    &[(X2, 1.0), (Z2, 1.0), (Y2, -2.0)],
    &[([1, 1, 0], 2.0)],
    &[([1, 0, 1], 2.0)],
    &[([0, 1, 1], 2.0)],
    &[([1, 0, 0], 2.0)],
    &[([0, 1, 0], 2.0)],
    &[([0, 0, 1], 2.0)],
    &[([0, 0, 0], 1.0)],
];

/// Regression target `x² + y² + z²`.
pub(crate) const TARGET: &[Term] = &[(X2, 1.0), (Y2, 1.0), (Z2, 1.0)];

/// Fit result in scaled coordinates.
struct Fit {
    center: [f64; 3],
    w: Matrix3<f64>,
    radius: f64,
    semi_axes: [f64; 3],
    rms_error: f64,
    offset_std_error: f64,
}

fn solve(mom: &Moments, count: u32) -> Result<Fit, Error> {
    let (u, normal) = least_squares(mom)?;
    let (c, shape, m_inv, k) = quadric_centre_and_shape(u)?;
    let (w, radius, semi_axes) = axes_and_soft_iron(shape)?;
    let rms_error = rms_residual(mom, &shape, &c);
    // The regression residual is k·p, p the residual rms_error is the RMS of ×½.
    let residual = 2.0 * k.abs() * rms_error;
    Ok(Fit {
        center: [c[0], c[1], c[2]],
        w,
        radius,
        semi_axes,
        rms_error,
        offset_std_error: centre_std_error(&normal, &m_inv, &c, residual, count),
    })
}

/// The equilibrated normal matrix's Cholesky factor `L` (lower triangle)
/// and the equilibration `D`: `N = D⁻¹LLᵀD⁻¹`.
struct NormalFactor {
    l: [[f64; 9]; 9],
    d: [f64; 9],
}

/// Largest per-axis standard error of the centre `c = −M⁻¹b` (scaled
/// units). To first order `dc = −M⁻¹G·du`, where column `k` of `G` is half
/// the gradient of regressor `k` at `c`; with `Cov(u) = σ²/n · N⁻¹` and
/// `N⁻¹ = D L⁻ᵀL⁻¹ D`, axis `j`'s variance is `σ²/n · |L⁻¹DGᵀM⁻¹eⱼ|²`.
fn centre_std_error(
    f: &NormalFactor,
    m_inv: &Matrix3<f64>,
    c: &Vector3<f64>,
    residual: f64,
    count: u32,
) -> f64 {
    let mut worst = 0.0f64;
    for j in 0..3 {
        let v = m_inv.column(j);
        let (x, y, z) = (c[0], c[1], c[2]);
        let mut g = [
            x * v[0] + y * v[1] - 2.0 * z * v[2],
            x * v[0] - 2.0 * y * v[1] + z * v[2],
            y * v[0] + x * v[1],
            z * v[0] + x * v[2],
            z * v[1] + y * v[2],
            v[0],
            v[1],
            v[2],
            0.0,
        ];
        for (gi, di) in g.iter_mut().zip(&f.d) {
            *gi *= di;
        }
        forward_substitute(&f.l, &mut g);
        worst = worst.max(g.iter().map(|v| v * v).sum());
    }
    residual * libm::sqrt(worst / f64::from(count.max(1)))
}

/// The nine regression coefficients `u` of `REGRESSORS·u ≈ TARGET`, and
/// the normal matrix's factor.
fn least_squares(mom: &Moments) -> Result<([f64; 9], NormalFactor), Error> {
    // Normal matrix N = mean φφᵀ (lower triangle is enough) and right-hand
    // side mean φ·target, then Jacobi equilibration D·N·D (unit diagonal)
    // with D = diag(1/√Nᵢᵢ).
    let mut a = [[0.0f64; 9]; 9];
    let mut rhs = [0.0f64; 9];
    for ((row, r), phi_i) in a.iter_mut().zip(&mut rhs).zip(REGRESSORS.iter()) {
        for (aij, phi_j) in row.iter_mut().zip(REGRESSORS.iter()) {
            *aij = mom.product(phi_i, phi_j);
        }
        *r = mom.product(phi_i, TARGET);
    }
    let mut d = [0.0f64; 9];
    for (di, (i, row)) in d.iter_mut().zip(a.iter().enumerate()) {
        let nii = row.get(i).copied().unwrap_or(f64::NAN);
        if nii.is_nan() || nii <= 0.0 || !nii.is_finite() {
            return Err(Error::Singular);
        }
        *di = 1.0 / libm::sqrt(nii);
    }
    for (row, di) in a.iter_mut().zip(&d) {
        for (aij, dj) in row.iter_mut().zip(&d) {
            *aij *= di * dj;
        }
    }
    for (r, di) in rhs.iter_mut().zip(&d) {
        *r *= di;
    }
    cholesky_solve(&mut a, &mut rhs)?;
    for (r, di) in rhs.iter_mut().zip(&d) {
        *r *= di;
    }
    Ok((rhs, NormalFactor { l: a, d }))
}

/// Centre `c` and shape `S` of the ellipsoid `(x − c)ᵀS(x − c) = 1` the
/// coefficients describe, with `M⁻¹` and the scale `k` (`S = M/k`); an
/// error where they describe no ellipsoid.
#[allow(clippy::type_complexity)]
fn quadric_centre_and_shape(
    u: [f64; 9],
) -> Result<(Vector3<f64>, Matrix3<f64>, Matrix3<f64>, f64), Error> {
    let [u1, u2, u3, u4, u5, u6, u7, u8, u9] = u;

    // Quadric xᵀMx + 2bᵀx + J = 0 (= regressors·u − target).
    let m = Matrix3::new(
        u1 + u2 - 1.0,
        u3,
        u4,
        u3,
        u1 - 2.0 * u2 - 1.0,
        u5,
        u4,
        u5,
        u2 - 2.0 * u1 - 1.0,
    );
    let b = Vector3::new(u6, u7, u8);
    let j = u9;
    let m_inv = m.try_inverse().ok_or(Error::NotEllipsoid)?;
    let c = -(m_inv * b);
    let k = c.dot(&(m * c)) - j;
    if !(k.is_finite() && k != 0.0) {
        return Err(Error::NotEllipsoid);
    }
    let shape = m / k;
    if !shape.iter().all(|v| v.is_finite()) {
        return Err(Error::NotEllipsoid);
    }
    Ok((c, shape, m_inv, k))
}

/// Soft-iron matrix `W` (maps the ellipsoid onto a sphere of the mean
/// radius), that radius, and the semi-axes ascending.
fn axes_and_soft_iron(shape: Matrix3<f64>) -> Result<(Matrix3<f64>, f64, [f64; 3]), Error> {
    let eig = SymmetricEigen::try_new(shape, 1.0e-14, 200).ok_or(Error::NotEllipsoid)?;
    let lambda = eig.eigenvalues;
    if !lambda.iter().all(|l| *l > 0.0 && l.is_finite()) {
        return Err(Error::NotEllipsoid);
    }
    let mut semi_axes = [0.0f64; 3];
    for (a, l) in semi_axes.iter_mut().zip(lambda.iter()) {
        *a = 1.0 / libm::sqrt(*l);
    }
    let radius = (semi_axes[0] + semi_axes[1] + semi_axes[2]) / 3.0;
    let sqrt_l = Vector3::new(
        radius * libm::sqrt(lambda[0]),
        radius * libm::sqrt(lambda[1]),
        radius * libm::sqrt(lambda[2]),
    );
    let v = eig.eigenvectors;
    let w = v * Matrix3::from_diagonal(&sqrt_l) * v.transpose();
    sort3(&mut semi_axes);
    Ok((w, radius, semi_axes))
}

/// RMS of the residual `((x − c)ᵀS(x − c) − 1) / 2` over the samples: to
/// first order the relative deviation of the corrected magnitude.
fn rms_residual(mom: &Moments, shape: &Matrix3<f64>, c: &Vector3<f64>) -> f64 {
    // Residual p(x) = (x − c)ᵀS(x − c) − 1 = xᵀSx − 2(Sc)ᵀx + cᵀSc − 1,
    // mean of p² from the moments.
    let sc = shape * c;
    let p: [Term; 10] = [
        (X2, shape[(0, 0)]),
        (Y2, shape[(1, 1)]),
        (Z2, shape[(2, 2)]),
        ([1, 1, 0], 2.0 * shape[(0, 1)]),
        ([1, 0, 1], 2.0 * shape[(0, 2)]),
        ([0, 1, 1], 2.0 * shape[(1, 2)]),
        ([1, 0, 0], -2.0 * sc[0]),
        ([0, 1, 0], -2.0 * sc[1]),
        ([0, 0, 1], -2.0 * sc[2]),
        ([0, 0, 0], c.dot(&sc) - 1.0),
    ];
    let mean_p2 = mom.product(&p, &p);
    0.5 * libm::sqrt(mean_p2.max(0.0))
}

/// Sort three values ascending (no slice-sort machinery on the target).
pub(crate) fn sort3<T: PartialOrd + Copy>(v: &mut [T; 3]) {
    let [mut a, mut b, mut c] = *v;
    if a > b {
        core::mem::swap(&mut a, &mut b);
    }
    if b > c {
        core::mem::swap(&mut b, &mut c);
    }
    if a > b {
        core::mem::swap(&mut a, &mut b);
    }
    *v = [a, b, c];
}

/// Solve `A·x = b` in place for a symmetric positive-definite 9×9 `A`
/// (Cholesky–Banachiewicz on the lower triangle, then forward and back
/// substitution; `b` becomes `x`, `A`'s lower triangle becomes `L`).
///
/// Written out instead of using nalgebra's `Cholesky` to keep `finish`'s
/// stack small (one 648-byte matrix, no copies). All indices are loop
/// variables bounded by the array length 9, so no index can be out of range.
/// [`Error::Singular`] when a pivot² falls below [`PIVOT_MIN`] (for the
/// unit-diagonal input: the share of a regressor's variance not explained by
/// the previous ones) or is not finite.
#[allow(clippy::needless_range_loop)] // index form mirrors the textbook algorithm
fn cholesky_solve(a: &mut [[f64; 9]; 9], b: &mut [f64; 9]) -> Result<(), Error> {
    const N: usize = 9;
    for i in 0..N {
        for j in 0..=i {
            let mut sum = a[i][j];
            for k in 0..j {
                sum -= a[i][k] * a[j][k];
            }
            if i == j {
                if sum.is_nan() || sum < PIVOT_MIN || !sum.is_finite() {
                    return Err(Error::Singular);
                }
                a[i][i] = libm::sqrt(sum);
            } else {
                a[i][j] = sum / a[j][j];
            }
        }
    }
    forward_substitute(a, b);
    // Lᵀ·x = y
    for i in (0..N).rev() {
        let mut sum = b[i];
        for k in (i + 1)..N {
            sum -= a[k][i] * b[k];
        }
        b[i] = sum / a[i][i];
    }
    if b.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::Singular)
    }
}

/// `L·y = b` in place for the lower triangle `L` of `a` (`b` becomes `y`).
#[allow(clippy::needless_range_loop)] // index form mirrors the textbook algorithm
fn forward_substitute(a: &[[f64; 9]; 9], b: &mut [f64; 9]) {
    for i in 0..9 {
        let mut sum = b[i];
        for k in 0..i {
            sum -= a[i][k] * b[k];
        }
        b[i] = sum / a[i][i];
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::needless_range_loop)]
mod tests {
    use super::*;

    #[test]
    fn exponent_table_matches_index_formula() {
        for (i, e) in EXPONENTS.iter().enumerate() {
            assert_eq!(moment_index(e[0], e[1], e[2]), Some(i + 1), "{e:?}");
        }
        assert_eq!(moment_index(0, 0, 0), Some(0));
        assert_eq!(moment_index(5, 0, 0), None);
    }

    #[test]
    fn accumulated_terms_match_exponents() {
        let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
        fit.push([0.0, 0.0, 0.0]).unwrap();
        let (x, y, z) = (1.5f32, -0.7f32, 2.3f32);
        fit.push([x, y, z]).unwrap();
        for (acc, e) in fit.block.iter().zip(EXPONENTS.iter()) {
            let want = x.powi(i32::from(e[0])) * y.powi(i32::from(e[1])) * z.powi(i32::from(e[2]));
            assert!(
                (acc - want).abs() <= 1e-5 * want.abs().max(1.0),
                "{e:?}: {acc} vs {want}"
            );
        }
    }

    #[test]
    fn cholesky_solves_a_known_system_and_rejects_singular() {
        // A = MᵀM + I for a fixed M, x known.
        let mut a = [[0.0f64; 9]; 9];
        for i in 0..9 {
            for j in 0..9 {
                let mij = |i: usize, j: usize| ((i * 7 + j * 3) % 5) as f64 - 2.0;
                a[i][j] = (0..9).map(|k| mij(k, i) * mij(k, j)).sum::<f64>();
            }
            a[i][i] += 1.0;
        }
        let x: [f64; 9] = [1.0, -2.0, 0.5, 3.0, 0.0, -1.5, 2.5, 4.0, -0.25];
        let mut b = [0.0; 9];
        for i in 0..9 {
            b[i] = (0..9).map(|j| a[i][j] * x[j]).sum();
        }
        let mut a2 = a;
        cholesky_solve(&mut a2, &mut b).unwrap();
        for (got, want) in b.iter().zip(&x) {
            assert!((got - want).abs() < 1e-9, "{got} vs {want}");
        }
        // Rank-deficient: two equal rows/columns.
        let mut s = [[1.0f64; 9]; 9];
        let mut rhs = [1.0; 9];
        assert_eq!(cholesky_solve(&mut s, &mut rhs), Err(Error::Singular));
    }
}
