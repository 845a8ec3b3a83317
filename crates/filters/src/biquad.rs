//! Second-order sections from the bilinear transform with pre-warping
//! (R. Bristow-Johnson's "Audio EQ Cookbook"): the Butterworth-like
//! low-pass, exactly −3 dB at its cut-off for Q = 1/√2, and the notch, a
//! zero on the unit circle at its centre with a −3 dB width of f₀/Q. Run as
//! direct form I: the fixed-point form keeps the input and output history
//! exactly and accumulates the five taps in 64 bits, so no internal state
//! can overflow.

use crate::{check, sat32, to_q, FilterError, Response};

/// A biquad's taps, normalised so a₀ = 1:
/// y = b₀x + b₁x₁ + b₂x₂ − a₁y₁ − a₂y₂. Only the designs below make them, so
/// Σ|tap| < 7 (a low-pass's b sum to at most 1, |a₁| < 2, |a₂| < 1; a
/// notch's |b₁| < 2): what [`BiquadQ`]'s accumulator relies on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiquadCoeffs {
    b: [f32; 3],
    a: [f32; 2],
}

/// sin ω₀ and cos ω₀ of `freq_hz` at `sample_hz`, checked.
fn omega(freq_hz: f32, q: f32, sample_hz: f32) -> Result<(f32, f32), FilterError> {
    check(freq_hz, sample_hz)?;
    if !(q > 0.1 && q <= 50.0) {
        return Err(FilterError::Quality);
    }
    let w0 = 2.0 * core::f32::consts::PI * freq_hz / sample_hz;
    Ok((libm::sinf(w0), libm::cosf(w0)))
}

impl BiquadCoeffs {
    /// Low-pass with cut-off `cutoff_hz` and quality `q` (1/√2: Butterworth,
    /// −3 dB at the cut-off, no peak) at `sample_hz`.
    ///
    /// # Errors
    /// [`FilterError`] for a sample rate, frequency or Q out of range.
    pub fn low_pass(cutoff_hz: f32, q: f32, sample_hz: f32) -> Result<Self, FilterError> {
        let (s, c) = omega(cutoff_hz, q, sample_hz)?;
        let alpha = s / (2.0 * q);
        let a0 = 1.0 + alpha;
        let b1 = (1.0 - c) / a0;
        Ok(Self {
            b: [0.5 * b1, b1, 0.5 * b1],
            a: [-2.0 * c / a0, (1.0 - alpha) / a0],
        })
    }

    /// Notch at `center_hz` with quality `q` (the −3 dB width is
    /// `center_hz / q`) at `sample_hz`.
    ///
    /// # Errors
    /// [`FilterError`] for a sample rate, frequency or Q out of range.
    pub fn notch(center_hz: f32, q: f32, sample_hz: f32) -> Result<Self, FilterError> {
        let (s, c) = omega(center_hz, q, sample_hz)?;
        let alpha = s / (2.0 * q);
        let a0 = 1.0 + alpha;
        let b0 = 1.0 / a0;
        let b1 = -2.0 * c / a0;
        Ok(Self {
            b: [b0, b1, b0],
            a: [b1, (1.0 - alpha) / a0],
        })
    }

    /// The feed-forward taps b₀, b₁, b₂ and the feedback taps a₁, a₂.
    #[must_use]
    pub fn taps(&self) -> ([f32; 3], [f32; 2]) {
        (self.b, self.a)
    }

    /// Gain, phase and delay at `f_hz` for `sample_hz`.
    #[must_use]
    pub fn response(&self, f_hz: f32, sample_hz: f32) -> Response {
        let b = self.b.map(f64::from);
        let a = [1.0, f64::from(self.a[0]), f64::from(self.a[1])];
        Response::of_ratio(b, a, f_hz, sample_hz)
    }
}

/// A biquad in `f32`, direct form I (the reference of [`BiquadQ`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Biquad {
    c: BiquadCoeffs,
    x: [f32; 2],
    y: [f32; 2],
}

impl Biquad {
    /// With taps `c`, its history cleared.
    #[must_use]
    pub fn new(c: &BiquadCoeffs) -> Self {
        Self {
            c: *c,
            x: [0.0; 2],
            y: [0.0; 2],
        }
    }

    /// One sample.
    pub fn apply(&mut self, x: f32) -> f32 {
        let [b0, b1, b2] = self.c.b;
        let [a1, a2] = self.c.a;
        let y = b0 * x + b1 * self.x[0] + b2 * self.x[1] - a1 * self.y[0] - a2 * self.y[1];
        self.x = [x, self.x[0]];
        self.y = [y, self.y[0]];
        y
    }
}

/// A biquad in fixed point: taps in Q29, the history in the signal's own
/// Q-format, five 32×32→64 products a sample accumulated in `i64`.
///
/// Range: the designs' taps sum to less than 7 in magnitude (7·2^29 < 2^32 in
/// Q29), so with any i32 history the five products sum to less than 2^63; the
/// output is saturated to i32.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BiquadQ {
    b: [i32; 3],
    a: [i32; 2],
    x: [i32; 2],
    y: [i32; 2],
}

impl BiquadQ {
    /// The fixed-point form of `c`, its history cleared.
    #[must_use]
    pub fn new(c: &BiquadCoeffs) -> Self {
        Self {
            b: c.b.map(|t| to_q(t, 29)),
            a: c.a.map(|t| to_q(t, 29)),
            x: [0; 2],
            y: [0; 2],
        }
    }

    /// One sample, the sum truncated to the signal's Q-format (at most one LSB
    /// low: a bias of half an LSB, 8 µrad/s for a Q16 gyro, for two fewer
    /// instructions a sample).
    pub fn apply(&mut self, x: i32) -> i32 {
        let m = |a: i32, b: i32| i64::from(a) * i64::from(b);
        let acc = m(self.b[0], x) + m(self.b[1], self.x[0]) + m(self.b[2], self.x[1])
            - m(self.a[0], self.y[0])
            - m(self.a[1], self.y[1]);
        let y = sat32(acc >> 29);
        self.x = [x, self.x[0]];
        self.y = [y, self.y[0]];
        y
    }
}
