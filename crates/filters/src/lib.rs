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
//! assert_eq!(y, 1 << 16); // unity gain at DC, no deadband
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
const fn check(freq_hz: f32, sample_hz: f32) -> Result<(), FilterError> {
    if !(sample_hz > 0.0 && sample_hz.is_finite()) {
        return Err(FilterError::SampleRate);
    }
    if !(freq_hz > 0.0 && freq_hz < 0.45 * sample_hz) {
        return Err(FilterError::Frequency);
    }
    Ok(())
}

/// `x` in Q`frac`, rounded half away from zero (in f64: every i32 and
/// every half is exact there), saturated to i32 (`as` saturates). A
/// `const fn`, so a design fixed at build time puts no conversion code on
/// the target.
const fn to_q(x: f32, frac: u32) -> i32 {
    let v = x as f64 * (1u64 << frac) as f64;
    (if v >= 0.0 { v + 0.5 } else { v - 0.5 }) as i32
}

/// sin w and cos w for |w| ≤ π (a design's ω₀ = 2π·f/f_s < 0.9π), as a
/// `const fn` so designs can be constants: the Taylor series of the half
/// angle to its 13th/14th power (truncation below 2·10⁻¹⁰ at |w/2| ≤ π/2;
/// within 5·10⁻⁷ of libm in f32),
/// then sin w = 2·s·c, cos w = c² − s².
const fn sin_cos(w: f32) -> (f32, f32) {
    let h = 0.5 * w;
    let h2 = h * h;
    // Horner from the innermost term: sin h = h·(1 − h²/(2·3)·(1 − h²/(4·5)·(…))),
    // cos h = 1 − h²/(1·2)·(1 − h²/(3·4)·(…)).
    let mut s = 1.0;
    let mut k = 6;
    while k > 0 {
        let n = (2 * k) as f32;
        s = 1.0 - h2 / (n * (n + 1.0)) * s;
        k -= 1;
    }
    let mut c = 1.0;
    let mut k = 7;
    while k > 0 {
        let n = (2 * k) as f32;
        c = 1.0 - h2 / ((n - 1.0) * n) * c;
        k -= 1;
    }
    let s = h * s;
    (2.0 * s * c, c * c - s * s)
}

/// i64 saturated to i32.
fn sat32(x: i64) -> i32 {
    x.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn const_sin_cos_matches_libm_over_the_design_range() {
        for i in 0..=1000 {
            let w = core::f32::consts::PI * i as f32 / 1000.0;
            let (s, c) = sin_cos(w);
            assert!((s - libm::sinf(w)).abs() < 5e-7, "sin {w}: {s}");
            assert!((c - libm::cosf(w)).abs() < 5e-7, "cos {w}: {c}");
        }
    }

    #[test]
    fn to_q_rounds_half_away_from_zero_and_saturates() {
        assert_eq!(to_q(0.5, 1), 1);
        assert_eq!(to_q(1.25, 1), 3); // 2.5 → 3
        assert_eq!(to_q(-1.25, 1), -3);
        assert_eq!(to_q(0.2, 0), 0);
        // Exact where f32 arithmetic would round: 0.49999997 stays below ½,
        // an odd value in [2²³, 2²⁴) stays odd.
        assert_eq!(to_q(0.499_999_97, 0), 0);
        assert_eq!(to_q(8_388_609.0 / (1u64 << 29) as f32, 29), 8_388_609);
        assert_eq!(to_q(8.0, 29), i32::MAX);
        assert_eq!(to_q(-8.0, 29), i32::MIN);
    }
}
