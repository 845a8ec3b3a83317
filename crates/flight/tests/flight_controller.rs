//! Every arming, disarm, failsafe and motor-test rule of the flight
//! controller, driven step by step at 1 kHz.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::*;
use control::controllers::BodyRates;
use control::loops::Quat;
use flight::flightctl::*;

/// A change made to the rig before a step.
type Setup = fn(&mut Rig);

/// The vertical estimator's output at `height_m`, moving at
/// `vertical_speed_mps` (up positive).
fn altitude(height_m: f32, vertical_speed_mps: f32) -> Option<AltitudeEstimate> {
    AltitudeEstimate::from_f32(height_m, vertical_speed_mps)
}

fn tilted_deg(deg: f32) -> Quat {
    Quat::from_euler(deg.to_radians(), 0.0, 0.3)
}

// ---- arming ----------------------------------------------------------------

#[test]
fn arms_on_switch_edge_with_everything_ready() {
    let mut r = Rig::new();
    r.arm();
    let out = r.step();
    assert!(matches!(out.motors, Motors::Run(_)), "armed but motors off");
    let m = out.motors.commands();
    for v in m {
        assert!((0.05..=0.1).contains(&v), "idle expected, got {m:?}");
    }
}

#[test]
fn switch_on_at_boot_never_arms() {
    let mut r = Rig::new();
    r.pilot.arm_switch = true;
    let ev = r.run_ms(2_000);
    assert!(ev.is_empty(), "{ev:?}");
    assert_eq!(r.fc.state(), FlightState::Disarmed);
    // Cycling it arms.
    r.arm();
}

#[test]
fn switch_on_when_link_comes_up_never_arms() {
    let mut r = Rig::new();
    r.pilot.link_ok = false;
    r.pilot.arm_switch = false;
    r.run_ms(100);
    r.pilot.arm_switch = true;
    r.run_ms(100);
    r.pilot.link_ok = true;
    let ev = r.run_ms(100);
    assert!(ev.is_empty(), "{ev:?}");
    assert_eq!(r.fc.state(), FlightState::Disarmed);
}

fn refusal_after(setup: impl FnOnce(&mut Rig)) -> (Rig, Vec<Event>) {
    let mut r = Rig::new();
    r.pilot.arm_switch = false;
    r.run_ms(20);
    setup(&mut r);
    r.pilot.arm_switch = true;
    let ev = r.run_ms(1);
    (r, ev)
}

#[test]
fn each_refusal_is_named() {
    let cases: [(ArmRefusal, Setup); 7] = [
        (ArmRefusal::CalibrationRunning, |r| {
            r.status.calibration_running = true
        }),
        (ArmRefusal::SensorsUnhealthy, |r| {
            r.status.sensors_healthy = false
        }),
        (ArmRefusal::GyroBiasPending, |r| {
            r.status.gyro_bias_done = false
        }),
        (ArmRefusal::AttitudeInvalid, |r| {
            r.vehicle.gyro.roll_rps = f32::NAN
        }),
        (ArmRefusal::NotLevel, |r| {
            r.vehicle.attitude = tilted_deg(26.0)
        }),
        (ArmRefusal::ThrottleNotLow, |r| {
            r.pilot.sticks.throttle = 0.1
        }),
        (ArmRefusal::AccelNotCalibrated, |r| {
            r.status.accel_calibrated = false
        }),
    ];
    for (reason, setup) in cases {
        let (r, ev) = refusal_after(setup);
        assert_eq!(ev, vec![Event::ArmRefused(reason)], "{reason:?}");
        assert_eq!(r.fc.state(), FlightState::Disarmed);
    }
}

#[test]
fn self_levelling_modes_refuse_to_arm_without_accel_calibration_acro_arms() {
    for (mode, arms) in [
        (FlightMode::Angle, false),
        (FlightMode::AltitudeHold, false),
        (FlightMode::Acro, true),
    ] {
        let (r, ev) = refusal_after(|r| {
            r.status.accel_calibrated = false;
            r.pilot.mode = mode;
        });
        let blockers = r.fc.arm_blockers(&r.pilot, &r.status, &r.vehicle.state());
        if arms {
            assert_eq!(ev, vec![Event::Armed], "{mode:?}");
            assert!(blockers.is_empty(), "{mode:?}: {blockers:?}");
        } else {
            assert_eq!(
                ev,
                vec![Event::ArmRefused(ArmRefusal::AccelNotCalibrated)],
                "{mode:?}"
            );
            assert!(blockers.contains(ArmRefusal::AccelNotCalibrated));
            assert_eq!(r.fc.state(), FlightState::Disarmed);
        }
    }
}

#[test]
fn the_pipeline_reports_whether_its_record_holds_an_accel_calibration() {
    use sensor_stack::pipeline::{Pipeline, PipelineConfig};
    use sensor_stack::storage::{CalibrationRecord, ValidParts};
    // A blank flash page loads the defaults: no fitted accelerometer.
    let mut p = Pipeline::new(PipelineConfig::new(), &CalibrationRecord::default()).unwrap();
    assert!(!p.accel_calibrated());
    // Only the magnetometer fitted: still not.
    let mag_only = CalibrationRecord {
        valid: ValidParts(ValidParts::MAG),
        ..CalibrationRecord::default()
    };
    p.set_calibration(&mag_only);
    assert!(!p.accel_calibrated());
    // The six-position fit saved (what the calibration mode sets).
    let fitted = CalibrationRecord {
        valid: ValidParts(ValidParts::ACCEL | ValidParts::MAG),
        accel_offset_g: [0.07, -0.06, 0.08],
        ..CalibrationRecord::default()
    };
    p.set_calibration(&fitted);
    assert!(p.accel_calibrated());
    let p = Pipeline::new(PipelineConfig::new(), &fitted).unwrap();
    assert!(p.accel_calibrated());
}

