//! The self-level loop in fixed point: the same law as
//! [`LevelController`](crate::loops::LevelController) (P on the quaternion
//! attitude error towards the current heading with the commanded tilt,
//! rate-limited), on the AHRS's Q30 quaternion, in integer arithmetic only:
//! no soft-float call, no trigonometry, two integer square roots.
//!
//! # Q-formats, ranges and resolution
//!
//! | quantity | format | range | resolution |
//! |---|---|---|---|
//! | quaternion components, tilt setpoint | Q30 `i32` ([`QuatQ30`]) | accepted below ±1.5, `0.25 ≤ \|q\|² ≤ 2` | 9.3e-10 |
//! | products and their sums (heading, error) | Q60 `i64` | ±8 | exact |
//! | heading direction `(hx, hy)`, `h ± hx` | Q28 `i32` | ±4 | 3.7e-9 |
//! | heading half-angle `(cos ψ/2, sin ψ/2)` | Q30 | unit | 1e-8 (relative) |
//! | attitude error (rad, small angles) | Q29 `i32` | ±4 (the error is ≤ 2·1.375·1.42) | 1.9e-9 |
//! | gain `kp` (1/s) | Q16 `i32` | up to 32 767 /s | 1.5e-5 /s |
//! | rate setpoint (rad/s) | Q16 `i32` | ±`max_rate` | 1.5e-5 rad/s |
//!
//! * **Quaternion.** The AHRS keeps `|q| = 1` to within 1e-6; a quaternion
//!   outside `0.25 ≤ |q|² ≤ 2` (or a component beyond ±1.5) is refused
//!   ([`Error::OutOfRange`]), as the `f32` loop refuses `|q|² < 0.25`.
//!   With every component below 1.5 the four squares sum below 9 in Q60,
//!   inside `u64`; with `|q|² ≤ 2` every later product sum is below 4 in
//!   Q60, inside `i64`.
//! * **Heading.** The heading half-angle is the direction of
//!   `(h + hx, hy)`, or for `hx < 0` (where that sum cancels near ψ = π)
//!   of `(|hy|, sign(hy)·(h − hx))`, as in
//!   [`crate::loops::attitude_error_q`]. Both vectors are normalised by shifting their larger
//!   component to 30 bits; `1/|v|` starts from a 16-bit integer square
//!   root and takes one Newton step (64-bit products, no division beyond
//!   one 32-bit `UDIV`): the half-angle's direction within 1e-8 rad.
//! * **Error and setpoint.** The error is `2·sign(w)·(1.5 − |q|²/2)·vec(e)`
//!   in Q29 (the `f32` loop's Newton step for `1/|q|`); the rate setpoint
//!   `kp · error` is one 64-bit product, clamped to `±max_rate`.
//!
//! # Agreement with the `f32` loop
//!
//! Tested side by side (`tests/levelq.rs`): random attitudes (every
//! heading, tilts to 180°, `|q|` within 5 % of 1) and tilt setpoints to
//! ±80°: the error vectors within 2e-5 rad of
//! [`attitude_error_q`](crate::loops::attitude_error_q)'s and the rate
//! setpoints within 2e-4 rad/s of
//! [`LevelController::rate_setpoint_q`](crate::loops::LevelController::rate_setpoint_q)'s
//! at gains to 20 /s (measured over 2·10⁶ cases at the default gain:
//! 3.1e-6 rad and 3.0e-5 rad/s), except within 1 % of the two degenerate
//! attitudes (nose straight up or down, where the heading is undefined and
//! each loop picks its own); the cosine of the tilt within 2e-4.
//!
//! ```
//! use control::levelq::{LevelControllerQ, QuatQ30, TiltQ30};
//! use control::loops::{LevelConfig, TiltQuat};
//! use control::shaping::TiltSetpoint;
//! let level = LevelControllerQ::new(&LevelConfig::default())?;
//! // Level now, commanded 10° right roll: positive roll-rate demand (Q16).
//! let tilt = TiltQ30::new(&TiltQuat::new(&TiltSetpoint { roll_rad: 0.17, pitch_rad: 0.0 })?);
//! let sp = level.rate_setpoint_q16(&QuatQ30::IDENTITY, &tilt)?;
//! assert!(sp[0] > 0 && sp[1] == 0);
//! # Ok::<(), control::Error>(())
//! ```

