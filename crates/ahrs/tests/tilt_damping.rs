//! The tilt loop's damping, from its steady state under a constant gyro bias.
//!
//! With the first low-pass stage turned by a share c of each tilt correction the
//! loop is e'' + (1 + c)/τ·e' + e/τ² = x/τ²; a gyro bias b (bias estimation off)
//! drives e' by b, so the tilt settles at (1 + c)·b·τ: 1.5·b·τ in the hand-held form
//! (c = ½, ζ = ¾), 2·b·τ critically damped (c = 1: in flight, or with the
//! multirotor mode configured). Both filters, level and at rest.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use fc_ahrs::fixed::{dt_s_to_q31, rps_to_q20, FixedConfig, MadgwickFixed};
use fc_ahrs::{Config, Madgwick, Quaternion, UpdatePath};

const G: f32 = 9.80665;
const COUNTS_PER_G: f32 = 16384.0;
const DT_S: f32 = 0.001;
/// The gyro's bias about body x (rad/s): 0.5 °/s.
const BIAS_RPS: f32 = 0.5 * core::f32::consts::PI / 180.0;
/// Long enough to settle: 15 time constants of the 3 s loop.
const RUN_S: f32 = 45.0;

/// Start-up and bias estimation off (the bias must stay in the gyro); a multirotor's
/// drag coefficients when `multirotor`.
fn cfg(multirotor: bool) -> Config {
    let base = if multirotor {
        Config::multirotor(0.1 / 0.6, 0.006 / 0.6)
    } else {
        Config::DEFAULT
    };
    let mut c = Config {
        startup_s: 0.0,
        ..base
    };
    c.bias.enabled = false;
    c
}

/// Angle (deg) between the estimate's vertical and the true one (level body).
fn tilt_deg(q: &Quaternion) -> f32 {
    q.rotate_inverse([0.0, 0.0, 1.0])[2]
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

fn settle_f32(multirotor: bool, in_flight: bool) -> f32 {
    let mut f = Madgwick::new(cfg(multirotor));
    f.set_in_flight(in_flight);
    for _ in 0..(RUN_S / DT_S) as u32 {
        let st = f.update_imu([BIAS_RPS, 0.0, 0.0], [0.0, 0.0, -G], DT_S);
        assert_eq!(st.path, UpdatePath::Imu);
    }
    tilt_deg(&f.quaternion())
}

fn settle_fixed(multirotor: bool, in_flight: bool) -> f32 {
    let c = FixedConfig::from_config(&Config {
        gravity_norm: COUNTS_PER_G,
        ..cfg(multirotor)
    });
    let mut f = MadgwickFixed::new(c);
    f.set_in_flight(in_flight);
    let (dt, w) = (dt_s_to_q31(DT_S), rps_to_q20(BIAS_RPS));
    for _ in 0..(RUN_S / DT_S) as u32 {
        let st = f.update_imu([w, 0, 0], [0, 0, -(COUNTS_PER_G as i32)], dt);
        assert_eq!(st.path, UpdatePath::Imu);
    }
    tilt_deg(&f.quaternion_f32())
}

/// (1 + c)·b·τ in degrees.
fn expected_deg(c: f32) -> f32 {
    ((1.0 + c) * BIAS_RPS * Config::DEFAULT.tilt_tau_s).to_degrees()
}

#[test]
fn hand_held_the_loop_is_damped_at_three_quarters() {
    for (name, tilt) in [
        ("f32", settle_f32(false, false)),
        ("fixed", settle_fixed(false, false)),
    ] {
        let want = expected_deg(0.5);
        assert!(
            (tilt - want).abs() < 0.03 * want,
            "{name}: {tilt}°, {want}° expected"
        );
    }
}

#[test]
fn in_flight_or_as_a_multirotor_the_loop_is_critically_damped() {
    let want = expected_deg(1.0);
    for (name, tilt) in [
        ("f32 in flight", settle_f32(false, true)),
        ("fixed in flight", settle_fixed(false, true)),
        ("f32 multirotor on the ground", settle_f32(true, false)),
        ("fixed multirotor on the ground", settle_fixed(true, false)),
    ] {
        assert!(
            (tilt - want).abs() < 0.03 * want,
            "{name}: {tilt}°, {want}° expected"
        );
    }
}
