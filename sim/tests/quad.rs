//! Physical truths of the quadcopter model, and the chips reading its motion.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use sim::physics::G0_MPS2;
use sim::quad::{QuadState, Spin, STEP_S};
use sim::*;

fn quad() -> Quadcopter {
    Quadcopter::new(QuadParams::class_250()).unwrap()
}

/// The quad hovering 10 m up, level, rotors at the hover speed.
fn airborne() -> Quadcopter {
    let mut q = quad();
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    let w = q.steady_rotor_rps(c, q.state().battery_voltage_v);
    let s = QuadState {
        position_ned_m: [0.0, 0.0, -10.0],
        rotor_rps: [w; 4],
        on_ground: false,
        ..*q.state()
    };
    q.set_state(s);
    q
}

#[test]
fn starts_at_rest_on_the_ground_and_stays_there_with_motors_off() {
    let mut q = quad();
    q.advance_to(2.0, [0.0; 4]);
    let t = q.truth();
    assert!(q.state().on_ground);
    assert_eq!(t.height_m, 0.0);
    // At rest the accelerometer's truth is 1 g up (−z body).
    assert!(
        (t.specific_force_body_mps2[2] + G0_MPS2).abs() < 1e-9,
        "{t:?}"
    );
    assert!(!t.moving);
}

#[test]
fn hover_command_gives_thrust_equal_to_weight_and_holds_height() {
    let mut q = airborne();
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    // A 250-class quad hovers at 55-65 % of full rotor speed (37 % of full thrust).
    assert!((0.5..0.7).contains(&c), "{c}");
    // The hover current sags the battery by about 0.5 V: a throttle that
    // follows the present voltage, as the altitude loop does.
    for k in 1..=100 {
        let c = q.command_for_thrust(q.params().weight_n() / 4.0);
        q.advance_to(0.01 * f64::from(k), [c; 4]);
    }
    let w = q.params().weight_n();
    assert!(
        (q.total_thrust_n() - w).abs() < 0.005 * w,
        "{} vs {w}",
        q.total_thrust_n()
    );
    assert!(q.state().accel_ned_mps2[2].abs() < 0.05, "{:?}", q.state());
    let t = q.truth();
    assert!((t.height_m - 10.0).abs() < 0.05, "{}", t.height_m);
    assert!(t.specific_force_body_mps2[2] < -0.98 * G0_MPS2);
    // Hover current of a 250-class quad on 3S: about 8-14 A.
    assert!(
        (6.0..16.0).contains(&q.state().battery_current_a),
        "{}",
        q.state().battery_current_a
    );
}

#[test]
fn motors_respond_with_the_first_order_time_constant() {
    let mut q = quad();
    let tau = q.params().propulsion.tau_s;
    let v0 = q.state().battery_voltage_v;
    q.advance_to(tau, [0.5; 4]);
    let target = q.steady_rotor_rps(0.5, v0);
    let frac = q.state().rotor_rps[0] / target;
    // 1 − 1/e after one time constant (the sagging voltage lowers the target slightly).
    assert!((frac - (1.0 - (-1.0f64).exp())).abs() < 0.02, "{frac}");
    q.advance_to(tau + 5.0 * tau, [0.5; 4]);
    let target = q.steady_rotor_rps(0.5, q.state().battery_voltage_v);
    let frac = q.state().rotor_rps[0] / target;
    assert!(frac > 0.97, "{frac}");
}

