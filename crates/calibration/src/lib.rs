//! Sensor calibration: gyro bias at rest, magnetometer hard/soft iron (min/max
//! and full ellipsoid fit), accelerometer six-position — and the correction
//! types they produce.
//!
//! # What it does
//!
//! Every estimator is fed `[f32; 3]` samples one at a time, keeps only small
//! running statistics (no samples are stored, no heap; sizes below), and
//! returns a plain-data correction once enough good data has been seen:
//!
//! | estimator | result | `apply` |
//! |---|---|---|
//! | [`GyroBiasEstimator`] | [`GyroBias`] | `raw − bias` |
//! | [`MagMinMax`] | [`MagCalibration`] (diagonal) | `soft_iron · (raw − offset)` |
//! | [`EllipsoidFit`] | [`EllipsoidSolution`] → [`MagCalibration`] (full) | `soft_iron · (raw − offset)` |
//! | [`EllipsoidFitF32`] (board: integer moments, `f32` solve) | the same | the same |
//! | [`AccelSixPosition`] | [`AccelCalibration`] | `scale ⊙ (raw − offset)` |
//!
//! # Units and frames
//!
//! The crate knows nothing about specific sensors. Inputs are vectors in any
//! consistent unit and frame (rad/s or °/s or counts for rates; µT or counts
//! for the magnetic field; g or m/s² for specific force); offsets and biases
//! come back in that same unit and frame, gains are dimensionless. Only the
//! default thresholds assume units, and say which (`GyroBiasConfig::RPS_AND_G`,
//! `MagMinMaxConfig::MICROTESLA`, `EllipsoidFitConfig::MICROTESLA`,
//! `AccelSixPositionConfig::G`).
//!
//! # What it does not do
//!
//! No sensor access, no axis remapping between sensor frames, no persistence
//! (the correction types are `Copy`, `#[repr(C)]` plain data; the firmware
//! serialises them), no temperature compensation, no misalignment/cross-axis
//! correction for the accelerometer.
//!
//! # Robustness
//!
//! A sample with a NaN/infinite component ([`Error::NonFinite`]) or a
//! component beyond ±[`INPUT_LIMIT`] ([`Error::InputOutOfRange`]) is skipped
//! and counted; the accumulated state is unchanged. No code path panics. Every
//! result is checked (`validate`) before it is returned.
//!
//! # Cost
//!
//! Per-sample work is a handful of f32 operations, except
//! [`EllipsoidFit::push`] (≈ 31 f32 multiplies and 40 adds, plus 34 f64 adds
//! every 64 samples). The one-off [`EllipsoidFit::finish`] works in f64
//! (9×9 in-place Cholesky, 3×3 symmetric eigen-decomposition); on
//! thumbv7m (release, opt-level "s") its frame is 2.8 KB plus ≈ 0.5 KB in the
//! eigen-solver, so call it from a context with ≈ 3.5 KB of stack to spare.
//! [`EllipsoidFitF32`] is the same fit for the board: exact `i64` moments
//! (34 integer multiply-adds per sample), an `f32` solve, no `f64` and no
//! nalgebra; about 5.5 KiB of thumbv7m code at opt-level "z".
//! [`MagCalibrationQ16`] applies a magnetometer correction to integer counts
//! with 9 multiply-accumulates.
//!
//! State sizes (`core::mem::size_of`): [`GyroBiasEstimator`] 152 B,
//! [`MagMinMax`] 40 B, [`EllipsoidFit`] 704 B, [`EllipsoidFitF32`] 568 B,
//! [`AccelSixPosition`] 168 B;
//! [`MagCalibration`] 48 B, [`AccelCalibration`] 24 B, [`GyroBias`] 12 B.
#![no_std]
#![deny(unsafe_code)]

mod accel;
mod correction;
mod ellipsoid;
mod ellipsoid_f32;
mod error;
mod gyro;
mod minmax;
mod sqrt;
mod stats;

pub use accel::{AccelSixPosition, AccelSixPositionConfig, Position, Progress, SixPositionEvent};
pub use correction::{
    AccelCalibration, GyroBias, MagCalibration, MagCalibrationQ16, MAG_Q16_MAX_GAIN,
};
pub use ellipsoid::{EllipsoidFit, EllipsoidFitConfig, EllipsoidSolution, COVERAGE_BINS};
pub use ellipsoid_f32::{EllipsoidFitF32, MAX_SAMPLES_F32, PIVOT_MIN_F32};
pub use error::{Error, MotionCheck};
pub use gyro::{GyroBiasConfig, GyroBiasEstimator};
pub use minmax::{MagMinMax, MagMinMaxConfig};

/// Largest accepted magnitude of any input component (any unit). Larger
/// finite values are refused with [`Error::InputOutOfRange`]; the bound keeps
/// every accumulated sum (up to 4th powers in the ellipsoid fit) far from
/// f32 overflow. It is above any 16-bit raw count and any physical reading in
/// SI units.
pub const INPUT_LIMIT: f32 = 1.0e6;

/// Smallest plausible gain (soft-iron diagonal, accelerometer scale).
pub const MIN_GAIN: f32 = 0.2;

/// Largest plausible gain (soft-iron diagonal, accelerometer scale).
pub const MAX_GAIN: f32 = 5.0;

/// Refuse non-finite or oversized samples.
fn check_input(v: &[f32; 3]) -> Result<(), Error> {
    if !v.iter().all(|x| x.is_finite()) {
        Err(Error::NonFinite)
    } else if v.iter().any(|x| x.abs() > INPUT_LIMIT) {
        Err(Error::InputOutOfRange)
    } else {
        Ok(())
    }
}
