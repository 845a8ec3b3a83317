//! The first-order low-pass (Betaflight's "PT1"): y += k·(x − y) with
//! k = dt/(RC + dt), RC = 1/(2π·f_c), the backward-Euler discretisation of
//! 1/(1 + s·RC). Its delay at low frequency is about RC (1.6 ms at 100 Hz).

use crate::{check, to_q, FilterError, Response};

/// The gain k = dt/(RC + dt) of a cut-off `cutoff_hz` at `sample_hz`, checked.
pub(crate) const fn gain(cutoff_hz: f32, sample_hz: f32) -> Result<f32, FilterError> {
    if let Err(e) = check(cutoff_hz, sample_hz) {
        return Err(e);
    }
    let rc = 1.0 / (2.0 * core::f32::consts::PI * cutoff_hz);
    let dt = 1.0 / sample_hz;
    Ok(dt / (rc + dt))
}

/// First-order low-pass in `f32` (the reference of [`Pt1Q`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pt1 {
    k: f32,
    y: f32,
}

impl Pt1 {
    /// Cut-off `cutoff_hz` at `sample_hz`.
    ///
    /// # Errors
    /// [`FilterError::SampleRate`], [`FilterError::Frequency`].
    pub const fn new(cutoff_hz: f32, sample_hz: f32) -> Result<Self, FilterError> {
        match gain(cutoff_hz, sample_hz) {
            Ok(k) => Ok(Self { k, y: 0.0 }),
            Err(e) => Err(e),
        }
    }

    /// The gain k (0, 1).
    #[must_use]
    pub fn gain(&self) -> f32 {
        self.k
    }

    /// One sample.
    pub fn apply(&mut self, x: f32) -> f32 {
        self.y += self.k * (x - self.y);
        self.y
    }

    /// Sets the state (the output held) to `y`.
    pub fn reset(&mut self, y: f32) {
        self.y = y;
    }

    /// Gain, phase and delay at `f_hz` for `sample_hz`: H(z) = k/(1 − (1 − k)·z⁻¹).
    #[must_use]
    pub fn response(&self, f_hz: f32, sample_hz: f32) -> Response {
        let k = f64::from(self.k);
        Response::of_ratio([k, 0.0, 0.0], [1.0, k - 1.0, 0.0], f_hz, sample_hz)
    }
}

/// First-order low-pass in fixed point: the gain in Q30, the state in the
/// signal's own Q-format; one 32×32→64 multiply a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pt1Q {
    k_q30: i32,
    y: i32,
    /// The last step's truncated remainder, Q30 of one LSB, 0 ≤ e < 2^30
    /// (error feedback, as [`BiquadQ`](crate::BiquadQ): no deadband).
    e: i32,
}

impl Pt1Q {
    /// The fixed-point form of `f`, its state cleared.
    #[must_use]
    pub const fn new(f: &Pt1) -> Self {
        Self {
            k_q30: to_q(f.k, 30),
            y: 0,
            e: 0,
        }
    }

    /// One sample: y + k·(x − y), the difference saturated to i32 (it keeps
    /// its sign, so the result lies between y and x and fits), the step's
    /// truncation remainder carried into the next, so a held input is
    /// reached exactly.
    // Inlined: the call would cost a tenth of the sample again.
    #[inline(always)]
    pub fn apply(&mut self, x: i32) -> i32 {
        let d = crate::sat32(i64::from(x) - i64::from(self.y));
        let acc = i64::from(self.k_q30) * i64::from(d) + i64::from(self.e);
        self.y += (acc >> 30) as i32;
        self.e = (acc & ((1 << 30) - 1)) as i32;
        self.y
    }

    /// Sets the state to `y`.
    pub fn reset(&mut self, y: i32) {
        self.y = y;
        self.e = 0;
    }

    /// Gain, phase and delay at `f_hz` for `sample_hz` of the Q30 gain as
    /// it runs.
    #[must_use]
    pub fn response(&self, f_hz: f32, sample_hz: f32) -> Response {
        let k = f64::from(self.k_q30) / f64::from(1u32 << 30);
        Response::of_ratio([k, 0.0, 0.0], [1.0, k - 1.0, 0.0], f_hz, sample_hz)
    }
}
