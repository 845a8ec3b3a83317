//! Known-motion, fallback, rejection and f32-vs-fixed tests.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use core::f32::consts::{FRAC_PI_2, PI};
use fc_ahrs::fixed::{dt_s_to_q31, rps_to_q20, FixedConfig, MadgwickFixed};
use fc_ahrs::{frames, Config, Madgwick, MagState, Quaternion, UpdatePath};

const G: f32 = 9.80665;
/// Berlin-like field in NED (µT): 19.5 north, 45 down (dip ≈ 67°).
const B_NED: [f32; 3] = [19.5, 0.0, 45.0];

/// Body-frame accel (specific force) and field for an orientation q_ned_from_body.
fn sense(q: &Quaternion) -> ([f32; 3], [f32; 3]) {
    (q.rotate_inverse([0.0, 0.0, -G]), q.rotate_inverse(B_NED))
}

fn plain() -> Config {
    let mut c = Config::DEFAULT;
    c.bias.enabled = false;
    c.startup_s = 0.0;
    c
}

fn wrap(a: f32) -> f32 {
    let mut a = a;
    while a > PI {
        a -= 2.0 * PI;
    }
    while a < -PI {
        a += 2.0 * PI;
    }
    a
}

#[test]
fn constant_rate_integrates_about_each_axis() {
    // Gyro only (zero accel => GyroOnly path): 90° in 1 s about each body axis.
    for axis in 0..3 {
        let mut f = Madgwick::new(plain());
        let mut w = [0.0; 3];
        w[axis] = FRAC_PI_2;
        for _ in 0..1000 {
            let st = f.update_imu(w, [0.0; 3], 0.001);
            assert_eq!(st.path, UpdatePath::GyroOnly);
            assert!(st.accel_invalid);
        }
        let mut ax = [0.0; 3];
        ax[axis] = 1.0;
        let expected = Quaternion::from_axis_angle(ax, FRAC_PI_2);
        assert!(f.quaternion().angle_to(&expected) < 1e-3, "axis {axis}");
    }
}

// The test above again for the fixed filter, on purpose: its inputs are Q-formats.
#[test]
fn fixed_constant_rate_integrates() {
    for axis in 0..3 {
        let mut f = MadgwickFixed::new(FixedConfig::from_config(&plain()));
        let mut w = [0; 3];
        w[axis] = rps_to_q20(FRAC_PI_2);
        for _ in 0..1000 {
            f.update_imu(w, [0; 3], dt_s_to_q31(0.001));
        }
        let mut ax = [0.0; 3];
        ax[axis] = 1.0;
        let expected = Quaternion::from_axis_angle(ax, FRAC_PI_2);
        assert!(f.quaternion_f32().angle_to(&expected) < 1e-3, "axis {axis}");
    }
}

#[test]
fn static_tilts_give_roll_pitch_and_known_fields_give_yaw() {
    for &(roll, pitch, yaw) in &[
        (0.0f32, 0.0f32, 0.0f32),
        (20.0, 0.0, 90.0),
        (0.0, -30.0, 180.0),
        (-45.0, 10.0, -90.0),
        (10.0, 25.0, 45.0),
        (5.0, -5.0, -135.0),
    ] {
        let truth =
            Quaternion::from_euler_rad(roll.to_radians(), pitch.to_radians(), yaw.to_radians());
        let (a, m) = sense(&truth);
        // Direct initialisation
        let f = Madgwick::from_accel_mag(Config::DEFAULT, a, m);
        let e = f.euler_rad();
        assert!((e[0] - roll.to_radians()).abs() < 1e-3, "{roll} {e:?}");
        assert!((e[1] - pitch.to_radians()).abs() < 1e-3);
        assert!(
            wrap(e[2] - yaw.to_radians()).abs() < 1e-3,
            "yaw {yaw} {e:?}"
        );
        if yaw.abs() > 170.0 {
            continue; // 180° from the start: a saddle of the cost function
        }
        // Convergence from the identity (start-up gain, then the first-order heading
        // correction, τ 40 s).
        let mut f = Madgwick::new(Config::DEFAULT);
        for _ in 0..40_000 {
            f.update_marg([0.0; 3], a, m, 0.001);
        }
        let err = f.quaternion().angle_to(&truth).to_degrees();
        assert!(err < 1.0, "{roll} {pitch} {yaw}: {err}");
        let mut fx = MadgwickFixed::new(FixedConfig::from_config(&Config {
            gravity_norm: G * 65536.0,
            ..Config::DEFAULT
        }));
        let q16 = |v: [f32; 3]| v.map(|x| fc_ahrs::fixed::float_to_q(x, 16));
        for _ in 0..40_000 {
            fx.update_marg([0; 3], q16(a), q16(m), dt_s_to_q31(0.001));
        }
        assert!(fx.quaternion_f32().angle_to(&truth) < 1.0f32.to_radians());
    }
}

