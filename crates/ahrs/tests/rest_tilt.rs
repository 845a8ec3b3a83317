//! The tilt correction at rest (`Config::rest_tilt_tau_s`).
//!
//! A body rolls 90° in 1 s while its gyro reads 10 % too much (the 9° of tilt
//! a scale error leaves after a fast turn about a horizontal axis), then rests.
//! The long tilt time constant (3 s) leaves 70 % of it after 2.5 s of rest;
//! at rest (the bias estimator's test holds after 1.5 s) the stages run at
//! 0.25 s and all but a few tenths of a degree are gone by then. In flight, or with the rest time
//! constant set to the tilt one, the 3 s loop runs throughout.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use core::f32::consts::FRAC_PI_2;
use fc_ahrs::fixed::{dt_s_to_q31, rps_to_q20, FixedConfig, MadgwickFixed};
use fc_ahrs::{Config, Madgwick, Quaternion, UpdatePath};

const G: f32 = 9.80665;
/// Fixed-point accelerometer counts per g (the MPU-9250 at ±2 g).
const COUNTS_PER_G: f32 = 16384.0;
const DT_S: f32 = 0.001;
/// The roll (1 s at 90 °/s), the gyro's scale error, the rest that follows (s).
const ROLL_S: f32 = 1.0;
const SCALE: f32 = 1.10;
const REST_S: f32 = 2.5;

/// Start-up off, so the test sees the steady loop; `rest_tau` the rest time constant.
fn cfg(rest_tau: f32) -> Config {
    Config {
        startup_s: 0.0,
        rest_tilt_tau_s: rest_tau,
        ..Config::DEFAULT
    }
}

/// The true attitude at `t` (s), the gyro reading (rad/s, FRD) and the specific force
/// (m/s², FRD).
fn truth(t: f32) -> (Quaternion, [f32; 3], [f32; 3]) {
    let rate = if t < ROLL_S { FRAC_PI_2 / ROLL_S } else { 0.0 };
    let q = Quaternion::from_axis_angle([1.0, 0.0, 0.0], FRAC_PI_2 * (t / ROLL_S).min(1.0));
    (
        q,
        [rate * SCALE, 0.0, 0.0],
        q.rotate_inverse([0.0, 0.0, -G]),
    )
}

/// Angle (deg) between the estimate's vertical and the true one.
fn tilt_err_deg(est: &Quaternion, truth: &Quaternion) -> f32 {
    let (a, b) = (
        est.rotate_inverse([0.0, 0.0, 1.0]),
        truth.rotate_inverse([0.0, 0.0, 1.0]),
    );
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    dot.clamp(-1.0, 1.0).acos().to_degrees()
}

/// Tilt errors (deg) of the f32 filter at the roll's end and at the rest's end.
fn run_f32(rest_tau: f32, in_flight: bool) -> (f32, f32) {
    let mut f = Madgwick::new(cfg(rest_tau));
    f.init_from_accel_mag(truth(0.0).2, [20.0, 0.0, 45.0]);
    f.set_in_flight(in_flight);
    let mut at_roll_end = 0.0;
    let n = ((ROLL_S + REST_S) / DT_S) as u32;
    for i in 1..=n {
        let (q, w, a) = truth(i as f32 * DT_S);
        assert_eq!(f.update_imu(w, a, DT_S).path, UpdatePath::Imu);
        if i == (ROLL_S / DT_S) as u32 {
            at_roll_end = tilt_err_deg(&f.quaternion(), &q);
        }
    }
    (
        at_roll_end,
        tilt_err_deg(&f.quaternion(), &truth(ROLL_S + REST_S).0),
    )
}

/// [`run_f32`] for the fixed filter (accelerometer in counts, gyro in Q20 rad/s).
fn run_fixed(rest_tau: f32, in_flight: bool) -> (f32, f32) {
    let c = FixedConfig::from_config(&Config {
        gravity_norm: COUNTS_PER_G,
        ..cfg(rest_tau)
    });
    let counts = |a: [f32; 3]| a.map(|x| (x / G * COUNTS_PER_G).round() as i32);
    let mut f = MadgwickFixed::from_accel_mag(c, counts(truth(0.0).2), [2000, 0, 4500]);
    f.set_in_flight(in_flight);
    let dt = dt_s_to_q31(DT_S);
    let mut at_roll_end = 0.0;
    let n = ((ROLL_S + REST_S) / DT_S) as u32;
    for i in 1..=n {
        let (q, w, a) = truth(i as f32 * DT_S);
        let st = f.update_imu(w.map(rps_to_q20), counts(a), dt);
        assert_eq!(st.path, UpdatePath::Imu);
        if i == (ROLL_S / DT_S) as u32 {
            at_roll_end = tilt_err_deg(&f.quaternion_f32(), &q);
        }
    }
    let end = tilt_err_deg(&f.quaternion_f32(), &truth(ROLL_S + REST_S).0);
    (at_roll_end, end)
}

#[test]
fn at_rest_a_tilt_the_gyro_left_is_gone_within_a_second_of_the_rest_test() {
    let rest = Config::DEFAULT.rest_tilt_tau_s;
    for (name, (left_by_roll, left)) in [
        ("f32", run_f32(rest, false)),
        ("fixed", run_fixed(rest, false)),
    ] {
        // 10 % of 90°, less what the 3 s loop took during the second.
        assert!(
            left_by_roll > 7.0 && left_by_roll < 9.5,
            "{name}: {left_by_roll}°"
        );
        // The rest test holds 1.5 s into the rest; 1 s at 0.25 s leaves a few % (ζ = ¾).
        assert!(left < 0.5, "{name}: {left}° left");
    }
}

#[test]
fn in_flight_or_switched_off_the_tilt_loop_keeps_its_3_s() {
    // The 3 s loop leaves about 70 % after 2.5 s (ζ = ¾ on the ground: 6.2° of
    // 8.8°; critically damped in flight, a little slower: 6.5°).
    let tau = Config::DEFAULT.tilt_tau_s;
    let rest = Config::DEFAULT.rest_tilt_tau_s;
    for (name, (_, flying), (roll_end, off)) in [
        ("f32", run_f32(rest, true), run_f32(tau, false)),
        ("fixed", run_fixed(rest, true), run_fixed(tau, false)),
    ] {
        for (what, left) in [("in flight", flying), ("off", off)] {
            assert!(
                left > 0.2 * roll_end && left < 0.8 * roll_end,
                "{name} {what}: {left}° left of {roll_end}°"
            );
        }
    }
}
