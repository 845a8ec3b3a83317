//! The attitude filter in fixed point for an FPU-less Cortex-M3: the same algorithm, API shape,
//! status reports and features as [`crate::Madgwick`], in integer arithmetic.
//!
//! Q-formats (Qm.n = n fractional bits):
//! * quaternion `q_ned_from_body`: Q2.30 in `i32` (`_q30`);
//! * gyro rates and the bias estimate: rad/s in Q11.20 `i32` (`_rps_q20`, ±2048 rad/s,
//!   resolution 0.95 µrad/s);
//! * time step: seconds in Q0.31 `i32` (`dt_s_q31`, valid range (0, 1) s); timers are
//!   seconds in Q20 `i64`;
//! * gains β: rad/s in Q8.24 `i32`;
//! * accelerometer and magnetometer: `i32` in any consistent unit (raw counts are fine;
//!   they are normalised inside); [`crate::Config::gravity_norm`] must then be 1 g in
//!   accelerometer units;
//! * unit vectors, rotation-matrix entries, cosines and sines: Q2.30.
//!
//! * the earth-frame low-passed specific force of the tilt correction, and of its
//!   body-plane part in multirotor mode: g in Q26 `i32`; 1/μ (s) and 1/(μ·τ) in Q16.
//!
//! All products are 32×32→64-bit (one `SMULL`/`SMLAL` on the M3) accumulated in `i64`
//! with one shift per result; every such sum has its overflow bound in a comment instead
//! of saturating arithmetic. The accelerometer, magnetometer and (textbook mode) the
//! gradient are normalised with one integer reciprocal square root each (32-bit
//! leading-zero normalisation + 48-entry table + two Newton steps in 32-bit arithmetic,
//! < 3e-7 relative error); the quaternion is renormalised once per update with the
//! first-order q·(3 − ‖q‖²)/2 (every normal step: ‖q‖² is within 2^-10 of 1) or a full
//! reciprocal square root otherwise. The only divisions are two 32-bit `SDIV`s: the
//! heading error and 1/|y_z| of the tilt correction. Conversions from the f32 [`crate::Config`] happen once, in
//! [`FixedConfig::from_config`].

// The steps and checks repeat madgwick.rs's, under the same names, on purpose: the two
// files read side by side, and the fixed-point filter is tested against the f32 one.

// `max(lo).min(hi)` instead of `clamp`: `clamp` asserts lo ≤ hi (a panic path) and stays
// an out-of-line call at the firmware's opt-level "z".
#![allow(clippy::manual_clamp)]

use crate::config::{Algorithm, Config, MagState, UpdatePath, UpdateStatus};
use crate::Quaternion;

const ONE_Q30: i64 = 1 << 30;
/// 2π·[`crate::madgwick::DRAG_INPUT_CUTOFF_HZ`] in Q20 (rad/s).
const DRAG_INPUT_WC_Q20: i64 = 32_941_240;

/// Bound on the rate about the vertical entering the mean used by the heading gain
/// schedule (64 rad/s, as the f32 filter), in Q20 and Q40.
const MAX_MEAN_RATE_Q20: i64 = 64 << 20;
const MAX_MEAN_RATE_Q40: i64 = 64 << 40;

/// 1/√m in Q29 at the midpoints of 48 bins of m ∈ [0.25, 1).
const RSQRT_TABLE: [u32; 48] = [
    1057347856, 1026693558, 998559613, 972618566, 948599586, 926276469, 905458609, 885984104,
    867714429, 850530263, 834328203, 819018128, 804521086, 790767575, 777696137, 765252196,
    753387102, 742057327, 731223792, 720851298, 710908045, 701365222, 692196655, 683378504,
    674889000, 666708225, 658817909, 651201261, 643842818, 636728315, 629844563, 623179354,
    616721362, 610460069, 604385689, 598489102, 592761802, 587195840, 581783781, 576518662,
    571393950, 566403514, 561541591, 556802759, 552181909, 547674226, 543275165, 538980433,
];

/// 1/√M in Q29 for M = `m_q32`/2^32 ∈ [0.25, 1) (`m_q32` ≥ 2^30): table start (≤ 1.6 %
/// off) and two Newton steps y ← y·(3 − M·y²)/2 in 32-bit arithmetic (`UMULL`, high words),
/// relative error < 3e-7 (test `rsqrt_accuracy`; 1.5·ε² after the second step).
///
/// Bounds: Newton steps for 1/√M never overshoot (y·(3 − My²)/2 ≤ 1/√M), so y stays
/// ≤ 2 (2^31 in Q30) after the first step, and the table start is < 2^31 too: y² < 2^62,
/// M·y² (Q28) < 2^30, t ≤ 3·2^28, y·t < 2^61. Out-of-range `m_q32` (< 2^30) gives a
/// meaningless result but no panic.
#[inline(always)]
fn rsqrt_q29(m_q32: u32) -> i32 {
    let idx = ((m_q32 >> 26) as usize).wrapping_sub(16);
    // Q30 start; two steps written out (a two-trip loop stays a loop at `opt-level = "s"`).
    let y = RSQRT_TABLE.get(idx).copied().unwrap_or(1 << 29) << 1;
    (newton_rsqrt(newton_rsqrt(y, m_q32), m_q32) >> 1) as i32 // ≤ 2^30
}

/// One Newton step y·(3 − M·y²)/2 for 1/√M, y in Q30, M = `m_q32`/2^32 (see `rsqrt_q29`).
#[inline(always)]
fn newton_rsqrt(y: u32, m_q32: u32) -> u32 {
    let y2 = ((u64::from(y) * u64::from(y)) >> 32) as u32; // y² in Q28
    let my2 = ((u64::from(m_q32) * u64::from(y2)) >> 32) as u32; // M·y² in Q28
    let t = (3u32 << 28).saturating_sub(my2); // (3 − M·y²) in Q28
    ((u64::from(y) * u64::from(t)) >> 29) as u32 // Q30·Q28/2 → Q30
}

/// For s ∈ [1, 2^62): (m, k) with s·4^k ∈ [2^60, 2^62) and m = s·4^k/2^30 (its top 32
/// bits, m ∈ [2^30, 2^32)), k ∈ 0..=30. 32-bit shifts only: a variable 64-bit shift is a
/// library call (`__aeabi_llsl`) on the M3 at `opt-level = "s"`. Other s give a meaningless
/// result, no panic.
#[inline(always)]
fn norm_parts(s: u64) -> (u32, u32) {
    let hi = (s >> 32) as u32;
    let lo = s as u32;
    if hi != 0 {
        // s << z ∈ [2^62, 2^64) with z even, 2..=30 (hi < 2^30).
        let z = hi.leading_zeros() & !1;
        let m = (hi << z) | lo.checked_shr(32 - z).unwrap_or(0);
        (m, (z / 2).saturating_sub(1))
    } else {
        // s << (32 + z) ∈ [2^62, 2^64), z even, 0..=30 (lo ≠ 0).
        let z = lo.leading_zeros() & !1;
        (lo.checked_shl(z).unwrap_or(0), (z / 2 + 15).min(30))
    }
}

/// Σ vᵢ² of a 4-vector, exact: i32::MIN is first raised to −i32::MAX, so each term is
/// < 2^62 and four of them < 2^64. (Written out per component: at `opt-level = "s"`
/// array maps stay loops over stack copies.)
#[inline(always)]
fn sumsq4(v: [i32; 4]) -> u64 {
    let sq = |x: i32| {
        let x = i64::from(x.max(-i32::MAX));
        (x * x) as u64
    };
    let [a, b, c, d] = v;
    sq(a) + sq(b) + sq(c) + sq(d)
}

/// v·2^30/√s, the unit vector in Q30, for s = Σ vᵢ² ∈ [1, 2^62) (zeros for s = 0).
///
/// An even shift 2k takes s to [2^60, 2^62); v·2^k then stays below 2^31 in magnitude
/// (|vᵢ| ≤ √s), and u = (v·2^k·Y_q29) >> 30 with Y = 1/√(s·4^k/2^62). |uᵢ| ≤ 2^30 + 1.
#[inline(always)]
fn scale4(v: [i32; 4], s: u64) -> [i32; 4] {
    let (m_q32, k) = norm_parts(s);
    let y = rsqrt_q29(m_q32);
    let f = |x: i32| ((m64(x << k, y) + (1 << 29)) >> 30) as i32;
    let [a, b, c, d] = v;
    [f(a), f(b), f(c), f(d)]
}

/// Normalise a 4-vector to Q30; `None` if zero. Also returns ‖v‖².
fn unit4(v: [i32; 4]) -> Option<([i32; 4], u64)> {
    let s = sumsq4(v);
    if s == 0 {
        return None;
    }
    let u = if s < 1 << 62 {
        scale4(v, s)
    } else {
        // Rare (components ≥ 2^30): v/4 has Σ < 2^60 and is non-zero.
        let [a, b, c, d] = v;
        let v4 = [a >> 2, b >> 2, c >> 2, d >> 2];
        scale4(v4, sumsq4(v4))
    };
    Some((u, s))
}

/// The textbook filter's normalisation: `v/‖v‖` in Q30 (`None` if zero) with one
/// Newton step from the table (relative error of the scale ≤ 1.5·0.016² < 4e-4, and
/// the same for every component, so the direction is exact to rounding). Enough
/// there: a common scale error of the accelerometer or magnetometer vector moves the
/// gradient only to second order near the minimum (J ᵀ·down = 0 for a unit q), and of
/// the gradient only the step length. No i32::MIN clamp: the callers pass 3-vectors
/// (4th component 0: Σ < 3·2^62) or the gradient (components < 2^30).
#[cfg(feature = "textbook")]
#[inline(never)]
fn unit_fast(v: [i32; 4]) -> Option<[i32; 4]> {
    let sq = |x: i32| m64(x, x) as u64;
    let [a, b, c, d] = v;
    let s = sq(a) + sq(b) + sq(c) + sq(d);
    if s == 0 {
        return None;
    }
    // Rare (components ≥ 2^30): v/4 has Σ < 2^60 (and ≥ 2^58: non-zero).
    let (v, s) = if s < 1 << 62 {
        (v, s)
    } else {
        let v4 = [a >> 2, b >> 2, c >> 2, d >> 2];
        let [a, b, c, d] = v4;
        (v4, sq(a) + sq(b) + sq(c) + sq(d))
    };
    let (m_q32, k) = norm_parts(s);
    let idx = ((m_q32 >> 26) as usize).wrapping_sub(16);
    let y0 = RSQRT_TABLE.get(idx).copied().unwrap_or(1 << 29) << 1;
    let y = (newton_rsqrt(y0, m_q32) >> 1) as i32;
    let f = |x: i32| ((m64(x << k, y) + (1 << 29)) >> 30) as i32;
    let [a, b, c, d] = v;
    Some([f(a), f(b), f(c), f(d)])
}

/// [`unit_fast`] of a 3-vector.
#[cfg(feature = "textbook")]
#[inline(always)]
fn unit3_fast(v: [i32; 3]) -> Option<[i32; 3]> {
    let [a, b, c] = v;
    unit_fast([a, b, c, 0]).map(|[x, y, z, _]| [x, y, z])
}