#[test]
fn level_within_25_degrees_arms() {
    let (r, ev) = refusal_after(|r| r.vehicle.attitude = tilted_deg(24.0));
    assert_eq!(ev, vec![Event::Armed]);
    assert!(r.fc.is_armed());
}

#[test]
fn zero_quaternion_is_invalid_attitude() {
    let (_, ev) = refusal_after(|r| {
        r.vehicle.attitude = Quat {
            w: 0.0,
            x: 0.0,
            y: 0.0,
            z: 0.0,
        }
    });
    assert_eq!(ev, vec![Event::ArmRefused(ArmRefusal::AttitudeInvalid)]);
}

#[test]
fn refusal_needs_the_switch_cycled_again() {
    let (mut r, ev) = refusal_after(|r| r.pilot.sticks.throttle = 0.3);
    assert_eq!(ev, vec![Event::ArmRefused(ArmRefusal::ThrottleNotLow)]);
    r.pilot.sticks.throttle = 0.0;
    assert!(r.run_ms(500).is_empty());
    assert_eq!(r.fc.state(), FlightState::Disarmed);
    r.arm();
}

#[test]
fn blockers_list_link_loss_and_motor_test() {
    let mut r = Rig::new();
    r.run_ms(10);
    r.fc.start_motor_test(1, &r.pilot).unwrap();
    r.pilot.link_ok = false;
    r.status.sensors_healthy = false;
    let b = r.fc.arm_blockers(&r.pilot, &r.status, &r.vehicle.state());
    assert!(b.contains(ArmRefusal::LinkLost));
    assert!(b.contains(ArmRefusal::SensorsUnhealthy));
    assert!(b.contains(ArmRefusal::MotorTestActive));
    assert!(!b.contains(ArmRefusal::NotLevel));
    assert_eq!(b.first(), Some(ArmRefusal::LinkLost));
    let ok = Rig::new();
    assert!(ok
        .fc
        .arm_blockers(&ok.pilot, &ok.status, &ok.vehicle.state())
        .is_empty());
}

// ---- disarming -------------------------------------------------------------

#[test]
fn disarms_on_switch() {
    let mut r = Rig::new();
    r.take_off();
    r.pilot.arm_switch = false;
    assert_eq!(r.run_ms(1), vec![Event::Disarmed(DisarmCause::Switch)]);
}

#[test]
fn crash_tilt_disarms_after_half_a_second_in_angle_mode() {
    let mut r = Rig::new();
    r.take_off();
    r.vehicle.attitude = tilted_deg(75.0);
    r.expect_event_after(Event::Disarmed(DisarmCause::CrashTilt), 2_000, 499..=501);
}

#[test]
fn brief_tilt_and_acro_inverted_do_not_disarm() {
    let mut r = Rig::new();
    r.take_off();
    r.vehicle.attitude = tilted_deg(80.0);
    r.run_ms(400);
    r.vehicle.attitude = Quat::IDENTITY;
    r.run_ms(100);
    r.vehicle.attitude = tilted_deg(80.0);
    r.run_ms(400);
    assert!(r.fc.is_armed());
    r.pilot.mode = FlightMode::Acro;
    r.vehicle.attitude = tilted_deg(180.0);
    r.run_ms(3_000);
    assert!(r.fc.is_armed(), "acro may fly inverted");
}

#[test]
fn saturated_rates_disarm_in_any_mode() {
    let mut r = Rig::new();
    r.pilot.mode = FlightMode::Acro;
    r.take_off();
    r.vehicle.gyro.yaw_rps = 990f32.to_radians();
    r.expect_event_after(Event::Disarmed(DisarmCause::CrashRate), 2_000, 299..=301);
}

#[test]
fn landing_detected_after_two_seconds() {
    let mut r = Rig::new();
    r.take_off();
    r.pilot.sticks.throttle = 0.0;
    r.expect_event_after(Event::Disarmed(DisarmCause::Landed), 5_000, 1_999..=2_001);
}

#[test]
fn no_landing_while_rotating_or_sinking() {
    let mut r = Rig::new();
    r.take_off();
    r.pilot.sticks.throttle = 0.0;
    r.vehicle.gyro.roll_rps = 30f32.to_radians();
    r.run_ms(3_000);
    assert!(r.fc.is_armed());
    r.vehicle.gyro.roll_rps = 0.0;
    r.vehicle.altitude = altitude(10.0, -2.0);
    r.run_ms(3_000);
    assert!(r.fc.is_armed(), "falling is not landed");
    r.vehicle.altitude = altitude(0.0, 0.05);
    r.expect_event_within(Event::Disarmed(DisarmCause::Landed), 2_100);
}

// ---- landing detection: descents and landings, with and without barometer --