#[test]
fn gravity_and_linear_accel() {
    let truth = Quaternion::from_euler_rad(0.3, -0.2, 1.0);
    let (a, m) = sense(&truth);
    let f = Madgwick::from_accel_mag(Config::DEFAULT, a, m);
    let g = f.gravity_body();
    for i in 0..3 {
        assert!((g[i] + a[i] / G).abs() < 1e-4);
    }
    // At rest the linear acceleration is zero; add 2 m/s² up in NED.
    let lin = f.linear_accel_ned_mps2(a);
    assert!(lin.iter().all(|x| x.abs() < 1e-3));
    let a_up = truth.rotate_inverse([0.0, 0.0, -G - 2.0]);
    assert!((f.vertical_accel_up_mps2(a_up) - 2.0).abs() < 1e-3);
    // fixed version, Q16 m/s²
    let q16 = |v: [f32; 3]| v.map(|x| fc_ahrs::fixed::float_to_q(x, 16));
    let fx = MadgwickFixed::from_accel_mag(
        FixedConfig::from_config(&Config {
            gravity_norm: G * 65536.0,
            ..Config::DEFAULT
        }),
        q16(a),
        q16(m),
    );
    let up = fx.vertical_accel_up_mps2_q16(q16(a_up)) as f32 / 65536.0;
    assert!((up - 2.0).abs() < 1e-3, "{up}");
}

