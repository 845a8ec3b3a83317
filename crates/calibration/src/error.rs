//! The crate's single error type.

use core::fmt;

/// Which stillness test a sample window failed (see [`Error::Moved`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MotionCheck {
    /// Peak-to-peak (max − min) of the rate samples on one axis.
    GyroSpread,
    /// Standard deviation of the rate samples on one axis.
    GyroStdDev,
    /// Peak-to-peak (max − min) of the accelerometer samples on one axis.
    AccelSpread,
    /// Standard deviation of the accelerometer samples on one axis.
    AccelStdDev,
}

/// Everything that can go wrong while collecting or fitting calibration data.
///
/// Axis numbers are 0 = x, 1 = y, 2 = z of the input frame. Values carried in
/// variants are in the unit of the input samples unless stated otherwise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Error {
    /// A sample had a NaN or infinite component. It was skipped and counted;
    /// the accumulated state is unchanged.
    NonFinite,
    /// A finite sample had a component larger in magnitude than
    /// [`INPUT_LIMIT`](crate::INPUT_LIMIT). It was skipped and counted; the
    /// accumulated state is unchanged.
    InputOutOfRange,
    /// The configuration is unusable (zero sample count, negative or NaN
    /// threshold, ...).
    InvalidConfig,
    /// Not enough accepted samples to compute a result.
    TooFewSamples {
        /// Accepted samples so far.
        have: u32,
        /// Samples required.
        need: u32,
    },
    /// The samples show that the device was not at rest.
    Moved {
        /// Which test failed.
        check: MotionCheck,
        /// Axis (0 = x, 1 = y, 2 = z).
        axis: u8,
        /// The measured spread or standard deviation.
        value: f32,
        /// The configured limit it exceeded.
        limit: f32,
    },
    /// An axis was not swept over a wide enough range (not enough rotation).
    RangeTooSmall {
        /// Axis (0 = x, 1 = y, 2 = z).
        axis: u8,
        /// Observed max − min on that axis.
        range: f32,
        /// Configured minimum max − min.
        min: f32,
    },
    /// The samples cover too few directions around the centre for a full
    /// ellipsoid fit (for example a single plane or a small cap).
    InsufficientCoverage {
        /// Coverage directions covered (of [`COVERAGE_BINS`](crate::COVERAGE_BINS) = 14).
        bins_hit: u8,
        /// Bins required by the configuration.
        bins_needed: u8,
    },
    /// The normal equations are singular or too badly conditioned to solve
    /// (the data do not determine the model).
    Singular,
    /// The fitted quadric is not an ellipsoid (shape matrix not positive
    /// definite).
    NotEllipsoid,
    /// The ellipsoid fits the data poorly.
    PoorFit {
        /// RMS relative magnitude error of the corrected samples (see
        /// [`EllipsoidSolution::rms_error`](crate::EllipsoidSolution::rms_error)).
        rms_error: f32,
        /// Configured limit.
        limit: f32,
    },
    /// The fitted centre (hard-iron offset) is too uncertain: its largest
    /// per-axis standard error, from the fit's residual and the geometry of
    /// the samples, is above the configured limit (too few samples on some
    /// side, or a noisy or disturbed field).
    UncertainOffset {
        /// Largest per-axis standard error of the centre (see
        /// [`EllipsoidSolution::offset_std_error`](crate::EllipsoidSolution::offset_std_error)).
        std_error: f32,
        /// Configured limit.
        limit: f32,
    },
    /// Six-position calibration: the averaged still vector is not close enough
    /// to any ± axis (tilt too large) or its magnitude is implausible.
    NotAxisAligned,
    /// Six-position calibration: not all six positions have been collected.
    Incomplete {
        /// Bit mask of collected positions (bit = [`Position::bit`](crate::Position::bit)).
        positions_done: u8,
    },
    /// A computed correction is non-finite or outside the plausible range
    /// (gain outside [`MIN_GAIN`](crate::MIN_GAIN)..=[`MAX_GAIN`](crate::MAX_GAIN),
    /// soft-iron matrix not positive definite).
    OutOfRange,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::NonFinite => f.write_str("sample has a NaN or infinite component (skipped)"),
            Error::InputOutOfRange => {
                f.write_str("sample component exceeds the input limit (skipped)")
            }
            Error::InvalidConfig => f.write_str("invalid calibration configuration"),
            Error::TooFewSamples { have, need } => {
                write!(f, "too few samples: have {have}, need {need}")
            }
            Error::Moved {
                check,
                axis,
                value,
                limit,
            } => write!(
                f,
                "device moved: {check:?} on axis {axis} is {value}, limit {limit}"
            ),
            Error::RangeTooSmall { axis, range, min } => write!(
                f,
                "not enough rotation: axis {axis} range {range} is below {min}"
            ),
            Error::InsufficientCoverage {
                bins_hit,
                bins_needed,
            } => write!(
                f,
                "insufficient direction coverage: {bins_hit} of 14 directions covered, {bins_needed} needed"
            ),
            Error::Singular => {
                f.write_str("normal equations are singular (data do not determine the fit)")
            }
            Error::NotEllipsoid => f.write_str("fitted surface is not an ellipsoid"),
            Error::PoorFit { rms_error, limit } => {
                write!(
                    f,
                    "poor ellipsoid fit: rms error {rms_error}, limit {limit}"
                )
            }
            Error::UncertainOffset { std_error, limit } => write!(
                f,
                "uncertain hard-iron offset: standard error {std_error}, limit {limit}"
            ),
            Error::NotAxisAligned => f.write_str(
                "still vector is not aligned with an axis or has an implausible magnitude",
            ),
            Error::Incomplete { positions_done } => {
                write!(
                    f,
                    "six-position calibration incomplete (done mask {positions_done:#08b})"
                )
            }
            Error::OutOfRange => f.write_str("computed correction is non-finite or implausible"),
        }
    }
}