/// Taken off and hovering at `height_m` (with a barometer: the estimate
/// follows the flight; without: none), then the pilot's throttle stick at
/// `stick`, level, still, sinking at `sink_mps` until the ground; the
/// craft stays on the ground from there. Runs `ms`; returns the time of
/// touchdown and of a disarm (ms from the start of the descent).
fn descend(
    baro: bool,
    height_m: f32,
    stick: f32,
    sink_mps: f32,
    ms: u32,
) -> (Option<u32>, Option<(u32, Event)>) {
    let mut r = Rig::new();
    let est = |h: f32, v: f32| if baro { altitude(h, v) } else { None };
    r.vehicle.altitude = est(height_m, 0.0);
    r.take_off();
    r.pilot.sticks.throttle = stick;
    let (mut h, mut touchdown) = (height_m, None);
    for t in 1..=ms {
        h = (h - sink_mps * 1e-3).max(0.0);
        let v = if h > 0.0 { -sink_mps } else { 0.0 };
        if h == 0.0 && touchdown.is_none() {
            touchdown = Some(t);
        }
        r.vehicle.altitude = est(h, v);
        let out = r.step();
        let disarm = out.events.iter().find(|e| matches!(e, Event::Disarmed(_)));
        if let Some(e) = disarm {
            return (touchdown, Some((t, e)));
        }
    }
    (touchdown, None)
}

#[test]
fn slow_low_throttle_descent_never_disarms_with_or_without_barometer() {
    // Stick 12 %: a collective under the landing threshold (0.15), no
    // rotation, 1 g of specific force, what a landed craft also shows.
    // 0.4 m/s from 20 m: 10 s in the air, five times the detector's hold.
    for baro in [false, true] {
        let (touchdown, disarm) = descend(baro, 20.0, 0.12, 0.4, 10_000);
        assert_eq!(touchdown, None);
        assert_eq!(disarm, None, "baro {baro}: disarmed in the air");
    }
}

#[test]
fn fast_descent_never_disarms_in_the_air_with_or_without_barometer() {
    // Without a barometer: the stick just above its minimum (6 %); with
    // one, even the stick at zero: 4 m/s from 50 m is 12.5 s in the air.
    for (baro, stick) in [(false, 0.06), (true, 0.0)] {
        let (touchdown, disarm) = descend(baro, 50.0, stick, 4.0, 12_000);
        assert_eq!(touchdown, None);
        assert_eq!(disarm, None, "baro {baro}: disarmed in the air");
    }
}

#[test]
fn real_landing_disarms_two_seconds_after_touchdown_with_barometer() {
    // Sinking at 0.5 m/s from 1 m at 12 % stick: on the ground after 2 s,
    // disarmed 2 s later without the stick at its minimum.
    let (touchdown, disarm) = descend(true, 1.0, 0.12, 0.5, 10_000);
    let touchdown = touchdown.expect("touched down");
    let (t, e) = disarm.expect("disarmed");
    assert_eq!(e, Event::Disarmed(DisarmCause::Landed));
    assert!((1_999..=2_001).contains(&touchdown), "{touchdown}");
    assert!(
        (touchdown + 1_990..=touchdown + 2_010).contains(&t),
        "disarmed {} ms after touchdown",
        t - touchdown
    );
}

#[test]
fn real_landing_without_barometer_disarms_on_the_stick_at_minimum() {
    // On the ground at 12 % stick: no disarm (the controller cannot see
    // the ground). The pilot pulls the stick to zero: 2 s later, disarmed.
    let mut r = Rig::new();
    r.take_off();
    r.pilot.sticks.throttle = 0.12;
    assert!(r.run_ms(5_000).is_empty());
    assert!(r.fc.is_armed());
    r.pilot.sticks.throttle = 0.05;
    r.expect_event_after(Event::Disarmed(DisarmCause::Landed), 5_000, 1_999..=2_001);
}

#[test]
fn blind_failsafe_descent_disarms_only_after_its_ramp_reaches_zero() {
    let mut r = Rig::new();
    r.vehicle.altitude = altitude(5.0, 0.0);
    r.take_off();
    r.pilot.link_ok = false;
    r.expect_event_within(Event::FailsafeDescent, 1_100);
    r.vehicle.altitude = None; // the barometer fails, the craft still sinks
    let mut at_zero = None;
    for t in 1..=20_000u32 {
        let out = r.step();
        if out.collective <= 0.0 && at_zero.is_none() {
            at_zero = Some(t);
        }
        if out.events.iter().any(|e| matches!(e, Event::Disarmed(_))) {
            let z = at_zero.expect("disarmed before the ramp reached zero");
            assert!(out
                .events
                .contains(Event::Disarmed(DisarmCause::FailsafeLanded)));
            assert!((z + 1_999..=z + 2_001).contains(&t), "{t} ms, zero at {z}");
            return;
        }
    }
    panic!("no disarm");
}

#[test]
fn no_take_off_disarms_after_five_seconds() {
    let mut r = Rig::new();
    r.arm();
    r.expect_event_after(
        Event::Disarmed(DisarmCause::NoTakeOff),
        10_000,
        4_990..=5_000,
    );
}

#[test]
fn single_bad_sample_keeps_motors_and_persistent_fault_disarms() {
    let mut r = Rig::new();
    r.take_off();
    let before = r.step().motors;
    r.vehicle.gyro.pitch_rps = f32::NAN;
    let out = r.step();
    assert!(out.events.contains(Event::InputRejected));
    assert_eq!(out.motors, before);
    r.vehicle.gyro.pitch_rps = 0.0;
    r.run_ms(10);
    assert!(r.fc.is_armed());
    r.vehicle.attitude.w = f32::INFINITY;
    r.expect_event_after(Event::Disarmed(DisarmCause::SensorFault), 1_000, 250..=251);
}

