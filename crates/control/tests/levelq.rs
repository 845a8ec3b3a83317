//! The fixed-point self-level loop (`levelq`) against its `f32` reference
//! (`loops::LevelController`, `loops::attitude_error_q`): property tests
//! over every heading, tilts to 180°, `|q|` within 5 % of 1 and tilt
//! setpoints to ±80°.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use control::fixed::{q_to_f32, ONE_Q30};
use control::levelq::{attitude_error_q29, LevelControllerQ, QuatQ30, TiltQ30};
use control::loops::{attitude_error_q, LevelConfig, LevelController, Quat, TiltQuat};
use control::shaping::TiltSetpoint;
use proptest::prelude::*;

/// Rate setpoints: the fixed loop within this of the `f32` one, rad/s.
const RATE_TOL_RPS: f32 = 2e-4;
/// Error vectors: within this, rad.
const ERROR_TOL_RAD: f32 = 2e-5;
/// Attitudes whose body x axis is within this (sin of the angle) of
/// vertical are excluded: the heading is undefined there and each loop
/// picks its own.
const VERTICAL_NOSE: f32 = 1e-2;

/// A quaternion from four Gaussian-ish components, normalised, then scaled
/// so `|q|` is `scale`.
fn quat(c: [f32; 4], scale: f32) -> Option<Quat> {
    let n = c.iter().map(|v| v * v).sum::<f32>().sqrt();
    if n < 0.1 {
        return None;
    }
    let k = scale / n;
    Some(Quat {
        w: c[0] * k,
        x: c[1] * k,
        y: c[2] * k,
        z: c[3] * k,
    })
}

/// Sine of the body x axis's angle from the horizontal plane's normal is
/// `|h|/|q|²`; below `VERTICAL_NOSE` the nose points (nearly) straight up
/// or down.
fn nose_vertical(q: &Quat) -> bool {
    let n2 = q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z;
    let hx = q.w * q.w + q.x * q.x - q.y * q.y - q.z * q.z;
    let hy = 2.0 * (q.w * q.z + q.x * q.y);
    (hx * hx + hy * hy).sqrt() < VERTICAL_NOSE * n2
}

fn tilt(roll_deg: f32, pitch_deg: f32) -> TiltQuat {
    TiltQuat::new(&TiltSetpoint {
        roll_rad: roll_deg.to_radians(),
        pitch_rad: pitch_deg.to_radians(),
    })
    .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn error_matches_the_f32_loop(
        c in prop::array::uniform4(-1.0f32..1.0),
        scale in 0.95f32..1.05,
        roll in -80.0f32..80.0,
        pitch in -80.0f32..80.0,
    ) {
        let Some(q) = quat(c, scale) else { return Ok(()) };
        prop_assume!(!nose_vertical(&q));
        let t = tilt(roll, pitch);
        let reference = attitude_error_q(&q, &t);
        let fixed = attitude_error_q29(&QuatQ30::from_quat(&q), &TiltQ30::new(&t)).unwrap();
        for (r, f) in reference.iter().zip(fixed) {
            let f = q_to_f32(f, 29);
            prop_assert!((r - f).abs() < ERROR_TOL_RAD, "{reference:?} vs {fixed:?} at {q:?}");
        }
    }

    #[test]
    fn rate_setpoints_match_the_f32_loop(
        c in prop::array::uniform4(-1.0f32..1.0),
        scale in 0.95f32..1.05,
        roll in -80.0f32..80.0,
        pitch in -80.0f32..80.0,
        kp in 0.5f32..20.0,
    ) {
        let Some(q) = quat(c, scale) else { return Ok(()) };
        prop_assume!(!nose_vertical(&q));
        let cfg = LevelConfig { kp_per_s: kp, ..LevelConfig::default() };
        let t = tilt(roll, pitch);
        let reference = LevelController::new(cfg).unwrap().rate_setpoint_q(&q, &t, 0.0).unwrap();
        let fixed = LevelControllerQ::new(&cfg)
            .unwrap()
            .rate_setpoint_q16(&QuatQ30::from_quat(&q), &TiltQ30::new(&t))
            .unwrap();
        // The tolerance scales with the gain above the default 6 /s.
        let tol = RATE_TOL_RPS * (kp / 6.0).max(1.0);
        prop_assert!((reference.roll_rps - q_to_f32(fixed[0], 16)).abs() < tol);
        prop_assert!((reference.pitch_rps - q_to_f32(fixed[1], 16)).abs() < tol);
    }

    #[test]
    fn cos_tilt_matches_the_quaternion(
        c in prop::array::uniform4(-1.0f32..1.0),
        scale in 0.55f32..1.4,
    ) {
        let Some(q) = quat(c, scale) else { return Ok(()) };
        let n2 = scale * scale;
        let exact = 1.0 - 2.0 * (q.x * q.x + q.y * q.y) / n2;
        let fixed = QuatQ30::from_quat(&q).cos_tilt_q30().unwrap();
        prop_assert!((exact - q_to_f32(fixed, 30)).abs() < 2e-4 / n2.min(1.0));
    }
}

#[test]
fn tilt_error_is_heading_free_near_half_a_turn() {
    // ψ = ±π (where h + hx cancels) with a 10° roll: the error towards
    // level is pure roll, whichever side of π.
    for yaw in [179.99f32, -179.99, 180.0, 179.0] {
        let q = Quat::from_euler(10f32.to_radians(), 0.0, yaw.to_radians());
        let e = attitude_error_q29(&QuatQ30::from_quat(&q), &TiltQ30::LEVEL).unwrap();
        let e = e.map(|v| q_to_f32(v, 29));
        let expect = -2.0 * 5f32.to_radians().sin();
        assert!(
            (e[0] - expect).abs() < 1e-4 && e[1].abs() < 1e-4,
            "yaw {yaw}: {e:?}"
        );
    }
}

#[test]
fn rate_setpoint_saturates_at_the_limit() {
    let cfg = LevelConfig::default();
    let level = LevelControllerQ::new(&cfg).unwrap();
    let upside_down = QuatQ30::from_quat(&Quat::about_x(3.0));
    let sp = level
        .rate_setpoint_q16(&upside_down, &TiltQ30::LEVEL)
        .unwrap();
    let max = (cfg.max_rate_rps * 65_536.0).round() as i32;
    assert_eq!(sp[0].abs(), max);
}

#[test]
fn a_broken_quaternion_is_refused() {
    let level = LevelControllerQ::new(&LevelConfig::default()).unwrap();
    let zero = QuatQ30([0, 0, 0, 0]);
    assert!(level.rate_setpoint_q16(&zero, &TiltQ30::LEVEL).is_err());
    let long = QuatQ30([ONE_Q30, ONE_Q30, ONE_Q30, 0]);
    assert!(level.rate_setpoint_q16(&long, &TiltQ30::LEVEL).is_err());
}
