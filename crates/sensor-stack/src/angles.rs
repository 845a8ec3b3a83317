//! Attitude angles and the vertical specific force from the fixed-point
//! quaternion, in integer arithmetic (the 100 Hz control step's inputs
//! without libm or soft-float).
//!
//! Q-formats: the quaternion `q_ned_from_body` and rotation-matrix elements
//! are Q30 (`1.0 = 2³⁰`); angles are Q16 radians (`π = 205_887`).
//!
//! Accuracy (checked by the tests against f64 `atan2`/`asin` over the
//! whole sphere): every angle within 1.2e-4 rad (0.007°) of the exact ZYX
//! Euler angle of the Q30 quaternion, away from the pitch = ±90°
//! singularity where roll and yaw are undefined. The error is the
//! Abramowitz–Stegun 4.4.47 arctangent polynomial (≤ 1e-5 rad), the Q16
//! ratio from one 32-bit division (≤ 3e-5 rad), the Q15 square root of the
//! pitch's cosine and the Q16 output rounding.

/// π in Q16 radians.
pub const PI_Q16: i32 = 205_887;
/// π/2 in Q16 radians.
const HALF_PI_Q16: i32 = 102_944;

/// Arctangent coefficients a1, a3, a5, a7, a9 (Abramowitz–Stegun 4.4.47,
/// |error| ≤ 1e-5 rad on 0 ≤ t ≤ 1), Q30.
const ATAN_Q30: [i64; 5] = [
    1_073_597_943,
    -354_656_388,
    193_424_926,
    -91_410_863,
    22_371_518,
];

/// `atan2(y, x)` in Q16 radians, in (−π, π]; any scale, the same for both
/// arguments; `atan2(0, 0) = 0`.
pub fn atan2_q16(y: i32, x: i32) -> i32 {
    let (ay, ax) = (y.unsigned_abs(), x.unsigned_abs());
    let (num, den) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if den == 0 {
        return 0;
    }
    // Normalise so den ∈ [2³¹, 2³²); num ≤ den keeps num in range. Then
    // den >> 16 ∈ [2¹⁵, 2¹⁶) and the quotient is t = num/den in Q16.
    let sh = den.leading_zeros();
    let (num, den) = (num << sh, den << sh);
    // den >> 16 ≥ 2¹⁵, so the division never fails; `checked_div` keeps
    // the panic path out of the firmware.
    let t_q16 = num.checked_div(den >> 16).unwrap_or(0).min(1 << 16);
    let t = i64::from(t_q16) << 14; // Q30
    let t2 = (t * t) >> 30;
    let mut p = ATAN_Q30[4];
    for c in [ATAN_Q30[3], ATAN_Q30[2], ATAN_Q30[1], ATAN_Q30[0]] {
        p = c + ((p * t2) >> 30);
    }
    // Q30 · Q30 >> 44 = Q16, rounded.
    let mut a = (((p * t) >> 43) + 1) >> 1;
    if ay > ax {
        a = i64::from(HALF_PI_Q16) - a;
    }
    if x < 0 {
        a = i64::from(PI_Q16) - a;
    }
    let a = a as i32; // |a| ≤ π in Q16
    if y < 0 {
        -a
    } else {
        a
    }
}

/// Integer square root, `floor(√v)`.
// The digit-by-digit loop of calibration's private `sqrtf`, on 32 bits instead
// of that one's 48-bit radicand: too small to share across the crates.
pub fn isqrt_u32(v: u32) -> u32 {
    let (mut rem, mut root) = (v, 0u32);
    let mut bit = 1u32 << 30;
    while bit > rem {
        bit >>= 2;
    }
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    root
}