#[test]
fn sensor_loss_is_bridged_last_motors_then_even_thrust_then_disarm() {
    let mut r = Rig::new();
    r.take_off();
    // A manoeuvre: the rate loop commands a torque (motors uneven).
    r.pilot.sticks.roll = 0.5;
    r.run_ms(30);
    let motors = r.step().motors;
    assert!(matches!(motors, Motors::Run(_)), "armed");
    let before = motors.commands();
    let spread = |m: &[f32; 4]| {
        m.iter().fold(f32::MIN, |a, b| a.max(*b)) - m.iter().fold(f32::MAX, |a, b| a.min(*b))
    };
    assert!(spread(&before) > 0.01, "{before:?}");
    // The MPU stops (lost samples, a reset and its settle): no gyro.
    r.vehicle.gyro.roll_rps = f32::NAN;
    for ms in 1..250u32 {
        let out = r.step();
        assert!(r.fc.is_armed(), "armed at {ms} ms");
        assert!(out.events.contains(Event::InputRejected));
        assert!(
            matches!(out.motors, Motors::Run(_)),
            "motors off at {ms} ms"
        );
        let m = out.motors.commands();
        if ms <= 10 {
            assert_eq!(m, before, "{ms} ms: the last commands");
        } else {
            assert!(spread(&m) < 1e-6, "{ms} ms: even thrust {m:?}");
            assert!(m.iter().all(|x| *x > 0.04), "{ms} ms: {m:?}");
        }
    }
    let out = r.step();
    assert!(out
        .events
        .contains(Event::Disarmed(DisarmCause::SensorFault)));
    assert_eq!(out.motors, Motors::Off);
}

#[test]
fn sensor_loss_bridge_ends_when_samples_return_and_the_switch_still_disarms() {
    let mut r = Rig::new();
    r.take_off();
    r.vehicle.gyro.roll_rps = f32::NAN;
    r.run_ms(200);
    assert!(r.fc.is_armed());
    // Samples back: the bridge's timer starts over.
    r.vehicle.gyro.roll_rps = 0.0;
    assert!(!r.step().events.contains(Event::InputRejected));
    r.vehicle.gyro.roll_rps = f32::NAN;
    r.run_ms(200);
    assert!(r.fc.is_armed(), "a new loss gets the whole bridge");
    // The pilot's arm switch is obeyed during the bridge.
    r.pilot.arm_switch = false;
    let out = r.step();
    assert!(out.events.contains(Event::Disarmed(DisarmCause::Switch)));
    assert_eq!(out.motors, Motors::Off);
}

// ---- failsafe --------------------------------------------------------------

#[test]
fn link_loss_without_altitude_holds_level_then_disarms() {
    let mut r = Rig::new();
    r.take_off();
    // The pilot was rolling hard when the link went.
    r.pilot.sticks.roll = 1.0;
    r.run_ms(10);
    r.pilot.link_ok = false;
    let out = r.step();
    assert!(out.events.contains(Event::FailsafeHold { altitude: false }));
    assert_eq!(out.state, FlightState::Failsafe(FailsafePhase::Hold));
    // Level hold: no roll demand from the stale stick, the last collective.
    assert!(out.rate_setpoint.roll_rps.abs() < 1e-6);
    assert!((out.collective - 0.5).abs() < 1e-6);
    assert!(matches!(out.motors, Motors::Run(_)));
    r.expect_event_after(
        Event::Disarmed(DisarmCause::FailsafeNoAltitude),
        2_000,
        998..=1_000,
    );
}

/// Taken off, the pilot flies `stick(t_ms)` for `ms`, level, no barometer;
/// then the link is lost. Returns the rig after the first failsafe step
/// and the collectives of the whole level hold.
fn lose_link_after(stick: impl Fn(u32) -> f32, ms: u32) -> (Rig, Vec<f32>) {
    let mut r = Rig::new();
    r.take_off();
    for t in 0..ms {
        r.pilot.sticks.throttle = stick(t);
        r.step();
    }
    r.pilot.link_ok = false;
    let mut hold = Vec::new();
    for _ in 0..995 {
        let out = r.step();
        assert_eq!(out.state, FlightState::Failsafe(FailsafePhase::Hold));
        hold.push(out.collective);
    }
    r.expect_event_within(Event::Disarmed(DisarmCause::FailsafeNoAltitude), 10);
    (r, hold)
}

#[test]
fn link_lost_in_a_full_throttle_climb_without_barometer_holds_at_most_a_hover() {
    // 5 s hovering at 0.45, then 2 s of full throttle, level.
    let (r, hold) = lose_link_after(|t| if t < 5_000 { 0.45 } else { 1.0 }, 7_000);
    let est = r.fc.hover_collective().unwrap();
    // The estimate moved most of the way up in 2 s (1 − e^(−2/1.5) = 0.74).
    assert!((0.8..0.9).contains(&est), "hover estimate {est}");
    let max = FlightConfig::default().safety.failsafe_collective_max;
    for c in &hold {
        assert!(*c <= max + 1e-6 && *c <= est, "collective {c} in the hold");
    }
    assert!((hold[0] - 0.6).abs() < 1e-6, "{}", hold[0]);
}

#[test]
fn link_lost_in_a_hover_without_barometer_holds_about_the_hover_collective() {
    // Hovering at 0.42 with the pilot's ±0.05 corrections at 2 Hz; the link
    // goes at a correction's peak (stick 0.47).
    let stick = |t: u32| 0.42 + 0.05 * (2.0 * core::f32::consts::PI * 2.0 * t as f32 * 1e-3).sin();
    let (_, hold) = lose_link_after(stick, 5_125);
    for c in &hold {
        assert!((c - 0.42).abs() < 0.01, "collective {c}, hover 0.42");
    }
}