use crate::error::Error;
use crate::fixed::{f32_to_q, to_q16, ONE_Q30};
use crate::loops::{LevelConfig, Quat, TiltQuat};

/// A quaternion `q_ned_from_body` (Hamilton, scalar first) in Q30, as the
/// fixed-point AHRS keeps it (`[w, x, y, z]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct QuatQ30(pub [i32; 4]);

/// The largest accepted component magnitude, Q30 (1.5).
const COMPONENT_MAX_Q30: i32 = 3 << 29;
/// `|q|²` bounds in Q60: 0.25 and 2.
const NORM2_MIN_Q60: u64 = 1 << 58;
const NORM2_MAX_Q60: u64 = 1 << 61;

impl QuatQ30 {
    /// No rotation.
    pub const IDENTITY: Self = Self([ONE_Q30, 0, 0, 0]);

    /// From an `f32` quaternion by the bits ([`f32_to_q`]); NaN becomes 0
    /// and is then refused by [`norm2_q60`](Self::norm2_q60)'s checks.
    pub fn from_quat(q: &Quat) -> Self {
        let c = |x: f32| f32_to_q(x, 30);
        Self([c(q.w), c(q.x), c(q.y), c(q.z)])
    }

    /// `|q|²` in Q60 after the range checks: every component within ±1.5
    /// and `0.25 ≤ |q|² ≤ 2`, else [`Error::OutOfRange`].
    pub fn norm2_q60(&self) -> Result<u64, Error> {
        let mut n2: u64 = 0;
        for c in self.0 {
            if c.unsigned_abs() > COMPONENT_MAX_Q30 as u32 {
                return Err(Error::OutOfRange);
            }
            let a = u64::from(c.unsigned_abs());
            n2 += a * a; // < 4 · 2.25 · 2⁶⁰ < 2⁶⁴
        }
        if (NORM2_MIN_Q60..=NORM2_MAX_Q60).contains(&n2) {
            Ok(n2)
        } else {
            Err(Error::OutOfRange)
        }
    }

    /// Cosine of the tilt (body down · earth down), Q30:
    /// `1 − 2(x² + y²)/|q|²`, within 2e-4 (one 32-bit `SDIV` of 15-bit
    /// operands; 0.01° at a 60° threshold). Errors: [`norm2_q60`](Self::norm2_q60)'s.
    pub fn cos_tilt_q30(&self) -> Result<i32, Error> {
        let n2 = self.norm2_q60()?;
        let [_, x, y, _] = self.0;
        let xy = sq(x) + sq(y);
        // n2 − 2·xy ∈ [−n2, n2]; n2 ∈ [2⁵⁸, 2⁶¹].
        let num = n2 as i64 - 2 * xy;
        let den = (n2 >> 46) as i32; // Q14 of |q|²: [2¹², 2¹⁵]
        let num_s = (num >> 46) as i32; // same scale, |num_s| ≤ den
                                        // Q15 quotient, |.| ≤ 1: num_s · 2¹⁵ ≤ 2³⁰ fits.
        let c_q15 = (num_s << 15) / den.max(1);
        Ok(c_q15.clamp(-(1 << 15), 1 << 15) << 15)
    }
}

/// `x²` in Q60 (Q30 in).
fn sq(x: i32) -> i64 {
    i64::from(x) * i64::from(x)
}

/// A tilt setpoint ([`TiltQuat`], `q_y(θ) ⊗ q_x(φ)`) in Q30: converted
/// once per pilot frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TiltQ30([i32; 4]);

impl TiltQ30 {
    /// Level.
    pub const LEVEL: Self = Self([ONE_Q30, 0, 0, 0]);

