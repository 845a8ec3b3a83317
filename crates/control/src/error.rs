//! The crate's single error type.

/// Everything that can go wrong in `control`.
///
/// Every fallible call checks its inputs before touching any state, so an
/// `Err` means "nothing changed": the estimator, PID or controller is exactly
/// as it was before the call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// An input value (setpoint, measurement, feed-forward, acceleration,
    /// pressure, height, ...) was NaN or infinite.
    NonFinite,
    /// A time step `dt_s` was zero, negative, non-finite, or larger than the
    /// configured maximum.
    InvalidDt,
    /// A gain that must be non-negative (kp, ki, kd, or a P-loop gain) was negative or not finite.
    NegativeGain,
    /// A `min` limit was above its `max`, or a limit was not finite.
    InvalidLimits,
    /// A configuration parameter that must be strictly positive (noise sigma,
    /// crossover frequency, reference pressure, ...) was zero, negative or non-finite,
    /// or a parameter was outside its documented range.
    InvalidParameter,
    /// An input was finite but outside the domain of the formula (for example
    /// a pressure of zero or below, or a height at or above 44 330 m).
    OutOfRange,
    /// The inputs were finite but an intermediate result overflowed to a
    /// non-finite value; the update was discarded.
    Overflow,
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let s = match self {
            Error::NonFinite => "input is NaN or infinite",
            Error::InvalidDt => "time step is not in (0, max]",
            Error::NegativeGain => "gain is negative or not finite",
            Error::InvalidLimits => "limit min is above max or not finite",
            Error::InvalidParameter => "configuration parameter out of its valid range",
            Error::OutOfRange => "input outside the formula's domain",
            Error::Overflow => "intermediate result overflowed",
        };
        f.write_str(s)
    }
}

/// Returns `Err(Error::NonFinite)` unless `x` is finite.
#[inline]
pub(crate) fn finite(x: f32) -> Result<f32, Error> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(Error::NonFinite)
    }
}

/// Checks that `dt_s` is finite and strictly positive.
#[inline]
pub(crate) fn check_dt(dt_s: f32) -> Result<f32, Error> {
    if dt_s.is_finite() && dt_s > 0.0 {
        Ok(dt_s)
    } else {
        Err(Error::InvalidDt)
    }
}

/// Checks that a gain is finite and `>= 0`.
// Out of line: a config-time check called from every constructor;
// one copy instead of one per call site saves flash.
#[inline(never)]
pub(crate) fn check_gain(g: f32) -> Result<(), Error> {
    if g.is_finite() && g >= 0.0 {
        Ok(())
    } else {
        Err(Error::NegativeGain)
    }
}

/// Checks that `min <= max` and both are finite.
// Out of line: a config-time check called from every constructor;
// one copy instead of one per call site saves flash.
#[inline(never)]
pub(crate) fn check_limits(min: f32, max: f32) -> Result<(), Error> {
    if min.is_finite() && max.is_finite() && min <= max {
        Ok(())
    } else {
        Err(Error::InvalidLimits)
    }
}

/// Checks that a parameter is finite and strictly positive.
// Out of line: a config-time check called from every constructor;
// one copy instead of one per call site saves flash.
#[inline(never)]
pub(crate) fn check_positive(x: f32) -> Result<(), Error> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidParameter)
    }
}
