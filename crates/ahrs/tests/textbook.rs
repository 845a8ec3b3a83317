//! The textbook mode against a direct transcription of Madgwick's 2010 report, written
//! here in f64 from the equations (not from the crate's code): f_g and J_g (eqs. 25–26),
//! f_b and J_b (eqs. 29–30), h = q ⊗ m ⊗ q* and b = (0, √(hx²+hy²), 0, hz) (eqs. 45–46),
//! ∇f = Jᵀf (eq. 34 stacked for MARG), q̇ = ½ q ⊗ (0, ω) − β ∇f/‖∇f‖ (eqs. 42–44),
//! q ← normalise(q + q̇·Δt).
//!
//! The report's earth gravity reference is (0, 0, 1) with the accelerometer measuring it;
//! the crate works in NED with the specific force (up) measured, so the transcription is
//! fed â = −a/‖a‖ (documented in `madgwick.rs`).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use fc_ahrs::fixed::{dt_s_to_q31, float_to_q, rps_to_q20, FixedConfig, MadgwickFixed};
use fc_ahrs::{Algorithm, Config, Madgwick, Quaternion};

type Q = [f64; 4];

fn qmul(a: Q, b: Q) -> Q {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

fn unit(v: &[f64]) -> Vec<f64> {
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.iter().map(|x| x / n).collect()
}

/// One step of the report's filter. `mag` = None: the IMU form (eqs. 25–26 only).
/// Also returns ‖∇f‖.
fn report_step(
    q: Q,
    gyro: [f64; 3],
    acc: [f64; 3],
    mag: Option<[f64; 3]>,
    beta: f64,
    dt: f64,
) -> (Q, f64) {
    let [q1, q2, q3, q4] = q;
    let a = unit(&acc.map(|x| -x));
    // eq. 25 (d = (0, 0, 1)) and eq. 26
    let mut f = vec![
        2.0 * (q2 * q4 - q1 * q3) - a[0],
        2.0 * (q1 * q2 + q3 * q4) - a[1],
        2.0 * (0.5 - q2 * q2 - q3 * q3) - a[2],
    ];
    let mut j = vec![
        [-2.0 * q3, 2.0 * q4, -2.0 * q1, 2.0 * q2],
        [2.0 * q2, 2.0 * q1, 2.0 * q4, 2.0 * q3],
        [0.0, -4.0 * q2, -4.0 * q3, 0.0],
    ];
    if let Some(mag) = mag {
        let m = unit(&mag);
        // eq. 45: h = q ⊗ (0, m) ⊗ q*
        let h = qmul(qmul(q, [0.0, m[0], m[1], m[2]]), [q1, -q2, -q3, -q4]);
        // eq. 46
        let bx = (h[1] * h[1] + h[2] * h[2]).sqrt();
        let bz = h[3];
        // eq. 29
        f.push(2.0 * bx * (0.5 - q3 * q3 - q4 * q4) + 2.0 * bz * (q2 * q4 - q1 * q3) - m[0]);
        f.push(2.0 * bx * (q2 * q3 - q1 * q4) + 2.0 * bz * (q1 * q2 + q3 * q4) - m[1]);
        f.push(2.0 * bx * (q1 * q3 + q2 * q4) + 2.0 * bz * (0.5 - q2 * q2 - q3 * q3) - m[2]);
        // eq. 30
        j.push([
            -2.0 * bz * q3,
            2.0 * bz * q4,
            -4.0 * bx * q3 - 2.0 * bz * q1,
            -4.0 * bx * q4 + 2.0 * bz * q2,
        ]);
        j.push([
            -2.0 * bx * q4 + 2.0 * bz * q2,
            2.0 * bx * q3 + 2.0 * bz * q1,
            2.0 * bx * q2 + 2.0 * bz * q4,
            -2.0 * bx * q1 + 2.0 * bz * q3,
        ]);
        j.push([
            2.0 * bx * q3,
            2.0 * bx * q4 - 4.0 * bz * q2,
            2.0 * bx * q1 - 4.0 * bz * q3,
            2.0 * bx * q2,
        ]);
    }
    // eq. 34: ∇f = Jᵀ f
    let mut grad = [0.0; 4];
    for (row, fi) in j.iter().zip(&f) {
        for (g, jij) in grad.iter_mut().zip(row) {
            *g += jij * fi;
        }
    }
    let gn = grad.iter().map(|x| x * x).sum::<f64>().sqrt();
    // eq. 12 and eqs. 42–44
    let qw = qmul(q, [0.0, gyro[0], gyro[1], gyro[2]]);
    let mut nq = [0.0; 4];
    for i in 0..4 {
        let corr = if gn > 0.0 { beta * grad[i] / gn } else { 0.0 };
        nq[i] = q[i] + (0.5 * qw[i] - corr) * dt;
    }
    let n = nq.iter().map(|x| x * x).sum::<f64>().sqrt();
    (nq.map(|x| x / n), gn)
}

/// Angle between two orientations, 2·atan2(‖vec(a* ⊗ b)‖, |w|): well conditioned for
/// small angles (2·acos of the dot product is not, for an f32 quaternion).
fn angle_deg(a: Quaternion, b: Q) -> f64 {
    let a = [a.w, -a.x, -a.y, -a.z].map(f64::from);
    let e = qmul(a, b);
    let v = (e[1] * e[1] + e[2] * e[2] + e[3] * e[3]).sqrt();
    2.0 * v.atan2(e[0].abs()).to_degrees()
}

/// A tumbling, accelerating sequence with a field (µT, NED-like) and a start far off.
fn inputs(i: usize) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let t = i as f64 * 0.004;
    let gyro = [
        1.5 * (1.3 * t).sin(),
        -0.8 * (0.7 * t).cos(),
        2.0 * (0.3 * t).sin(),
    ];
    let acc = [
        2.0 * (3.0 * t).sin(),
        1.0 + (2.0 * t).cos(),
        -9.81 + 0.5 * (5.0 * t).sin(),
    ];
    let mag = [20.0 + 5.0 * (0.9 * t).sin(), 3.0 * (0.4 * t).cos(), 45.0];
    (gyro, acc, mag)
}