#[test]
fn free_fall_with_motors_off() {
    let mut q = airborne();
    q.advance_to(0.3, [0.0; 4]);
    // The rotors have spun down (τ = 30 ms): gravity less drag only.
    assert!(q.total_thrust_n() < 1e-3);
    let p = *q.params();
    let v = q.state().velocity_ned_mps[2];
    let drag = p.drag.linear_n_per_mps[2] * v + p.drag.quadratic_n_per_mps2[2] * v * v;
    let a = q.state().accel_ned_mps2[2];
    assert!((a - (G0_MPS2 - drag / p.mass_kg)).abs() < 1e-3, "{a} {v}");
    // The accelerometer reads only the drag (well under 1 g at 3 m/s).
    let t = q.truth();
    let f = sim::math::norm(t.specific_force_body_mps2);
    assert!((f - drag / p.mass_kg).abs() < 1e-3 && f < 1.5, "{t:?}");
    q.advance_to(1.0, [0.0; 4]);
    // After 1 s: ½ g t² less the spin-down and the drag (terminal speed 15 m/s).
    let fall = q.truth().height_m - 10.0;
    let free = -0.5 * G0_MPS2;
    assert!(fall < 0.85 * free && fall > free, "{fall}");
    // ...until the ground: it stops there and does not go through.
    q.advance_to(4.0, [0.0; 4]);
    assert!(q.state().on_ground);
    assert_eq!(q.truth().height_m, 0.0);
}

#[test]
fn more_thrust_on_the_left_rolls_right_positive_p() {
    let mut q = airborne();
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    let mut cmd = [c; 4];
    for (i, m) in q.params().motors.iter().enumerate() {
        // Left motors (y < 0 in FRD) up, right ones down.
        cmd[i] += if m.position_body_m[1] < 0.0 {
            0.05
        } else {
            -0.05
        };
    }
    q.advance_to(0.2, cmd);
    let w = q.truth().omega_body_rps;
    assert!(w[0] > 0.5, "{w:?}");
    assert!(
        w[1].abs() < 0.05 * w[0] && w[2].abs() < 0.05 * w[0],
        "{w:?}"
    );
    // Roll right: the right side goes down, roll angle positive.
    assert!(q.truth().q_ned_from_body.to_euler()[0] > 0.0);
}

#[test]
fn more_thrust_at_the_front_pitches_up_positive_q() {
    let mut q = airborne();
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    let mut cmd = [c; 4];
    for (i, m) in q.params().motors.iter().enumerate() {
        cmd[i] += if m.position_body_m[0] > 0.0 {
            0.05
        } else {
            -0.05
        };
    }
    q.advance_to(0.2, cmd);
    let w = q.truth().omega_body_rps;
    assert!(w[1] > 0.5 && w[0].abs() < 0.05 * w[1], "{w:?}");
}

#[test]
fn speeding_up_the_counter_clockwise_props_yaws_the_nose_right() {
    let mut q = airborne();
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    let mut cmd = [c; 4];
    for (i, m) in q.params().motors.iter().enumerate() {
        cmd[i] += match m.spin {
            Spin::CounterClockwise => 0.05,
            Spin::Clockwise => -0.05,
        };
    }
    q.advance_to(0.3, cmd);
    let w = q.truth().omega_body_rps;
    // Reaction torque: positive r (nose right, clockwise from above).
    assert!(w[2] > 0.1, "{w:?}");
    assert!(
        w[0].abs() < 0.05 * w[2] && w[1].abs() < 0.05 * w[2],
        "{w:?}"
    );
    // The diagonal pairs keep the thrust balanced: no roll or pitch.
    assert!(q.truth().q_ned_from_body.to_euler()[0].abs() < 1e-3);
}

/// The quad hovering as [`airborne`] with `params`.
fn airborne_with(params: QuadParams) -> Quadcopter {
    let s = *airborne().state();
    let mut q = Quadcopter::new(params).unwrap();
    q.set_state(s);
    q
}

#[test]
fn swapped_esc_signals_drive_each_motor_with_the_others_command() {
    // Motors 1 and 2 (rear right, front right) swapped: the command meant
    // for the front right spins the rear right.
    let mut q = airborne_with(QuadParams::class_250().with_swapped_esc_signals(0, 1));
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    // "More thrust at the front" as the controller means it.
    let cmd = [c - 0.05, c + 0.05, c - 0.05, c + 0.05];
    q.advance_to(0.2, cmd);
    let w = q.truth().omega_body_rps;
    // The right side's pitch torque turns round and cancels the left
    // side's; the rear-right CW and front-right CCW speed changes add up
    // to a yaw torque (nose left) instead.
    assert!(w[2] < -0.1, "{w:?}");
    assert!(w[1].abs() < 0.05 * w[2].abs(), "{w:?}");
    assert!(q.state().rotor_rps[0] > q.state().rotor_rps[1]);
}