/// Normalise an i32 3-vector to Q30; `None` if zero. Also returns ‖v‖².
fn unit3(v: [i32; 3]) -> Option<([i32; 3], u64)> {
    let [a, b, c] = v;
    unit4([a, b, c, 0]).map(|([x, y, z, _], s)| ([x, y, z], s))
}

/// √s rounded, from `norm_parts` and `rsqrt_q29`: √s = M·Y·2^(31−k) with
/// m_q32·Y_q29 = M·Y·2^61 < 2^62, so (m·y) >> 30 fits in u32 and the rest is a 32-bit
/// shift by k. s ∈ [1, 2^62).
#[inline(always)]
fn sqrt_parts(m: u32, y: i32, k: u32) -> u32 {
    let r = ((u64::from(m) * u64::from(y.unsigned_abs())) >> 30) as u32;
    // r >> k, rounded (k = 0: no rounding bit).
    (r >> k) + (r.checked_shr(k.wrapping_sub(1)).unwrap_or(0) & 1)
}

/// Integer √s, relative error < 3e-7 (absolute ≤ ½ for small s).
fn isqrt(s: u64) -> i64 {
    sqrt_and_ratio(s, 0).0
}

/// (√s, v·2^30/√s) with one reciprocal square root; (0, 0) for s = 0. The ratio needs
/// |v| ≤ √s (it is a sine or cosine: v² is one term of s); otherwise it is meaningless
/// (no panic).
fn sqrt_and_ratio(s: u64, v: i64) -> (i64, i64) {
    if s == 0 {
        return (0, 0);
    }
    // s ≥ 2^62: √s = 4·√(s/16), v/√s = (v/4)/√(s/16).
    let big = s >= 1 << 62;
    let (s, v) = if big { (s >> 4, v >> 2) } else { (s, v) };
    let (m, k) = norm_parts(s);
    let y = rsqrt_q29(m);
    let sq = i64::from(sqrt_parts(m, y, k)) * if big { 4 } else { 1 };
    // v·2^30/√s = (v·2^k)·Y/2^31·2^30: |v·2^k| ≤ √(s·4^k) < 2^31 as in `scale4`.
    let vk = (v.max(-i64::from(i32::MAX)).min(i64::from(i32::MAX)) as i32) << k;
    (sq, (m64(vk, y) + (1 << 29)) >> 30)
}

/// ½ω·dt in Q30 (Q20·Q31 = Q51 → >> 22), clamped to ±¼ rad (half angle) per axis and
/// step (as the f32 filter; 2000 °/s reaches it at dt = 14 ms). The clamp tests the
/// product's high word (¼ in Q30 is 2^50 in Q51, 2^18 in the high word): 32-bit compares.
/// `clamped` is set if a clamp acted.
#[inline(always)]
fn half_angles(w: [i32; 3], dt_q31: i32, clamped: &mut bool) -> [i32; 3] {
    let mut h = |x: i32| {
        let p = m64(x, dt_q31);
        let hi = (p >> 32) as i32;
        if hi >= 1 << 18 {
            *clamped = true;
            ONE_Q30 as i32 / 4
        } else if hi < -(1 << 18) {
            *clamped = true;
            -(ONE_Q30 as i32) / 4
        } else {
            (p >> 22) as i32
        }
    };
    [h(w[0]), h(w[1]), h(w[2])]
}

/// |ω·dt| (Q51) beyond which the full filter's gyro step is split: 2·(1/32) rad.
const SUBSTEP_WDT_Q51: u64 = 1 << 47;

/// The full filter's gyro step split into n = 1 + ⌊|ω·dt|max / (1/16)⌋ (at most
/// `MAX_SUBSTEPS`) equal sub-steps, renormalised between them, the last one left for the
/// caller's renormalisation (as the f32 filter). At ≤ 1/32 rad of half angle per
/// sub-step the first-order step's error (2(h − atan h) ≈ ⅔h³ rad) is 0.001° each, ~0.5°
/// over the 559 sub-steps of 2000 °/s for 1 s; at 1 kHz the MPU-9250's 2000 °/s is one
/// step and never comes here (out of line: the common path stays short).
#[inline(never)]
fn substep(q: [i32; 4], w: [i32; 3], dt_q31: i32, clamped: &mut bool) -> [i64; 4] {
    let m = w
        .iter()
        .map(|&x| m64(x, dt_q31).unsigned_abs())
        .max()
        .unwrap_or(0);
    let n = ((m / SUBSTEP_WDT_Q51) as u32).min(crate::madgwick::MAX_SUBSTEPS - 1) + 1;
    let dt_sub = dt_q31 / n as i32;
    let mut q0 = q;
    for _ in 1..n {
        q0 = renormalise(propagate(q0, half_angles(w, dt_sub, clamped))).unwrap_or(q0);
    }
    propagate(q0, half_angles(w, dt_sub, clamped))
}

/// |ω|² in Q40 for ω in Q20: three squares ≤ 2^62 each sum exactly in u64 (< 3·2^62),
/// then saturate once to i64.
fn w_sq(w: [i32; 3]) -> i64 {
    let [a, b, d] = w;
    let sq = |x: i32| (i64::from(x) * i64::from(x)) as u64;
    (sq(a) + sq(b) + sq(d)).min(i64::MAX as u64) as i64
}

fn sub_sat3(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [
        a[0].saturating_sub(b[0]),
        a[1].saturating_sub(b[1]),
        a[2].saturating_sub(b[2]),
    ]
}

/// One first-order low-pass step s + k·(x − s), k in Q30 (0 ≤ k ≤ 2^30). The result
/// lies between s and x (the difference saturated to i32 keeps its sign and does not
/// grow), so it fits.
#[inline(always)]
fn lp_step(s: i32, x: i32, k: i32) -> i32 {
    let d = sat32(i64::from(x) - i64::from(s));
    s + (m64(k, d) >> 30) as i32
}

fn sat32(x: i64) -> i32 {
    x.max(i64::from(i32::MIN)).min(i64::from(i32::MAX)) as i32
}

fn mul30(a: i32, b: i32) -> i64 {
    (i64::from(a) * i64::from(b)) >> 30
}

/// 32×32→64 product (one `SMULL`).
fn m64(a: i32, b: i32) -> i64 {
    i64::from(a) * i64::from(b)
}

/// Dot product of two Q30 vectors with |aᵢ|, |bᵢ| ≤ 2^30 + 2^20 (unit vectors, rows of
/// R(q)): each product < 2^61, the sum < 2^63. Result Q30.
fn dot30u(a: [i32; 3], b: [i32; 3]) -> i32 {
    dot30u_inline(a, b)
}

/// [`dot30u`], inlined where every instruction counts (the textbook update).
#[inline(always)]
fn dot30u_inline(a: [i32; 3], b: [i32; 3]) -> i32 {
    ((m64(a[0], b[0]) + m64(a[1], b[1]) + m64(a[2], b[2]) + (1 << 29)) >> 30) as i32
}

/// Row 2 of R(q) (body → NED), "down" in body axes, Q30, for a unit Q30 quaternion
/// (entries ≤ |q|² ≤ 1 + 1e-6, so they fit: no saturation needed).
fn down_row(q: [i32; 4]) -> [i32; 3] {
    let [w, x, y, z] = q;
    // 2ab in Q30 = (a·b) >> 29; 1 − 2(xx + yy) = (2^59 − xx − yy) >> 29.
    [
        ((m64(x, z) - m64(w, y) + (1 << 28)) >> 29) as i32,
        ((m64(y, z) + m64(w, x) + (1 << 28)) >> 29) as i32,
        (((1i64 << 59) - m64(x, x) - m64(y, y) + (1 << 28)) >> 29) as i32,
    ]
}

/// Accelerometer gradient J_gᵀ f_g / 2 (eqs. 25–26), up to a positive scale (only its
/// direction and, for the step limit, its size relative to that scale are used):
/// f_g = down − d in Q29 (|fᵢ| ≤ 2^30 + 1). Single-coefficient terms use q in Q29 (q >> 1),
/// doubled ones 2q in Q29 (= q's raw Q30 value): products Q58, at most 2^59 + 2^59 + 2^60
/// = 2^61 (×(1+1e-6)²) per component, so the sums fit and the high word (>> 32) is
/// ∇f/2 in Q26 with |gᵢ| < 2^30.
// Used by the textbook filter only.
#[cfg_attr(not(feature = "textbook"), allow(dead_code))]
fn accel_grad(q: [i32; 4], down: [i32; 3], d: [i32; 3]) -> [i32; 4] {
    let [d2q1, d2q2, d2q3, d2q4] = q;
    let (q1, q2, q3, q4) = (d2q1 >> 1, d2q2 >> 1, d2q3 >> 1, d2q4 >> 1);
    let f1 = (down[0] >> 1) - (d[0] >> 1);
    let f2 = (down[1] >> 1) - (d[1] >> 1);
    let f3 = (down[2] >> 1) - (d[2] >> 1);
    let hi = |x: i64| (x >> 32) as i32;
    [
        hi(m64(q2, f2) - m64(q3, f1)),
        hi(m64(q4, f1) + m64(q1, f2) - m64(d2q2, f3)),
        hi(m64(q4, f2) - m64(q1, f1) - m64(d2q3, f3)),
        hi(m64(q2, f1) + m64(q3, f2)),
    ]
}

/// Magnetometer gradient J_bᵀ f_b / 2 (eqs. 29–30 with the correct 2bx, 2bz), up to a
/// positive scale. b = (bx, 0, bz) in Q30 with bx² + bz² ≤ 1, rows of R(q) in Q30.
/// Bounds: f_b = bx·row0 + bz·row2 − m in Q28 (|bx·r0ᵢ + bz·r2ᵢ| ≤ 2^60 by Cauchy–Schwarz,
/// so |f_bᵢ| ≤ 2^29); bx·qᵢ, bz·qᵢ in Q28 (high words, ≤ 2^28), coefficient sums
/// ≤ 3·2^28; products ≤ 3·2^57, three of them < 2^61; the high word is ∇f/2 in Q24
/// (|gᵢ| < 2^29).
// Used by the textbook filter only.
#[cfg_attr(not(feature = "textbook"), allow(dead_code))]
fn mag_grad(q: [i32; 4], r0: [i32; 3], r2: [i32; 3], m: [i32; 3], bx: i32, bz: i32) -> [i32; 4] {
    let hi = |x: i64| (x >> 32) as i32;
    let [r00, r01, r02] = r0;
    let [r20, r21, r22] = r2;
    let [m0, m1, m2] = m;
    let f1 = hi(m64(bx, r00) + m64(bz, r20)) - (m0 >> 2);
    let f2 = hi(m64(bx, r01) + m64(bz, r21)) - (m1 >> 2);
    let f3 = hi(m64(bx, r02) + m64(bz, r22)) - (m2 >> 2);
    let [q1, q2, q3, q4] = q;
    let (x, z) = (|q: i32| hi(m64(bx, q)), |q: i32| hi(m64(bz, q)));
    let (bx1, bx2, bx3, bx4) = (x(q1), x(q2), x(q3), x(q4));
    let (bz1, bz2, bz3, bz4) = (z(q1), z(q2), z(q3), z(q4));
    [
        hi(m64(bx3, f3) - m64(bz3, f1) + m64(bz2 - bx4, f2)),
        hi(m64(bz4, f1) + m64(bx3 + bz1, f2) + m64(bx4 - 2 * bz2, f3)),
        hi(m64(bx2 + bz4, f2) - m64(2 * bx3 + bz1, f1) + m64(bx1 - 2 * bz3, f3)),
        hi(m64(bx2, f3) + m64(bz2 - 2 * bx4, f1) + m64(bz3 - bx1, f2)),
    ]
}

