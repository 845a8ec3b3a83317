//! Shared helpers for the end-to-end tests in this folder: a simulated board
//! (clock, bus, delay) and small statistics.

use sim::{SimBus, SimClock, SimConfig, SimDelay};

/// A simulated board: one clock, one bus with the three chips, one delay.
pub struct Rig {
    /// Simulated time.
    pub clock: SimClock,
    /// The bus (clone it for each driver).
    pub bus: SimBus,
    /// A delay advancing `clock`.
    pub delay: SimDelay,
}

impl Rig {
    /// A board built from `config`.
    pub fn new(config: SimConfig) -> Self {
        let clock = SimClock::new();
        let bus = SimBus::new(&clock, config);
        let delay = clock.delay();
        Self { clock, bus, delay }
    }
}

/// Mean and standard deviation.
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len().max(1) as f64;
    let m = xs.iter().sum::<f64>() / n;
    let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n;
    (m, v.sqrt())
}

/// Per-axis mean of 3-vectors.
pub fn mean3(xs: &[[f64; 3]]) -> [f64; 3] {
    let n = xs.len().max(1) as f64;
    let mut m = [0.0; 3];
    for x in xs {
        for i in 0..3 {
            m[i] += x[i] / n;
        }
    }
    m
}

/// `f32` triple → `f64` triple.
pub fn f64x3(v: [f32; 3]) -> [f64; 3] {
    v.map(f64::from)
}
