//! Start-up gain with long time steps: the gradient step per update is limited to the
//! step that removes the error (‖∇f‖/4), so β·dt ≫ 1 (β = 2.5 rad/s, dt up to
//! `MAX_DT_S`) converges instead of spinning the estimate away.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use fc_ahrs::fixed::{dt_s_to_q31, float_to_q, FixedConfig, MadgwickFixed};
use fc_ahrs::{Config, Madgwick, Quaternion};

const G: f32 = 9.80665;
/// Field in NED (µT), dip ≈ 67°.
const B_NED: [f32; 3] = [19.5, 0.0, 45.0];

fn sense(q: &Quaternion) -> ([f32; 3], [f32; 3]) {
    (q.rotate_inverse([0.0, 0.0, -G]), q.rotate_inverse(B_NED))
}

/// Start-up gain (2.5 rad/s) for the whole test.
fn long_startup() -> Config {
    Config {
        startup_s: 1000.0,
        ..Config::DEFAULT
    }
}

fn q16(v: [f32; 3]) -> [i32; 3] {
    v.map(|x| float_to_q(x, 16))
}

fn fixed_cfg() -> FixedConfig {
    FixedConfig::from_config(&Config {
        gravity_norm: G * 65536.0,
        ..long_startup()
    })
}

#[test]
fn still_input_stays_put_with_start_up_gain_and_long_dt() {
    let truth = Quaternion::from_euler_rad(0.2, -0.1, 2.0);
    let (a, m) = sense(&truth);
    for dt in [1.0f32, 0.9, 0.5, 0.2, 0.05] {
        let mut f = Madgwick::from_accel_mag(long_startup(), a, m);
        let mut fx = MadgwickFixed::from_accel_mag(fixed_cfg(), q16(a), q16(m));
        for _ in 0..50 {
            f.update_marg([0.0; 3], a, m, dt);
            fx.update_marg([0; 3], q16(a), q16(m), dt_s_to_q31(dt));
            let e = f.quaternion().angle_to(&truth).to_degrees();
            let ex = fx.quaternion_f32().angle_to(&truth).to_degrees();
            assert!(e < 0.1, "f32 dt {dt}: {e}°");
            assert!(ex < 0.1, "fixed dt {dt}: {ex}°");
        }
        for _ in 0..20 {
            f.update_imu([0.0; 3], a, dt);
            fx.update_imu([0; 3], q16(a), dt_s_to_q31(dt));
        }
        assert!(f.quaternion().angle_to(&truth).to_degrees() < 0.1);
        assert!(fx.quaternion_f32().angle_to(&truth).to_degrees() < 0.1);
    }
}

#[test]
fn large_initial_error_converges_with_start_up_gain_and_long_dt() {
    let truth = Quaternion::from_euler_rad(0.5, 0.3, -1.5);
    let (a, m) = sense(&truth);
    for dt in [1.0f32, 0.5, 0.1] {
        // Start at the identity: ~90° of error, tilt and heading.
        let mut f = Madgwick::new(long_startup());
        let mut fx = MadgwickFixed::new(fixed_cfg());
        let mut last = (f32::MAX, f32::MAX);
        for i in 0..300 {
            f.update_marg([0.0; 3], a, m, dt);
            fx.update_marg([0; 3], q16(a), q16(m), dt_s_to_q31(dt));
            let e = f.quaternion().angle_to(&truth).to_degrees();
            let ex = fx.quaternion_f32().angle_to(&truth).to_degrees();
            if i >= 100 {
                // Monotone (within rounding) once near the minimum: no limit cycle.
                assert!(
                    e <= last.0 + 1e-3 && ex <= last.1 + 1e-3,
                    "dt {dt} step {i}"
                );
            }
            last = (e, ex);
        }
        assert!(last.0 < 0.1, "f32 dt {dt}: {}°", last.0);
        assert!(last.1 < 0.1, "fixed dt {dt}: {}°", last.1);
    }
}