/// q + ½ q ⊗ (0, ω)·dt in Q60 (`hw` = ½ω·dt in Q30, each |hwᵢ| ≤ 2^29).
/// Bound: ‖q‖·(1 + ‖hw‖)·2^60 ≤ (1 + √3/2)·2^60·(1 + 1e-6) < 1.87·2^60.
fn propagate(q: [i32; 4], hw: [i32; 3]) -> [i64; 4] {
    propagate_inline(q, hw)
}

/// [`propagate`], inlined where every instruction counts (the textbook update).
#[inline(always)]
fn propagate_inline(q: [i32; 4], hw: [i32; 3]) -> [i64; 4] {
    let [q1, q2, q3, q4] = q;
    let [h0, h1, h2] = hw;
    let b = |x: i32| i64::from(x) << 30;
    [
        b(q1) - m64(q2, h0) - m64(q3, h1) - m64(q4, h2),
        b(q2) + m64(q1, h0) + m64(q3, h2) - m64(q4, h1),
        b(q3) + m64(q1, h1) - m64(q2, h2) + m64(q4, h0),
        b(q4) + m64(q1, h2) + m64(q2, h1) - m64(q3, h0),
    ]
}

/// Turns a tilt low-pass state `s` (Q26 g) by the small rotation `t` (Q30 rad):
/// s += t × s.
#[inline(never)]
fn turn_state(s: &mut [i32; 3], t: [i32; 3]) {
    let [s0, s1, s2] = *s;
    let [t0, t1, t2] = t;
    // t × s: Q30·Q26 >> 30 → Q26.
    let c0 = (m64(t1, s2) - m64(t2, s1)) >> 30;
    let c1 = (m64(t2, s0) - m64(t0, s2)) >> 30;
    let c2 = (m64(t0, s1) - m64(t1, s0)) >> 30;
    *s = [
        sat32(i64::from(s0) + c0),
        sat32(i64::from(s1) + c1),
        sat32(i64::from(s2) + c2),
    ];
}

/// Renormalise the Q60 accumulator to a unit Q30 quaternion; `None` if (near) zero
/// (‖acc‖ < 2^-10). Bound: ‖acc‖ < (1.87 + 3·½)·2^60 = 3.37·2^60 (propagation, two
/// gradient steps and the heading term, each ≤ ½), so the Q29 components are < 2^31 and
/// ‖nq‖²·2^58 < 11.4·2^58 < 2^62.
/// Fast path (‖nq‖² = 1 + δ, |δ| < 2^-10, every normal step): nq·(3 − ‖nq‖²)/2, error
/// 3δ²/8 < 4e-7 (corrected again by the next step); otherwise a full reciprocal square root.
fn renormalise(acc: [i64; 4]) -> Option<[i32; 4]> {
    renormalise_inline(acc)
}

/// [`renormalise`], inlined where every instruction counts (the textbook update).
#[inline(always)]
fn renormalise_inline(acc: [i64; 4]) -> Option<[i32; 4]> {
    let q29 = |a: i64| ((a + (1 << 30)) >> 31) as i32;
    let [a0, a1, a2, a3] = acc;
    let (n0, n1, n2, n3) = (q29(a0), q29(a1), q29(a2), q29(a3));
    let s = m64(n0, n0) + m64(n1, n1) + m64(n2, n2) + m64(n3, n3);
    let dev = s - (1 << 58);
    if dev.unsigned_abs() < 1 << 48 {
        let f = (1 << 30) - (dev >> 29) as i32; // (3 − ‖nq‖²)/2 in Q30, |dev >> 29| < 2^19
        let r = |x: i32| ((m64(x, f) + (1 << 28)) >> 29) as i32;
        Some([r(n0), r(n1), r(n2), r(n3)])
    } else if s < 1 << 38 {
        None
    } else {
        unit4([n0, n1, n2, n3]).map(|(u, _)| u)
    }
}
/// a·b >> 30 for `a` a unit vector or a row of R(q) in Q30 (|aᵢ| ≤ 2^30 + 2^10) and any
/// `b`: each product ≤ 2^61·(1 + 2^-20), the sum of three < 2^63 (no saturation needed).
fn dot30(a: [i32; 3], b: [i32; 3]) -> i64 {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    (m64(a0, b0) + m64(a1, b1) + m64(a2, b2)) >> 30
}

fn cross30(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    let c = |p: i32, q: i32, r: i32, s: i32| sat32(mul30(p, q) - mul30(r, s));
    [
        c(a[1], b[2], a[2], b[1]),
        c(a[2], b[0], a[0], b[2]),
        c(a[0], b[1], a[1], b[0]),
    ]
}

/// 2^`e` as f32, exact, for `e` ≤ 127. Built from its exponent field rather than as
/// `(1u64 << e) as f32`, which links the soft 64-bit shift and u64 → f32 routines into a
/// firmware that has no other use for them.
const fn pow2_f32(e: u32) -> f32 {
    f32::from_bits((127 + e) << 23)
}

/// `x as u64` (truncation toward zero; NaN and negatives → 0, ≥ 2^64 → `u64::MAX`) in
/// 32-bit integer steps: the same result as the cast without linking the soft-float
/// library's `f32 → u64`/`i64` conversions, which the firmware uses only at start-up.
#[must_use]
pub fn f32_to_u64(x: f32) -> u64 {
    let bits = x.to_bits();
    if x.is_nan() || bits >> 31 != 0 {
        return 0;
    }
    // x = m · 2^(e − 23), 2^23 ≤ m < 2^24.
    let e = (bits >> 23) as i32 - 127;
    if e < 0 {
        return 0;
    }
    if e >= 64 {
        return u64::MAX;
    }
    let m = (bits & 0x7f_ffff) | 0x80_0000;
    if e <= 23 {
        return u64::from(m >> (23 - e));
    }
    let s = (e - 23) as u32; // 1..=40
    if s >= 32 {
        u64::from(m << (s - 32)) << 32
    } else {
        (u64::from(m >> (32 - s)) << 32) | u64::from(m << s)
    }
}

/// Convert an f32 to Q-format with `frac_bits` fractional bits (saturating; NaN → 0).
#[must_use]
pub fn float_to_q(x: f32, frac_bits: u32) -> i32 {
    let v = x * pow2_f32(frac_bits.min(62));
    if v.is_nan() {
        0
    } else {
        // `as` saturates for floats.
        libm::roundf(v) as i32
    }
}

/// rad/s (f32) to the gyro format, Q20 rad/s.
#[must_use]
pub fn rps_to_q20(rps: f32) -> i32 {
    float_to_q(rps, 20)
}

/// Seconds (f32) to the dt format, Q31 s (saturating at just under 1 s).
#[must_use]
pub fn dt_s_to_q31(dt_s: f32) -> i32 {
    float_to_q(dt_s, 31)
}

/// Microseconds to the dt format (Q31 s), saturating at just under 1 s.
#[must_use]
pub fn dt_us_to_q31(dt_us: u32) -> i32 {
    // us·2^31/1e6 = us·2147.483648 = (us·2147.483648·2^20) >> 20
    let v = (u64::from(dt_us) * 2_251_799_814 + (1 << 19)) >> 20;
    sat32(v.min(i32::MAX as u64) as i64)
}

/// The filter configuration converted to fixed point (built once, with f32).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FixedConfig {
    /// [`Algorithm::Textbook`] (else the full filter).
    textbook: bool,
    /// [`Config::bias`]`.enabled`: the gyro bias estimator runs.
    bias_enabled: bool,
    /// [`Config::accel_rejection`]`.enabled`.
    accel_rejection_enabled: bool,
    /// [`Config::mag_rejection`]`.enabled`.
    mag_rejection_enabled: bool,
    beta_q24: i32,
    inv_heading_tau_q24: i32,
    startup_beta_q24: i32,
    half_scale_tol_q30: i64,
    inv_scale_tau_q20: i64,
    startup_q20: i64,
    inv_startup_q30: i64,
    rest_gyro_sq_q40: i64,
    rest_acc_lo: u64,
    rest_acc_hi: u64,
    rest_time_q20: i64,
    inv_bias_tau_q30: i64,
    bias_max_q20: i32,
    acc_lo: u64,
    acc_hi: u64,
    cos_acc_q30: i64,
    acc_recovery_q20: i64,
    mag_lo_q16: u64,
    mag_hi_q16: u64,
    sin_dip_tol_q30: i64,
    mag_recovery_q20: i64,
    mag_min_rate_sq_q40: i64,
    mag_fallback_q20: i64,
    /// 1/`ref_tau_s` in Q30 (≤ 1/s; 0 = frozen).
    inv_mag_ref_tau_q30: i64,
    inv_tilt_tau_q20: i64,
    inv_tilt_tau0_q20: i64,
    /// 1/`rest_tilt_tau_s` in Q20.
    inv_rest_tilt_tau_q20: i64,
    inv_g_q32: i32,
    acc_pre_shift: u32,
    acc_pre_lim: i32,
    max_tilt_step_q26: i32,
    /// 1/[`Config::rotor_drag_per_s`] in Q16 (s); 0: not a multirotor.
    inv_drag_q16: i64,
    /// β of the drag law in Q16 (≤ 2^22; 0: rotor drag only).
    drag_beta_q16: u32,
}

/// 1/τ in Q20 (≤ 2000/s; τ ≤ 0 or NaN → 2000/s, so k = dt/τ saturates at 1 per step).
fn inv_q20(tau_s: f32) -> i64 {
    if tau_s > 0.0 {
        i64::from(float_to_q((1.0 / tau_s).min(2000.0), 20))
    } else {
        2000 << 20
    }
}

/// 1/g for the accelerometer in g (Q26) with one 32-bit shift and one multiply:
/// a/g = (a·2^p)·m / 2^32 with m = 2^(58−p)/g ∈ [2^30, 2^31) for p = 27 − ⌊log₂ g⌋ (g the
/// accelerometer units per g; p = 0 for g ≥ 2^27, clamped to [1, 2^40]). Inputs are
/// saturated so a·2^p fits in i32: at 2^(31−p) > 8 g, so the fixed filter sees at most
/// 8–16 g of specific force (the MPU-9250's largest range is 16 g).
fn inv_g_parts(g: f32) -> (i32, u32) {
    let g = if g.is_finite() {
        g.clamp(1.0, 1.0e12)
    } else {
        1.0
    };
    let mut e = 0u32;
    while e < 40 && pow2_f32(e + 1) <= g {
        e += 1;
    }
    let p = 27u32.saturating_sub(e);
    let m = pow2_f32(58 - p) / g;
    (libm::roundf(m).min(i32::MAX as f32) as i32, p)
}

fn s_to_q20(s: f32) -> i64 {
    i64::from(float_to_q(s.min(2000.0), 20))
}

