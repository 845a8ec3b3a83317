//! Second-order sections from the bilinear transform with pre-warping
//! (R. Bristow-Johnson's "Audio EQ Cookbook"): the Butterworth-like
//! low-pass, exactly −3 dB at its cut-off for Q = 1/√2, and the notch, a
//! zero on the unit circle at its centre with a −3 dB width of f₀/Q. Run as
//! direct form I: the fixed-point form keeps the input and output history
//! exactly and accumulates the five taps in 64 bits, so no internal state
//! can overflow.

use crate::{check, sin_cos, to_q, FilterError, Response};

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
const fn omega(freq_hz: f32, q: f32, sample_hz: f32) -> Result<(f32, f32), FilterError> {
    if let Err(e) = check(freq_hz, sample_hz) {
        return Err(e);
    }
    if !(q > 0.1 && q <= 50.0) {
        return Err(FilterError::Quality);
    }
    Ok(sin_cos(2.0 * core::f32::consts::PI * freq_hz / sample_hz))
}

impl BiquadCoeffs {
    /// Low-pass with cut-off `cutoff_hz` and quality `q` (1/√2: Butterworth,
    /// −3 dB at the cut-off, no peak) at `sample_hz`.
    ///
    /// # Errors
    /// [`FilterError`] for a sample rate, frequency or Q out of range.
    pub const fn low_pass(cutoff_hz: f32, q: f32, sample_hz: f32) -> Result<Self, FilterError> {
        let (s, c) = match omega(cutoff_hz, q, sample_hz) {
            Ok(sc) => sc,
            Err(e) => return Err(e),
        };
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
    pub const fn notch(center_hz: f32, q: f32, sample_hz: f32) -> Result<Self, FilterError> {
        let (s, c) = match omega(center_hz, q, sample_hz) {
            Ok(sc) => sc,
            Err(e) => return Err(e),
        };
        let alpha = s / (2.0 * q);
        let a0 = 1.0 + alpha;
        let b0 = 1.0 / a0;
        let b1 = -2.0 * c / a0;
        Ok(Self {
            b: [b0, b1, b0],
            a: [b1, (1.0 - alpha) / a0],
        })
    }

    /// The first-order low-pass [`Pt1`](crate::Pt1) as a section
    /// (b₀ = k, a₁ = k − 1, the other taps 0): the same filter, so one
    /// fixed-point stage type runs either.
    ///
    /// # Errors
    /// [`FilterError::SampleRate`], [`FilterError::Frequency`].
    pub const fn pt1(cutoff_hz: f32, sample_hz: f32) -> Result<Self, FilterError> {
        let k = match crate::pt1::gain(cutoff_hz, sample_hz) {
            Ok(k) => k,
            Err(e) => return Err(e),
        };
        Ok(Self {
            b: [k, 0.0, 0.0],
            a: [k - 1.0, 0.0],
        })
    }

    /// The identity (b₀ = 1): a stage that is off.
    pub const PASS: Self = Self {
        b: [1.0, 0.0, 0.0],
        a: [0.0, 0.0],
    };

    /// The feed-forward taps b₀, b₁, b₂ and the feedback taps a₁, a₂.
    #[must_use]
    pub const fn taps(&self) -> ([f32; 3], [f32; 2]) {
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

/// b₁ (Q29) that makes Σb = 2^29 + a₁ + a₂: unity gain at DC. In i64 (the
/// designs' |a₁| < 2, |a₂| < 1 keep it well inside i32; saturated anyway).
const fn b1_for_unity_dc(b0: i32, b2: i32, a: [i32; 2]) -> i32 {
    let s = (1i64 << 29) + a[0] as i64 + a[1] as i64 - b0 as i64 - b2 as i64;
    if s > i32::MAX as i64 {
        i32::MAX
    } else if s < i32::MIN as i64 {
        i32::MIN
    } else {
        s as i32
    }
}

/// A biquad in fixed point: taps in Q29, the history in the signal's own
/// Q-format, five 32×32→64 products a sample accumulated in `i64`, with
/// error feedback: the remainder the output's truncation drops is carried
/// into the next sample's sum, so no deadband holds a low-pass off its
/// input (truncation alone stalls it 1/(1 + a₁ + a₂) LSB short of a held
/// input: 3.7 LSB at 100 Hz, 69 LSB at 20 Hz, 265 LSB at 10 Hz, for a
/// 1 kHz rate). A resonant section (a notch, a peaking low-pass) can still
/// keep a small limit cycle: ±1 LSB for a Q 2 notch, up to ±15 LSB for a
/// Q 50 one (in a Q16 gyro 0.2 mrad/s).
///
/// Range: the designs' taps sum to less than 7 in magnitude (7·2^29 < 2^32 in
/// Q29), so with any i32 history the five products and the remainder (< 2^29)
/// sum to less than 2^63; the output is saturated to i32.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BiquadQ {
    b: [i32; 3],
    /// −a₁, −a₂: negated, so the sample's sum is five multiply-accumulates.
    neg_a: [i32; 2],
    x: [i32; 2],
    y: [i32; 2],
    /// The last truncation's remainder, Q29 of one LSB, 0 ≤ e < 2^29.
    e: i32,
}

impl BiquadQ {
    /// The fixed-point form of `c`, its history cleared. Every design here
    /// has unity gain at DC, and the Q29 form keeps it exactly: b₁ is not
    /// rounded on its own but set to 2^29 + a₁ + a₂ − b₀ − b₂ (at most a few
    /// LSB from its rounding), so a low-pass brings a held input through
    /// unchanged.
    #[must_use]
    pub const fn new(c: &BiquadCoeffs) -> Self {
        let (b, a) = (c.b, c.a);
        let (b0, b2) = (to_q(b[0], 29), to_q(b[2], 29));
        let a = [to_q(a[0], 29), to_q(a[1], 29)];
        Self {
            b: [b0, b1_for_unity_dc(b0, b2, a), b2],
            neg_a: [-a[0], -a[1]],
            x: [0; 2],
            y: [0; 2],
            e: 0,
        }
    }

    /// Gain, phase and delay at `f_hz` for `sample_hz` of the Q29 taps as
    /// they run (the design's response with the taps' rounding).
    #[must_use]
    pub fn response(&self, f_hz: f32, sample_hz: f32) -> Response {
        let q = |t: i32| f64::from(t) / f64::from(1u32 << 29);
        let b = self.b.map(q);
        let a = [1.0, -q(self.neg_a[0]), -q(self.neg_a[1])];
        Response::of_ratio(b, a, f_hz, sample_hz)
    }

    /// Sets the history as if `x` had been the input for ever and the output
    /// had settled on it (a unity-DC-gain design: the low-pass, the notch,
    /// the PT1), so the filter starts without a transient.
    pub fn settle(&mut self, x: i32) {
        self.x = [x, x];
        self.y = [x, x];
        self.e = 0;
    }

    /// One sample.
    // Inlined: the call would cost a tenth of the sample again.
    #[inline(always)]
    pub fn apply(&mut self, x: i32) -> i32 {
        let m = |a: i32, b: i32| i64::from(a) * i64::from(b);
        // The remainder first: the accumulator starts from it, and each
        // product is one SMLAL.
        let mut acc = i64::from(self.e);
        acc += m(self.b[0], x);
        acc += m(self.b[1], self.x[0]);
        acc += m(self.b[2], self.x[1]);
        acc += m(self.neg_a[0], self.y[0]);
        acc += m(self.neg_a[1], self.y[1]);
        // Saturated to i32: the wide result's low word, unless the high word
        // is not its sign extension (cheaper than a 64-bit clamp).
        let wide = acc >> 29;
        let low = wide as i32;
        let y = if i64::from(low) == wide {
            low
        } else if wide < 0 {
            i32::MIN
        } else {
            i32::MAX
        };
        self.e = (acc & ((1 << 29) - 1)) as i32;
        self.x = [x, self.x[0]];
        self.y = [y, self.y[0]];
        y
    }
}
