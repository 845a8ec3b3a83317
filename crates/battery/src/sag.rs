//! The sag filter: a first-order low-pass (y += k·(x − y), k = dt/(τ + dt),
//! as `filters::Pt1`) whose time constant depends on the direction: it
//! falls with [`SAG_FALL_TAU_MS`] (4 s) and rises with [`SAG_RISE_TAU_MS`]
//! (0.5 s). It follows the pack's voltage at its lightest recent load,
//! the closer to its resting voltage: a throttle burst's sag must last
//! seconds before it counts, and the recovery after it counts at once, so
//! bursts with cruise between them do not add up the way they would in a
//! symmetric low-pass (whose slow recovery keeps a burst's sag for seconds
//! after it). The pack's own decline (minutes) passes with about 4 s of
//! lag.
//!
//! Fixed point: the signal is ADC counts in Q16 (`i32`, 0..=4095·2^16), the
//! gains Q30, designed at build time in integers; one 32×32→64 multiply a
//! step, the shift rounded to nearest.

/// Time constant while the voltage falls, ms.
pub const SAG_FALL_TAU_MS: u32 = 4000;

/// Time constant while the voltage rises, ms.
pub const SAG_RISE_TAU_MS: u32 = 500;

/// k = dt/(τ + dt) in Q30, rounded, for a period of `dt_ms`.
const fn gain_q30(tau_ms: u32, dt_ms: u32) -> i32 {
    let num = (dt_ms as u64) << 30;
    let den = (tau_ms + dt_ms) as u64;
    ((num + den / 2) / den) as i32
}

/// The filter (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct SagFilter {
    fall_q30: i32,
    rise_q30: i32,
    y_q16: i32,
}

impl SagFilter {
    /// For a sample period of `dt_ms`, the state at 0.
    pub(crate) const fn new(dt_ms: u32) -> Self {
        Self {
            fall_q30: gain_q30(SAG_FALL_TAU_MS, dt_ms),
            rise_q30: gain_q30(SAG_RISE_TAU_MS, dt_ms),
            y_q16: 0,
        }
    }

    /// Sets the state to `y_q16`.
    pub(crate) fn reset(&mut self, y_q16: i32) {
        self.y_q16 = y_q16;
    }

    /// The output, Q16 counts.
    pub(crate) fn output_q16(&self) -> i32 {
        self.y_q16
    }

    /// One sample `x_q16` (Q16 counts, 0..=4095·2^16); returns the output.
    pub(crate) fn apply(&mut self, x_q16: i32) -> i32 {
        let d = i64::from(x_q16) - i64::from(self.y_q16);
        let k = if d < 0 { self.fall_q30 } else { self.rise_q30 };
        // |k·d| < 2^30 · 2^32: the step lies between y and x, so it fits.
        let step = (i64::from(k) * d + (1 << 29)) >> 30;
        self.y_q16 = (i64::from(self.y_q16) + step) as i32;
        self.y_q16
    }
}