#[test]
fn the_hover_estimate_ignores_banked_flight_and_the_ground() {
    let mut r = Rig::new();
    r.arm();
    r.run_ms(500); // on the ground at idle: nothing to learn
    assert_eq!(r.fc.hover_collective(), None);
    r.pilot.sticks.throttle = 0.5;
    r.run_ms(3_000);
    let level = r.fc.hover_collective().unwrap();
    assert!((level - 0.5).abs() < 1e-3, "{level}");
    // A 30° banked turn at 0.8: the collective a tilted hover needs.
    r.vehicle.attitude = tilted_deg(30.0);
    r.pilot.sticks.throttle = 0.8;
    r.run_ms(2_000);
    assert_eq!(r.fc.hover_collective(), Some(level));
}

#[test]
fn failsafe_collective_max_is_validated() {
    let mut cfg = FlightConfig::default();
    for bad in [0.1, 0.15, 1.1, f32::NAN] {
        cfg.safety.failsafe_collective_max = bad;
        assert_eq!(
            FlightController::new(cfg).err(),
            Some(FlightConfigError::Safety(SafetyField::FailsafeCollective)),
            "{bad}"
        );
    }
    cfg.safety.failsafe_collective_max = 0.6;
    assert!(FlightController::new(cfg).is_ok());
}

#[test]
fn link_loss_with_altitude_holds_descends_and_lands() {
    let mut r = Rig::new();
    r.vehicle.altitude = altitude(5.0, 0.0);
    r.take_off();
    r.pilot.link_ok = false;
    // The arm switch reads "off" while the link is down: it is not trusted.
    r.pilot.arm_switch = false;
    let out = r.step();
    assert!(out.events.contains(Event::FailsafeHold { altitude: true }));
    assert_eq!(out.mode, FlightMode::AltitudeHold);
    // Holding at 5 m: the collective stays at the bumpless value.
    assert!((out.collective - 0.5).abs() < 0.02, "{}", out.collective);
    r.expect_event_after(Event::FailsafeDescent, 2_000, 998..=1_000);
    // Descending: the collective drops below hover.
    r.run_ms(200);
    let c = r.last.unwrap().collective;
    assert!(c < 0.45, "collective {c}");
    // The model sits still on the ground: the landing detector ends it.
    r.vehicle.altitude = altitude(0.0, 0.0);
    r.expect_event_within(Event::Disarmed(DisarmCause::FailsafeLanded), 10_000);
}

#[test]
fn link_return_gives_control_back() {
    let mut r = Rig::new();
    r.take_off();
    r.pilot.link_ok = false;
    r.run_ms(300);
    r.pilot.link_ok = true;
    assert_eq!(r.run_ms(1), vec![Event::FailsafeCleared]);
    assert_eq!(r.fc.state(), FlightState::Armed);
    r.pilot.sticks.roll = 1.0;
    let out = r.step();
    assert!(out.rate_setpoint.roll_rps > 0.5);
}

#[test]
fn non_finite_stick_counts_as_link_loss() {
    let mut r = Rig::new();
    r.take_off();
    r.pilot.sticks.yaw = f32::NAN;
    let out = r.step();
    assert!(out.events.contains(Event::FailsafeHold { altitude: false }));
}

// ---- motor test ------------------------------------------------------------

#[test]
fn motor_test_spins_one_motor_and_ends_on_stick_movement() {
    let mut r = Rig::new();
    r.run_ms(10);
    r.fc.start_motor_test(2, &r.pilot).unwrap();
    let out = r.step();
    assert!(out.events.contains(Event::MotorTestStarted(2)));
    assert_eq!(out.state, FlightState::MotorTest(2));
    assert_eq!(out.motors, Motors::run_f32([0.0, 0.0, 0.08, 0.0]));
    r.run_ms(500);
    r.pilot.sticks.pitch = 0.05; // inside the tolerance
    r.run_ms(10);
    assert_eq!(r.fc.state(), FlightState::MotorTest(2));
    r.pilot.sticks.pitch = 0.2;
    assert_eq!(
        r.run_ms(1),
        vec![Event::MotorTestEnded(MotorTestEnd::StickMoved)]
    );
    assert_eq!(r.last.unwrap().motors, Motors::Off);
}

#[test]
fn motor_test_ends_on_link_loss_arm_switch_timeout_and_stop() {
    let ends: [(MotorTestEnd, Setup); 3] = [
        (MotorTestEnd::LinkLost, |r| r.pilot.link_ok = false),
        (MotorTestEnd::ArmSwitch, |r| r.pilot.arm_switch = true),
        (MotorTestEnd::Stopped, |r| r.fc.stop_motor_test()),
    ];
    for (end, act) in ends {
        let mut r = Rig::new();
        r.run_ms(10);
        r.fc.start_motor_test(0, &r.pilot).unwrap();
        r.run_ms(100);
        act(&mut r);
        assert_eq!(r.run_ms(1), vec![Event::MotorTestEnded(end)], "{end:?}");
        assert_eq!(r.fc.state(), FlightState::Disarmed);
        // The arm switch that ended the test does not arm.
        assert!(r.run_ms(100).is_empty());
    }
    let mut r = Rig::new();
    r.run_ms(10);
    r.fc.start_motor_test(3, &r.pilot).unwrap();
    r.expect_event_after(
        Event::MotorTestEnded(MotorTestEnd::Timeout),
        10_000,
        4_999..=5_001,
    );
}

