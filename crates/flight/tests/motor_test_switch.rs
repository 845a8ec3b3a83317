//! The motor test from the transmitter: the motor-test switch's edges, the
//! motor sequence, its refusals and the arming lock, driven through
//! `FlightController::step` at 1 kHz.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::*;
use flight::flightctl::*;

const TEST_COMMAND: f32 = 0.08;

/// Motor index `m` alone at the test command.
fn only(m: usize) -> Motors {
    let mut c = [0.0; 4];
    c[m] = TEST_COMMAND;
    Motors::run_f32(c)
}

#[test]
fn each_flip_runs_the_next_motor_and_wraps_after_motor_4() {
    let mut r = Rig::new();
    for want in [0u8, 1, 2, 3, 0] {
        assert_eq!(r.flip_test_switch(), vec![Event::MotorTestStarted(want)]);
        assert_eq!(r.fc.state(), FlightState::MotorTest(want));
        assert_eq!(r.motors(), only(usize::from(want)));
        assert!(r.run_ms(500).is_empty(), "held on: keeps spinning");
        assert_eq!(r.motors(), only(usize::from(want)));
        r.pilot.motor_test_switch = false;
        assert_eq!(
            r.run_ms(1),
            vec![Event::MotorTestEnded(MotorTestEnd::SwitchOff)]
        );
        assert_eq!(r.motors(), Motors::Off);
        assert_eq!(r.fc.state(), FlightState::Disarmed);
    }
}

#[test]
fn switch_on_at_boot_starts_nothing() {
    let mut r = Rig::new();
    r.pilot.motor_test_switch = true;
    assert!(r.run_ms(2_000).is_empty());
    assert_eq!(r.motors(), Motors::Off);
    assert_eq!(r.fc.state(), FlightState::Disarmed);
    // Off and on again: now it is a flip.
    assert_eq!(r.flip_test_switch(), vec![Event::MotorTestStarted(0)]);
}

#[test]
fn switch_on_when_the_link_returns_starts_nothing() {
    let mut r = Rig::new();
    r.run_ms(20);
    r.pilot.link_ok = false;
    r.run_ms(200);
    // Flipped on while the link was down; frames arrive again with it on.
    r.pilot.motor_test_switch = true;
    r.run_ms(200);
    r.pilot.link_ok = true;
    assert!(r.run_ms(1_000).is_empty());
    assert_eq!(r.motors(), Motors::Off);
}

#[test]
fn link_loss_ends_a_running_test_and_its_return_does_not_restart_it() {
    let mut r = Rig::new();
    r.flip_test_switch();
    r.run_ms(100);
    r.pilot.link_ok = false;
    assert_eq!(
        r.run_ms(1),
        vec![Event::MotorTestEnded(MotorTestEnd::LinkLost)]
    );
    r.pilot.link_ok = true;
    assert!(r.run_ms(500).is_empty());
    assert_eq!(r.motors(), Motors::Off);
}

#[test]
fn every_refused_flip_names_its_reason_and_retries_the_same_motor() {
    let mut r = Rig::new();
    r.pilot.arm_switch = true;
    assert_eq!(
        r.flip_test_switch(),
        vec![Event::MotorTestRefused(MotorTestRefusal::ArmSwitchOn)]
    );
    assert_eq!(r.motors(), Motors::Off);
    r.pilot.arm_switch = false;
    r.pilot.sticks.throttle = 0.3;
    assert_eq!(
        r.flip_test_switch(),
        vec![Event::MotorTestRefused(MotorTestRefusal::ThrottleNotLow)]
    );
    assert_eq!(r.motors(), Motors::Off);
    r.pilot.sticks.throttle = 0.0;
    // Calibrating: the craft is in someone's hands.
    r.status.calibration_running = true;
    assert_eq!(
        r.flip_test_switch(),
        vec![Event::MotorTestRefused(
            MotorTestRefusal::CalibrationRunning
        )]
    );
    assert_eq!(
        r.fc.start_motor_test(0, &r.pilot),
        Err(MotorTestRefusal::CalibrationRunning)
    );
    assert_eq!(r.motors(), Motors::Off);
    r.status.calibration_running = false;
    // The programmatic start has the same throttle rule.
    let mut up = r.pilot;
    up.sticks.throttle = 0.3;
    assert_eq!(
        r.fc.start_motor_test(0, &up),
        Err(MotorTestRefusal::ThrottleNotLow)
    );
    assert_eq!(r.flip_test_switch(), vec![Event::MotorTestStarted(0)]);

    // Armed (with the test switch off), a flip is refused and the motors
    // stay under flight control.
    r.pilot.motor_test_switch = false;
    r.run_ms(20);
    assert_eq!(r.flip_arm_switch(), vec![Event::Armed]);
    assert_eq!(
        r.flip_test_switch(),
        vec![Event::MotorTestRefused(MotorTestRefusal::Armed)]
    );
    assert_eq!(r.fc.state(), FlightState::Armed);
    let m = r.motors();
    assert!(matches!(m, Motors::Run(_)), "armed motors off");
    assert!(m.commands().iter().all(|&c| c > 0.0), "{m:?}");
}

