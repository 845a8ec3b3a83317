//! The ellipsoid fit for the board; the method is documented on
//! [`EllipsoidFitF32`].

// The API and the solve's steps repeat ellipsoid.rs's on purpose: the same fit with
// integer moments and f32 arithmetic, so the board links no f64 code; the end-to-end
// test `board_ellipsoid_fit_agrees_with_the_host_fit` compares the two.

use crate::ellipsoid::{
    check_ranges, moment_index, sort3, Coverage, COVERAGE_COS, DIRECTIONS, EXPONENTS, N_MOMENTS,
};
use crate::{
    check_input, EllipsoidFitConfig, EllipsoidSolution, Error, MagCalibration, COVERAGE_BINS,
};

/// Most samples [`EllipsoidFitF32`] accumulates (the `i64` sums stay exact).
pub const MAX_SAMPLES_F32: u32 = 30_000;

/// Largest quantised distance from the first sample, per axis.
const X_MAX: i32 = 4096;

/// Smallest accepted Cholesky pivot² of the equilibrated normal matrix.
pub const PIVOT_MIN_F32: f32 = 1.0e-5;

/// A polynomial term: exponents and coefficient.
type TermF32 = ([u8; 3], f32);

const X2: [u8; 3] = [2, 0, 0];
const Y2: [u8; 3] = [0, 2, 0];
const Z2: [u8; 3] = [0, 0, 2];