#[test]
fn motor_test_refusals() {
    let mut r = Rig::new();
    r.run_ms(10);
    assert_eq!(
        r.fc.start_motor_test(4, &r.pilot),
        Err(MotorTestRefusal::InvalidMotor)
    );
    let mut lost = r.pilot;
    lost.link_ok = false;
    assert_eq!(
        r.fc.start_motor_test(0, &lost),
        Err(MotorTestRefusal::LinkLost)
    );
    let mut sw = r.pilot;
    sw.arm_switch = true;
    assert_eq!(
        r.fc.start_motor_test(0, &sw),
        Err(MotorTestRefusal::ArmSwitchOn)
    );
    r.take_off();
    let mut off = r.pilot;
    off.arm_switch = false;
    assert_eq!(r.fc.start_motor_test(0, &off), Err(MotorTestRefusal::Armed));
}

// ---- modes -----------------------------------------------------------------

#[test]
fn altitude_hold_without_altitude_falls_back_to_angle_once() {
    let mut r = Rig::new();
    r.pilot.mode = FlightMode::AltitudeHold;
    r.arm();
    r.pilot.sticks.throttle = 0.6;
    let ev = r.run_ms(100);
    assert_eq!(ev, vec![Event::AltitudeUnavailable]);
    assert_eq!(r.last.unwrap().mode, FlightMode::Angle);
    assert!((r.last.unwrap().collective - 0.6).abs() < 1e-6);
}

#[test]
fn altitude_hold_holds_at_mid_stick_and_climbs_above() {
    let mut r = Rig::new();
    r.vehicle.altitude = altitude(3.0, 0.0);
    r.take_off();
    r.pilot.mode = FlightMode::AltitudeHold;
    r.run_ms(500);
    let hold = r.last.unwrap();
    assert_eq!(hold.mode, FlightMode::AltitudeHold);
    assert!((hold.collective - 0.5).abs() < 0.02, "{}", hold.collective);
    r.pilot.sticks.throttle = 1.0;
    r.run_ms(300);
    assert!(r.last.unwrap().collective > 0.55);
}

#[test]
fn time_standing_still_does_not_rerun_the_loops() {
    let mut r = Rig::new();
    r.take_off();
    let a = r.step();
    let b = r.fc.step(r.now_us, &r.pilot, &r.status, &r.vehicle.state());
    assert_eq!(a.motors, b.motors);
}

#[test]
fn motors_off_whenever_disarmed_under_random_inputs() {
    // Deterministic pseudo-random walk through every input; `Rig::step`
    // asserts Off in every disarmed step.
    let mut r = Rig::new();
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut rnd = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f32 / (1u64 << 53) as f32
    };
    let (mut armed_steps, mut disarmed_steps) = (0, 0);
    for _ in 0..20_000 {
        if rnd() < 0.01 {
            r.pilot.arm_switch = rnd() < 0.6;
        }
        if rnd() < 0.002 {
            r.pilot.link_ok = rnd() < 0.8;
        }
        if rnd() < 0.01 {
            r.pilot.sticks.throttle = if rnd() < 0.5 { 0.0 } else { rnd() };
            r.pilot.sticks.roll = 2.0 * rnd() - 1.0;
        }
        if rnd() < 0.005 {
            r.vehicle.attitude = tilted_deg(90.0 * rnd());
        }
        if rnd() < 0.001 {
            let _ = r.fc.start_motor_test((rnd() * 5.0) as u8, &r.pilot);
        }
        let out = r.step();
        for v in out.motors.commands() {
            assert!((0.0..=1.0).contains(&v));
        }
        if r.fc.is_armed() {
            armed_steps += 1;
        } else {
            disarmed_steps += 1;
        }
    }
    // The walk visits both sides.
    assert!(
        armed_steps > 1_000 && disarmed_steps > 1_000,
        "{armed_steps} {disarmed_steps}"
    );
}

#[test]
fn no_integrator_windup_before_take_off() {
    let mut r = Rig::new();
    r.arm();
    // Sitting 10° tilted on uneven ground, throttle low: a constant
    // self-level demand that the vehicle cannot follow.
    r.vehicle.attitude = tilted_deg(10.0);
    r.run_ms(100);
    let early = r.last.unwrap().torque.roll;
    r.run_ms(3_000);
    let late = r.last.unwrap().torque.roll;
    assert!(early < 0.0, "levelling demand expected");
    assert!((early - late).abs() < 1e-6, "wound up: {early} → {late}");
    // In the air the integrator acts.
    r.pilot.sticks.throttle = 0.5;
    r.run_ms(500);
    assert!(r.last.unwrap().torque.roll < late - 0.05);
}

#[test]
fn no_integrator_windup_on_the_ground_after_a_landing() {
    let mut r = Rig::new();
    r.take_off();
    // In the air the integrator acts on a held 2° error (well inside its
    // limits after 0.4 s).
    r.vehicle.attitude = tilted_deg(2.0);
    r.run_ms(200);
    let flying = r.last.unwrap().torque.roll;
    r.run_ms(200);
    assert!(
        r.last.unwrap().torque.roll < flying - 0.01,
        "no integration in the air"
    );
    // Landed on a 2° slope, throttle down, not disarmed yet: the torque
    // stays where the touch-down left it instead of winding up against the
    // ground for the 2 s the landing takes to disarm (without the hold:
    // −0.14 → −0.35 here).
    r.pilot.sticks.throttle = 0.0;
    r.run_ms(100);
    let landed = r.last.unwrap().torque.roll;
    r.run_ms(1_500);
    assert!(r.fc.is_armed());
    let late = r.last.unwrap().torque.roll;
    assert!(
        (landed - late).abs() < 1e-3,
        "wound up on the ground: {landed} → {late}"
    );
}