#[test]
fn a_reversed_motor_yaws_the_other_way_with_a_fraction_of_the_thrust() {
    let rev = QuadParams::class_250().with_reversed_motor(0, 0.5);
    assert_eq!(rev.motors[0].spin, Spin::CounterClockwise);
    let mut q = airborne_with(rev);
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    // Thrust: half of a correct propeller's at the same rotor speed.
    let good = airborne();
    assert!((q.thrust_n(0) - 0.5 * good.thrust_n(0)).abs() < 1e-12);
    q.advance_to(0.3, [c; 4]);
    let w = q.truth().omega_body_rps;
    // Three propellers' reaction torque yaws the nose right; the weak
    // rear-right one rolls right (right side down) and pitches up.
    assert!(w[2] > 0.1 && w[0] > 0.5 && w[1] > 0.5, "{w:?}");
}

#[test]
fn battery_sag_lowers_thrust_at_the_same_command() {
    let fresh = QuadParams::class_250();
    let mut tired = fresh;
    tired.battery.used_at_start_ah = 0.85 * fresh.battery.capacity_ah;
    let mut a = Quadcopter::new(fresh).unwrap();
    let mut b = Quadcopter::new(tired).unwrap();
    a.advance_to(1.0, [0.8; 4]);
    b.advance_to(1.0, [0.8; 4]);
    let (va, vb) = (a.state().battery_voltage_v, b.state().battery_voltage_v);
    assert!(vb < va - 0.5, "{va} {vb}");
    // Under load the terminal voltage is below the open-circuit one by I·R.
    let ocv = fresh.battery.open_circuit_v(a.state().battery_used_ah);
    let r = fresh.battery.r_internal_ohm;
    assert!((ocv - va - a.state().battery_current_a * r).abs() < 0.05);
    // Thrust scales with V² at a given command.
    let ratio = b.total_thrust_n() / a.total_thrust_n();
    assert!(
        (ratio - (vb / va).powi(2)).abs() < 0.01,
        "{ratio} {va} {vb}"
    );
    // Draining the pack during a hover lowers the voltage.
    let mut c = airborne();
    let v0 = c.state().battery_voltage_v;
    let cmd = c.command_for_thrust(c.params().weight_n() / 4.0);
    c.advance_to(60.0, [cmd; 4]);
    assert!(c.state().battery_voltage_v < v0 - 0.1);
    assert!(c.state().battery_used_ah > 0.1);
}

#[test]
fn drag_limits_the_speed_of_a_fall() {
    let mut q = airborne();
    let mut s = *q.state();
    s.position_ned_m[2] = -10_000.0;
    s.rotor_rps = [0.0; 4];
    q.set_state(s);
    q.advance_to(60.0, [0.0; 4]);
    let v = q.state().velocity_ned_mps[2];
    // Terminal speed: m g = c1 v + c2 v².
    let p = q.params();
    let (c1, c2) = (p.drag.linear_n_per_mps[2], p.drag.quadratic_n_per_mps2[2]);
    let vt = (-c1 + (c1 * c1 + 4.0 * c2 * p.weight_n()).sqrt()) / (2.0 * c2);
    assert!((v - vt).abs() < 0.01 * vt, "{v} {vt}");
    assert!(STEP_S < p.propulsion.tau_s / 10.0);
}