const BETA: f32 = 0.1;
const DT: f32 = 0.004;

fn textbook() -> Config {
    Config {
        algorithm: Algorithm::Textbook,
        beta: BETA,
        ..Config::DEFAULT
    }
}

#[test]
fn textbook_f32_matches_the_report_equations() {
    for marg in [true, false] {
        let mut f = Madgwick::new(textbook());
        let start = Quaternion::from_euler_rad(0.4, -0.3, 1.0);
        f.set_quaternion(start);
        let mut r: Q = [start.w, start.x, start.y, start.z].map(f64::from);
        let mut worst = 0f64;
        let mut near_min = 0;
        for i in 0..5000 {
            let (g, a, m) = inputs(i);
            let f32v = |v: [f64; 3]| v.map(|x| x as f32);
            if marg {
                f.update_marg(f32v(g), f32v(a), f32v(m), DT);
            } else {
                f.update_imu(f32v(g), f32v(a), DT);
            }
            // One step of the report from the filter's previous state: an error in any
            // equation shows at once, f32 rounding does not accumulate.
            let (next, gn) =
                report_step(r, g, a, marg.then_some(m), f64::from(BETA), f64::from(DT));
            // Near the minimum ∇f is f32 rounding noise and its normalised direction
            // arbitrary (the textbook filter's own jitter of β·Δt): not a transcription
            // difference, so those steps are counted, not compared.
            if gn > 1e-3 {
                worst = worst.max(angle_deg(f.quaternion(), next));
            } else {
                near_min += 1;
            }
            let q = f.quaternion();
            r = [q.w, q.x, q.y, q.z].map(f64::from);
        }
        assert!(
            near_min < 50,
            "marg {marg}: {near_min} steps near the minimum"
        );
        assert!(
            worst < 1e-3,
            "marg {marg}: worst {worst}° from the report's equations"
        );
        // The corrections act: the sequence moved the estimate.
        assert!(
            angle_deg(
                f.quaternion(),
                [start.w, start.x, start.y, start.z].map(f64::from)
            ) > 5.0
        );
    }
}

#[test]
fn textbook_fixed_matches_textbook_f32() {
    let fc = FixedConfig::from_config(&Config {
        gravity_norm: 9.80665 * 65536.0,
        ..textbook()
    });
    for marg in [true, false] {
        let mut f = Madgwick::new(textbook());
        let mut fx = MadgwickFixed::new(fc);
        let mut worst = 0f64;
        for i in 0..5000 {
            let (g, a, m) = inputs(i);
            let f32v = |v: [f64; 3]| v.map(|x| x as f32);
            let q16 = |v: [f64; 3]| v.map(|x| float_to_q(x as f32, 16));
            let gq = f32v(g).map(rps_to_q20);
            if marg {
                f.update_marg(f32v(g), f32v(a), f32v(m), DT);
                fx.update_marg(gq, q16(a), q16(m), dt_s_to_q31(DT));
            } else {
                f.update_imu(f32v(g), f32v(a), DT);
                fx.update_imu(gq, q16(a), dt_s_to_q31(DT));
            }
            let q = f.quaternion();
            worst = worst.max(angle_deg(
                fx.quaternion_f32(),
                [q.w, q.x, q.y, q.z].map(f64::from),
            ));
        }
        assert!(worst < 0.01, "marg {marg}: fixed vs f32 worst {worst}°");
    }
}
