//! Attitude (IMU and MARG) in f32 and fixed point, for a flight controller.
//!
//! * [`Madgwick`]: the f32 filter; [`fixed::MadgwickFixed`]: the same algorithm in
//!   integer arithmetic (Q2.30 quaternion, 64-bit intermediates) for an FPU-less Cortex-M3.
//! * [`Algorithm::Full`] (default): inclination from the specific force low-passed in the
//!   earth frame (accelerations of a body that goes nowhere average out, gravity does
//!   not), heading from the magnetometer only, gyro bias estimation at rest, accelerometer
//!   and magnetic disturbance rejection, a scale-factor heading gain; each switchable in
//!   [`Config`]. [`Algorithm::Textbook`]: Madgwick's 2010 filter exactly, for comparison.
//! * Frames: the estimate is `q_ned_from_body` (body FRD -> earth NED);
//!   [`frames`] converts to ENU and aligns sensor axes.
//! * Every update reports what it did ([`UpdateStatus`]); zero, huge or non-finite inputs
//!   never produce a NaN or non-unit quaternion.
//!
//! Not included: sensor calibration (see the `calibration` crate) and reading sensors.
//!
//! ```
//! use fc_ahrs::{Config, Madgwick, UpdatePath};
//! let mut ahrs = Madgwick::from_accel_mag(Config::default(), [0.0, 0.0, -9.81], [20.0, 0.0, 45.0]);
//! for _ in 0..1000 {
//!     let st = ahrs.update_marg([0.0, 0.0, 0.1], [0.0, 0.0, -9.81], [20.0, 0.0, 45.0], 0.001);
//!     assert_ne!(st.path, UpdatePath::Skipped);
//! }
//! let q_enu = fc_ahrs::frames::enu_from_ned(ahrs.quaternion());
//! assert!((q_enu.norm() - 1.0).abs() < 1e-5);
//! ```
#![no_std]
#![deny(unsafe_code)]

mod config;
pub mod fixed;
pub mod frames;
mod madgwick;
mod quat;

pub use config::{
    AccelRejectionConfig, Algorithm, BiasConfig, Config, MagRejectionConfig, MagState, UpdatePath,
    UpdateStatus,
};
pub use madgwick::{Madgwick, MAX_DT_S, STANDARD_GRAVITY_MPS2};
pub use quat::Quaternion;