#[test]
fn the_chips_read_the_body_through_the_link() {
    use embedded_hal::i2c::I2c;
    let link = QuadLink::new();
    // The rigid body only: the frame's vibration would add to the truth
    // the chips read (its own tests are below).
    let mut q = Quadcopter::new(QuadParams::class_250().with_vibration_scale(0.0)).unwrap();
    q.set_state(*airborne().state());
    // A steady roll rate: the MPU-9250 gyro must see it.
    let mut s = *q.state();
    s.omega_body_rps = [1.0, 0.0, 0.0];
    q.set_state(s);
    link.publish(&q);
    let clock = SimClock::new();
    let cfg = SimConfig {
        trajectory: link.trajectory(),
        errors: SensorErrors::ideal(),
        ..SimConfig::default()
    };
    let mut bus = SimBus::new(&clock, cfg);
    // Wake the MPU-9250 (PWR_MGMT_1 = 0), ±250 °/s.
    bus.write(0x68, &[0x6B, 0x00]).unwrap();
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    for _ in 0..20 {
        let t = bus.next_mpu_sample_ns() as f64 * 1e-9;
        q.advance_to(t, [c; 4]);
        link.publish(&q);
        bus.advance_to_next_mpu_sample();
    }
    let truth = bus.truth_at_last_mpu_sample().unwrap();
    assert!((truth.omega_body_rps[0] - q.truth().omega_body_rps[0]).abs() < 1e-6);
    assert!((truth.height_m - q.truth().height_m).abs() < 1e-6);
    let mut raw = [0u8; 14];
    bus.write_read(0x68, &[0x3B], &mut raw).unwrap();
    let gx = i16::from_be_bytes([raw[8], raw[9]]);
    // Body x = MPU x; 131 LSB per °/s at ±250 °/s.
    let expect = q.truth().omega_body_rps[0].to_degrees() * 131.0;
    assert!(
        (f64::from(gx) - expect).abs() < 0.02 * expect,
        "{gx} {expect}"
    );
    // Specific force: hovering, about −1 g on body z = +1 g on MPU z.
    let az = i16::from_be_bytes([raw[4], raw[5]]);
    assert!((f64::from(az) / 16384.0 - 1.0).abs() < 0.05, "{az}");
}

#[test]
fn a_gentle_touch_down_settles_level_and_a_crash_stays_on_its_side() {
    for (roll_deg, stays_tilted) in [(20.0f64, false), (80.0, true)] {
        let mut q = airborne();
        let mut s = *q.state();
        s.position_ned_m[2] = -0.5;
        s.rotor_rps = [0.0; 4];
        s.q_ned_from_body = Quat::from_euler(roll_deg.to_radians(), 0.0, 0.3);
        q.set_state(s);
        q.advance_to(2.0, [0.0; 4]);
        assert!(q.state().on_ground);
        let e = q.truth().q_ned_from_body.to_euler();
        if stays_tilted {
            assert!((e[0].to_degrees() - roll_deg).abs() < 1.0, "{e:?}");
        } else {
            assert!(e[0].abs() < 1e-9 && e[1].abs() < 1e-9, "{e:?}");
        }
        // The heading is kept either way, and nothing moves.
        assert!((e[2] - 0.3).abs() < 1e-6, "{e:?}");
        assert!(!q.truth().moving);
    }
}

#[test]
fn unphysical_parameters_are_refused_by_name() {
    use sim::quad::QuadParamsError as E;
    let ok = QuadParams::class_250();
    assert_eq!(ok.validate(), Ok(()));
    type Break = fn(&mut QuadParams);
    let cases: [(Break, E); 9] = [
        (|p| p.mass_kg = 0.0, E::Mass),
        (|p| p.inertia_kgm2[2] = f64::NAN, E::Inertia),
        (
            |p| p.motors[1].position_body_m[0] = f64::INFINITY,
            E::MotorPosition,
        ),
        (|p| p.motors[2].esc_input = 4, E::MotorWiring),
        (|p| p.motors[3].prop_fraction = 0.0, E::MotorWiring),
        (|p| p.propulsion.tau_s = 0.0, E::Propulsion),
        (|p| p.propulsion.efficiency = 1.5, E::Propulsion),
        (|p| p.battery.used_at_start_ah = 2.0, E::Battery),
        (|p| p.drag.quadratic_n_per_mps2[0] = -0.1, E::Drag),
    ];
    for (break_it, want) in cases {
        let mut p = ok;
        break_it(&mut p);
        assert_eq!(Quadcopter::new(p).err(), Some(want));
    }
}

