//! Barometric altitude, vertical estimation, PID, the altitude/attitude
//! controllers, and the flight loops from sticks to ESC pulses.
//!
//! `#![no_std]`, no heap, no hardware: plain `f32` maths (plus `libm` for
//! the exact barometric law and square roots; the rotation half-angles are
//! an f32 polynomial, [`loops::half_angle_sin_cos`]), written for a
//! Cortex-M3 **without FPU** where every float operation is a library call,
//! so the per-sample paths avoid `powf`, trigonometry and most divisions;
//! the flight controller's per-sample loops run in fixed point
//! ([`levelq`], [`rateq`], [`fixed::AltitudeHoldQ`]) with the `f32` forms
//! as their tested reference.
//!
//! * [`baro`] — exact ISA height ↔ pressure ([`baro::altitude_m`],
//!   [`baro::pressure_pa`]) and [`baro::CheapBaro`], a table form costing
//!   3 fmul + 4 fadd per sample (< 5 mm error from −500 m to 5000 m).
//! * [`vertical`] — [`vertical::VerticalEstimator`]: third-order
//!   complementary filter (height, vertical speed, accelerometer bias) with
//!   an innovation gate, re-sync and ground-effect handling.
//! * [`pid`] — [`pid::Pid`]: anti-windup (clamp + conditional integration),
//!   derivative on measurement with a low-pass, feed-forward, bumpless reset.
//! * [`body`] — [`body::BodyRates`] and [`body::TorqueCommand`], the FRD
//!   body-frame types the stages share (a leaf module: no import cycles
//!   between `shaping`, `loops` and `controllers`).
//! * [`controllers`] — [`controllers::AltitudeHold`] (height P → speed PID
//!   → throttle) and [`controllers::AttitudeController`] (angle P → rate PID
//!   per axis).
//! * [`shaping`] — stick expo, rates and max angle, throttle curve:
//!   [`shaping::StickShaping`] turns normalised sticks into rate or tilt
//!   setpoints.
//! * [`loops`] — [`loops::RateController`] (1 kHz body-rate PIDs on the
//!   gyro → normalised torques) and [`loops::LevelController`] (self-level:
//!   P on the quaternion attitude error, rate-limited).
//! * [`mixer`] — quad-X [`mixer::Mixer`] (Betaflight numbering, props in)
//!   with PX4-style desaturation: roll/pitch first, yaw gives way, the
//!   collective shifts; idle when armed.
//! * [`esc`] — [`esc::EscTimer`]: motor command → PWM (1000–2000 µs) or
//!   OneShot125 (125–250 µs) pulse → timer compare value, and the off value.
//! * [`fixed`] — the PID and both controllers in fixed point (Q16 inputs,
//!   Q30 outputs) for a constant loop period: the same laws, integer
//!   arithmetic only ([`fixed::AltitudeHoldQ`] is the flight controller's
//!   altitude hold), and the bit-level `f32` ↔ Q conversions
//!   ([`fixed::f32_to_q`], [`fixed::q_to_f32`]).
//! * [`shapingq`] — stick shaping in fixed point, once per pilot frame
//!   ([`shapingq::StickShapingQ`]: Q30 sticks → Q16 rad/s rates, the Q30
//!   tilt quaternion from integer sine/cosine, Q30 throttle), the `f32`
//!   [`shaping::StickShaping`] kept as its reference.
//! * [`levelq`] — the self-level loop in fixed point on the AHRS's Q30
//!   quaternion ([`levelq::LevelControllerQ`]: Q30 attitude and tilt
//!   setpoint → Q16 rad/s rate setpoints, two integer square roots, no
//!   soft-float call), the `f32` [`loops::LevelController`] kept as its
//!   reference (equivalence tested).
//! * [`rateq`] — the 1 kHz rate loop ([`rateq::RateControllerQ`]: three
//!   [`fixed::PidQ`], Q16 rad/s → Q30 torque) and the quad-X mixer with its
//!   desaturation ([`rateq::MixerQ`], Q30 in and out) in fixed point, the
//!   `f32` [`loops::RateController`] and [`mixer::Mixer`] kept as their
//!   reference (equivalence tested).
//!
//! Conventions: height and vertical speed are **up** positive, in metres
//! above the baro reference pressure; attitude is NED/FRD Euler angles in
//! radians, rates in rad/s. Units are in every name.
//!
//! What it does **not** do: read sensors, run the AHRS, drive timers, or
//! decide flight modes, arming and failsafe — those belong to the driver crates, `fc-ahrs` and
//! `flight`. Every fallible call returns [`Error`] and leaves the state
//! untouched on error.
//!
//! ```
//! use control::baro::CheapBaro;
//! use control::vertical::{Config, VerticalEstimator};
//! use control::controllers::{AltitudeHold, AltitudeHoldConfig};
//!
//! let baro = CheapBaro::new(100_900.0)?;           // take-off pressure = 0 m
//! let mut est = VerticalEstimator::new(Config::default())?;
//! let mut hold = AltitudeHold::new(AltitudeHoldConfig::default())?;
//! est.update_baro(baro.height_m(100_900))?;        // 100 Hz
//! est.predict(0.0, 0.001)?;                        // 1 kHz, accel up (g removed)
//! let throttle = hold.update(1.5, est.height_m(), est.velocity_mps(), 0.001)?;
//! assert!(throttle > 0.5); // below the 1.5 m target: climb
//! # Ok::<(), control::Error>(())
//! ```
#![no_std]
#![deny(unsafe_code)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod baro;
pub mod body;
pub mod controllers;
mod error;
pub mod esc;
pub mod fixed;
pub mod levelq;
pub mod loops;
pub mod mixer;
pub mod pid;
pub mod rateq;
pub mod shaping;
pub mod shapingq;
pub mod vertical;

pub use error::Error;