/// Rotational rigid body around the controller's motor outputs (the
/// mixer's inverse, 25 ms motor lag, 120 rad/s² per unit torque).
fn fly_roll_stick(mode: FlightMode, stick: f32, ms: u32) -> (Rig, Vec<f32>) {
    let mut r = Rig::new();
    r.pilot.mode = mode;
    r.take_off();
    let mut motors = [0.5f32; 4];
    let mut w = [0.0f32; 3];
    let mut q = Quat::IDENTITY;
    let mut roll_trace = Vec::new();
    r.pilot.sticks.roll = stick;
    for _ in 0..ms {
        r.vehicle.attitude = q;
        r.vehicle.gyro = BodyRates {
            roll_rps: w[0],
            pitch_rps: w[1],
            yaw_rps: w[2],
        };
        let cmd = r.step().motors.commands();
        for (m, c) in motors.iter_mut().zip(cmd) {
            *m += (1.0 / 26.0) * (c - *m);
        }
        let (_, t) = control::mixer::unmix(&motors);
        w[0] += 120.0 * t.roll * 1e-3;
        w[1] += 120.0 * t.pitch * 1e-3;
        w[2] += 25.0 * t.yaw * 1e-3;
        let dq = q.mul(&Quat {
            w: 0.0,
            x: w[0],
            y: w[1],
            z: w[2],
        });
        let v = Quat {
            w: q.w + 0.5e-3 * dq.w,
            x: q.x + 0.5e-3 * dq.x,
            y: q.y + 0.5e-3 * dq.y,
            z: q.z + 0.5e-3 * dq.z,
        };
        let k = 1.0 / (v.w * v.w + v.x * v.x + v.y * v.y + v.z * v.z).sqrt();
        q = Quat {
            w: v.w * k,
            x: v.x * k,
            y: v.y * k,
            z: v.z * k,
        };
        roll_trace.push((2.0 * (q.w * q.x + q.y * q.z)).atan2(1.0 - 2.0 * (q.x * q.x + q.y * q.y)));
    }
    (r, roll_trace)
}

#[test]
fn closed_loop_angle_mode_stick_holds_the_commanded_tilt() {
    // Half stick, no expo on angles: 15° of the 30° maximum.
    let (r, roll) = fly_roll_stick(FlightMode::Angle, 0.5, 1_500);
    let target = (0.5f32 - 0.02) / 0.98 * 30.0;
    let last = roll.last().unwrap().to_degrees();
    let peak = roll.iter().cloned().fold(f32::MIN, f32::max).to_degrees();
    assert!((last - target).abs() < 0.5, "{last}° for {target}°");
    assert!(peak < target * 1.1, "overshoot: {peak}°");
    assert!(r.fc.is_armed());
}

#[test]
fn closed_loop_acro_stick_gives_the_shaped_rate() {
    let (r, roll) = fly_roll_stick(FlightMode::Acro, 1.0, 600);
    // Full stick: 500 °/s; rolling continuously (acro may flip).
    let out = r.last.unwrap();
    assert!((out.rate_setpoint.roll_rps - 500f32.to_radians()).abs() < 1e-3);
    let n = roll.len();
    // Unwrapped roll over the last 100 ms ≈ 50°.
    let mut d = roll[n - 1] - roll[n - 101];
    if d < 0.0 {
        d += 2.0 * core::f32::consts::PI;
    }
    assert!(
        (d.to_degrees() - 50.0).abs() < 5.0,
        "{}°/100 ms",
        d.to_degrees()
    );
}

#[test]
fn altitude_lost_during_failsafe_descent_still_lands() {
    let mut r = Rig::new();
    r.vehicle.altitude = altitude(5.0, 0.0);
    r.take_off();
    r.pilot.link_ok = false;
    r.expect_event_within(Event::FailsafeDescent, 1_100);
    r.vehicle.altitude = None; // the barometer fails
    let c0 = r.step().collective;
    r.run_ms(1_000);
    let c1 = r.last.unwrap().collective;
    assert!(c1 < c0 - 0.04, "collective {c0} → {c1}");
    r.expect_event_within(Event::Disarmed(DisarmCause::FailsafeLanded), 30_000);
}

#[test]
fn vehicle_state_from_the_pipeline_is_body_frd_in_rad_per_s() {
    use sensor_stack::pipeline::{ImuInput, Pipeline, PipelineConfig};
    let mut p = Pipeline::new(PipelineConfig::new(), &Default::default()).unwrap();
    p.set_gyro_bias_counts([0; 3]);
    // 328 counts at 32.8 counts/(°/s) = 10 °/s about each MPU axis.
    p.imu_step(&ImuInput {
        accel: [0, 0, 8192],
        gyro: [328, 328, 328],
        dt_cycles: 72_000,
    });
    let v = VehicleState::from_pipeline(&p);
    let ten = 10f32.to_radians();
    // Default mounting: body = (x, −y, −z) of the MPU.
    let g = v.gyro().unwrap();
    assert!((g.roll_rps - ten).abs() < 1e-3, "{g:?}");
    assert!((g.pitch_rps + ten).abs() < 1e-3);
    assert!((g.yaw_rps + ten).abs() < 1e-3);
    assert_eq!(v.gyro_rps_q16, Some(p.body_rates_q16()));
    assert!(v.altitude.is_none(), "no barometer reading yet");
    let q = v.attitude();
    assert!(q.w * q.w + q.x * q.x > 0.99);
    // The pipeline's own Q30 quaternion, no f32 round trip.
    assert_eq!(v.attitude_q30.0, p.quaternion_q30());
    let esc =
        control::esc::EscTimer::for_clock(control::esc::EscProtocol::OneShot125, 2_000, 72_000_000)
            .unwrap();
    assert_eq!(Motors::Off.compares(&esc), [9_000; 4]);
    assert_eq!(
        Motors::run_f32([0.0, 1.0, 0.5, 0.0]).compares(&esc),
        [9_000, 18_000, 13_500, 9_000]
    );
}