/// RMS per axis of the vibration's angular rate (°/s) and acceleration
/// (m/s²) over 1 s sampled at 32 kHz, rotors at `w` rad/s.
fn vibration_rms(params: QuadParams, w: f64) -> ([f64; 3], [f64; 3]) {
    let mut q = Quadcopter::new(params).unwrap();
    let s = QuadState {
        rotor_rps: [w, w * 1.01, w * 0.99, w * 1.02],
        on_ground: false,
        position_ned_m: [0.0, 0.0, -10.0],
        ..*q.state()
    };
    q.set_state(s);
    let n = 32_000;
    let (mut g, mut a) = ([0.0; 3], [0.0; 3]);
    for k in 0..n {
        let v = sim::quad::vibration::at(q.params(), q.state(), k as f64 / 32e3);
        for i in 0..3 {
            g[i] += v.omega_body_rps[i].to_degrees().powi(2) / n as f64;
            a[i] += v.accel_body_mps2[i].powi(2) / n as f64;
        }
    }
    (g.map(f64::sqrt), a.map(f64::sqrt))
}

fn hover_rotor_rps() -> f64 {
    let q = quad();
    let c = q.command_for_thrust(q.params().weight_n() / 4.0);
    q.steady_rotor_rps(c, q.state().battery_voltage_v)
}

#[test]
fn the_default_frame_vibrates_at_the_level_its_source_states() {
    // The module doc's calibration: about 2 m/s² RMS per horizontal axis
    // of unfiltered acceleration at hover.
    let (g, a) = vibration_rms(QuadParams::class_250(), hover_rotor_rps());
    let full = vibration_rms(QuadParams::class_250(), 2140.0);
    println!("unfiltered RMS (°/s; m/s²), hover: {g:.2?} {a:.2?}; full: {full:.2?}");
    for (i, ai) in a.iter().take(2).enumerate() {
        assert!((1.5..2.5).contains(ai), "axis {i}: {a:?}");
    }
    let none = vibration_rms(QuadParams::class_250().with_vibration_scale(0.0), 1500.0);
    assert_eq!(none, ([0.0; 3], [0.0; 3]));
}

#[test]
fn vibration_grows_linearly_with_its_scale() {
    let w = hover_rotor_rps();
    let (g1, a1) = vibration_rms(QuadParams::class_250(), w);
    let (g3, a3) = vibration_rms(QuadParams::class_250().with_vibration_scale(3.0), w);
    for i in 0..3 {
        assert!((g3[i] / g1[i] - 3.0).abs() < 1e-9 && (a3[i] / a1[i] - 3.0).abs() < 1e-9);
    }
    assert!(QuadParams::class_250()
        .with_vibration_scale(-1.0)
        .validate()
        .is_err());
}

#[test]
fn a_lone_imbalance_on_a_rigid_frame_gives_the_textbook_motion() {
    // Only rotor 0 turning, only its 1x imbalance, no frame mode: the body
    // accelerates by u ω² / m turning with the rotor, and yaws at
    // |r × F| / (I_z ω) peak, the rotor plane at the centre of mass' height.
    let mut p = QuadParams::class_250();
    p.vibration.harmonic_ratio = [0.0, 0.0];
    p.vibration.blade_pass_fraction = 0.0;
    p.vibration.participation = 0.0;
    p.vibration.rotor_height_m = 0.0;
    let mut q = Quadcopter::new(p).unwrap();
    let w = 1500.0;
    let s = QuadState {
        rotor_rps: [w, 0.0, 0.0, 0.0],
        ..*q.state()
    };
    q.set_state(s);
    let f = p.vibration.imbalance_kgm * w * w;
    let r = QuadParams::ARM_250_M;
    let (mut a_max, mut yaw_max, mut roll_max) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..2000 {
        let v = sim::quad::vibration::at(q.params(), q.state(), k as f64 * 1e-5);
        let a = v.accel_body_mps2;
        // A force turning in the rotor plane: constant magnitude.
        let mag = (a[0] * a[0] + a[1] * a[1]).sqrt();
        assert!((mag - f / p.mass_kg).abs() < 1e-9 * mag, "{a:?}");
        a_max = a_max.max(mag);
        yaw_max = yaw_max.max(v.omega_body_rps[2].abs());
        roll_max = roll_max.max(v.omega_body_rps[0].abs());
    }
    let yaw = r * f / (p.inertia_kgm2[2] * w);
    assert!((yaw_max - yaw).abs() < 0.01 * yaw, "{yaw_max} vs {yaw}");
    assert_eq!(roll_max, 0.0);
    assert!(a_max > 0.0);
}