/// `2·(a·b + c·d)` of Q30 values, Q30, saturated.
fn two_ab_cd(a: i32, b: i32, c: i32, d: i32) -> i32 {
    let s = (i64::from(a) * i64::from(b) + i64::from(c) * i64::from(d)) >> 29;
    s.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// `a² + b² − c² − d²` of Q30 values, Q30, saturated.
fn sq_diff(a: i32, b: i32, c: i32, d: i32) -> i32 {
    let sq = |v: i32| i64::from(v) * i64::from(v);
    let s = (sq(a) + sq(b) - sq(c) - sq(d)) >> 30;
    s.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// The third row of `R(q_ned_from_body)`: the body-frame components of
/// NED "down", Q30.
pub fn down_row_q30(q: [i32; 4]) -> [i32; 3] {
    let [w, x, y, z] = q;
    [
        two_ab_cd(x, z, -w, y),
        two_ab_cd(y, z, w, x),
        sq_diff(w, z, x, y),
    ]
}

/// ZYX Euler angles (roll, pitch, yaw) of `q_ned_from_body` (Q30), Q16 rad.
/// Pitch is `atan2(−R₂₀, √(R₂₁² + R₂₂²))`, which equals `asin(−R₂₀)` for a
/// unit quaternion and stays accurate near ±90°.
pub fn euler_q16(q: [i32; 4]) -> [i32; 3] {
    let [w, x, y, z] = q;
    let [r20, r21, r22] = down_row_q30(q);
    let roll = atan2_q16(r21, r22);
    // cos(pitch) in Q15 from the Q30 elements shifted to Q15 (sum ≤ 2³¹).
    let (a, b) = (r21 >> 15, r22 >> 15);
    let c2 =
        (a.unsigned_abs() * a.unsigned_abs()).saturating_add(b.unsigned_abs() * b.unsigned_abs());
    let cos_q30 = (isqrt_u32(c2) << 15).min(i32::MAX as u32) as i32;
    let pitch = atan2_q16(r20.saturating_neg(), cos_q30);
    let r00 = sq_diff(w, x, y, z);
    let r10 = two_ab_cd(x, y, w, z);
    let yaw = atan2_q16(r10, r00);
    [roll, pitch, yaw]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q30(q: [f64; 4]) -> [i32; 4] {
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        q.map(|v| (v / n * (1u64 << 30) as f64).round() as i32)
    }

    fn exact_euler(q: [i32; 4]) -> [f64; 3] {
        let [w, x, y, z] = q.map(|v| f64::from(v) / (1u64 << 30) as f64);
        let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
        let pitch = (2.0 * (w * y - x * z)).clamp(-1.0, 1.0).asin();
        let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
        [roll, pitch, yaw]
    }

    fn wrap(d: f64) -> f64 {
        let two_pi = 2.0 * core::f64::consts::PI;
        (d + core::f64::consts::PI).rem_euclid(two_pi) - core::f64::consts::PI
    }

    #[test]
    fn atan2_matches_f64_on_a_dense_circle_and_scales() {
        let mut worst = 0.0f64;
        for k in 0..20_000 {
            let th = -core::f64::consts::PI + core::f64::consts::TAU * f64::from(k) / 20_000.0;
            for r in [1.0e3, 1.0e6, 1.07e9, 2.1e9] {
                let (y, x) = ((r * th.sin()) as i32, (r * th.cos()) as i32);
                let got = f64::from(atan2_q16(y, x)) / 65_536.0;
                let want = f64::from(y).atan2(f64::from(x));
                worst = worst.max(wrap(got - want).abs());
            }
        }
        assert!(worst < 5e-5, "worst atan2 error {worst} rad");
        assert_eq!(atan2_q16(0, 0), 0);
        assert_eq!(atan2_q16(0, -5), PI_Q16);
        // −3π/4 = −154 415.4 in Q16; the extreme input must not overflow.
        assert!((atan2_q16(i32::MIN, i32::MIN) + 154_415).abs() <= 2);
    }

    #[test]
    fn isqrt_is_the_floor_root() {
        for v in (0..5_000u32).chain([u32::MAX, 1 << 30, (1 << 31) - 1, 65_535 * 65_535]) {
            let r = isqrt_u32(v);
            assert!(u64::from(r) * u64::from(r) <= u64::from(v), "{v}");
            assert!(u64::from(r + 1) * u64::from(r + 1) > u64::from(v), "{v}");
        }
    }

    #[test]
    fn euler_within_the_stated_accuracy_over_the_sphere() {
        let mut worst = 0.0f64;
        let mut s = 0x1234_5678u32;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            f64::from(s) / f64::from(u32::MAX) * 2.0 - 1.0
        };
        for _ in 0..50_000 {
            let q = q30([rnd(), rnd(), rnd(), rnd()]);
            let want = exact_euler(q);
            if want[1].abs() > 1.5 {
                continue; // within 4° of gimbal lock roll and yaw are ill-defined
            }
            let got = euler_q16(q).map(|v| f64::from(v) / 65_536.0);
            for i in 0..3 {
                worst = worst.max(wrap(got[i] - want[i]).abs());
            }
        }
        assert!(worst < 1.2e-4, "worst Euler error {worst} rad");
        // Pitch alone stays accurate up to the pole.
        for deg in [89.0f64, 89.9, 90.0, -90.0] {
            let h = deg.to_radians() / 2.0;
            let q = q30([h.cos(), 0.0, h.sin(), 0.0]);
            let p = f64::from(euler_q16(q)[1]) / 65_536.0;
            assert!((p - deg.to_radians()).abs() < 1.2e-4, "{deg}: {p}");
        }
    }

    #[test]
    fn down_row_is_gravity_in_body() {
        // Level: down = +z body.
        assert_eq!(down_row_q30([1 << 30, 0, 0, 0]), [0, 0, 1 << 30]);
        // Rolled 90° right: down appears on +y body.
        let h = core::f64::consts::FRAC_PI_4;
        let d = down_row_q30(q30([h.cos(), h.sin(), 0.0, 0.0]));
        assert!(
            (d[1] - (1 << 30)).abs() < 4 && d[0].abs() < 4 && d[2].abs() < 4,
            "{d:?}"
        );
    }
}