#[test]
fn receiver_sticks_map_with_the_same_signs() {
    use rc_input::{ChannelMap, ChannelOrder, RcFrame};
    let map = ChannelMap::new(ChannelOrder::AETR);
    let mut ch = [1500u16; 16];
    ch[0] = 2000; // roll full right
    ch[1] = 2000; // pitch full forward
    ch[2] = 1000; // throttle low
    let sticks = map.sticks(&RcFrame::new(ch, 8)).unwrap();
    let pilot = PilotInput::from_rc(&sticks, false, FlightMode::Acro, true);
    let mut r = Rig::new();
    r.pilot = pilot;
    r.pilot.mode = FlightMode::Acro;
    r.arm();
    r.pilot = PilotInput::from_rc(&sticks, true, FlightMode::Acro, true);
    let out = r.step();
    // Right roll stick → right wing down (+p); forward → nose down (−q).
    assert!(out.rate_setpoint.roll_rps > 8.0);
    assert!(out.rate_setpoint.pitch_rps < -8.0);
}

#[test]
fn in_flight_once_the_take_off_has_had_time_to_leave_the_ground() {
    use flight::flightctl::IN_FLIGHT_AFTER_US;
    let mut r = Rig::new();
    assert!(!r.fc.in_flight(), "disarmed");
    r.arm();
    r.run_ms(1_000);
    assert!(!r.fc.in_flight(), "armed at idle, on the ground");
    // The collective rises above the landing threshold with the throttle.
    r.pilot.sticks.throttle = 0.5;
    let after_ms = IN_FLIGHT_AFTER_US / 1_000;
    r.run_ms(after_ms - 10);
    assert!(!r.fc.in_flight(), "still taking off");
    r.run_ms(20);
    assert!(r.fc.in_flight());
    // The collective down to the landing threshold ends it at once, before
    // the touch-down the landing detector waits 2 s to confirm.
    r.pilot.sticks.throttle = 0.0;
    r.run_ms(50);
    assert!(!r.fc.in_flight() && r.fc.is_armed());
    r.expect_event_within(Event::Disarmed(DisarmCause::Landed), 5_000);
    assert!(!r.fc.in_flight());
}

// ---- low-battery descent -------------------------------------------------

#[test]
fn battery_descent_levels_and_lowers_the_height_target_at_the_failsafe_rate() {
    let mut r = Rig::new();
    r.vehicle.altitude = altitude(5.0, 0.0);
    r.take_off();
    r.pilot.mode = FlightMode::Angle;
    r.pilot.sticks.roll = 0.5; // the pilot's stick no longer commands
    r.fc.set_battery_descent(true);
    let out = r.step();
    assert_eq!(out.mode, FlightMode::AltitudeHold);
    let h0 = r.fc.altitude_target_m().unwrap();
    r.run_ms(2_000);
    let h1 = r.fc.altitude_target_m().unwrap();
    let rate = (h0 - h1) / 2.0;
    let want = r.fc.safety().failsafe_descent_mps;
    assert!((rate - want).abs() < 0.01 * want, "{rate} m/s, want {want}");
    // Level: no roll rate asked of a level craft, whatever the stick says.
    assert!(r.last.unwrap().rate_setpoint.roll_rps.abs() < 1e-3);
    assert!(r.fc.is_armed(), "a descent never disarms in the air");
}

#[test]
fn battery_descent_ends_when_asked_and_is_ignored_without_altitude() {
    let mut r = Rig::new();
    r.take_off();
    r.pilot.mode = FlightMode::Angle;
    r.pilot.sticks.roll = 0.5;
    let free = r.step();
    r.fc.set_battery_descent(true);
    let asked = r.step();
    assert_eq!(
        asked.mode,
        FlightMode::Angle,
        "no barometer: a warning only"
    );
    assert_eq!(asked.rate_setpoint, free.rate_setpoint);
    r.vehicle.altitude = altitude(5.0, 0.0);
    assert_eq!(r.step().mode, FlightMode::AltitudeHold);
    r.fc.set_battery_descent(false);
    let back = r.step();
    assert_eq!(back.mode, FlightMode::Angle);
    assert!(back.rate_setpoint.roll_rps > 0.1, "the pilot's stick again");
}

#[test]
fn battery_descent_is_ignored_in_acro() {
    let mut r = Rig::new();
    r.vehicle.altitude = altitude(5.0, 0.0);
    r.take_off();
    r.pilot.mode = FlightMode::Acro;
    r.pilot.sticks.roll = 0.5;
    let free = r.step();
    r.fc.set_battery_descent(true);
    let asked = r.step();
    assert_eq!(asked.mode, FlightMode::Acro, "acro: a warning only");
    assert_eq!(asked.rate_setpoint, free.rate_setpoint);
}