fn sq_u64(x: f32) -> u64 {
    let v = x * x;
    if v.is_finite() && v > 0.0 {
        f32_to_u64(v.min(1.8e19))
    } else {
        0
    }
}

impl FixedConfig {
    /// Convert a physical [`Config`]. `cfg.gravity_norm` must be 1 g in the units the
    /// fixed filter's accelerometer input uses (e.g. counts).
    #[must_use]
    pub fn from_config(cfg: &Config) -> Self {
        let g = cfg.gravity_norm;
        let inv = |t: f32| {
            if t > 0.0 {
                i64::from(float_to_q((1.0 / t).min(1.9), 30))
            } else {
                1 << 30
            }
        };
        let f30 = |x: f32| i64::from(float_to_q(x, 30));
        let sq_q40 = |x: f32| {
            let v = i64::from(float_to_q(x, 20));
            v.saturating_mul(v)
        };
        let mr = cfg.mag_rejection;
        let (inv_g_q32, acc_pre_shift) = inv_g_parts(g);
        let drag = crate::madgwick::drag_model(cfg);
        Self {
            textbook: cfg.algorithm == Algorithm::Textbook,
            bias_enabled: cfg.bias.enabled,
            accel_rejection_enabled: cfg.accel_rejection.enabled,
            mag_rejection_enabled: cfg.mag_rejection.enabled,
            beta_q24: float_to_q(cfg.beta, 24),
            inv_heading_tau_q24: float_to_q(
                crate::madgwick::inv_heading_tau(cfg.heading_tau_s),
                24,
            ),
            startup_beta_q24: float_to_q(cfg.startup_beta, 24),
            // ½·tol in Q30, tol clamped to [0, 1] (NaN → 0).
            half_scale_tol_q30: f30(0.5 * cfg.gyro_scale_tol.clamp(0.0, 1.0)),
            // 1/τ in Q20 (≤ 2000/s; τ ≤ 0 or NaN → k = 1 per step, as the f32 filter).
            inv_scale_tau_q20: inv_q20(cfg.gyro_scale_tau_s),
            startup_q20: s_to_q20(cfg.startup_s.max(0.0)),
            inv_startup_q30: inv(cfg.startup_s),
            rest_gyro_sq_q40: sq_q40(cfg.bias.rest_gyro_rps),
            rest_acc_lo: sq_u64(g * (1.0 - cfg.bias.rest_accel_tol)),
            rest_acc_hi: sq_u64(g * (1.0 + cfg.bias.rest_accel_tol)),
            rest_time_q20: s_to_q20(cfg.bias.rest_time_s),
            inv_bias_tau_q30: inv(cfg.bias.tau_s),
            bias_max_q20: float_to_q(cfg.bias.max_rps, 20),
            acc_lo: sq_u64(g * (1.0 - cfg.accel_rejection.norm_tol)),
            acc_hi: sq_u64(g * (1.0 + cfg.accel_rejection.norm_tol)),
            cos_acc_q30: f30(crate::quat::cos_deg(cfg.accel_rejection.angle_deg)),
            acc_recovery_q20: s_to_q20(cfg.accel_rejection.recovery_s),
            mag_lo_q16: sq_u64((1.0 - mr.norm_tol) * 256.0),
            mag_hi_q16: sq_u64((1.0 + mr.norm_tol) * 256.0),
            sin_dip_tol_q30: f30(crate::quat::sin_deg(mr.dip_tol_deg)),
            mag_recovery_q20: s_to_q20(mr.recovery_s),
            mag_min_rate_sq_q40: sq_q40(mr.recovery_min_rate_rps),
            mag_fallback_q20: s_to_q20(mr.fallback_s),
            inv_mag_ref_tau_q30: if mr.ref_tau_s > 0.0 {
                f30((1.0 / mr.ref_tau_s).min(1.0))
            } else {
                0
            },
            inv_tilt_tau_q20: inv_q20(cfg.tilt_tau_s),
            inv_tilt_tau0_q20: inv_q20(cfg.tilt_tau_s.min(crate::madgwick::STARTUP_TILT_TAU_S)),
            inv_rest_tilt_tau_q20: inv_q20(cfg.rest_tilt_tau_s),
            inv_g_q32,
            acc_pre_shift,
            acc_pre_lim: i32::MAX >> acc_pre_shift,
            max_tilt_step_q26: float_to_q(crate::madgwick::MAX_TILT_STEP_RAD, 26),
            inv_drag_q16: drag.map_or(0, |d| i64::from(float_to_q(1.0 / d.mu, 16))),
            drag_beta_q16: drag.map_or(0, |d| float_to_q(d.beta, 16).unsigned_abs()),
        }
    }
}

/// Field reference: ‖m‖² with its accepted band, dip sine and its tolerance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct MagRef {
    n2: u64,
    lo: u64,
    hi: u64,
    hz_q30: i64,
    hz_tol_q30: i64,
}

/// Madgwick AHRS in fixed point (see the module docs for the Q-formats).
///
/// ```
/// use fc_ahrs::fixed::{dt_us_to_q31, FixedConfig, MadgwickFixed};
/// use fc_ahrs::{Config, UpdatePath};
/// // MPU-9250 at ±2 g: 16384 counts per g, already in FRD body axes.
/// let cfg = FixedConfig::from_config(&Config { gravity_norm: 16384.0, ..Config::DEFAULT });
/// let mut f = MadgwickFixed::from_accel_mag(cfg, [0, 0, -16384], [200, 0, 450]);
/// let st = f.update_marg([0; 3], [0, 0, -16384], [200, 0, 450], dt_us_to_q31(1000));
/// assert_eq!(st.path, UpdatePath::Marg);
/// let q = f.quaternion_q30();
/// assert!((i64::from(q[0]) - (1 << 30)).abs() < 1000);
/// ```
#[derive(Debug, Clone)]
pub struct MadgwickFixed {
    c: FixedConfig,
    q: [i32; 4],
    bias_q20: [i32; 3],
    bias_q40: [i64; 3],
    time_q20: i64,
    rest_q20: i64,
    acc_reject_q20: i64,
    acc_forced: bool,
    mag_ref: Option<MagRef>,
    cand: Option<(u64, i64)>,
    cand_q20: i64,
    /// Time rejected without a break (Q20 s), for the fallback.
    mag_reject_q20: i64,
    rate_lp_down_q40: i64,
    /// Two first-order low-pass stages of the specific force (g, Q26) in the estimate's
    /// NED frame.
    acc_lp: [[i32; 3]; 2],
    /// The rotor-plane specific force in NED through the drag model's input low-pass
    /// (g, Q26).
    drag_lp: [i32; 2],
    /// The drag law's linear part of the previous sample, body x and y (g, Q26).
    drag_p: [i32; 2],
    /// In flight ([`MadgwickFixed::set_in_flight`]).
    in_flight: bool,
    /// The tilt loop's hand-held form (as the f32 filter's).
    hand_held_tilt: bool,
    /// Samples the tilt correction skipped since the drag model last ran.
    drag_skipped: u32,
    /// The last heading correction (Q30 rad), for the drag model's states.
    drag_tz: i32,
    acc_lp_valid: bool,
}

impl MadgwickFixed {
    /// New filter at the identity orientation.
    #[must_use]
    pub fn new(c: FixedConfig) -> Self {
        Self {
            c,
            q: [1 << 30, 0, 0, 0],
            bias_q20: [0; 3],
            bias_q40: [0; 3],
            time_q20: 0,
            rest_q20: 0,
            acc_reject_q20: 0,
            acc_forced: false,
            mag_ref: None,
            cand: None,
            cand_q20: 0,
            mag_reject_q20: 0,
            rate_lp_down_q40: 0,
            acc_lp: [[0; 3]; 2],
            drag_lp: [0; 2],
            drag_p: [0; 2],
            in_flight: false,
            hand_held_tilt: c.inv_drag_q16 == 0,
            drag_skipped: 0,
            drag_tz: 0,
            acc_lp_valid: false,
        }
    }

    /// New filter initialised from one accelerometer and magnetometer sample (see
    /// [`MadgwickFixed::init_from_accel_mag`]).
    #[must_use]
    pub fn from_accel_mag(c: FixedConfig, accel: [i32; 3], mag: [i32; 3]) -> Self {
        let mut f = Self::new(c);
        f.init_from_accel_mag(accel, mag);
        f
    }

    /// Reset the orientation from an accelerometer and magnetometer sample (body frame,
    /// any units) and learn the magnetic reference; yaw 0 if the field is unusable.
    /// Returns false (state unchanged) if the accelerometer is zero.
    pub fn init_from_accel_mag(&mut self, accel: [i32; 3], mag: [i32; 3]) -> bool {
        let Some((a, _)) = unit3(accel) else {
            return false;
        };
        let d = a.map(|x| x.saturating_neg());
        let m = unit3(mag);
        let east = m.and_then(|(m, _)| unit3(cross30(d, m)));
        let e = match east {
            Some((e, _)) => e,
            None => {
                let helper = if d[0].unsigned_abs() < (0.9 * ONE_Q30 as f32) as u32 {
                    [1 << 30, 0, 0]
                } else {
                    [0, 1 << 30, 0]
                };
                unit3(cross30(d, helper)).map_or([0, 1 << 30, 0], |(e, _)| e)
            }
        };
        let n = cross30(e, d);
        self.q = quat_from_rows_q30([n, e, d]);
        self.acc_lp_valid = false;
        self.mag_ref = None;
        if let Some((mu, n2)) = m {
            self.mag_ref = Some(self.make_ref(n2, dot30(mu, d)));
        }
        true
    }

