//! Shared rig for the general-purpose timer model's tests: one timer, the
//! time the test has reached, and register access that fails the test on a
//! register or feature the model does not have. Each test file adds the
//! steps of its own mode (PWM output, input capture) as methods of `Rig`.

#![allow(dead_code, clippy::expect_used)]

use emulator::tim::{reg, GpTimer};

/// One microsecond in ns.
pub const US: u64 = 1_000;

/// A timer and the current time.
pub struct Rig {
    pub t: GpTimer,
    pub now: u64,
}

impl Rig {
    /// Timer `name` on a kernel clock of `hz`, at reset, time 0.
    pub fn new(name: &'static str, hz: u32) -> Self {
        Self {
            t: GpTimer::new(name, hz),
            now: 0,
        }
    }

    /// Writes `v` to the register at offset `off` now.
    pub fn wr(&mut self, off: u32, v: u32) {
        self.t
            .write(off, v, self.now)
            .expect("modelled register")
            .expect("modelled feature");
    }

    /// Reads the register at offset `off` now.
    pub fn rd(&mut self, off: u32) -> u32 {
        self.t.read(off, self.now).expect("modelled register")
    }

    /// EGR.UG loads the preloaded PSC, ARR and CCRx, its UIF is cleared,
    /// then CR1 = `cr1` (with CEN, the counter starts).
    pub fn update_then_start(&mut self, cr1: u32) {
        self.wr(reg::EGR, 1);
        self.wr(reg::SR, 0);
        self.wr(reg::CR1, cr1);
    }
}