    /// From the `f32` tilt quaternion (unit length, so every component
    /// fits Q30).
    pub fn new(tilt: &TiltQuat) -> Self {
        let q = tilt.quat();
        Self([q.w, q.x, q.y, q.z].map(|c| f32_to_q(c, 30)))
    }

    /// From its Q30 components `[w, x, y, z]` (a unit `q_y(θ) ⊗ q_x(φ)`,
    /// as [`crate::shapingq::tilt_q30`] makes it).
    pub fn from_q30(q: [i32; 4]) -> Self {
        Self(q)
    }

    /// The Q30 components `[w, x, y, z]`.
    pub fn q30(&self) -> [i32; 4] {
        self.0
    }
}

/// The self-level loop in fixed point. Stateless apart from its gains.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LevelControllerQ {
    kp_q16: i32,
    max_rate_q16: i32,
}

impl LevelControllerQ {
    /// The loop for `cfg`. Errors: [`LevelConfig::validate`]'s, and
    /// [`Error::OutOfRange`] for a gain or rate limit beyond Q16.
    #[inline(always)]
    pub fn new(cfg: &LevelConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self {
            kp_q16: to_q16(cfg.kp_per_s)?,
            max_rate_q16: to_q16(cfg.max_rate_rps)?,
        })
    }

    /// Roll and pitch rate setpoints (Q16 rad/s, FRD) for attitude `q` and
    /// the tilt setpoint. Errors: [`QuatQ30::norm2_q60`]'s.
    pub fn rate_setpoint_q16(&self, q: &QuatQ30, tilt: &TiltQ30) -> Result<[i32; 2], Error> {
        let e = attitude_error_q29(q, tilt)?;
        let m = self.max_rate_q16;
        // max/min, not `clamp`: clamp's check of its bounds links
        // `core::fmt` (1.8 KiB of flash) for a panic that cannot happen.
        let rate = |e: i32| {
            let r = (i64::from(self.kp_q16) * i64::from(e)) >> 29;
            r.max(-i64::from(m)).min(i64::from(m)) as i32
        };
        Ok([rate(e[0]), rate(e[1])])
    }
}

/// Body-frame attitude error vector, Q29 rad for small errors: the
/// fixed-point form of [`crate::loops::attitude_error_q`] (see the
/// module docs for the formats). Errors: [`QuatQ30::norm2_q60`]'s.
pub fn attitude_error_q29(q: &QuatQ30, tilt: &TiltQ30) -> Result<[i32; 3], Error> {
    let n2 = q.norm2_q60()?;
    let (w, x, y, z) = (wide(q.0[0]), wide(q.0[1]), wide(q.0[2]), wide(q.0[3]));
    // Heading of q: body x on the horizontal, summed in Q60, then Q28
    // (|.| ≤ |q|² ≤ 2); "tiny" is 1e-6·|q|² (2⁻²⁰) in Q28.
    let hx = ((w * w + x * x - y * y - z * z) >> 32) as i32;
    let hy = ((w * z + x * y) >> 31) as i32;
    let (c, s) = heading_half_angle_q30(hx, hy, (n2 >> 52) as i32);
    // The measured tilt p = q_z(ψ)⁻¹ ⊗ q, then e = p⁻¹ ⊗ t, Q30.
    let p = conj_mul_q30(&[c, 0, 0, s], &q.0);
    let e = conj_mul_q30(&p, &tilt.0);
    let (ew, ex, ey, ez) = (e[0], wide(e[1]), wide(e[2]), wide(e[3]));
    // 2·sign(ew)·(1.5 − |q|²/2)·e in Q29 is sign(ew)·(1.5 − |q|²/2)·e in
    // Q30: the Q30 error times the Q30 factor, shifted by 30.
    let inv_n = (3i64 << 29) - (n2 >> 31) as i64; // Q30: 1.5 − |q|²/2
    let k = if ew < 0 { -inv_n } else { inv_n };
    let scale = |v: i64| ((v * k) >> 30) as i32;
    Ok([scale(ex), scale(ey), scale(ez)])
}

