//! The output guard's latch against the flight controller: a forced off
//! disarms the controller at the next sample step, and a sample arriving
//! after it cannot spin the motors again until the pilot flips the arm
//! switch off → on.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::*;
use flight::flightctl::*;
use flight::outputguard::{
    ForceOffReason, OutputGuard, OutputVerdict, TickAction, NO_SAMPLE_TIMEOUT_US,
};

/// One sample step as the firmware runs it: take the latch, disarm the
/// controller for it, step, and ask the guard what to write.
fn sample_step(r: &mut Rig, g: &mut OutputGuard) -> (Option<Event>, Motors) {
    let forced = g.take_forced();
    let ev = forced.and_then(|f| r.fc.force_disarm(f.disarm_cause()));
    let out = r.step();
    let running = matches!(out.motors, Motors::Run(_));
    let written = match g.on_step(r.now_us, r.fc.is_armed(), running) {
        OutputVerdict::Run => out.motors,
        OutputVerdict::ForceOff(_) => Motors::Off,
    };
    (ev, written)
}

#[test]
fn samples_after_a_forced_off_do_not_spin_the_motors_again() {
    let mut r = Rig::new();
    r.arm();
    let mut g = OutputGuard::new(r.now_us);
    let (_, m) = sample_step(&mut r, &mut g);
    assert!(matches!(m, Motors::Run(_)));
    // The samples stop; the periodic check forces off.
    let dead_until = r.now_us.wrapping_add(NO_SAMPLE_TIMEOUT_US + 5_000);
    assert_eq!(
        g.on_tick(dead_until),
        Some(TickAction::ForceOff(ForceOffReason::NoSamples))
    );
    r.now_us = dead_until;
    // They come back with the arm switch still on.
    let (ev, m) = sample_step(&mut r, &mut g);
    assert_eq!(ev, Some(Event::Disarmed(DisarmCause::NoImuSamples)));
    assert_eq!(m, Motors::Off);
    assert_eq!(r.fc.state(), FlightState::Disarmed);
    for _ in 0..1_000 {
        assert_eq!(sample_step(&mut r, &mut g).1, Motors::Off);
    }
    // Only a fresh flip arms again.
    r.arm();
    assert!(matches!(sample_step(&mut r, &mut g).1, Motors::Run(_)));
}

#[test]
fn the_arm_switch_off_seen_by_the_receiver_disarms_with_its_cause() {
    let mut r = Rig::new();
    r.arm();
    let mut g = OutputGuard::new(r.now_us);
    sample_step(&mut r, &mut g);
    assert_eq!(g.on_pilot(false, true), Some(ForceOffReason::ArmSwitchOff));
    r.pilot.arm_switch = false;
    let (ev, m) = sample_step(&mut r, &mut g);
    assert_eq!(ev, Some(Event::Disarmed(DisarmCause::Switch)));
    assert_eq!(m, Motors::Off);
    assert!(!r.fc.is_armed());
}

#[test]
fn force_disarm_ends_the_motor_test_and_is_silent_when_disarmed() {
    let mut r = Rig::new();
    assert_eq!(r.fc.force_disarm(DisarmCause::NoImuSamples), None);
    r.pilot.arm_switch = false;
    r.run_ms(10);
    r.flip_test_switch();
    assert!(matches!(r.fc.state(), FlightState::MotorTest(_)));
    assert_eq!(
        r.fc.force_disarm(DisarmCause::NoImuSamples),
        Some(Event::Disarmed(DisarmCause::NoImuSamples))
    );
    assert_eq!(r.step().motors, Motors::Off);
    assert_eq!(r.fc.state(), FlightState::Disarmed);
}