#[test]
fn arming_is_refused_while_the_test_switch_is_on() {
    let mut r = Rig::new();
    r.flip_test_switch();
    // The arm switch ends the test, and does not arm.
    r.pilot.arm_switch = true;
    assert_eq!(
        r.run_ms(1),
        vec![Event::MotorTestEnded(MotorTestEnd::ArmSwitch)]
    );
    assert!(r.run_ms(100).is_empty());
    // A fresh arm flip with the test switch still on: refused.
    assert_eq!(
        r.flip_arm_switch(),
        vec![Event::ArmRefused(ArmRefusal::MotorTestSwitchOn)]
    );
    let blockers = r.fc.arm_blockers(&r.pilot, &r.status, &r.vehicle.state());
    assert!(blockers.contains(ArmRefusal::MotorTestSwitchOn));
    assert_eq!(r.motors(), Motors::Off);
    // Test switch off: arming works.
    r.pilot.motor_test_switch = false;
    assert_eq!(r.flip_arm_switch(), vec![Event::Armed]);
}

#[test]
fn the_controllers_end_conditions_apply_and_a_held_switch_does_not_restart() {
    let mut r = Rig::new();
    assert_eq!(r.flip_test_switch(), vec![Event::MotorTestStarted(0)]);
    r.pilot.sticks.throttle = 0.3;
    assert_eq!(
        r.run_ms(1),
        vec![Event::MotorTestEnded(MotorTestEnd::StickMoved)]
    );
    r.pilot.sticks.throttle = 0.0;
    assert!(r.run_ms(6_000).is_empty(), "switch still on: nothing");
    assert_eq!(r.flip_test_switch(), vec![Event::MotorTestStarted(1)]);
    let ms = r.run_ms(6_000);
    assert_eq!(ms, vec![Event::MotorTestEnded(MotorTestEnd::Timeout)]);
    assert_eq!(r.motors(), Motors::Off);
}

/// Random switch, link and stick sequences: a motor only ever starts on a
/// step whose test switch was on after an off with the link up, never
/// while armed, and a running test spins exactly one motor at the test
/// command.
#[test]
fn random_inputs_never_start_a_motor_without_a_flip() {
    let mut seed: u64 = 0x2545_F491_4F6C_DD1D;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut r = Rig::new();
    let mut prev_on: Option<bool> = None;
    let (mut starts, mut refusals) = (0, 0);
    for _ in 0..200_000 {
        if rnd() < 0.01 {
            r.pilot.motor_test_switch = !r.pilot.motor_test_switch;
        }
        if rnd() < 0.002 {
            r.pilot.link_ok = !r.pilot.link_ok;
        }
        if rnd() < 0.003 {
            r.pilot.arm_switch = !r.pilot.arm_switch;
        }
        if rnd() < 0.003 {
            r.pilot.sticks.throttle = if rnd() < 0.7 { 0.0 } else { 0.5 };
        }
        let was_armed = r.fc.is_armed();
        let out = r.step();
        let flip = r.pilot.link_ok && r.pilot.motor_test_switch && prev_on == Some(false);
        prev_on = r.pilot.link_ok.then_some(r.pilot.motor_test_switch);
        for e in out.events.iter() {
            match e {
                Event::MotorTestStarted(_) => {
                    starts += 1;
                    assert!(flip, "started without a flip: {:?}", r.pilot);
                    assert!(!was_armed, "started while armed");
                }
                Event::MotorTestRefused(_) => refusals += 1,
                _ => {}
            }
        }
        if let FlightState::MotorTest(m) = out.state {
            assert_eq!(out.motors, only(usize::from(m)));
            let p = &r.pilot;
            assert!(p.motor_test_switch && p.link_ok && !p.arm_switch, "{p:?}");
        }
        if out.state == FlightState::Disarmed {
            assert_eq!(out.motors, Motors::Off);
        }
    }
    // The sequence exercised both outcomes.
    assert!(
        starts >= 50 && refusals >= 50,
        "{starts} starts, {refusals} refusals"
    );
}
