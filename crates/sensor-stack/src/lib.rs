//! The sensor stack's management for the Blue Pill flight controller,
//! hardware-free: the three drivers on one bus with their health, boot-time
//! probing and I2C bus recovery, sample planning and loop-timing
//! statistics, the per-sample processing pipeline (calibration → AHRS →
//! vertical estimator), the calibration sessions and the calibration
//! flash record. What it produces (attitude, body rates, height) is what
//! the flight controller (the `flight` crate) consumes; it knows nothing
//! of the controller.
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
//! | [`calmode`] | magnetometer (ellipsoid or min/max) and accelerometer calibrations, button decoder, the calibration session state machine (per build), raw-log rows |
//! | [`sample`] | one 1 kHz sample end to end: start-up bias, pipeline steps, calibration and raw-log values |
//! | [`gyro_filter`] | the rate loop's gyro: a low-pass and a notch per axis, fixed point, designed at build time |
//! | [`pipeline`] | the 1 kHz / 100 Hz processing chain (fixed-point AHRS by default, f32 with `f32-ahrs`) |
//! | [`mounting`] | MPU frame → body FRD signed axis permutation, the six faces |
//! | [`angles`] | integer Euler angles and the down axis from the Q30 quaternion |
//! | [`crc32`] | the record's CRC-32 |
//!
//! ```
//! use sensor_stack::pipeline::{ImuInput, Pipeline, PipelineConfig};
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
pub mod boot;
pub mod calmode;
pub mod crc32;
pub mod gyro_filter;
pub mod health;
pub mod mounting;
pub mod pipeline;
pub mod sample;
pub mod schedule;
pub mod sensors;
pub mod storage;

pub use mounting::{Face, Mounting};
