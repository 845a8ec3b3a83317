//! The flight controller on a test rig: stepped at 1 kHz with the pilot's
//! input, the system status and the vehicle state set by the test.
#![allow(
    dead_code,
    missing_docs,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic
)]

use control::controllers::BodyRates;
use control::loops::Quat;
use control::shaping::Sticks;
use flight::flightctl::*;
use std::ops::RangeInclusive;

/// One controller step, µs.
pub const STEP_US: u32 = 1_000;

/// A flight controller with its inputs, stepped by the test.
pub struct Rig {
    pub fc: FlightController,
    pub now_us: u32,
    pub pilot: PilotInput,
    pub status: SystemStatus,
    pub vehicle: Vehicle,
    pub last: Option<FlightOutput>,
}

/// Sensors healthy, gyro bias done, accelerometer calibrated, no
/// calibration running: ready to arm.
pub fn ready_status() -> SystemStatus {
    SystemStatus {
        sensors_healthy: true,
        gyro_bias_done: true,
        calibration_running: false,
        accel_calibrated: true,
    }
}

/// The vehicle as a test sets it, in `f32` (a NaN or infinity for a
/// lost sample); the controller gets it through
/// [`VehicleState::from_f32`] at every step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vehicle {
    /// Attitude `q_ned_from_body`.
    pub attitude: Quat,
    /// Gyro body rates, rad/s, FRD.
    pub gyro: BodyRates,
    /// Height and vertical speed.
    pub altitude: Option<AltitudeEstimate>,
}

impl Vehicle {
    /// What the controller is handed.
    pub fn state(&self) -> VehicleState {
        VehicleState::from_f32(&self.attitude, &self.gyro, self.altitude)
    }
}

/// Level and still, no altitude estimate.
pub fn level() -> Vehicle {
    Vehicle {
        attitude: Quat::IDENTITY,
        gyro: BodyRates::default(),
        altitude: None,
    }
}

impl Rig {
    /// Disarmed, sticks centred, link up, angle mode, everything ready.
    pub fn new() -> Self {
        Self {
            fc: FlightController::new(FlightConfig::default()).unwrap(),
            // Start near the wrap of the µs clock: nothing may depend on it.
            now_us: u32::MAX - 500_000,
            pilot: PilotInput {
                sticks: Sticks::default(),
                arm_switch: false,
                mode: FlightMode::Angle,
                link_ok: true,
                motor_test_switch: false,
            },
            status: ready_status(),
            vehicle: level(),
            last: None,
        }
    }

    /// One 1 kHz step; checks the motors are off whenever disarmed.
    pub fn step(&mut self) -> FlightOutput {
        self.now_us = self.now_us.wrapping_add(STEP_US);
        let out = self.fc.step(
            self.now_us,
            &self.pilot,
            &self.status,
            &self.vehicle.state(),
        );
        if out.state == FlightState::Disarmed {
            assert_eq!(out.motors, Motors::Off, "motors must be off when disarmed");
        }
        self.last = Some(out);
        out
    }

    /// Runs `ms` steps; returns every event in order.
    pub fn run_ms(&mut self, ms: u32) -> Vec<Event> {
        let mut ev = Vec::new();
        for _ in 0..ms {
            ev.extend(self.step().events.iter());
        }
        ev
    }

    /// Runs until an event matching `f` or `max_ms`; returns the ms taken.
    pub fn run_until(&mut self, max_ms: u32, f: impl Fn(&Event) -> bool) -> Option<u32> {
        (1..=max_ms).find(|_| self.step().events.iter().any(|e| f(&e)))
    }

    /// Runs until `event`, which must come within `max_ms`.
    pub fn expect_event_within(&mut self, event: Event, max_ms: u32) -> u32 {
        self.run_until(max_ms, |e| *e == event)
            .unwrap_or_else(|| panic!("no {event:?} within {max_ms} ms"))
    }

    /// Runs until `event`, which must come after a number of steps in
    /// `expected_ms`.
    pub fn expect_event_after(
        &mut self,
        event: Event,
        max_ms: u32,
        expected_ms: RangeInclusive<u32>,
    ) {
        let ms = self.expect_event_within(event, max_ms);
        assert!(
            expected_ms.contains(&ms),
            "{event:?} after {ms} ms, expected {expected_ms:?}"
        );
    }

    /// Switch off for a while, then on: one arm request.
    pub fn flip_arm_switch(&mut self) -> Vec<Event> {
        self.pilot.arm_switch = false;
        self.run_ms(20);
        self.pilot.arm_switch = true;
        self.run_ms(1)
    }

    /// Motor-test switch off for a while, then on: one test request.
    pub fn flip_test_switch(&mut self) -> Vec<Event> {
        self.pilot.motor_test_switch = false;
        self.run_ms(20);
        self.pilot.motor_test_switch = true;
        self.run_ms(1)
    }

    /// Disarmed to armed through one switch flip, which must succeed.
    pub fn arm(&mut self) {
        let ev = self.flip_arm_switch();
        assert_eq!(ev, vec![Event::Armed], "arming failed");
        assert_eq!(self.fc.state(), FlightState::Armed);
    }

    /// Armed and flying at hover throttle, calm, for long enough (0.6 s)
    /// that the runaway-takeoff check has switched off (0.5 s).
    pub fn take_off(&mut self) {
        self.arm();
        self.pilot.sticks.throttle = 0.5;
        let ev = self.run_ms(600);
        assert!(ev.is_empty(), "{ev:?}");
    }

    /// The motors of the last step.
    pub fn motors(&self) -> Motors {
        self.last.map_or(Motors::Off, |o| o.motors)
    }
}
