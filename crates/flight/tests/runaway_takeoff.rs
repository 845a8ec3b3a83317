//! The runaway-takeoff disarm (`flight::runaway`) through the flight
//! controller, stepped at 1 kHz: a rate loop pushing at ≥ 60 % of the
//! mixer's authority while the craft turns disarms after 75 ms, until
//! 0.5 s of calm flight at a collective ≥ 0.2 switches the check off.
//! The closed-loop proof with wiring errors on the quad model is in
//! `sim` (scenarios `swapped` and `reversedprop`).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::*;
use flight::flightctl::*;

const RUNAWAY: Event = Event::Disarmed(DisarmCause::RunawayTakeoff);

/// Armed, take-off throttle, `calm_ms` of calm flight.
fn lifting_off(calm_ms: u32) -> Rig {
    let mut r = Rig::new();
    r.arm();
    r.pilot.sticks.throttle = 0.5;
    let ev = r.run_ms(calm_ms);
    assert!(ev.is_empty(), "{ev:?}");
    r
}

#[test]
fn a_yaw_spin_the_loop_cannot_stop_disarms_after_75_ms() {
    let safety = FlightConfig::default().safety;
    let mut r = lifting_off(100);
    // Yaw stick centred, the craft spins right at 200 °/s (a reversed
    // motor): the yaw loop saturates at once; the spin is far below the
    // crash rate (950 °/s).
    r.vehicle.gyro.yaw_rps = 200f32.to_radians();
    r.expect_event_after(RUNAWAY, 1_000, 74..=76);
    assert!(!r.fc.is_armed());
    assert_eq!(r.motors(), Motors::Off);
    assert!(200.0 < safety.crash_rate_dps);
    // The motors stay off.
    r.run_ms(500);
    assert_eq!(r.motors(), Motors::Off);
}

#[test]
fn a_roll_flip_disarms_in_acro_too() {
    let mut r = lifting_off(100);
    r.pilot.mode = FlightMode::Acro;
    // Roll stick centred, rolling left at 300 °/s (motors crossed).
    r.vehicle.gyro.roll_rps = -300f32.to_radians();
    r.expect_event_after(RUNAWAY, 1_000, 74..=76);
}

#[test]
fn a_slow_yaw_below_50_dps_never_disarms() {
    // Props off on the bench, the craft in a hand: turning slowly while the
    // loop pushes at its limit is not a runaway.
    let mut r = lifting_off(100);
    r.vehicle.gyro.yaw_rps = 49f32.to_radians();
    r.vehicle.gyro.roll_rps = 14f32.to_radians();
    r.vehicle.gyro.pitch_rps = -14f32.to_radians();
    let ev = r.run_ms(3_000);
    assert!(!ev.contains(&RUNAWAY), "{ev:?}");
    assert!(r.fc.is_armed());
}

#[test]
fn half_a_second_of_calm_flight_switches_it_off_until_the_next_arming() {
    let mut r = lifting_off(600);
    r.vehicle.gyro.yaw_rps = 200f32.to_radians();
    let ev = r.run_ms(1_000);
    assert!(!ev.contains(&RUNAWAY), "{ev:?}");
    assert!(r.fc.is_armed());
    // Disarm and arm again: the check is back.
    r.vehicle.gyro.yaw_rps = 0.0;
    r.pilot.sticks.throttle = 0.0;
    r.pilot.arm_switch = false;
    r.run_ms(10);
    r.arm();
    r.pilot.sticks.throttle = 0.5;
    r.run_ms(100);
    r.vehicle.gyro.yaw_rps = 200f32.to_radians();
    r.expect_event_after(RUNAWAY, 1_000, 74..=76);
}

#[test]
fn calm_time_below_the_collective_or_while_pushing_does_not_count() {
    // At idle (collective below 0.2) for 2 s: not flying, still watching.
    let mut r = Rig::new();
    r.arm();
    r.pilot.sticks.throttle = 0.1;
    r.run_ms(2_000);
    r.pilot.sticks.throttle = 0.5;
    r.run_ms(100);
    r.vehicle.gyro.yaw_rps = 200f32.to_radians();
    r.expect_event_after(RUNAWAY, 1_000, 74..=76);
}

#[test]
fn a_runaway_cause_is_validated() {
    let mut cfg = FlightConfig::default();
    cfg.safety.runaway_off_torque_max = cfg.safety.runaway_torque_min;
    assert_eq!(
        FlightController::new(cfg).err(),
        Some(FlightConfigError::Safety(SafetyField::Runaway))
    );
    let mut cfg = FlightConfig::default();
    cfg.safety.runaway_time_s = 0.0;
    assert_eq!(
        FlightController::new(cfg).err(),
        Some(FlightConfigError::Safety(SafetyField::Time))
    );
}
