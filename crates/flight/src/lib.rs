//! Hardware-free firmware logic for the Blue Pill flight controller: the
//! calibration flash record, sensor health and I2C bus recovery, scheduling
//! and loop-timing statistics, boot-time probing, calibration state
//! machines and the per-sample processing pipeline.
//!
//! Everything here is `no_std`, heap-free and generic over
//! `embedded_hal` traits, so it runs unchanged on the host (tests, against
//! mocks and the `sim` bus) and in the RTIC firmware, which only wires it
//! to interrupts, timers and peripherals. It does not touch hardware
//! registers, own peripherals, or decide task priorities.
//!
//! | module | what |
//! |---|---|
//! | [`storage`] | calibration record in the flash page: encode/decode, CRC-32, typed errors, [`storage::CalibrationStore`] + RAM mock |
//! | [`health`] | per-sensor counters and state, retry / re-init / bus-recovery policy, stuck-bus recovery procedure |
//! | [`schedule`] | mag every 10th IMU sample, periodic deadlines, dt from cycle counts, µs clock, loop statistics, watchdog gate |
//! | [`boot`] | bounded probing with typed verdicts, graceful degradation, start-up gyro bias |
//! | [`sensors`] | the three drivers on one bus with their health: boot, reads, config checks, stepwise re-init, re-probing, bus-recovery requests |
//! | [`calmode`] | magnetometer (ellipsoid or min/max) and accelerometer calibrations, button decoder, the calibration session state machine, raw-log rows |
//! | [`sample`] | one 1 kHz sample end to end: start-up bias, pipeline steps, calibration and raw-log values |
//! | [`pipeline`] | the 1 kHz / 100 Hz processing chain (fixed-point AHRS by default, f32 with `f32-ahrs`) |
//! | [`mounting`] | MPU frame → body FRD signed axis permutation |
//! | [`flightctl`] | [`flightctl::FlightController`]: pilot input + attitude + gyro + time → 4 motor commands, state, events (modes, arming, crash/landing disarm, failsafe, motor test) |
//! | [`motortest`] | the motor-test switch: off → on flips while disarmed spin motors 1, 2, 3, 4 in turn |
//! | [`arming`] | arming refusals, disarm causes, events and the safety limits |
//! | [`runaway`] | runaway-takeoff check: saturated rate loop while turning, before normal flight |
//! | [`angles`] | integer Euler angles and the down axis from the Q30 quaternion |
//!
//! ```
//! use flight::pipeline::{ImuInput, Pipeline, PipelineConfig};
//! let mut p = Pipeline::new(PipelineConfig::new(), &Default::default()).unwrap();
//! let due = p.imu_step(&ImuInput { accel: [0, 0, 8192], gyro: [0; 3], dt_cycles: 72_000 });
//! assert!(!due); // the control step runs every 10th sample
//! ```
#![no_std]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::field_reassign_with_default
    )
)]

pub mod angles;
pub mod arming;
pub mod boot;
pub mod calmode;
pub mod crc32;
pub mod flightctl;
pub mod health;
pub mod motortest;
pub mod mounting;
pub mod outputguard;
pub mod pipeline;
pub mod runaway;
pub mod sample;
pub mod schedule;
pub mod sensors;
pub mod storage;

pub use mounting::{Face, Mounting};