/// The host fit's Petrov regressors with `f32` coefficients (the same
/// small integers; a test checks the tables agree), so no `f64` → `f32`
/// conversion is linked.
const REGRESSORS_F32: [&[TermF32]; 9] = [
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
const TARGET_F32: &[TermF32] = &[(X2, 1.0), (Y2, 1.0), (Z2, 1.0)];

/// A 3×3 matrix, row-major. Indices in this file are loop variables or
/// constants bounded by the array lengths (3 and 9), so none is out of range.
type M3 = [[f32; 3]; 3];

/// The ellipsoid fit for the board: the same model, coverage check and
/// fit-quality figure as [`EllipsoidFit`](crate::EllipsoidFit), with exact
/// integer moments and an `f32` solve, so it links no `f64` arithmetic and
/// no linear-algebra crate.
///
/// # Method
///
/// Samples are quantised relative to the first accepted one,
/// `x = round((m − p₀) / quantum)` (`|x| ≤ 4096` per axis), and the 34
/// monomials of degree 1..=4 are summed in `i64` — exactly: `4096⁴ · 30 000
/// < 2⁶³`, so at most [`MAX_SAMPLES_F32`] samples are taken. The rounding
/// adds uniform noise of `quantum / √12` per axis (0.036 µT at the
/// 0.125 µT the firmware uses, below the AK8963's 0.15 µT step).
///
/// At `finish` the sums become means rescaled by the RMS distance `s`
/// (f32), and the trace-constrained quadric (Petrov's regressors, as the
/// host fit) is solved from its 9×9 normal equations: Jacobi-equilibrated
/// to a unit diagonal, then an in-place Cholesky decomposition in `f32`.
///
/// # Conditioning
///
/// Equilibration gives the normal matrix a unit diagonal, so its Cholesky
/// pivots² are the fractions of each regressor's variance the previous ones
/// leave unexplained, and their smallest bounds the condition number. A
/// pivot² below [`PIVOT_MIN_F32`] (1e-5: a condition number above ~10⁵,
/// where `f32`'s 6e-8 relative precision would leave fewer than three
/// significant digits in the solution) is refused as [`Error::Singular`]
/// instead of being solved badly. The moments themselves are exact. The
/// e2e tests compare with the `f64` host fit on the simulator's distortions
/// (figure-eight, 40 s, soft iron ±15 % and ±30 %, hard iron up to 83 µT):
/// offsets within 0.05 µT, soft-iron elements within 1e-3, radius within
/// 0.02 µT, rms error within 1 %, the same coverage; a planar sweep and a
/// hemisphere are refused with the same error as by the host fit.
///
/// The code mirrors `ellipsoid.rs` step by step (the same checks in the
/// same order, `f32` for `f64`) so the two read side by side; what both use
/// (coverage record, range check, exponent table, sort) lives there once.
///
/// Then, as the host fit: centre `c = −M⁻¹b`, shape `S = M / (cᵀMc − J)`,
/// symmetric eigen-decomposition (cyclic Jacobi in `f32`), `W = R · V
/// diag(√λ) Vᵀ` with `R` the mean semi-axis, and the rms error from the
/// moments. The coverage is judged exactly as by the host fit (14
/// directions, 30°), before the fit from the min/max box and after it from
/// the fitted centre and `W`.
///
/// Same configuration, errors and [`EllipsoidSolution`] as
/// [`EllipsoidFit`](crate::EllipsoidFit).
///
/// ```
/// use calibration::{EllipsoidFitConfig, EllipsoidFitF32};
///
/// let mut fit = EllipsoidFitF32::new(EllipsoidFitConfig::MICROTESLA, 0.125)?;
/// // 50 µT field, hard-iron offset (12, -7, 30) µT, z squeezed to 80 %.
/// for i in 0..40 {
///     let t = -0.95 + 1.9 * (i as f32 + 0.5) / 40.0;
///     let r = libm::sqrtf(1.0 - t * t);
///     for j in 0..20 {
///         let phi = j as f32 * 0.314_159_27 + i as f32 * 0.1;
///         let h = [r * libm::cosf(phi), r * libm::sinf(phi), t];
///         fit.push([12.0 + 50.0 * h[0], -7.0 + 50.0 * h[1], 30.0 + 40.0 * h[2]])?;
///     }
/// }
/// let sol = fit.finish()?;
/// assert!((sol.calibration.offset[2] - 30.0).abs() < 0.05);
/// let c = sol.calibration.apply([12.0, -7.0, 70.0]); // +z pole
/// assert!((c[2] - sol.radius).abs() < 0.01 * sol.radius);
/// # Ok::<(), calibration::Error>(())
/// ```
///
/// State 568 bytes (`size_of` on the host): 34 `i64` sums, the reference sample, the min/max box
/// and 14 support points.
#[derive(Debug, Clone, Copy)]
pub struct EllipsoidFitF32 {
    config: EllipsoidFitConfig,
    quantum: f32,
    inv_quantum: f32,
    origin: [f32; 3],
    sums: [i64; N_MOMENTS],
    count: u32,
    rejected: u32,
    cov: Coverage,
}

impl EllipsoidFitF32 {
    /// A fresh fit; `quantum` is the input resolution of the moments (e.g.
    /// 0.125 µT), samples may lie up to `4096 · quantum` from the first one.
    /// [`Error::InvalidConfig`] if `config` or `quantum` is unusable.
    pub fn new(config: EllipsoidFitConfig, quantum: f32) -> Result<Self, Error> {
        config.validate()?;
        if !(quantum.is_finite() && quantum > 0.0) {
            return Err(Error::InvalidConfig);
        }
        Ok(Self {
            config,
            quantum,
            inv_quantum: 1.0 / quantum,
            origin: [0.0; 3],
            sums: [0; N_MOMENTS],
            count: 0,
            rejected: 0,
            cov: Coverage::new(),
        })
    }

    /// Accepted samples.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Samples skipped (non-finite, out of range, or beyond
    /// [`MAX_SAMPLES_F32`]).
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Coverage directions covered so far, judged from the min/max box.
    pub fn bins_hit(&self) -> u8 {
        self.box_coverage()
    }

    /// Per-axis max − min so far (input unit).
    pub fn ranges(&self) -> [f32; 3] {
        self.cov.ranges()
    }

    /// Add a sample (input unit). [`Error::NonFinite`],
    /// [`Error::InputOutOfRange`] (also farther than `4096 · quantum` from
    /// the first sample, or past [`MAX_SAMPLES_F32`]): skipped and counted,
    /// state unchanged.
    // Not inlined into the caller: one copy, and a smaller firmware.
    #[inline(never)]
    pub fn push(&mut self, m: [f32; 3]) -> Result<(), Error> {
        if let Err(e) = check_input(&m) {
            self.rejected = self.rejected.saturating_add(1);
            return Err(e);
        }
        if self.count >= MAX_SAMPLES_F32 {
            self.rejected = self.rejected.saturating_add(1);
            return Err(Error::InputOutOfRange);
        }
        let origin = if self.count == 0 { m } else { self.origin };
        let mut q = [0i32; 3];
        for ((qi, &mi), &oi) in q.iter_mut().zip(&m).zip(&origin) {
            let v = (mi - oi) * self.inv_quantum;
            if v.is_nan() || v.abs() > X_MAX as f32 {
                self.rejected = self.rejected.saturating_add(1);
                return Err(Error::InputOutOfRange);
            }
            *qi = (if v >= 0.0 { v + 0.5 } else { v - 0.5 }) as i32;
        }
        if self.count == 0 {
            self.origin = m;
        }
        self.accumulate(q);
        self.cov.push(m, self.count == 0);
        self.count = self.count.saturating_add(1);
        Ok(())
    }

    /// Adds every monomial `xᵃyᵇzᶜ` (degree 1..=4, the host fit's order)
    /// from the powers of each coordinate: a table loop rather than 34
    /// written-out products, which saves ~1 KiB of flash.
    fn accumulate(&mut self, q: [i32; 3]) {
        let powers = |v: i32| {
            let v = i64::from(v);
            let v2 = v * v;
            [1, v, v2, v2 * v, v2 * v2]
        };
        let [px, py, pz] = q.map(powers);
        let pick = |p: &[i64; 5], e: u8| p.get(usize::from(e)).copied().unwrap_or(0);
        for (s, e) in self.sums.iter_mut().zip(EXPONENTS.iter()) {
            // |x|, |y|, |z| ≤ 4096 and degree ≤ 4: every product fits.
            let t = pick(&px, e[0])
                .wrapping_mul(pick(&py, e[1]))
                .wrapping_mul(pick(&pz, e[2]));
            // Exact by the sample cap; saturation only as a guard.
            *s = s.saturating_add(t);
        }
    }

    fn box_coverage(&self) -> u8 {
        if self.count == 0 {
            return 0;
        }
        let mut center = [0.0f32; 3];
        let mut inv_half = [0.0f32; 3];
        for (((c, ih), lo), hi) in center
            .iter_mut()
            .zip(&mut inv_half)
            .zip(&self.cov.min)
            .zip(&self.cov.max)
        {
            *c = 0.5 * (lo + hi);
            let half = 0.5 * (hi - lo);
            if half.is_nan() || half <= 0.0 {
                return 0;
            }
            *ih = 1.0 / half;
        }
        let [a, b, c] = inv_half;
        self.coverage(center, &[[a, 0.0, 0.0], [0.0, b, 0.0], [0.0, 0.0, c]])
    }

    /// As the host fit's: the support point of raw direction `d` is
    /// covered when, corrected by `w` about `center`, it lies within 30° of
    /// the corrected direction `w⁻ᵀd`.
    fn coverage(&self, center: [f32; 3], w: &M3) -> u8 {
        let Some(w_inv_t) = inverse_t(w) else {
            return 0;
        };
        const COS: f32 = COVERAGE_COS as f32;
        let cos = COS;
        let mut covered = 0u8;
        for (dir, sup) in DIRECTIONS.iter().zip(&self.cov.support) {
            let d = dir.map(f32::from);
            let want = mul(&w_inv_t, d);
            let got = mul(w, sub(*sup, center));
            let denom2 = dot(want, want) * dot(got, got);
            let wg = dot(want, got);
            // want·got ≥ cos·|want||got|, squared (both sides ≥ 0).
            if denom2 > 0.0 && wg > 0.0 && wg * wg >= cos * cos * denom2 {
                covered = covered.saturating_add(1);
            }
        }
        covered
    }

    /// Fit the ellipsoid. Errors, in the order checked, as
    /// [`EllipsoidFit::finish`](crate::EllipsoidFit::finish).
    // Not inlined into the caller: one copy, and a smaller firmware.
    #[inline(never)]
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
        let mom = self.scaled_moments()?;
        let fit = solve(&mom, self.count)?;
        let s = mom.scale * self.quantum;
        let [ox, oy, oz] = self.origin;
        let [cx, cy, cz] = fit.center;
        let center = [ox + s * cx, oy + s * cy, oz + s * cz];
        let bins_hit = self.coverage(center, &fit.w);
        if bins_hit < bins_needed {
            return Err(Error::InsufficientCoverage {
                bins_hit,
                bins_needed,
            });
        }
        let calibration = MagCalibration {
            offset: center,
            soft_iron: fit.w,
        };
        calibration.validate()?;
        let solution = EllipsoidSolution {
            calibration,
            radius: s * fit.radius,
            semi_axes: fit.semi_axes.map(|a| s * a),
            rms_error: fit.rms_error,
            offset_std_error: s * fit.offset_std_error,
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
        if solution.rms_error > self.config.max_rms_error {
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

    /// Means of the quantised monomials rescaled by the RMS distance.
    fn scaled_moments(&self) -> Result<MomentsF32, Error> {
        let inv_n = 1.0 / self.count as f32;
        let mut mean = [0.0f32; N_MOMENTS + 1];
        mean[0] = 1.0;
        for (dst, &t) in mean.iter_mut().skip(1).zip(&self.sums) {
            *dst = t as f32 * inv_n;
        }
        let s2 = mean[4] + mean[7] + mean[9];
        if !(s2 > 0.0 && s2.is_finite()) {
            return Err(Error::Singular);
        }
        let scale = crate::sqrt::sqrtf(s2);
        let inv = 1.0 / scale;
        for (dst, e) in mean.iter_mut().skip(1).zip(EXPONENTS.iter()) {
            for _ in 0..e[0] + e[1] + e[2] {
                *dst *= inv;
            }
        }
        Ok(MomentsF32 { mean, scale })
    }
}

struct MomentsF32 {
    mean: [f32; N_MOMENTS + 1],
    scale: f32,
}

impl MomentsF32 {
    fn get(&self, e: [u8; 3]) -> f32 {
        moment_index(e[0], e[1], e[2])
            .and_then(|i| self.mean.get(i).copied())
            .unwrap_or(f32::NAN)
    }

    /// Mean of `p·q` for sparse polynomials of degree ≤ 2.
    fn product(&self, p: &[TermF32], q: &[TermF32]) -> f32 {
        let mut acc = 0.0f32;
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

struct FitF32 {
    center: [f32; 3],
    w: M3,
    radius: f32,
    semi_axes: [f32; 3],
    rms_error: f32,
    offset_std_error: f32,
}

#[inline(never)]
fn solve(mom: &MomentsF32, count: u32) -> Result<FitF32, Error> {
    let mut normal = NormalFactorF32 {
        l: [[0.0; 9]; 9],
        d: [0.0; 9],
    };
    let u = least_squares(mom, &mut normal)?;
    let (c, shape, m_inv, k) = quadric_centre_and_shape(u)?;
    let (w, radius, semi_axes) = axes_and_soft_iron(shape)?;
    let rms_error = rms_residual(mom, &shape, c);
    // The regression residual is k·p; rms_error is the RMS of p/2.
    let residual = 2.0 * k.abs() * rms_error;
    Ok(FitF32 {
        center: c,
        w,
        radius,
        semi_axes,
        rms_error,
        offset_std_error: centre_std_error(&normal, &m_inv, c, residual, count),
    })
}

/// The equilibrated normal matrix's Cholesky factor `L` (lower triangle)
/// and the equilibration `D`: `N = D⁻¹LLᵀD⁻¹`.
struct NormalFactorF32 {
    l: [[f32; 9]; 9],
    d: [f32; 9],
}

/// Largest per-axis standard error of the centre (scaled units), as the
/// host fit's `centre_std_error`: axis `j`'s variance is `σ²/n ·
/// |L⁻¹DGᵀM⁻¹eⱼ|²`, column `k` of `G` half the gradient of regressor `k`
/// at `c`.
#[inline(never)]
fn centre_std_error(f: &NormalFactorF32, m_inv: &M3, c: [f32; 3], residual: f32, n: u32) -> f32 {
    let [x, y, z] = c;
    let mut worst = 0.0f32;
    // M is symmetric: its rows are the columns M⁻¹eⱼ.
    for v in m_inv {
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
    residual * crate::sqrt::sqrtf(worst / n.max(1) as f32)
}

/// The nine regression coefficients `u` of `REGRESSORS_F32·u ≈ TARGET_F32`;
/// `f` receives the normal matrix's factor.
fn least_squares(mom: &MomentsF32, f: &mut NormalFactorF32) -> Result<[f32; 9], Error> {
    let NormalFactorF32 { l: a, d } = f;
    let mut rhs = [0.0f32; 9];
    for ((row, r), phi_i) in a.iter_mut().zip(&mut rhs).zip(REGRESSORS_F32.iter()) {
        for (aij, phi_j) in row.iter_mut().zip(REGRESSORS_F32.iter()) {
            *aij = mom.product(phi_i, phi_j);
        }
        *r = mom.product(phi_i, TARGET_F32);
    }
    for (i, (di, row)) in d.iter_mut().zip(a.iter()).enumerate() {
        let nii = row.get(i).copied().unwrap_or(f32::NAN);
        if !(nii > 0.0 && nii.is_finite()) {
            return Err(Error::Singular);
        }
        *di = 1.0 / crate::sqrt::sqrtf(nii);
    }
    for (row, di) in a.iter_mut().zip(d.iter()) {
        for (aij, dj) in row.iter_mut().zip(d.iter()) {
            *aij *= di * dj;
        }
    }
    for (r, di) in rhs.iter_mut().zip(d.iter()) {
        *r *= di;
    }
    cholesky_solve_f32(a, &mut rhs)?;
    for (r, di) in rhs.iter_mut().zip(d.iter()) {
        *r *= di;
    }
    Ok(rhs)
}

/// Centre `c` and shape `S` of the ellipsoid `(x − c)ᵀS(x − c) = 1` the
/// coefficients describe, with `M⁻¹` and the scale `k` (`S = M/k`); an
/// error where they describe no ellipsoid.
fn quadric_centre_and_shape(u: [f32; 9]) -> Result<([f32; 3], M3, M3, f32), Error> {
    let [u1, u2, u3, u4, u5, u6, u7, u8, u9] = u;
    let m: M3 = [
        [u1 + u2 - 1.0, u3, u4],
        [u3, u1 - 2.0 * u2 - 1.0, u5],
        [u4, u5, u2 - 2.0 * u1 - 1.0],
    ];
    // M is symmetric: M⁻ᵀ = M⁻¹.
    let m_inv = inverse_t(&m).ok_or(Error::NotEllipsoid)?;
    let c = mul(&m_inv, [u6, u7, u8]).map(|v| -v);
    let k = dot(c, mul(&m, c)) - u9;
    if !(k.is_finite() && k != 0.0) {
        return Err(Error::NotEllipsoid);
    }
    Ok((c, m.map(|r| r.map(|v| v / k)), m_inv, k))
}

/// Soft-iron matrix `W` (maps the ellipsoid onto a sphere of the mean
/// radius), that radius, and the semi-axes ascending.
fn axes_and_soft_iron(shape: M3) -> Result<(M3, f32, [f32; 3]), Error> {
    let (lambda, v) = jacobi_eigen3(shape).ok_or(Error::NotEllipsoid)?;
    if !lambda.iter().all(|l| *l > 0.0 && l.is_finite()) {
        return Err(Error::NotEllipsoid);
    }
    let mut semi_axes = lambda.map(|l| 1.0 / crate::sqrt::sqrtf(l));
    let radius = (semi_axes[0] + semi_axes[1] + semi_axes[2]) / 3.0;
    let root = lambda.map(|l| radius * crate::sqrt::sqrtf(l));
    // W = V diag(root) Vᵀ, symmetric: element (i, j) = Σₖ V[i][k] root[k] V[j][k].
    let w = mul_diag_t(&v, root, &v);
    sort3(&mut semi_axes);
    Ok((w, radius, semi_axes))
}

/// RMS of the residual `((x − c)ᵀS(x − c) − 1) / 2` over the samples: to
/// first order the relative deviation of the corrected magnitude.
fn rms_residual(mom: &MomentsF32, shape: &M3, c: [f32; 3]) -> f32 {
    let sc = mul(shape, c);
    let p = [
        ([2, 0, 0], shape[0][0]),
        ([0, 2, 0], shape[1][1]),
        ([0, 0, 2], shape[2][2]),
        ([1, 1, 0], 2.0 * shape[0][1]),
        ([1, 0, 1], 2.0 * shape[0][2]),
        ([0, 1, 1], 2.0 * shape[1][2]),
        ([1, 0, 0], -2.0 * sc[0]),
        ([0, 1, 0], -2.0 * sc[1]),
        ([0, 0, 1], -2.0 * sc[2]),
        ([0, 0, 0], dot(c, sc) - 1.0),
    ];
    let mean_p2 = mom.product(&p, &p);
    0.5 * crate::sqrt::sqrtf(mean_p2.max(0.0))
}

/// In-place Cholesky solve of a 9×9 symmetric positive-definite system
/// (the host fit's algorithm in `f32`), [`Error::Singular`] below
/// [`PIVOT_MIN_F32`]. Every index is bounded by its loop range (`k < j ≤ i
/// < 9`), so the compiler proves it in range and links no bounds-check panic.
// Index loops: iterator chains over rows of `a` while writing it are longer,
// and lost the compiler's proof that every index is in range.
#[allow(clippy::needless_range_loop)]
#[inline(never)]
fn cholesky_solve_f32(a: &mut [[f32; 9]; 9], b: &mut [f32; 9]) -> Result<(), Error> {
    for i in 0..9 {
        for j in 0..i + 1 {
            let mut sum = a[i][j];
            for k in 0..j {
                sum -= a[i][k] * a[j][k];
            }
            a[i][j] = if j == i {
                if !(sum >= PIVOT_MIN_F32 && sum.is_finite()) {
                    return Err(Error::Singular);
                }
                crate::sqrt::sqrtf(sum)
            } else {
                sum / a[j][j]
            };
        }
    }
    // L·y = b, then Lᵀ·x = y.
    forward_substitute(a, b);
    for i in (0..9).rev() {
        for k in i + 1..9 {
            b[i] -= a[k][i] * b[k];
        }
        b[i] /= a[i][i];
    }
    if b.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Error::Singular)
    }
}

/// `L·y = b` in place for the lower triangle `L` of `a` (`b` becomes `y`).
#[allow(clippy::needless_range_loop)] // as cholesky_solve_f32: provably in range
#[inline(never)]
fn forward_substitute(a: &[[f32; 9]; 9], b: &mut [f32; 9]) {
    for i in 0..9 {
        for k in 0..i {
            b[i] -= a[i][k] * b[k];
        }
        b[i] /= a[i][i];
    }
}

/// Eigenvalues and eigenvectors (columns of `V`) of a symmetric 3×3 by
/// cyclic Jacobi rotations; `None` when it has not converged in 12 sweeps
/// (a well-posed input needs 4–6).
#[inline(never)]
fn jacobi_eigen3(mut a: M3) -> Option<([f32; 3], M3)> {
    let mut v: M3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..12 {
        let diag = [a[0][0], a[1][1], a[2][2]];
        let off = [a[0][1], a[0][2], a[1][2]];
        let (off2, diag2) = (dot(off, off), dot(diag, diag));
        if !(off2.is_finite() && diag2.is_finite()) {
            return None;
        }
        if off2 <= 1.0e-14 * diag2 {
            return Some((diag, v));
        }
        // The pairs (0, 1), (0, 2), (1, 2).
        for k in 0..3 {
            rotate(&mut a, &mut v, k / 2, (k + 3) / 2);
        }
    }
    None
}

/// One Jacobi rotation zeroing `a[p][q]` (`A ← JᵀAJ`, `V ← VJ`), `p < q <
/// 3`. One copy for the three pairs: run-time indices, range-checked once.
#[allow(clippy::needless_range_loop)] // rows p and q of `a` are written in the loop
fn rotate(a: &mut M3, v: &mut M3, p: usize, q: usize) {
    if p >= 3 || q >= 3 {
        return;
    }
    let apq = a[p][q];
    if apq == 0.0 {
        return;
    }
    let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
    let t = theta.signum() / (theta.abs() + crate::sqrt::sqrtf(theta * theta + 1.0));
    let c = 1.0 / crate::sqrt::sqrtf(t * t + 1.0);
    let s = t * c;
    // Columns p, q of A and V, then rows p, q of A (A's transpose is A).
    for row in a.iter_mut().chain(v.iter_mut()) {
        (row[p], row[q]) = turn(c, s, row[p], row[q]);
    }
    for k in 0..3 {
        (a[p][k], a[q][k]) = turn(c, s, a[p][k], a[q][k]);
    }
}

#[inline(never)]
fn turn(c: f32, s: f32, x: f32, y: f32) -> (f32, f32) {
    (c * x - s * y, s * x + c * y)
}

/// `M⁻ᵀ`, the inverse transposed, `None` if `M` is singular: its rows are
/// the cross products of `M`'s rows (`r₁×r₂`, `r₂×r₀`, `r₀×r₁`) over the
/// determinant `r₀·(r₁×r₂)`. The callers need `M⁻ᵀ` (the coverage check)
/// or invert a symmetric `M` (the centre), so no transpose is taken.
#[inline(never)]
fn inverse_t(m: &M3) -> Option<M3> {
    let [r0, r1, r2] = *m;
    let adj = [cross(r1, r2), cross(r2, r0), cross(r0, r1)];
    let det = dot(r0, adj[0]);
    if !(det.is_finite() && det != 0.0) {
        return None;
    }
    let inv = 1.0 / det;
    Some(adj.map(|r| r.map(|v| v * inv)))
}

#[inline(never)]
fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn mul(m: &M3, v: [f32; 3]) -> [f32; 3] {
    m.map(|r| dot(r, v))
}

/// `a · diag(d) · bᵀ`.
fn mul_diag_t(a: &M3, d: [f32; 3], b: &M3) -> M3 {
    let mut out = [[0.0f32; 3]; 3];
    for (o, ra) in out.iter_mut().zip(a) {
        let ad = [ra[0] * d[0], ra[1] * d[1], ra[2] * d[2]];
        for (x, rb) in o.iter_mut().zip(b) {
            *x = dot(ad, *rb);
        }
    }
    out
}

#[inline(never)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

const _: () = assert!(COVERAGE_BINS as usize == DIRECTIONS.len());

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::ellipsoid::{REGRESSORS, TARGET};

    #[test]
    fn regressor_tables_match_the_host_fit() {
        let same = |a: &[TermF32], b: &[([u8; 3], f64)]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|((ea, ca), (eb, cb))| ea == eb && f64::from(*ca) == *cb)
        };
        for (a, b) in REGRESSORS_F32.iter().zip(REGRESSORS.iter()) {
            assert!(same(a, b));
        }
        assert!(same(TARGET_F32, TARGET));
    }

    #[test]
    fn accumulated_sums_are_the_exact_monomials() {
        let mut f = EllipsoidFitF32::new(EllipsoidFitConfig::MICROTESLA, 0.5).unwrap();
        f.push([1.0, 1.0, 1.0]).unwrap();
        // (3, −7, 4096) quanta from the first sample.
        f.push([2.5, -2.5, 2049.0]).unwrap();
        for (s, e) in f.sums.iter().zip(EXPONENTS.iter()) {
            let want = 3i64.pow(u32::from(e[0]))
                * (-7i64).pow(u32::from(e[1]))
                * 4096i64.pow(u32::from(e[2]));
            assert_eq!(*s, want, "{e:?}");
        }
    }

    #[test]
    fn jacobi_diagonalises_a_known_matrix() {
        // Eigenvalues 1, 2, 4 rotated by a fixed orthonormal V.
        let s = core::f32::consts::FRAC_1_SQRT_2;
        let v: M3 = [[s, -s, 0.0], [s, s, 0.0], [0.0, 0.0, 1.0]];
        let a = mul_diag_t(&v, [1.0, 2.0, 4.0], &v);
        let (mut l, vec) = jacobi_eigen3(a).unwrap();
        // Columns are eigenvectors: A·v_k = λ_k·v_k.
        for k in 0..3 {
            let col = [vec[0][k], vec[1][k], vec[2][k]];
            let av = mul(&a, col);
            for i in 0..3 {
                assert!((av[i] - l[k] * col[i]).abs() < 1e-5, "{l:?}");
            }
        }
        sort3(&mut l);
        for (got, want) in l.iter().zip([1.0, 2.0, 4.0]) {
            assert!((got - want).abs() < 1e-5, "{l:?}");
        }
    }

    #[test]
    fn inverse_t_is_the_inverse_transposed() {
        // Not symmetric, so a missing or extra transpose shows.
        let m: M3 = [[2.0, -1.0, 0.5], [0.25, 3.0, -2.0], [1.0, 0.5, 4.0]];
        let it = inverse_t(&m).unwrap();
        // m · (M⁻ᵀ)ᵀ = I: row i of m dotted with row j of M⁻ᵀ.
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((dot(m[i], it[j]) - want).abs() < 1e-6, "{i} {j}");
            }
        }
        assert!(inverse_t(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 0.0]]).is_none());
    }

    #[test]
    fn state_size_is_as_documented() {
        assert_eq!(core::mem::size_of::<EllipsoidFitF32>(), 568);
    }

    #[test]
    fn refuses_far_samples_and_bad_quantum() {
        let mut f = EllipsoidFitF32::new(EllipsoidFitConfig::MICROTESLA, 0.125).unwrap();
        f.push([0.0; 3]).unwrap();
        assert_eq!(f.push([600.0, 0.0, 0.0]), Err(Error::InputOutOfRange));
        assert_eq!(f.push([f32::NAN, 0.0, 0.0]), Err(Error::NonFinite));
        assert_eq!((f.count(), f.rejected()), (1, 2));
        assert_eq!(
            EllipsoidFitF32::new(EllipsoidFitConfig::MICROTESLA, 0.0).err(),
            Some(Error::InvalidConfig)
        );
    }
}