    fn make_ref(&self, n2: u64, hz_q30: i64) -> MagRef {
        let hz = hz_q30.max(-ONE_Q30).min(ONE_Q30);
        let c2 = (ONE_Q30 * ONE_Q30 - hz * hz).max(0) as u64; // cos²(dip), Q60
        let c = isqrt(c2).max(ONE_Q30 / 20); // Q30, ≥ 0.05
        let scaled =
            |k: u64| ((u128::from(n2) * u128::from(k)) >> 16).min(u128::from(u64::MAX)) as u64;
        MagRef {
            n2,
            lo: scaled(self.c.mag_lo_q16),
            hi: scaled(self.c.mag_hi_q16),
            hz_q30: hz,
            hz_tol_q30: (self.c.sin_dip_tol_q30 * c) >> 30,
        }
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &FixedConfig {
        &self.c
    }

    /// Whether the body is flying: the multirotor mode's drag model applies only
    /// then, the tilt loop's hand-held form only when not and without the multirotor
    /// mode (see [`crate::Madgwick::set_in_flight`]); false at construction.
    pub fn set_in_flight(&mut self, in_flight: bool) {
        self.in_flight = in_flight;
        self.hand_held_tilt = !in_flight && self.c.inv_drag_q16 == 0;
    }

    /// Orientation `q_ned_from_body` as (w, x, y, z) in Q30.
    #[must_use]
    pub fn quaternion_q30(&self) -> [i32; 4] {
        self.q
    }

    /// Orientation as an f32 [`Quaternion`] (for logging and host tools).
    #[must_use]
    pub fn quaternion_f32(&self) -> Quaternion {
        let s = 1.0 / ONE_Q30 as f32;
        Quaternion::new(
            self.q[0] as f32 * s,
            self.q[1] as f32 * s,
            self.q[2] as f32 * s,
            self.q[3] as f32 * s,
        )
    }

    /// Euler angles (roll, pitch, yaw) in rad, ZYX (uses f32 maths: not for the hot path).
    #[must_use]
    pub fn euler_rad(&self) -> [f32; 3] {
        self.quaternion_f32().to_euler_rad()
    }

    /// Gyro bias estimate, rad/s in Q20.
    #[must_use]
    pub fn gyro_bias_rps_q20(&self) -> [i32; 3] {
        self.bias_q20
    }

    /// Unit gravity direction ("down") in the body frame, Q30.
    #[must_use]
    pub fn gravity_body_q30(&self) -> [i32; 3] {
        rows(self.q)[2]
    }

    /// Earth-frame (NED) linear acceleration, m/s² in Q16, from the body specific force
    /// in m/s² Q16: `a_ned = R·f + (0, 0, g)`.
    #[must_use]
    pub fn linear_accel_ned_mps2_q16(&self, accel_body_mps2_q16: [i32; 3]) -> [i32; 3] {
        let r = rows(self.q);
        let g_q16: i64 = 642_689; // 9.80665·2^16
        [
            sat32(dot30(r[0], accel_body_mps2_q16)),
            sat32(dot30(r[1], accel_body_mps2_q16)),
            sat32(dot30(r[2], accel_body_mps2_q16) + g_q16),
        ]
    }

    /// Vertical linear acceleration, up positive, m/s² in Q16 (3 multiplies).
    #[must_use]
    pub fn vertical_accel_up_mps2_q16(&self, accel_body_mps2_q16: [i32; 3]) -> i32 {
        let r = rows(self.q);
        sat32(-(dot30(r[2], accel_body_mps2_q16) + 642_689))
    }

    /// IMU update. `gyro_rps_q20` body rates (Q20 rad/s), `accel` any unit (see
    /// [`Config::gravity_norm`]), `dt_s_q31` step in Q31 s (must be > 0).
    pub fn update_imu(
        &mut self,
        gyro_rps_q20: [i32; 3],
        accel: [i32; 3],
        dt_s_q31: i32,
    ) -> UpdateStatus {
        self.update_inner(gyro_rps_q20, accel, None, dt_s_q31)
    }

    /// MARG update (magnetometer in any unit).
    pub fn update_marg(
        &mut self,
        gyro_rps_q20: [i32; 3],
        accel: [i32; 3],
        mag: [i32; 3],
        dt_s_q31: i32,
    ) -> UpdateStatus {
        self.update_inner(gyro_rps_q20, accel, Some(mag), dt_s_q31)
    }

    fn update_inner(
        &mut self,
        gyro: [i32; 3],
        accel: [i32; 3],
        mag: Option<[i32; 3]>,
        dt_q31: i32,
    ) -> UpdateStatus {
        let mut st = UpdateStatus::new();
        if dt_q31 <= 0 {
            st.gyro_invalid = true;
            return st;
        }
        if self.c.textbook {
            #[cfg(feature = "textbook")]
            return self.update_textbook(gyro, accel, mag, dt_q31);
            // Built without it (the firmware, which runs the full filter): refuse to
            // update rather than run another algorithm than the one configured.
            #[cfg(not(feature = "textbook"))]
            {
                st.path = UpdatePath::Skipped;
                return st;
            }
        }
        let initialising = self.time_q20 < self.c.startup_q20;
        st.initialising = initialising;
        let acc = unit3(accel);
        st.accel_invalid = acc.is_none();

        let w = self.estimate_bias(gyro, acc.map(|(_, n2)| n2), dt_q31, &mut st);
        // Gyro step, not yet renormalised: ‖q‖² ≤ 1 + 3/16 (half angles ≤ ¼ per axis),
        // so the rows of R below stay < 2^31 (they carry ‖q‖², a common scale the
        // corrections do not see), and one renormalisation after the corrections does.
        // A step whose rotation is too large for one first-order step is split into
        // equal sub-steps (as the f32 filter), renormalised between them.
        let big = |x: i32| m64(x, dt_q31).unsigned_abs() >= SUBSTEP_WDT_Q51;
        let nq = if big(w[0]) || big(w[1]) || big(w[2]) {
            substep(self.q, w, dt_q31, &mut st.gyro_step_clamped)
        } else {
            propagate(self.q, half_angles(w, dt_q31, &mut st.gyro_step_clamped))
        };
        let q = nq.map(|a| ((a + (1 << 29)) >> 30) as i32);
        let r = rows(q);
        self.track_vertical_rate(r[2], w, dt_q31);
        let tilt = self.correct_tilt(&r, accel, acc, dt_q31, initialising, &mut st);
        let heading = match mag {
            Some(m) => self.correct_heading(&r, m, w_sq(w), dt_q31, initialising, &mut st),
            None => None,
        };
        st.path = match (tilt.is_some(), heading.is_some()) {
            (true, true) => UpdatePath::Marg,
            (true, false) => UpdatePath::Imu,
            (false, true) => UpdatePath::MagOnly,
            (false, false) => UpdatePath::GyroOnly,
        };
        let [tx, ty] = tilt.unwrap_or([0; 2]);
        if !self.fuse(nq, q, [tx, ty, heading.unwrap_or(0)]) {
            st.path = UpdatePath::Skipped;
            return st;
        }
        self.time_q20 = (self.time_q20 + i64::from(dt_q31 >> 11)).min(1 << 60);
        st
    }

    /// Gyro bias estimation at rest; returns the bias-corrected rate (Q20 rad/s).
    fn estimate_bias(
        &mut self,
        gyro: [i32; 3],
        accel_norm_sq: Option<u64>,
        dt_q31: i32,
        st: &mut UpdateStatus,
    ) -> [i32; 3] {
        // By reference: a copy of the whole configuration costs a `memcpy` per update.
        let c = &self.c;
        if !c.bias_enabled {
            return gyro;
        }
        let w = sub_sat3(gyro, self.bias_q20);
        let still = w_sq(w) < c.rest_gyro_sq_q40
            && accel_norm_sq.is_some_and(|n2| n2 > c.rest_acc_lo && n2 < c.rest_acc_hi);
        self.rest_q20 = if still {
            (self.rest_q20 + i64::from(dt_q31 >> 11)).min(1 << 50)
        } else {
            0
        };
        if self.rest_q20 >= c.rest_time_q20 {
            st.at_rest = true;
            let k = ((i64::from(dt_q31) * c.inv_bias_tau_q30) >> 31)
                .max(0)
                .min(ONE_Q30);
            // Bias kept in Q40 so the tiny steps k·w are not lost to truncation.
            let max = i64::from(c.bias_max_q20) << 20;
            for ((acc, b), w) in self
                .bias_q40
                .iter_mut()
                .zip(self.bias_q20.iter_mut())
                .zip(w)
            {
                // `max(-max).min(max)`, not `clamp`: no panic path for a misconfigured
                // negative limit, no formatting code linked.
                *acc = (*acc + ((k * i64::from(w)) >> 10)).max(-max).min(max);
                *b = sat32((*acc + (1 << 19)) >> 20);
            }
        }
        sub_sat3(gyro, self.bias_q20)
    }

    /// Mean rate about the vertical (Q40 rad/s) for the scale-factor heading gain
    /// schedule (`Config::gyro_scale_tol`): first-order low-pass, k = dt/τ in Q30.
    fn track_vertical_rate(&mut self, down: [i32; 3], w: [i32; 3], dt_q31: i32) {
        let c = &self.c;
        if c.half_scale_tol_q30 > 0 {
            let k = ((i64::from(dt_q31) * c.inv_scale_tau_q20) >> 21)
                .max(0)
                .min(ONE_Q30);
            let lp = self.rate_lp_down_q40;
            let x_q20 = dot30(down, w)
                .max(-MAX_MEAN_RATE_Q20)
                .min(MAX_MEAN_RATE_Q20);
            let e = x_q20 - (lp >> 20); // |e| ≤ 2^27, so k·e < 2^57
            self.rate_lp_down_q40 = (lp + ((k * e) >> 10))
                .max(-MAX_MEAN_RATE_Q40)
                .min(MAX_MEAN_RATE_Q40);
        }
    }

    /// Accelerometer (inclination) correction, as the f32 filter's: the specific force in
    /// g (Q26) in the estimate's NED frame through two first-order low-pass stages (Q26
    /// states, k = dt/τ in Q30); returns the earth-frame rotation (x, y) in Q30 rad that
    /// takes the low-passed vector onto the vertical.
    fn correct_tilt(
        &mut self,
        r: &[[i32; 3]; 3],
        accel: [i32; 3],
        acc: Option<([i32; 3], u64)>,
        dt_q31: i32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> Option<[i32; 2]> {
        // A skipped sample is not seen by the drag model either (as the f32 filter).
        let Some((a, n2)) = acc else {
            self.skip_drag();
            return None;
        };
        if self.reject_accel(r[2], a, n2, dt_q31, initialising, st) {
            self.skip_drag();
            return None;
        }
        let c = &self.c;
        // a/g in Q26: a saturated so a·2^p fits (≥ 8 g: see `inv_g_parts`), times the
        // Q32 mantissa, high word.
        let lim = c.acc_pre_lim;
        let g = |x: i32| (m64(x.max(-lim).min(lim) << c.acc_pre_shift, c.inv_g_q32) >> 32) as i32;
        let ag = [g(accel[0]), g(accel[1]), g(accel[2])];
        // Rows of R in Q30 times Q26 → Q26 (‖a/g‖ < √3·32, saturated).
        let u = [
            sat32(dot30(r[0], ag)),
            sat32(dot30(r[1], ag)),
            sat32(dot30(r[2], ag)),
        ];
        let first = !self.acc_lp_valid;
        if first {
            self.acc_lp = [u, u];
            self.acc_lp_valid = true;
        }
        // k = dt·(1/τ) in Q30 (Q31·Q20 >> 21); start-up ramps 1/τ (as the f32 filter).
        let inv_tau = if initialising && c.startup_q20 > 0 {
            let frac = ((self.time_q20 * c.inv_startup_q30) >> 20)
                .max(0)
                .min(ONE_Q30);
            let i0 = c.inv_tilt_tau0_q20;
            i0 + (((c.inv_tilt_tau_q20 - i0) * frac) >> 30)
        } else {
            c.inv_tilt_tau_q20
        };
        // At rest, hand-held: `rest_tilt_tau_s` where that is faster (as the f32
        // filter).
        let rest = i64::from(st.at_rest & self.hand_held_tilt);
        let inv_tau = inv_tau.max(c.inv_rest_tilt_tau_q20 * rest);
        let k = ((i64::from(dt_q31) * inv_tau) >> 21).max(0).min(ONE_Q30) as i32;
        let [s1, s2] = &mut self.acc_lp;
        let [u0, u1, u2] = u;
        let [a0, a1, a2] = s1;
        *a0 = lp_step(*a0, u0, k);
        *a1 = lp_step(*a1, u1, k);
        *a2 = lp_step(*a2, u2, k);
        let [b0, b1, b2] = s2;
        *b0 = lp_step(*b0, *a0, k);
        *b1 = lp_step(*b1, *a1, k);
        *b2 = lp_step(*b2, *a2, k);
        let (y0, y1, yz) = (*b0, *b1, b2.saturating_neg());
        let c = &self.c;
        // θ = ŷ × (0, 0, −1) with ŷ ≈ y/|y_z| (as the f32 filter), Q26 g → Q30 rad, at
        // most MAX_TILT_STEP per update. 1/|y_z| by one 32-bit division: |y_z| in Q16
        // (≥ 2^6 above 1/1024 g), 2^31/|y_z|_Q16 is 1/|y_z| in Q15.
        let d = if yz > 1 << 16 { yz >> 10 } else { 1 << 16 };
        let inv_q15 = i32::MAX.checked_div(d).unwrap_or(0);
        let lim = c.max_tilt_step_q26;
        let th = |v: i32| {
            let t = (m64(v, inv_q15) >> 15)
                .max(-i64::from(lim))
                .min(i64::from(lim));
            (t as i32) << 4
        };
        let theta = [th(y1.saturating_neg()), th(y0)];
        // Multirotor mode: −(the drag's acceleration) into the first stage, which the
        // second takes from the next sample on (as the f32 filter: only in flight,
        // not during the start-up ramp).
        if !cfg!(feature = "no-multirotor") && self.c.inv_drag_q16 > 0 {
            let on = self.in_flight && !initialising;
            // The velocity change across skipped samples, spread over them.
            // 1/τ ≤ 2000 in Q20 fits u32: one 32-bit `UDIV`, only after a gap.
            let inv_tau = match (on, self.drag_skipped) {
                (false, _) => 0,
                (true, 0) => inv_tau,
                (true, n) => i64::from(
                    (inv_tau as u32)
                        .checked_div(n.saturating_add(1))
                        .unwrap_or(0),
                ),
            };
            self.drag_skipped = 0;
            let [d0, d1] = self.drag_rate(r, ag, first, inv_tau, dt_q31);
            let s1 = &mut self.acc_lp[0];
            s1[0] = s1[0].saturating_add(d0);
            s1[1] = s1[1].saturating_add(d1);
        }
        Some(theta)
    }

    /// What the drag's acceleration takes from the first tilt stage this sample (g,
    /// Q26, NED, horizontal), as the f32 filter's: Δh/(μ·τ) with 1/τ `inv_tau` in Q20
    /// (0: nothing), `first` starting from this sample. c = 1/(μ·τ) in Q16 is at most
    /// 2^31 and |Δh| < 2^30 (|h| < 2^29: |p| ≤ 4 g, rows of R < 1.2 in norm), so the
    /// product is < 2^61.
    fn drag_rate(
        &mut self,
        r: &[[i32; 3]; 3],
        ag: [i32; 3],
        first: bool,
        inv_tau: i64,
        dt_q31: i32,
    ) -> [i32; 2] {
        let raw = drag_velocity_ned(&self.c, r, ag, &mut self.drag_p);
        if first {
            self.drag_lp = raw;
        }
        // The last heading correction turns the low-pass's state with the frame (as
        // the f32 filter): Q30·Q26 >> 30, |θz| ≤ ¼, |h| < 2^29.
        let tz = self.drag_tz;
        let [h0, h1] = self.drag_lp;
        let h = [
            h0 - (m64(tz, h1) >> 30) as i32,
            h1 + (m64(tz, h0) >> 30) as i32,
        ];
        // The input low-pass (as the f32 filter's): k = dt·ω_c in Q30 (Q31·Q20 >> 21);
        // its step is this sample's Δh. |raw|, |h| < 2^29: the difference fits.
        let k = ((i64::from(dt_q31) * DRAG_INPUT_WC_Q20) >> 21)
            .max(0)
            .min(ONE_Q30) as i32;
        let dh = [
            (m64(k, raw[0] - h[0]) >> 30) as i32,
            (m64(k, raw[1] - h[1]) >> 30) as i32,
        ];
        self.drag_lp = [h[0] + dh[0], h[1] + dh[1]];
        // Q20·Q16 >> 20 (< 2^31·2^23), at most 2^31.
        let c_q16 = ((inv_tau * self.c.inv_drag_q16) >> 20).min(i64::from(i32::MAX)) as i32;
        [
            sat32(m64(dh[0], c_q16) >> 16),
            sat32(m64(dh[1], c_q16) >> 16),
        ]
    }

    /// A sample the tilt correction skips: the drag model spreads the velocity change
    /// across the gap over the samples it spans when it next runs.
    fn skip_drag(&mut self) {
        if !cfg!(feature = "no-multirotor") {
            self.drag_skipped = self.drag_skipped.saturating_add(1);
        }
    }

    /// Accelerometer rejection with its recovery timeout; true if the sample is rejected.
    fn reject_accel(
        &mut self,
        down: [i32; 3],
        a: [i32; 3],
        n2: u64,
        dt_q31: i32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> bool {
        let c = &self.c;
        if !c.accel_rejection_enabled || initialising {
            return false;
        }
        let d = a.map(|x| x.saturating_neg());
        let mut reject = n2 < c.acc_lo || n2 > c.acc_hi || dot30(d, down) < c.cos_acc_q30;
        if reject {
            self.acc_reject_q20 = (self.acc_reject_q20 + i64::from(dt_q31 >> 11)).min(1 << 50);
            if self.acc_reject_q20 > c.acc_recovery_q20 {
                self.acc_forced = true;
            }
            if self.acc_forced {
                st.accel_recovering = true;
                reject = false;
            }
        } else {
            self.acc_reject_q20 = 0;
            self.acc_forced = false;
        }
        st.accel_rejected = reject;
        reject
    }

    /// Magnetometer (heading only) correction, as the f32 filter's: the earth-frame
    /// rotation about the vertical in Q30 rad, or `None` if the field is invalid or
    /// disturbed.
    fn correct_heading(
        &mut self,
        r: &[[i32; 3]; 3],
        mag: [i32; 3],
        w2_q40: i64,
        dt_q31: i32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> Option<i32> {
        let Some((m, n2)) = unit3(mag) else {
            st.mag_invalid = true;
            st.mag_state = MagState::Invalid;
            return None;
        };
        // h = R m (eq. 45), NED, Q30.
        let h = [dot30u(r[0], m), dot30u(r[1], m), dot30u(r[2], m)]
            .map(|x| i64::from(x).max(-ONE_Q30).min(ONE_Q30));
        if !self.check_mag(n2, h[2], w2_q40, dt_q31, initialising, st) {
            return None;
        }
        // Heading error, as the f32 filter: the east component over the north one (tan of
        // the error), in units of the linear zone (`e`) and in radians (`e_mag`), each ±1
        // beyond its zone or with the field pointing south. 32-bit divisions in Q12: h_N
        // is first scaled to [2^17, 2^18) (h_E with it), so a numerator below h_N·2^12
        // stays < 2^30 and h_E keeps 17 bits.
        let (hn, he) = (h[0] as i32, h[1] as i32); // |hᵢ| ≤ 2^30
        let g = crate::madgwick::HEADING_LINEAR_GAIN;
        let (e_q12, e_mag_q12) = if hn >= 1 << 17 {
            let r = 14 - hn.leading_zeros().min(14); // hn >> r ∈ [2^17, 2^18)
            let (hn, he) = (hn >> r, he >> r);
            let sat = he.signum() << 12;
            if he.abs() >= hn {
                (sat, sat)
            } else {
                let e_mag = (he << 12).checked_div(hn).unwrap_or(0);
                if (i64::from(he) * i64::from(g)).abs() >= i64::from(hn) {
                    (sat, e_mag)
                } else {
                    (((he * g) << 12).checked_div(hn).unwrap_or(0), e_mag)
                }
            }
        } else {
            (he.signum() << 12, he.signum() << 12)
        };
        let c = &self.c;
        // Start-up: a constant rate 2β ramping from `startup_beta` to 0.
        let beta_start = if initialising && c.startup_q20 > 0 {
            let frac = ((self.time_q20 * c.inv_startup_q30) >> 20)
                .max(0)
                .min(ONE_Q30);
            let sb = i64::from(c.startup_beta_q24);
            sb - ((sb * frac) >> 30)
        } else {
            0
        };
        // β_head = ½·tol·|ω̄_D|: Q20 (< 2^27) · Q30 → >> 26 gives Q24.
        let beta_head = (((self.rate_lp_down_q40 >> 20).abs()) * c.half_scale_tol_q30) >> 26;
        // 2β·dt: Q24·Q31 >> 24 is β·dt in Q31, i.e. 2β·dt in Q30. The start-up rate is
        // constant towards the field, β_head proportional within the linear zone, the
        // first-order term tan(error)/τ (as the f32 filter).
        let two_dt = |b: i64| (b.max(0).min(i64::from(i32::MAX)) * i64::from(dt_q31)) >> 24;
        let start_dt = two_dt(beta_start).min(ONE_Q30);
        let head = (two_dt(beta_head).min(ONE_Q30) * i64::from(e_q12)) >> 12;
        // (1/τ)·dt: Q24·Q31 >> 25 is Q30.
        let tau_dt = (i64::from(c.inv_heading_tau_q24) * i64::from(dt_q31)) >> 25;
        let first = (tau_dt * i64::from(e_mag_q12)) >> 12;
        let step = head + first + start_dt * h[1].signum();
        // A step never passes the field's heading (|h_E| ≤ the error's sine; as the f32
        // filter).
        let lim = h[1].abs().min(ONE_Q30 / 2);
        Some((-step).max(-lim).min(lim) as i32)
    }

    /// q ← q + ½ (0, θ) ⊗ q (θ the earth-frame correction, Q30 rad) on the propagated
    /// Q60 accumulator `acc` (q its Q30 value), renormalised; the low-passed
    /// accelerometer states rotate with it (s += θ × s). False if degenerate.
    fn fuse(&mut self, acc: [i64; 4], q: [i32; 4], theta: [i32; 3]) -> bool {
        let [q0, q1, q2, q3] = q;
        let [p1, p2, p3] = theta.map(|t| t >> 1);
        let [a0, a1, a2, a3] = acc;
        // |p₁|, |p₂| ≤ 0.025, |p₃| ≤ ¼, ‖q‖ < 1.09: the accumulator stays < 1.4·2^60.
        let acc = [
            a0 - m64(p1, q1) - m64(p2, q2) - m64(p3, q3),
            a1 + m64(p1, q0) + m64(p2, q3) - m64(p3, q2),
            a2 - m64(p1, q3) + m64(p2, q0) + m64(p3, q1),
            a3 + m64(p1, q2) - m64(p2, q1) + m64(p3, q0),
        ];
        let Some(n) = renormalise(acc) else {
            return false;
        };
        self.q = n;
        // The first stage turns by half the tilt hand-held, by all of it otherwise
        // (as the f32 filter's `fuse`).
        let first = if self.hand_held_tilt {
            [p1, p2, theta[2]]
        } else {
            theta
        };
        let [s_first, s_second] = &mut self.acc_lp;
        turn_state(s_first, first);
        turn_state(s_second, theta);
        // The drag model turns its states by it when it next runs.
        if !cfg!(feature = "no-multirotor") {
            self.drag_tz = theta[2];
        }
        true
    }

    /// Madgwick's 2010 filter exactly ([`Algorithm::Textbook`], as the f32 filter's):
    /// J_gᵀf_g + J_bᵀf_b normalised jointly, one fixed β, the raw gyro.
    // `update_inner`'s arguments, as it hands the call over when the configured
    // algorithm is `Algorithm::Textbook`.
    #[cfg(feature = "textbook")]
    fn update_textbook(
        &mut self,
        gyro: [i32; 3],
        accel: [i32; 3],
        mag: Option<[i32; 3]>,
        dt_q31: i32,
    ) -> UpdateStatus {
        let mut st = UpdateStatus::new();
        let q = self.q;
        let mut nq = propagate_inline(q, half_angles(gyro, dt_q31, &mut st.gyro_step_clamped));
        let acc = unit3_fast(accel);
        st.accel_invalid = acc.is_none();
        st.path = UpdatePath::GyroOnly;
        if let Some(a) = acc {
            let r = rows_inline(q);
            // ∇/2 in Q26 → Q24 to add the magnetometer's.
            // |aᵢ| ≤ 2^30·(1 + 4e-4): the negation cannot overflow.
            let [g0, g1, g2, g3] = accel_grad(q, r[2], a.map(|x| -x));
            let mut grad = [g0 >> 2, g1 >> 2, g2 >> 2, g3 >> 2];
            st.path = UpdatePath::Imu;
            if let Some(mag) = mag {
                match unit3_fast(mag) {
                    None => st.mag_invalid = true,
                    Some(m) => {
                        let h = [
                            dot30u_inline(r[0], m),
                            dot30u_inline(r[1], m),
                            dot30u_inline(r[2], m),
                        ]
                        .map(|x| i64::from(x).max(-ONE_Q30).min(ONE_Q30));
                        // bx = √(h₀² + h₁²) ≤ √2·2^30: s < 2^62, `isqrt`'s range without
                        // its large-argument branch.
                        let (sm, k) = norm_parts((h[0] * h[0] + h[1] * h[1]) as u64);
                        let bx = sqrt_parts(sm, rsqrt_q29(sm), k) as i32;
                        let [b0, b1, b2, b3] = mag_grad(q, r[0], r[2], m, bx, h[2] as i32);
                        // |∇_g/2| < 2^28 and |∇_b/2| < 2^29 in Q24: the sum fits.
                        let [g0, g1, g2, g3] = &mut grad;
                        *g0 += b0;
                        *g1 += b1;
                        *g2 += b2;
                        *g3 += b3;
                        st.path = UpdatePath::Marg;
                    }
                }
            }
            // β·dt: Q24·Q31 → Q30.
            let beta_dt = ((i64::from(self.c.beta_q24.max(0)) * i64::from(dt_q31)) >> 25)
                .max(0)
                .min(ONE_Q30);
            // Normalised gradient step: nq −= min(β·dt, ½)·∇/‖∇‖ (Q30·Q30 = Q60).
            if let Some([u0, u1, u2, u3]) = unit_fast(grad) {
                let s = beta_dt.min(1 << 29) as i32;
                let [a0, a1, a2, a3] = &mut nq;
                *a0 -= m64(s, u0);
                *a1 -= m64(s, u1);
                *a2 -= m64(s, u2);
                *a3 -= m64(s, u3);
            }
        }
        match renormalise_inline(nq) {
            Some(n) => self.q = n,
            None => st.path = UpdatePath::Skipped,
        }
        self.time_q20 = (self.time_q20 + i64::from(dt_q31 >> 11)).min(1 << 60);
        st
    }

    fn check_mag(
        &mut self,
        n2: u64,
        hz: i64,
        w2_q40: i64,
        dt_q31: i32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> bool {
        let c = &self.c;
        st.mag_state = MagState::Undisturbed;
        // By reference: copying the reference or the rejection configuration out of
        // `self` costs a `memcpy` per update.
        let Some(re) = self.mag_ref.as_ref() else {
            self.mag_ref = Some(self.make_ref(n2, hz));
            return true;
        };
        if initialising {
            // Low-pass the reference (τ = 1 s): k = dt/1 s in Q31.
            let k = i128::from(dt_q31);
            let n2r = i128::from(re.n2) + ((k * (i128::from(n2) - i128::from(re.n2))) >> 31);
            let hzr = re.hz_q30 + ((i64::from(dt_q31) * (hz - re.hz_q30)) >> 31);
            self.mag_ref = Some(self.make_ref(n2r.clamp(0, i128::from(u64::MAX)) as u64, hzr));
            return true;
        }
        if !c.mag_rejection_enabled {
            return true;
        }
        let ok =
            |rf: &MagRef| n2 >= rf.lo && n2 <= rf.hi && (hz - rf.hz_q30).abs() <= rf.hz_tol_q30;
        if ok(re) {
            let (ref_n2, ref_hz_q30, hz_tol_q30) = (re.n2, re.hz_q30, re.hz_tol_q30);
            let moving = cfg!(feature = "mag-ref-follow")
                && c.inv_mag_ref_tau_q30 > 0
                && w2_q40 > c.mag_min_rate_sq_q40;
            self.clear_disturbance();
            if moving {
                self.follow_reference(n2, hz, ref_n2, ref_hz_q30, hz_tol_q30, dt_q31);
                st.mag_state = MagState::Learning;
            }
            return true;
        }
        let hz_tol_q30 = re.hz_tol_q30;
        self.on_rejected(n2, hz, hz_tol_q30, w2_q40, dt_q31, st, ok)
    }

    /// The field matches the reference: no disturbance, no candidate.
    // Inlined: a call here costs every undisturbed update ~9 instructions.
    #[inline(always)]
    fn clear_disturbance(&mut self) {
        self.cand = None;
        self.cand_q20 = 0;
        self.mag_reject_q20 = 0;
    }

    /// Moving and undisturbed: the reference follows the field (as the f32 filter;
    /// the dip tolerance is kept).
    // Out of line, as `on_rejected`: off the undisturbed path, which is cheaper
    // without them.
    #[inline(never)]
    fn follow_reference(
        &mut self,
        n2: u64,
        hz: i64,
        ref_n2: u64,
        ref_hz_q30: i64,
        hz_tol_q30: i64,
        dt_q31: i32,
    ) {
        let c = &self.c;
        // k = dt/τ in Q31; ‖m‖² moves in steps of 2^12 so the product stays in 64 bits.
        let k = (i64::from(dt_q31) * c.inv_mag_ref_tau_q30) >> 30;
        let d = (n2 as i64).wrapping_sub(ref_n2 as i64) >> 12;
        let n2r = (ref_n2 as i64)
            .saturating_add(d.saturating_mul(k) >> 19)
            .max(0) as u64;
        let scaled = |q: u64| (n2r >> 16).saturating_mul(q);
        let r = MagRef {
            n2: n2r,
            lo: scaled(c.mag_lo_q16),
            hi: scaled(c.mag_hi_q16),
            hz_q30: ref_hz_q30 + ((k * (hz - ref_hz_q30)) >> 31),
            hz_tol_q30,
        };
        self.mag_ref = Some(r);
    }

    /// The field is off the reference: reject it, unless the disturbance has lasted
    /// long enough to adopt the field (fallback) or a candidate field has stayed
    /// consistent (by `ok`, with the reference's dip tolerance `hz_tol_q30`) through
    /// enough rotation (recovery). Returns true if the sample may be used.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn on_rejected(
        &mut self,
        n2: u64,
        hz: i64,
        hz_tol_q30: i64,
        w2_q40: i64,
        dt_q31: i32,
        st: &mut UpdateStatus,
        ok: impl Fn(&MagRef) -> bool,
    ) -> bool {
        let c = &self.c;
        st.mag_rejected = true;
        st.mag_state = MagState::Rejected;
        self.mag_reject_q20 = (self.mag_reject_q20 + i64::from(dt_q31 >> 11)).min(1 << 50);
        if self.mag_reject_q20 >= c.mag_fallback_q20 {
            // Fallback: the disturbance persisted; adopt the field as it is now.
            self.mag_ref = Some(self.make_ref(n2, hz));
            self.clear_disturbance();
            st.mag_rejected = false;
            st.mag_reference_relearned = true;
            st.mag_state = MagState::Fallback;
            return true;
        }
        let cand_ok = self.cand.is_some_and(|(cn2, chz)| {
            let cr = MagRef {
                hz_tol_q30,
                ..self.make_ref(cn2, chz)
            };
            ok(&cr)
        });
        if cand_ok {
            if w2_q40 > c.mag_min_rate_sq_q40 {
                self.cand_q20 += i64::from(dt_q31 >> 11);
            }
            if self.cand_q20 >= c.mag_recovery_q20 {
                if let Some((cn2, chz)) = self.cand {
                    self.mag_ref = Some(self.make_ref(cn2, chz));
                }
                self.clear_disturbance();
                st.mag_rejected = false;
                st.mag_reference_relearned = true;
                st.mag_state = MagState::Recovered;
                return true;
            }
        } else {
            self.cand = Some((n2, hz));
            self.cand_q20 = 0;
        }
        false
    }
}

/// The drag law's linear part p of a body-plane specific force x (g, Q26) given the
/// previous sample's, as [`crate::madgwick::DragModel::linear_part`]: x clamped to
/// ±4 g (2^28); 1 + β·|p| in Q16 (β ≤ 64 is ≤ 2^22 in Q16, |p| ≤ 2^28: the product
/// >> 26 is ≤ 2^24); its reciprocal in Q15 by one 32-bit `UDIV`.
fn drag_linear_part(c: &FixedConfig, x: i32, p_prev: i32) -> i32 {
    let x = x.max(-(1 << 28)).min(1 << 28);
    let den =
        (1 << 16) + ((u64::from(c.drag_beta_q16) * u64::from(p_prev.unsigned_abs())) >> 26) as u32;
    // `| 1` (at most 1/65536 of den) tells the compiler den ≠ 0: no zero check.
    let inv_q15 = (1u32 << 31) / (den | 1);
    ((i64::from(x) * i64::from(inv_q15)) >> 15) as i32
}

/// h = −μ·v/g (Q26 g) in the estimate's NED frame, horizontal part: the rows of R
/// (Q30) times (p_x, p_y, 0) of the accelerometer in g (Q26); `p` the body-plane
/// linear parts, updated.
fn drag_velocity_ned(
    c: &FixedConfig,
    r: &[[i32; 3]; 3],
    ag: [i32; 3],
    p: &mut [i32; 2],
) -> [i32; 2] {
    let px = drag_linear_part(c, ag[0], p[0]);
    let py = drag_linear_part(c, ag[1], p[1]);
    *p = [px, py];
    // |r| < 2^31, |p| ≤ 2^28: each sum < 2^60, the result < 2^30.
    [
        ((m64(r[0][0], px) + m64(r[0][1], py)) >> 30) as i32,
        ((m64(r[1][0], px) + m64(r[1][1], py)) >> 30) as i32,
    ]
}

/// Rows of the rotation matrix R(q) (body -> NED) in Q30; row 2 is "down" in body axes.
/// Every entry is ≤ 2·‖q‖² − 1 in magnitude: < 2 for the propagated ‖q‖² ≤ 1 + 3/16, so
/// it fits (see [`down_row`]).
fn rows(q: [i32; 4]) -> [[i32; 3]; 3] {
    rows_inline(q)
}

/// [`rows`], inlined where every instruction counts (the textbook update).
#[inline(always)]
fn rows_inline(q: [i32; 4]) -> [[i32; 3]; 3] {
    let [w, x, y, z] = q;
    let r = |v: i64| ((v + (1 << 28)) >> 29) as i32;
    [
        [
            r((1i64 << 59) - m64(y, y) - m64(z, z)),
            r(m64(x, y) - m64(w, z)),
            r(m64(x, z) + m64(w, y)),
        ],
        [
            r(m64(x, y) + m64(w, z)),
            r((1i64 << 59) - m64(x, x) - m64(z, z)),
            r(m64(y, z) - m64(w, x)),
        ],
        down_row(q),
    ]
}

/// Quaternion (Q30) of a rotation matrix given by its rows (Q30), Shepperd's method
/// with one integer square root and one reciprocal square root.
fn quat_from_rows_q30(m: [[i32; 3]; 3]) -> [i32; 4] {
    let e = |i: usize, j: usize| {
        m.get(i)
            .and_then(|r| r.get(j))
            .copied()
            .map_or(0, i64::from)
    };
    let (m00, m11, m22) = (e(0, 0), e(1, 1), e(2, 2));
    let tr = m00 + m11 + m22;
    // t = 1 + (pivot combination) ∈ (0, 4]; pivot component = ½√t, others = pair/(2√t).
    let (case, t) = if tr > 0 {
        (0, ONE_Q30 + tr)
    } else if m00 > m11 && m00 > m22 {
        (1, ONE_Q30 + m00 - m11 - m22)
    } else if m11 > m22 {
        (2, ONE_Q30 + m11 - m00 - m22)
    } else {
        (3, ONE_Q30 + m22 - m00 - m11)
    };
    let t = t.max(1) as u64; // Q30
    let sqrt_t = isqrt(t << 30); // √t in Q30
    let half_inv = if sqrt_t > 0 {
        (ONE_Q30 * ONE_Q30 / 2) / sqrt_t
    } else {
        0
    }; // 1/(2√t), init only
    let p = sqrt_t / 2;
    let k = |a: i64| (a * half_inv) >> 30;
    let q = match case {
        0 => [
            p,
            k(e(2, 1) - e(1, 2)),
            k(e(0, 2) - e(2, 0)),
            k(e(1, 0) - e(0, 1)),
        ],
        1 => [
            k(e(2, 1) - e(1, 2)),
            p,
            k(e(0, 1) + e(1, 0)),
            k(e(0, 2) + e(2, 0)),
        ],
        2 => [
            k(e(0, 2) - e(2, 0)),
            k(e(0, 1) + e(1, 0)),
            p,
            k(e(1, 2) + e(2, 1)),
        ],
        _ => [
            k(e(1, 0) - e(0, 1)),
            k(e(0, 2) + e(2, 0)),
            k(e(1, 2) + e(2, 1)),
            p,
        ],
    };
    unit4(q.map(sat32)).map_or([1 << 30, 0, 0, 0], |(u, _)| u)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::madgwick::drag_model;

    #[cfg(not(feature = "no-multirotor"))]
    /// The simulator's 250-class quad (μ = 0.1/0.6 per s, κ = 0.006/0.6 per m).
    fn quad_drag() -> (Config, crate::madgwick::DragModel) {
        let cfg = Config::multirotor(0.1 / 0.6, 0.006 / 0.6);
        (cfg, drag_model(&cfg).unwrap())
    }

    #[cfg(not(feature = "no-multirotor"))]
    #[test]
    fn the_drag_iteration_converges_on_the_inverse_of_the_drag_law() {
        // x = p + β·p·|p|: from p = 0, the iteration p ← x/(1 + β|p|) contracts by
        // β|p|/(1 + β|p|) per step (≤ 0.6 for the quad within 1 g).
        let (_, d) = quad_drag();
        assert!((d.beta - 3.53).abs() < 0.01, "{}", d.beta);
        for i in -100..=100 {
            let x = i as f32 * 0.01;
            let mut p = 0.0;
            for _ in 0..40 {
                p = d.linear_part(x, p);
            }
            let back = p + d.beta * p * p.abs();
            assert!((back - x).abs() < 1e-5, "x {x}: p {p} gives {back}");
        }
    }

    #[cfg(not(feature = "no-multirotor"))]
    #[test]
    fn the_fixed_drag_iteration_follows_the_f32_one() {
        let (cfg, d) = quad_drag();
        let c = FixedConfig::from_config(&cfg);
        for i in -40..=40 {
            let x = i as f32 * 0.05;
            let (mut p, mut pq) = (0.0f32, 0i32);
            for _ in 0..40 {
                p = d.linear_part(x, p);
                pq = drag_linear_part(&c, float_to_q(x, 26), pq);
            }
            let got = pq as f32 / (1u32 << 26) as f32;
            // The Q15 reciprocal: 2^-15 relative on 1/(1 + β|p|).
            assert!(
                (got - p).abs() < 1e-4 * (1.0 + p.abs()),
                "x {x}: {got} vs {p}"
            );
        }
    }

    #[test]
    fn no_drag_model_without_a_positive_finite_rotor_drag() {
        for mu in [0.0, -0.1, f32::NAN, f32::INFINITY] {
            let cfg = Config::multirotor(mu, 0.01);
            assert!(drag_model(&cfg).is_none(), "{mu}");
            assert_eq!(FixedConfig::from_config(&cfg).inv_drag_q16, 0);
        }
        // A tiny μ is raised to the smallest, and β stays within its bound.
        if cfg!(feature = "no-multirotor") {
            return;
        }
        let d = drag_model(&Config::multirotor(1e-6, 1.0)).unwrap();
        assert_eq!(d.mu, crate::madgwick::MIN_ROTOR_DRAG_PER_S);
        assert_eq!(d.beta, crate::madgwick::MAX_DRAG_BETA);
    }

    #[test]
    fn f32_to_u64_is_the_cast() {
        // Every 257th bit pattern (both signs, every exponent, NaNs and
        // infinities), and the edges around 2^23, 2^32, 2^63 and 2^64.
        let mut b: u32 = 0;
        loop {
            let x = f32::from_bits(b);
            assert_eq!(f32_to_u64(x), x as u64, "{x:e} ({b:#x})");
            match b.checked_add(257) {
                Some(n) => b = n,
                None => break,
            }
        }
        for e in [23u32, 24, 31, 32, 33, 55, 63, 64] {
            let p = pow2_f32(e);
            for x in [
                p,
                f32::from_bits(p.to_bits() - 1),
                f32::from_bits(p.to_bits() + 1),
            ] {
                assert_eq!(f32_to_u64(x), x as u64, "{x:e}");
            }
        }
        assert_eq!(f32_to_u64(0.999_999_94), 0);
        assert_eq!(f32_to_u64(-0.0), 0);
    }

    #[test]
    fn pow2_f32_is_the_integer_power_of_two() {
        for e in 0..64u32 {
            assert_eq!(pow2_f32(e), (1u64 << e) as f32, "2^{e}");
        }
        assert_eq!(pow2_f32(127), f32::MAX / (2.0 - f32::EPSILON));
    }

    #[test]
    fn rsqrt_accuracy() {
        // Every table bin, its edges and a dense sweep of M ∈ [0.25, 1).
        let mut worst = 0f64;
        for i in 0..=4096u64 {
            let m = ((1u64 << 30) + i * ((3u64 << 30) / 4096)).min(u64::from(u32::MAX)) as u32;
            let y = f64::from(rsqrt_q29(m)) / f64::from(1u32 << 29);
            let exact = 1.0 / (f64::from(m) / 2f64.powi(32)).sqrt();
            worst = worst.max((y / exact - 1.0).abs());
        }
        assert!(worst < 3e-7, "rsqrt worst relative error {worst}");
        for &s in &[
            1u64,
            2,
            3,
            7,
            1000,
            123_456_789,
            1 << 40,
            (1 << 60) - 1,
            (1 << 62) + 12345,
            u64::MAX,
        ] {
            let sq = isqrt(s) as f64;
            let exact = (s as f64).sqrt();
            assert!(
                (sq / exact - 1.0).abs() < 3e-7 || (sq - exact).abs() <= 0.5 + 1e-9,
                "isqrt {s}: {sq} vs {exact}"
            );
            let v = (s.min(1 << 60) as f64).sqrt() as i64 / 2;
            let (sq2, ratio) = sqrt_and_ratio(s, v);
            assert_eq!(sq2, isqrt(s));
            let want = v as f64 * 2f64.powi(30) / exact;
            assert!(
                (ratio as f64 - want).abs() <= 1.0 + want.abs() * 3e-7,
                "ratio {s}"
            );
        }
        // unit vectors of 4-vectors, including the ≥ 2^62 branch
        for v in [
            [1, 2, 3, 4],
            [i32::MIN; 4],
            [i32::MAX, 0, -5, 1 << 20],
            [0, 0, 0, -1],
        ] {
            let (u, _) = unit4(v).unwrap();
            let n: f64 = u
                .iter()
                .map(|&x| (f64::from(x) / 2f64.powi(30)).powi(2))
                .sum();
            assert!((n.sqrt() - 1.0).abs() < 3e-7, "{v:?} {u:?}");
            let vn: f64 = v.iter().map(|&x| f64::from(x).powi(2)).sum::<f64>().sqrt();
            for (a, b) in u.iter().zip(v) {
                assert!((f64::from(*a) / 2f64.powi(30) - f64::from(b) / vn).abs() < 3e-7);
            }
        }
    }

    #[test]
    fn renormalise_fast_and_slow_paths() {
        for scale in [1.0f64, 1.0005, 0.9995, 1.01, 2.5, 0.3] {
            let q = [0.5f64, -0.5, 0.5, 0.5].map(|x| (x * scale * 2f64.powi(60)) as i64);
            let n = renormalise(q).unwrap();
            let norm: f64 = n
                .iter()
                .map(|&x| (f64::from(x) / 2f64.powi(30)).powi(2))
                .sum();
            assert!((norm.sqrt() - 1.0).abs() < 1e-6, "{scale}: {norm}");
            assert!(n
                .iter()
                .all(|&x| (f64::from(x.abs()) / 2f64.powi(30) - 0.5).abs() < 1e-6));
        }
        assert!(renormalise([1 << 40, 0, 0, 0]).is_none());
    }

    #[test]
    fn unit_vectors() {
        let (u, _) = unit3([3, 4, 0]).unwrap();
        assert!((u[0] - (0.6 * ONE_Q30 as f64) as i32).abs() < 300);
        assert!((u[1] - (0.8 * ONE_Q30 as f64) as i32).abs() < 300);
        let (u, _) = unit3([i32::MIN, i32::MIN, i32::MIN]).unwrap();
        assert!(u.iter().all(|&x| x < 0));
        assert!(unit3([0, 0, 0]).is_none());
    }

    #[test]
    fn dt_conversions() {
        assert_eq!(dt_us_to_q31(1000), dt_s_to_q31(0.001));
        assert_eq!(dt_us_to_q31(u32::MAX), i32::MAX);
    }
}