#[test]
fn the_frame_mode_amplifies_near_its_frequency_and_not_far_below() {
    let v = sim::quad::VibrationParams::well_balanced();
    let mag = |f: f64| {
        let (r, i) = v.transmissibility(f);
        (r * r + i * i).sqrt()
    };
    assert!((mag(1.0) - 1.0).abs() < 1e-3);
    // Peak ≈ participation / (2ζ) + the rigid part.
    assert!(mag(v.mode_hz) > v.participation / (2.0 * v.mode_damping));
}

/// What a torque command of 1 means for the 250-class model: the mixer
/// moves each motor's command by ±½, so around the hover a roll command
/// `u` makes a torque 2·a·u·dT/dc about x (a: each motor's lateral offset,
/// dT/dc = 2·k_f·ω_h·ω_max·V/V_nom the thrust per unit command), a pitch
/// command the same about y, and a yaw command 2·u·k_m/k_f·dT/dc about z.
/// The model's angular acceleration, measured with the rotors already at
/// the mixed commands' steady speeds, agrees with that, and gives the
/// numbers `control`'s and `settings`' docs quote (≈ 490, 410, 34 rad/s²
/// per unit at a full pack).
#[test]
fn a_unit_torque_command_is_the_airframe_s_authority() {
    use control::controllers::TorqueCommand;
    use control::mixer::{Mixer, MixerConfig};
    let q0 = airborne();
    let p = *q0.params();
    let v = q0.state().battery_voltage_v;
    let hover = q0.command_for_thrust(p.weight_n() / 4.0);
    let w_h = q0.steady_rotor_rps(hover, v);
    let w_max = q0.steady_rotor_rps(1.0, v);
    let dt_dc = 2.0 * p.propulsion.k_f_n_per_rps2 * w_h * w_max;
    let a = QuadParams::ARM_250_M * std::f64::consts::FRAC_1_SQRT_2;
    let k_m = p.propulsion.k_m_nm_per_rps2 / p.propulsion.k_f_n_per_rps2;
    let expected = [
        2.0 * a * dt_dc / p.inertia_kgm2[0],
        2.0 * a * dt_dc / p.inertia_kgm2[1],
        2.0 * k_m * dt_dc / p.inertia_kgm2[2],
    ];
    let mixer = Mixer::new(MixerConfig::default()).unwrap();
    let u = 0.02; // small: the thrust is quadratic in the command
    for axis in 0..3 {
        let mut t = [0.0f32; 3];
        t[axis] = u as f32;
        let torque = TorqueCommand {
            roll: t[0],
            pitch: t[1],
            yaw: t[2],
        };
        let m = mixer
            .mix(hover as f32, &torque)
            .unwrap()
            .motors
            .map(f64::from);
        let mut q = q0.clone();
        let s = QuadState {
            rotor_rps: m.map(|c| q.steady_rotor_rps(c, v)),
            ..*q.state()
        };
        q.set_state(s);
        q.advance_to(q.state().t_s + 0.002, m);
        let alpha = q.state().omega_body_rps[axis] / 0.002 / u;
        let e = expected[axis];
        println!("axis {axis}: {alpha:.1} rad/s² per unit torque command (analytic {e:.1})");
        assert!((alpha - e).abs() < 0.05 * e, "axis {axis}: {alpha} vs {e}");
    }
    // The figures the docs quote.
    assert!((expected[0] - 490.0).abs() < 25.0 && (expected[1] - 410.0).abs() < 20.0);
    assert!((expected[2] - 34.0).abs() < 3.0, "{expected:?}");
}