/// `a⁻¹ ⊗ b` (the conjugate of `a` times `b`, Hamilton), Q30, for
/// `|a|·|b| < 2`: sixteen 64-bit products (`SMULL`), each component
/// summed in Q60. Out of line: one copy for both products of
/// [`attitude_error_q29`].
#[inline(never)]
fn conj_mul_q30(a: &[i32; 4], b: &[i32; 4]) -> [i32; 4] {
    // Element by element, not `array::map`: that goes through `try_map`
    // and `memcpy` on this target (a third of the loop's instructions).
    let (aw, ax, ay, az) = (wide(a[0]), wide(a[1]), wide(a[2]), wide(a[3]));
    let (bw, bx, by, bz) = (wide(b[0]), wide(b[1]), wide(b[2]), wide(b[3]));
    let q30 = |v: i64| (v >> 30) as i32;
    [
        q30(aw * bw + ax * bx + ay * by + az * bz),
        q30(aw * bx - ax * bw - ay * bz + az * by),
        q30(aw * by + ax * bz - ay * bw - az * bx),
        q30(aw * bz - ax * by + ay * bx - az * bw),
    ]
}

/// `x` widened for a 32×32→64 product.
fn wide(x: i32) -> i64 {
    i64::from(x)
}

/// `(cos ψ/2, sin ψ/2)` in Q30 for the heading whose direction is
/// `(hx, hy)` (Q28); `(1, 0)` when both are within `tiny` of zero (nose
/// straight up or down: any heading will do).
fn heading_half_angle_q30(hx: i32, hy: i32, tiny: i32) -> (i32, i32) {
    if hx.abs() <= tiny && hy.abs() <= tiny {
        return (ONE_Q30, 0);
    }
    // Q28: |h ± hx| ≤ 2|q|² ≤ 4 fits.
    let h = norm2d(hx, hy);
    if hx >= 0 {
        unit2d(h + hx, hy)
    } else if hy >= 0 {
        unit2d(hy, h - hx)
    } else {
        unit2d(-hy, hx - h)
    }
}

/// `(a, b) ≠ (0, 0)` (each within ±2³⁰) shifted left so the larger
/// magnitude has 30 bits, `1/|(a, b)|` of the shifted pair in Q30 (its
/// norm lies in [2²⁹, 2³⁰·√2)), and the shift.
///
/// `s = (a² + b²)/2⁶⁰ ∈ [¼, 2)`; `1/√s` starts from a 16-bit integer
/// square root (3e-5) and takes one Newton step `y(3 − s·y²)/2`, which
/// squares the error: within 1e-8 in all. 32-bit shifts and `SMULL`s only.
fn scaled_rsqrt(a: i32, b: i32) -> (i32, i32, i64, u32) {
    let m = a.unsigned_abs().max(b.unsigned_abs()).max(1);
    let shl = m.leading_zeros().saturating_sub(2);
    let (a, b) = (a << shl, b << shl);
    // s in Q30: (a² + b²) < 2⁶¹, shifted by 30.
    let s_q30 = (wide(a) * wide(a) + wide(b) * wide(b)) >> 30;
    let r0 = isqrt(s_q30 as u32).max(1); // √s in Q15
                                         // 1/√s in Q15 by one 32-bit division (r0 < 2¹⁶), then Q30.
    let y0 = wide(((1u32 << 30) / r0) as i32) << 15;
    let sy2 = (s_q30 * ((y0 * y0) >> 30)) >> 30; // ≈ 1, Q30
    let y = (y0 * ((3i64 << 30) - sy2)) >> 31;
    (a, b, y, shl)
}