#[test]
fn enu_output_matches_reference_convention() {
    // Sensor flat, z up, x pointing east (the BROAD start pose): in NED the body is
    // upside down. Level body "x east, y north, z up" ⇒ q_enu_from_body = identity.
    let body_to_ned = [[0.0f32, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
    let q_ned = Quaternion::from_matrix(&body_to_ned);
    let (a, m) = sense(&q_ned);
    assert!((a[2] - G).abs() < 1e-4, "accel reads +g on z when flat");
    let f = Madgwick::from_accel_mag(Config::DEFAULT, a, m);
    let q_enu = frames::enu_from_ned(f.quaternion());
    assert!(q_enu.angle_to(&Quaternion::IDENTITY) < 1e-3);
}

#[test]
fn invalid_inputs_fall_back_and_report() {
    let truth = Quaternion::from_euler_rad(0.1, 0.2, 0.3);
    let (a, m) = sense(&truth);
    let mut f = Madgwick::from_accel_mag(Config::DEFAULT, a, m);
    let q0 = f.quaternion();
    let st = f.update_marg([f32::NAN, 0.0, 0.0], a, m, 0.001);
    assert_eq!(st.path, UpdatePath::Skipped);
    assert!(st.gyro_invalid);
    assert_eq!(f.quaternion(), q0);
    assert_eq!(
        f.update_marg([0.0; 3], a, m, f32::INFINITY).path,
        UpdatePath::Skipped
    );
    assert_eq!(
        f.update_marg([0.0; 3], a, m, -0.001).path,
        UpdatePath::Skipped
    );
    assert_eq!(f.quaternion(), q0);
    let st = f.update_marg([0.0; 3], a, [0.0; 3], 0.001);
    assert_eq!(st.path, UpdatePath::Imu);
    assert!(st.mag_invalid);
    let st = f.update_marg([0.0; 3], a, [f32::NAN; 3], 0.001);
    assert_eq!(st.path, UpdatePath::Imu);
    let st = f.update_marg([0.0; 3], [0.0; 3], m, 0.001);
    assert_eq!(st.path, UpdatePath::MagOnly);
    let st = f.update_marg([0.0; 3], [f32::NAN; 3], [0.0; 3], 0.001);
    assert_eq!(st.path, UpdatePath::GyroOnly);
    assert!((f.quaternion().norm() - 1.0).abs() < 1e-5);
    // fixed
    let mut fx = MadgwickFixed::new(FixedConfig::from_config(&Config::DEFAULT));
    let st = fx.update_marg([0; 3], [0, 0, -10], [1, 0, 2], 0);
    assert_eq!(st.path, UpdatePath::Skipped);
    assert_eq!(
        fx.update_marg([0; 3], [0, 0, -10], [0; 3], 1000).path,
        UpdatePath::Imu
    );
    assert_eq!(
        fx.update_marg([0; 3], [0; 3], [0; 3], 1000).path,
        UpdatePath::GyroOnly
    );
}

#[test]
fn bias_is_learned_at_rest() {
    let truth = Quaternion::from_euler_rad(0.0, 0.0, 0.5);
    let (a, m) = sense(&truth);
    let bias = [0.01f32, -0.02, 0.008];
    let mut f = Madgwick::from_accel_mag(Config::DEFAULT, a, m);
    let mut fx = MadgwickFixed::from_accel_mag(
        FixedConfig::from_config(&Config {
            gravity_norm: G * 65536.0,
            ..Config::DEFAULT
        }),
        a.map(|x| fc_ahrs::fixed::float_to_q(x, 16)),
        m.map(|x| fc_ahrs::fixed::float_to_q(x, 16)),
    );
    let mut rest_seen = false;
    for _ in 0..20_000 {
        rest_seen |= f.update_marg(bias, a, m, 0.001).at_rest;
        fx.update_marg(
            bias.map(rps_to_q20),
            a.map(|x| fc_ahrs::fixed::float_to_q(x, 16)),
            m.map(|x| fc_ahrs::fixed::float_to_q(x, 16)),
            dt_s_to_q31(0.001),
        );
    }
    assert!(rest_seen);
    let b = f.gyro_bias_rps();
    let bx = fx.gyro_bias_rps_q20();
    for i in 0..3 {
        assert!((b[i] - bias[i]).abs() < 5e-4, "{b:?}");
        assert!((bx[i] as f32 / 1048576.0 - bias[i]).abs() < 5e-4, "{bx:?}");
    }
    // Motion stops the bias update.
    let st = f.update_marg([0.5, 0.0, 0.0], a, m, 0.001);
    assert!(!st.at_rest);
}

#[test]
fn magnetic_disturbance_is_rejected_and_recovers() {
    let truth = Quaternion::IDENTITY;
    let (a, m) = sense(&truth);
    let mut f = Madgwick::from_accel_mag(Config::DEFAULT, a, m);
    for _ in 0..4000 {
        f.update_marg([0.0; 3], a, m, 0.001);
    }
    // A magnet doubles the field and turns it 40° in heading: rejected, heading held.
    let dist = Quaternion::from_axis_angle([0.0, 0.0, 1.0], 0.7).rotate([39.0, 0.0, 90.0]);
    let mut rejected = 0;
    for _ in 0..5000 {
        let st = f.update_marg([0.0; 3], a, dist, 0.001);
        if st.mag_rejected {
            rejected += 1;
            assert_eq!(st.path, UpdatePath::Imu);
        }
    }
    assert_eq!(rejected, 5000);
    assert!(f.euler_rad()[2].abs() < 0.01);
    // Without rejection the same disturbance drags the heading.
    let mut g = Madgwick::from_accel_mag(
        Config {
            mag_rejection: fc_ahrs::MagRejectionConfig {
                enabled: false,
                ..Config::DEFAULT.mag_rejection
            },
            ..Config::DEFAULT
        },
        a,
        m,
    );
    for _ in 0..4000 {
        g.update_marg([0.0; 3], a, m, 0.001);
    }
    // (30 s: the heading correction is slow, τ 40 s.)
    for _ in 0..30_000 {
        g.update_marg([0.0; 3], a, dist, 0.001);
    }
    assert!(g.euler_rad()[2].abs() > 0.02);
    // Recovery: a new, consistent field while rotating becomes the reference.
    let mut relearned = false;
    let mut q = f.quaternion();
    let w = [0.0, 0.0, 0.5f32];
    let scaled = [m[0] * 1.3, m[1] * 1.3, m[2] * 1.3];
    for _ in 0..30_000 {
        q = q.mul(&Quaternion::from_axis_angle(w, 0.5 * 0.001));
        let (_, mb) = sense(&q);
        let st = f.update_marg(w, a, mb.map(|x| x * 1.3), 0.001);
        relearned |= st.mag_reference_relearned;
    }
    let _ = scaled;
    assert!(relearned);
}

#[test]
fn accel_rejection_triggers_and_recovers() {
    let mut c = Config::DEFAULT;
    c.accel_rejection.enabled = true;
    let truth = Quaternion::IDENTITY;
    let (a, m) = sense(&truth);
    let mut f = Madgwick::from_accel_mag(c, a, m);
    for _ in 0..4000 {
        f.update_marg([0.0; 3], a, m, 0.001);
    }
    // 1.5 g sideways push
    let push = [a[0] + 1.5 * G, a[1], a[2]];
    let st = f.update_marg([0.0; 3], push, m, 0.001);
    assert!(st.accel_rejected);
    assert_eq!(st.path, UpdatePath::MagOnly);
    // Sustained: after the recovery time it is accepted again.
    let mut recovering = false;
    for _ in 0..6000 {
        recovering |= f.update_marg([0.0; 3], push, m, 0.001).accel_recovering;
    }
    assert!(recovering);
    // fixed
    let mut fx = MadgwickFixed::from_accel_mag(
        FixedConfig::from_config(&Config {
            gravity_norm: 1000.0,
            ..c
        }),
        [0, 0, -1000],
        [195, 0, 450],
    );
    for _ in 0..4000 {
        fx.update_marg([0; 3], [0, 0, -1000], [195, 0, 450], dt_s_to_q31(0.001));
    }
    let st = fx.update_marg([0; 3], [1500, 0, -1000], [195, 0, 450], dt_s_to_q31(0.001));
    assert!(st.accel_rejected);
}

#[test]
fn f32_and_fixed_agree_on_a_synthetic_sequence() {
    let c = Config::DEFAULT;
    let mut q = Quaternion::from_euler_rad(0.2, -0.1, 1.0);
    let (a0, m0) = sense(&q);
    let mut f = Madgwick::from_accel_mag(c, a0, m0);
    let q16 = |v: [f32; 3]| v.map(|x| fc_ahrs::fixed::float_to_q(x, 16));
    let mut fx = MadgwickFixed::from_accel_mag(
        FixedConfig::from_config(&Config {
            gravity_norm: G * 65536.0,
            ..c
        }),
        q16(a0),
        q16(m0),
    );
    let dt = 0.001f32;
    let mut max_diff = 0.0f32;
    for i in 0..20_000 {
        let t = i as f32 * dt;
        let w = [
            0.8 * libm::sinf(1.3 * t),
            0.5 * libm::cosf(0.7 * t),
            0.3 + 0.6 * libm::sinf(0.4 * t),
        ];
        q = q.mul(&Quaternion::from_axis_angle(
            w,
            libm::sqrtf(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * dt,
        ));
        let (a, m) = sense(&q);
        let wm = [w[0] + 0.01, w[1] - 0.005, w[2] + 0.003];
        f.update_marg(wm, a, m, dt);
        fx.update_marg(wm.map(rps_to_q20), q16(a), q16(m), dt_s_to_q31(dt));
        if t > 3.5 {
            // after the start-up phase (whose high gain makes both chatter by β·dt)
            max_diff = max_diff.max(f.quaternion().angle_to(&fx.quaternion_f32()));
        }
    }
    assert!(max_diff < 0.05f32.to_radians(), "{}", max_diff.to_degrees());
    assert!(f.quaternion().angle_to(&q) < 3.0f32.to_radians());
}

#[test]
fn large_gyro_steps_are_sub_stepped_and_agree() {
    // 2000 °/s about a tilted axis with steps of 10–60 ms (a half angle of up to 0.67 rad
    // per axis): both filters split the step, lose no rotation and agree.
    let rate = 2000f32.to_radians();
    let w = [rate * 0.6, -rate * 0.48, rate * 0.64];
    let (a, m) = sense(&Quaternion::IDENTITY);
    let q16 = |v: [f32; 3]| v.map(|x| fc_ahrs::fixed::float_to_q(x, 16));
    let fc = FixedConfig::from_config(&Config {
        gravity_norm: G * 65536.0,
        ..Config::DEFAULT
    });
    for dt in [0.01f32, 0.02, 0.029, 0.06] {
        let mut f = Madgwick::from_accel_mag(Config::DEFAULT, a, m);
        let mut fx = MadgwickFixed::from_accel_mag(fc, q16(a), q16(m));
        for _ in 0..200 {
            let s = f.update_imu(w, [0.0; 3], dt);
            let sx = fx.update_imu(w.map(rps_to_q20), [0; 3], dt_s_to_q31(dt));
            assert!(!s.gyro_step_clamped && !sx.gyro_step_clamped, "dt {dt}");
            let d = f.quaternion().angle_to(&fx.quaternion_f32()).to_degrees();
            assert!(d < 0.01, "dt {dt}: f32 vs fixed {d}°");
        }
        // Gyro only (no accelerometer): the estimate is the integrated rotation, short by
        // the first-order steps' 2(h − atan h) ≈ ⅔h³ each (h ≤ 0.044 rad: < 0.1 %).
        let turned = rate * dt * 200.0;
        let truth = Quaternion::from_axis_angle([0.6, -0.48, 0.64], turned);
        let e = f.quaternion().angle_to(&truth);
        assert!(e < 1e-3 * turned, "dt {dt}: {e} rad from the true rotation");
    }
    // With the sub-steps at their maximum (1024) a half angle passes ¼ rad beyond
    // 512 rad in one step (1000 rad/s for 1 s, past any gyro's full scale): it is
    // clamped, and that is reported, in both number types.
    let w = [1000.0f32, 0.0, 0.0];
    let mut f = Madgwick::from_accel_mag(Config::DEFAULT, a, m);
    let mut fx = MadgwickFixed::from_accel_mag(fc, q16(a), q16(m));
    assert!(f.update_imu(w, a, 1.0).gyro_step_clamped);
    assert!(
        fx.update_imu(w.map(rps_to_q20), q16(a), dt_s_to_q31(1.0))
            .gyro_step_clamped
    );
}

#[test]
fn persisting_inconsistent_disturbance_is_adopted_after_the_fallback_time() {
    // A magnet riding along: the field's norm wanders (never a consistent candidate),
    // so only the fallback ends the rejection, after `fallback_s` without a break.
    let cfg = Config::DEFAULT;
    let (a, m) = sense(&Quaternion::IDENTITY);
    let q16 = |v: [f32; 3]| v.map(|x| fc_ahrs::fixed::float_to_q(x, 16));
    let fc = FixedConfig::from_config(&Config {
        gravity_norm: G * 65536.0,
        ..cfg
    });
    let mut f = Madgwick::from_accel_mag(cfg, a, m);
    let mut fx = MadgwickFixed::from_accel_mag(fc, q16(a), q16(m));
    let dt = 0.01f32;
    for _ in 0..500 {
        f.update_marg([0.0; 3], a, m, dt);
        fx.update_marg([0; 3], q16(a), q16(m), dt_s_to_q31(dt));
    }
    let n = (cfg.mag_rejection.fallback_s / dt) as usize;
    let (mut first, mut first_x) = (None, None);
    for i in 0..n + 100 {
        let k = 1.6 + 0.3 * (i as f32 * 0.37).sin();
        let d = [m[0] * k, m[1] + 10.0, m[2] * k];
        let s = f.update_marg([0.0; 3], a, d, dt);
        let sx = fx.update_marg([0; 3], q16(a), q16(d), dt_s_to_q31(dt));
        if s.mag_reference_relearned && first.is_none() {
            first = Some(i);
        }
        if sx.mag_reference_relearned && first_x.is_none() {
            first_x = Some(i);
        }
        if first.is_none() {
            assert!(s.mag_rejected, "f32 step {i}");
        }
    }
    let first = first.expect("f32 fallback");
    let first_x = first_x.expect("fixed fallback");
    assert!(
        first + 2 >= n && first <= n + 1,
        "f32 adopted at step {first}, fallback {n}"
    );
    assert!(
        first_x.abs_diff(first) <= 1,
        "fixed {first_x} vs f32 {first}"
    );
}

/// Spins the body about the vertical at 60 °/s for `secs`, the field seen with a
/// body-fixed offset added (µT, a magnet riding along); returns the count of each
/// `MagState` for the f32 and the fixed filter.
fn spin_with_offset(cfg: Config, offset: [f32; 3], secs: f32) -> [[usize; MagState::COUNT]; 2] {
    let q16 = |v: [f32; 3]| v.map(|x| fc_ahrs::fixed::float_to_q(x, 16));
    let fc = FixedConfig::from_config(&Config {
        gravity_norm: G * 65536.0,
        ..cfg
    });
    let (a, m) = sense(&Quaternion::IDENTITY);
    let mut f = Madgwick::from_accel_mag(cfg, a, m);
    let mut fx = MadgwickFixed::from_accel_mag(fc, q16(a), q16(m));
    let dt = 0.01f32;
    for _ in 0..500 {
        f.update_marg([0.0; 3], a, m, dt);
        fx.update_marg([0; 3], q16(a), q16(m), dt_s_to_q31(dt));
    }
    let rate = 60f32.to_radians();
    let mut counts = [[0usize; MagState::COUNT]; 2];
    for i in 0..(secs / dt) as usize {
        let q = Quaternion::from_axis_angle([0.0, 0.0, 1.0], rate * (i + 1) as f32 * dt);
        let (a, m) = sense(&q);
        let d = [m[0] + offset[0], m[1] + offset[1], m[2] + offset[2]];
        let s = f.update_marg([0.0, 0.0, rate], a, d, dt);
        let sx = fx.update_marg([0, 0, rps_to_q20(rate)], q16(a), q16(d), dt_s_to_q31(dt));
        counts[0][s.mag_state.index()] += 1;
        counts[1][sx.mag_state.index()] += 1;
    }
    counts
}

#[test]
fn a_magnet_riding_along_is_caught_as_the_body_turns() {
    // 30 µT body-fixed along x: as the body turns, the sum's norm swings 46–67 µT
    // against the earth's 49 µT and its dip with it; it is not an earth field, so most
    // of each turn is rejected (where norm and dip happen to pass, it is accepted).
    let c = spin_with_offset(Config::DEFAULT, [30.0, 0.0, 0.0], 12.0);
    for (name, n) in ["f32", "fixed"].iter().zip(c) {
        let total: usize = n.iter().sum();
        assert!(n[4] * 2 > total, "{name}: rejected {n:?}");
        assert_eq!(
            n[5], 0,
            "{name}: an inconsistent field must not be recovered"
        );
    }
    assert!(
        c[0][4].abs_diff(c[1][4]) <= 12,
        "f32 {:?} vs fixed {:?}",
        c[0],
        c[1]
    );
    // Without the magnet every sample is accepted.
    let c = spin_with_offset(Config::DEFAULT, [0.0; 3], 12.0);
    assert_eq!(c[0][2], 1200, "{:?}", c[0]);
    assert_eq!(c[1][2], 1200, "{:?}", c[1]);
}

#[test]
fn the_reference_is_learnt_only_while_moving_and_undisturbed() {
    let mut cfg = Config::DEFAULT;
    cfg.mag_rejection.ref_tau_s = 20.0;
    let c = spin_with_offset(cfg, [0.0; 3], 5.0);
    // 60 °/s is above `recovery_min_rate_rps`: every update refines the reference.
    assert_eq!(c[0][3], 500, "{:?}", c[0]);
    assert_eq!(c[1][3], 500, "{:?}", c[1]);
    // A disturbed field is rejected, never learnt.
    let c = spin_with_offset(cfg, [0.0, 0.0, 30.0], 5.0);
    assert_eq!(c[0][3] + c[0][2], 0, "{:?}", c[0]);
    assert_eq!(c[1][3] + c[1][2], 0, "{:?}", c[1]);
}
