//! Digital filters for a flight controller's gyro path, `#![no_std]`, no heap:
//! a first-order low-pass ([`Pt1`]) and the biquad low-pass and notch
//! ([`BiquadCoeffs::low_pass`], [`BiquadCoeffs::notch`]), each in `f32` (the
//! reference) and in fixed point for a Cortex-M3 without FPU ([`Pt1Q`],
//! [`BiquadQ`]: one 32×32→64 multiply per tap, no library call per sample),
//! with their analytic frequency response ([`Response`]) so a design can be
//! judged before it flies: gain, phase and delay at any frequency.
//!
//! Signals in fixed point are `i32` in whatever Q-format the caller uses
//! (the flight stack's gyro is rad/s in Q16); a filter's output has its
//! input's Q-format. Coefficients: PT1 gain in Q30, biquad taps in Q29
//! (|tap| < 4).
//!
//! ```
//! use filters::{BiquadCoeffs, BiquadQ};
//! // A 100 Hz Butterworth low-pass at 1 kHz on a Q16 gyro.
//! let c = BiquadCoeffs::low_pass(100.0, core::f32::consts::FRAC_1_SQRT_2, 1000.0).unwrap();
//! let mut f = BiquadQ::new(&c);
//! let mut y = 0;
//! for _ in 0..200 {
//!     y = f.apply(1 << 16); // 1 rad/s, held
//! }
//! assert!((y - (1 << 16)).abs() <= 2); // unity gain at DC
//! // Its delay at 50 Hz: 2.6 ms (the analog Butterworth's
//! // √2·ω_c·(ω_c² + ω²)/(ω_c⁴ + ω⁴) is 2.65 ms).
//! let d = c.response(50.0, 1000.0).group_delay_s;
//! assert!((d - 0.00265).abs() < 0.0001);
//! ```
#![no_std]
#![deny(missing_docs)]

mod biquad;
mod pt1;
mod response;

pub use biquad::{Biquad, BiquadCoeffs, BiquadQ};
pub use pt1::{Pt1, Pt1Q};
pub use response::Response;

/// Why a filter was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FilterError {
    /// The sample rate is not positive and finite.
    SampleRate,
    /// The cut-off or centre frequency is not within (0, 0.45 × the sample
    /// rate): beyond it the bilinear transform's warping leaves little of
    /// the design.
    Frequency,
    /// The quality factor is not within (0.1, 50].
    Quality,
}

impl core::fmt::Display for FilterError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::SampleRate => "sample rate not positive and finite",
            Self::Frequency => "frequency not within (0, 0.45 x the sample rate)",
            Self::Quality => "quality factor not within (0.1, 50]",
        })
    }
}

impl core::error::Error for FilterError {}

/// Checks a design's sample rate and frequency (Hz).
fn check(freq_hz: f32, sample_hz: f32) -> Result<(), FilterError> {
    if !(sample_hz > 0.0 && sample_hz.is_finite()) {
        return Err(FilterError::SampleRate);
    }
    if !(freq_hz > 0.0 && freq_hz < 0.45 * sample_hz) {
        return Err(FilterError::Frequency);
    }
    Ok(())
}

/// `x` in Q`frac` rounded, saturated to i32 (construction only).
fn to_q(x: f32, frac: u32) -> i32 {
    let v = libm::roundf(x * (1u64 << frac) as f32);
    if v >= i32::MAX as f32 {
        i32::MAX
    } else if v <= i32::MIN as f32 {
        i32::MIN
    } else {
        v as i32
    }
}

/// i64 saturated to i32.
fn sat32(x: i64) -> i32 {
    x.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}
