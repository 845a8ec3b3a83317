//! Simulated time shared by the bus models and the drivers' delays.

use std::cell::Cell;
use std::rc::Rc;

/// Simulated clock in nanoseconds since the start of the simulation.
///
/// Cheap to clone: every clone shares the same time. Time only moves forward,
/// and only when something advances it (a [`SimDelay`], the bus's transfer
/// time, or the test harness) — so a 10-minute flight runs as fast as the
/// host computes it.
#[derive(Clone, Debug, Default)]
pub struct SimClock {
    ns: Rc<Cell<u64>>,
}

impl SimClock {
    /// A clock at t = 0.
    pub fn new() -> Self {
        Self::default()
    }
    /// Current time in ns.
    pub fn now_ns(&self) -> u64 {
        self.ns.get()
    }
    /// Current time in µs (truncated).
    pub fn now_us(&self) -> u64 {
        self.ns.get() / 1_000
    }
    /// Current time in seconds.
    pub fn now_s(&self) -> f64 {
        self.ns.get() as f64 * 1e-9
    }
    /// Moves time forward by `ns`.
    pub fn advance_ns(&self, ns: u64) {
        self.ns.set(self.ns.get().saturating_add(ns));
    }
    /// Moves time forward to `t_ns` (no-op if already past it).
    pub fn advance_to_ns(&self, t_ns: u64) {
        if t_ns > self.ns.get() {
            self.ns.set(t_ns);
        }
    }
    /// A delay that advances this clock.
    pub fn delay(&self) -> SimDelay {
        SimDelay {
            clock: self.clone(),
        }
    }
}

/// `embedded_hal::delay::DelayNs` that advances the shared [`SimClock`]
/// instead of sleeping.
#[derive(Clone, Debug)]
pub struct SimDelay {
    clock: SimClock,
}

impl SimDelay {
    /// A delay on `clock`.
    pub fn new(clock: &SimClock) -> Self {
        Self {
            clock: clock.clone(),
        }
    }
    /// The clock this delay advances.
    pub fn clock(&self) -> &SimClock {
        &self.clock
    }
}

impl embedded_hal::delay::DelayNs for SimDelay {
    fn delay_ns(&mut self, ns: u32) {
        self.clock.advance_ns(u64::from(ns));
    }
    fn delay_us(&mut self, us: u32) {
        self.clock.advance_ns(u64::from(us) * 1_000);
    }
    fn delay_ms(&mut self, ms: u32) {
        self.clock.advance_ns(u64::from(ms) * 1_000_000);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use embedded_hal::delay::DelayNs;

    #[test]
    fn delay_advances_shared_clock() {
        let clock = SimClock::new();
        let mut d = clock.delay();
        let c2 = clock.clone();
        d.delay_ms(600_000); // ten minutes, instantly
        d.delay_us(5);
        d.delay_ns(7);
        assert_eq!(c2.now_ns(), 600_000_000_000 + 5_000 + 7);
        c2.advance_to_ns(10);
        assert_eq!(clock.now_ns(), 600_000_005_007);
    }
}