impl core::error::Error for Error {}

/// The board's log: the same sentences as `Display`, in fewer numbers
/// (the limits are the configuration's, stated in README; each variant one
/// interned format string).
#[cfg(feature = "defmt")]
impl defmt::Format for Error {
    fn format(&self, f: defmt::Formatter) {
        match *self {
            Error::NonFinite => {
                defmt::write!(f, "a sample has a NaN or infinite component (skipped)")
            }
            Error::InputOutOfRange => {
                defmt::write!(f, "a sample exceeds the input limit (skipped)")
            }
            Error::InvalidConfig => defmt::write!(f, "invalid calibration configuration"),
            Error::TooFewSamples { have, need } => {
                defmt::write!(f, "too few samples: {=u32} of {=u32}", have, need)
            }
            Error::Moved { axis, .. } => defmt::write!(f, "the board moved (axis {=u8})", axis),
            Error::RangeTooSmall { axis, .. } => {
                defmt::write!(f, "not enough rotation: axis {=u8} swept too little", axis)
            }
            Error::InsufficientCoverage {
                bins_hit,
                bins_needed,
            } => defmt::write!(
                f,
                "too few field directions: {=u8} of the {=u8} needed",
                bins_hit,
                bins_needed
            ),
            Error::Singular => defmt::write!(f, "the samples do not determine the fit"),
            Error::NotEllipsoid => defmt::write!(f, "the fitted surface is not an ellipsoid"),
            Error::PoorFit { .. } => defmt::write!(
                f,
                "poor fit: the field's magnitude varies more than the limit (a changing field nearby?)"
            ),
            Error::UncertainOffset { .. } => defmt::write!(
                f,
                "the offset is uncertain: too few samples on some side (turn it through every direction)"
            ),
            Error::NotAxisAligned => defmt::write!(f, "the board is not lying on a face"),
            Error::Incomplete { positions_done } => {
                defmt::write!(
                    f,
                    "not all six faces done (mask {=u8:#08b})",
                    positions_done
                )
            }
            Error::OutOfRange => defmt::write!(f, "the correction is implausible"),
        }
    }
}