/// `|(a, b)|`, in the inputs' scale (relative error 1e-8; `(a, b)`
/// within ±2³⁰ and not both zero).
fn norm2d(a: i32, b: i32) -> i32 {
    let (a, b, y, shl) = scaled_rsqrt(a, b);
    // |(a, b)| = (a² + b²)·y / 2⁶⁰ · 2³⁰ (the shifted pair's norm, < 2³¹).
    let s_q30 = (wide(a) * wide(a) + wide(b) * wide(b)) >> 30;
    (((s_q30 * y) >> 30) as i32) >> shl
}

/// The unit vector along `(a, b) ≠ (0, 0)` (each within ±2³⁰), Q30
/// (relative error 1e-8).
fn unit2d(a: i32, b: i32) -> (i32, i32) {
    let (a, b, y, _) = scaled_rsqrt(a, b);
    // |a| < 2³⁰ and y < 2³¹: the product fits; the quotient is ≤ 1 + 1e-8.
    let one = wide(ONE_Q30);
    let q30 = |v: i32| ((wide(v) * y) >> 30).max(-one).min(one) as i32;
    (q30(a), q30(b))
}

/// `⌊√x⌋`: Newton's iteration from a power of two above the root (it
/// decreases monotonically to the floor; five `UDIV`s at most for 31 bits).
pub fn isqrt(x: u32) -> u32 {
    if x == 0 {
        return 0;
    }
    let bits = 32 - x.leading_zeros();
    let mut r = 1u32 << bits.div_ceil(2);
    loop {
        let next = (r + x / r) / 2;
        if next >= r {
            return r;
        }
        r = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isqrt_is_the_floor_of_the_root() {
        let mut x: u32 = 1;
        let probes = (0..40_000u32)
            .chain((0..32).flat_map(|b| {
                let p = 1u64 << b;
                [p - 1, p, p + 1].map(|v| v.min(u64::from(u32::MAX)) as u32)
            }))
            .chain([u32::MAX, u32::MAX - 1]);
        for v in probes
            .chain(core::iter::from_fn(|| {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                Some(x)
            }))
            .take(200_000)
        {
            let r = u64::from(isqrt(v));
            assert!(
                r * r <= u64::from(v) && (r + 1) * (r + 1) > u64::from(v),
                "{v}"
            );
        }
    }

    #[test]
    fn level_quaternion_gives_no_error() {
        let e = attitude_error_q29(&QuatQ30::IDENTITY, &TiltQ30::LEVEL).unwrap();
        assert_eq!(e, [0, 0, 0]);
    }

    #[test]
    fn bad_norms_are_refused() {
        let tiny = QuatQ30([ONE_Q30 / 4, 0, 0, 0]);
        assert_eq!(tiny.norm2_q60(), Err(Error::OutOfRange));
        let big = QuatQ30([ONE_Q30, ONE_Q30, 0, 0]);
        assert!(big.norm2_q60().is_ok()); // |q|² = 2 exactly
        let bigger = QuatQ30([ONE_Q30, ONE_Q30, ONE_Q30 / 8, 0]);
        assert_eq!(bigger.norm2_q60(), Err(Error::OutOfRange));
        let saturated = QuatQ30([i32::MAX, 0, 0, 0]);
        assert_eq!(saturated.norm2_q60(), Err(Error::OutOfRange));
        let nan = QuatQ30::from_quat(&Quat {
            w: f32::NAN,
            x: 0.0,
            y: 0.0,
            z: 0.0,
        });
        assert_eq!(nan.norm2_q60(), Err(Error::OutOfRange));
    }

    #[test]
    fn cos_tilt_of_known_attitudes() {
        let q30 = |q: Quat| QuatQ30::from_quat(&q);
        let c = |q: Quat| q30(q).cos_tilt_q30().unwrap() as f32 / ONE_Q30 as f32;
        assert!((c(Quat::IDENTITY) - 1.0).abs() < 1e-4);
        let r60 = Quat::about_x(60f32.to_radians());
        assert!((c(r60) - 0.5).abs() < 1e-4);
        let inverted = Quat::about_y(core::f32::consts::PI);
        assert!((c(inverted) + 1.0).abs() < 1e-4);
    }
}
