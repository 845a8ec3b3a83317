//! Timing decisions as pure logic: which sensor to read on which IMU
//! sample, when periodic work is due, the AHRS time step from a cycle
//! counter, loop-timing statistics and the watchdog gate.
//!
//! All timestamps are free-running wrapping counters (`u32` µs or CPU
//! cycles); differences use wrapping arithmetic, so a wrap is harmless as
//! long as intervals stay below half the counter range (35 min in µs, 29 s
//! in 72 MHz cycles).

use core::num::NonZeroU32;

/// Nominal IMU sample rate (MPU-9250 data-ready), Hz.
pub const IMU_RATE_HZ: u32 = 1_000;
/// Magnetometer read every this many IMU samples (100 Hz).
pub const MAG_DIVIDER: u16 = 10;

/// What to do on this IMU data-ready event besides the IMU step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Tick {
    /// Read the magnetometer and run the mag step.
    pub read_mag: bool,
    /// Sequence number of this IMU sample (wrapping).
    pub sample: u32,
}

/// Per-sample scheduler: counts IMU samples and picks the magnetometer
/// sample (every [`MAG_DIVIDER`]th).
///
/// ```
/// use sensor_stack::schedule::SampleScheduler;
/// let mut s = SampleScheduler::new(10);
/// let mags = (0..100).filter(|_| s.on_imu_sample().read_mag).count();
/// assert_eq!(mags, 10);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SampleScheduler {
    mag_divider: u16,
    phase: u16,
    sample: u32,
}

impl SampleScheduler {
    /// A scheduler reading the magnetometer every `mag_divider` samples
    /// (0 is treated as 1).
    pub const fn new(mag_divider: u16) -> Self {
        Self {
            mag_divider: if mag_divider == 0 { 1 } else { mag_divider },
            phase: 0,
            sample: 0,
        }
    }

    /// Call once per IMU data-ready event.
    pub fn on_imu_sample(&mut self) -> Tick {
        let read_mag = self.phase == 0;
        self.phase = self.phase.wrapping_add(1);
        if self.phase >= self.mag_divider {
            self.phase = 0;
        }
        let sample = self.sample;
        self.sample = self.sample.wrapping_add(1);
        Tick { read_mag, sample }
    }

    /// IMU samples seen so far (wrapping).
    pub fn samples(&self) -> u32 {
        self.sample
    }
}

/// A periodic deadline on a wrapping µs clock that never drifts and never
/// bursts: after a long stall it skips to the next future slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Periodic {
    interval_us: NonZeroU32,
    next_us: u32,
    missed: u32,
}

impl Periodic {
    /// Due first at `start_us`, then every `interval_us` (at least 1).
    pub const fn new(start_us: u32, interval_us: u32) -> Self {
        Self {
            interval_us: match NonZeroU32::new(interval_us) {
                Some(n) => n,
                None => NonZeroU32::MIN,
            },
            next_us: start_us,
            missed: 0,
        }
    }

    /// `true` (once) when `now_us` reached the deadline; the deadline then
    /// advances by one interval, or past `now_us` if whole intervals were
    /// missed (counted in [`missed`](Self::missed)).
    pub fn poll(&mut self, now_us: u32) -> bool {
        let late = now_us.wrapping_sub(self.next_us) as i32;
        if late < 0 {
            return false;
        }
        let late = late as u32;
        let skipped = late / self.interval_us;
        self.missed = self.missed.saturating_add(skipped);
        self.next_us = self
            .next_us
            .wrapping_add(self.interval_us.get().wrapping_mul(skipped.wrapping_add(1)));
        true
    }

    /// µs until the deadline (0 if due).
    pub fn remaining_us(&self, now_us: u32) -> u32 {
        let d = self.next_us.wrapping_sub(now_us) as i32;
        d.max(0) as u32
    }

    /// Whole intervals skipped because polling came too late.
    pub fn missed(&self) -> u32 {
        self.missed
    }

    /// The interval, µs.
    pub fn interval_us(&self) -> u32 {
        self.interval_us.get()
    }
}

/// Retry timing with exponential back-off on a wrapping ms clock: for
/// re-probing a chip that is missing, so a board without it spends almost
/// no bus time on it while one that is plugged in later is found within
/// [`max_ms`](Self::new).
///
/// ```
/// use sensor_stack::schedule::Backoff;
/// let mut b = Backoff::new(1_000, 8_000);
/// assert!(!b.due(0));            // first call arms it: due at 1 s
/// assert!(b.due(1_000));
/// b.failed(1_000);               // next in 2 s, then 4 s, 8 s, 8 s ...
/// assert!(!b.due(2_999) && b.due(3_000));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Backoff {
    first_ms: u32,
    max_ms: u32,
    interval_ms: u32,
    next_ms: Option<u32>,
}

impl Backoff {
    /// First attempt `first_ms` after the first [`due`](Self::due) call;
    /// the interval doubles after each failure up to `max_ms`.
    pub const fn new(first_ms: u32, max_ms: u32) -> Self {
        let first = if first_ms == 0 { 1 } else { first_ms };
        Self {
            first_ms: first,
            max_ms: if max_ms < first { first } else { max_ms },
            interval_ms: first,
            next_ms: None,
        }
    }

    /// `true` when an attempt is due at `now_ms`; the first call only arms
    /// the timer.
    pub fn due(&mut self, now_ms: u32) -> bool {
        match self.next_ms {
            None => {
                self.next_ms = Some(now_ms.wrapping_add(self.first_ms));
                false
            }
            Some(next) => (now_ms.wrapping_sub(next) as i32) >= 0,
        }
    }

    /// The attempt at `now_ms` failed: the interval doubles (bounded).
    pub fn failed(&mut self, now_ms: u32) {
        self.interval_ms = self.interval_ms.saturating_mul(2).min(self.max_ms);
        self.next_ms = Some(now_ms.wrapping_add(self.interval_ms));
    }

    /// Interval to the next attempt, ms.
    pub fn interval_ms(&self) -> u32 {
        self.interval_ms
    }

    /// Makes an attempt due at `now_ms` (what it depends on just came up)
    /// without changing the interval.
    pub fn due_now(&mut self, now_ms: u32) {
        self.next_ms = Some(now_ms);
    }

    /// Back to the first interval (the device was found).
    pub fn reset(&mut self) {
        self.interval_ms = self.first_ms;
        self.next_ms = None;
    }
}

/// LSI clock of the independent watchdog, Hz: the datasheet's range
/// (STM32F103x8 datasheet, LSI 30–60 kHz; 40 kHz typical).
pub const LSI_MIN_HZ: u32 = 30_000;
/// See [`LSI_MIN_HZ`].
pub const LSI_MAX_HZ: u32 = 60_000;

/// Independent-watchdog prescaler (PR, divider 4 · 2^PR) and reload
/// (RLR, 12 bits) for a timeout of at least `min_timeout_ms` at the
/// LSI's fastest, 60 kHz (RM0008 §19.3: timeout = (RLR + 1) · 4 · 2^PR /
/// f_LSI). The real timeout lies in [`iwdg_timeout_range_ms`]; the
/// largest representable timeout (PR = 6, RLR = 4095) caps it.
///
/// ```
/// use sensor_stack::schedule::{iwdg_config, iwdg_timeout_range_ms};
/// assert_eq!(iwdg_config(500), (1, 3_749));
/// assert_eq!(iwdg_timeout_range_ms(1, 3_749), (500, 1_000));
/// ```
pub const fn iwdg_config(min_timeout_ms: u32) -> (u8, u16) {
    let lsi_cycles = min_timeout_ms.saturating_mul(LSI_MAX_HZ / 1_000);
    let mut pr = 0u8;
    while pr <= 6 {
        let ticks = lsi_cycles.div_ceil(4 << pr);
        if ticks <= 4_096 {
            let rlr = if ticks == 0 { 0 } else { ticks - 1 };
            return (pr, rlr as u16);
        }
        pr += 1;
    }
    (6, 4_095)
}

/// Shortest and longest real IWDG timeout, ms, for prescaler `pr` and
/// reload `rlr`, over the LSI's 30–60 kHz range.
pub const fn iwdg_timeout_range_ms(pr: u8, rlr: u16) -> (u32, u32) {
    let lsi_cycles = (rlr as u32 + 1) * (4 << (if pr > 6 { 6 } else { pr }));
    (
        lsi_cycles / (LSI_MAX_HZ / 1_000),
        lsi_cycles / (LSI_MIN_HZ / 1_000),
    )
}

/// AHRS time step from a free-running cycle counter (DWT CYCCNT), clamped
/// to a sane range so a stall or the first sample cannot feed the filter a
/// huge step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DtClock {
    cpu_hz: u32,
    last: Option<u32>,
    min_cycles: u32,
    max_cycles: u32,
    nominal_cycles: u32,
    clamped: u32,
}

impl DtClock {
    /// For a counter at `cpu_hz` and a nominal sample rate `rate_hz`;
    /// steps are clamped to ¼…4× nominal.
    pub const fn new(cpu_hz: u32, rate_hz: u32) -> Self {
        let rate = if rate_hz == 0 { 1 } else { rate_hz };
        let nominal = cpu_hz / rate;
        Self {
            cpu_hz,
            last: None,
            min_cycles: nominal / 4,
            max_cycles: nominal.saturating_mul(4),
            nominal_cycles: nominal,
            clamped: 0,
        }
    }

    /// Cycles since the previous call (the nominal step on the first call),
    /// clamped.
    pub fn step_cycles(&mut self, now_cycles: u32) -> u32 {
        let raw = match self.last {
            None => self.nominal_cycles,
            Some(prev) => now_cycles.wrapping_sub(prev),
        };
        self.last = Some(now_cycles);
        if raw < self.min_cycles || raw > self.max_cycles {
            self.clamped = self.clamped.saturating_add(1);
        }
        // max-then-min, not `clamp`: no panic path even if the bounds
        // were ever inverted (a zero clock).
        raw.max(self.min_cycles).min(self.max_cycles)
    }

    /// Cycles → µs (rounded down).
    pub fn cycles_to_us(&self, cycles: u32) -> u32 {
        let mhz = (self.cpu_hz / 1_000_000).max(1);
        cycles / mhz
    }

    /// Steps that fell outside ¼…4× nominal (missed samples or glitches).
    pub fn clamped(&self) -> u32 {
        self.clamped
    }
}

/// Loop-timing report for one window.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoopReport {
    /// Task executions in the window.
    pub runs: u32,
    /// Mean task time, cycles.
    pub mean_cycles: u32,
    /// Worst task time, cycles.
    pub worst_cycles: u32,
    /// Busy cycles / elapsed cycles, per mille.
    pub load_permille: u32,
}

/// Accumulates task execution times (cycle counts) and busy time; a
/// [`report`](Self::report) closes the window.
///
/// ```
/// use sensor_stack::schedule::LoopStats;
/// let mut s = LoopStats::new(0);
/// s.record(100);
/// s.record(300);
/// let r = s.report(1_000);
/// assert_eq!((r.runs, r.mean_cycles, r.worst_cycles, r.load_permille), (2, 200, 300, 400));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LoopStats {
    window_start: u32,
    runs: u32,
    sum: u64,
    worst: u32,
    worst_ever: u32,
}

impl LoopStats {
    /// Starts a window at `now_cycles`.
    pub const fn new(now_cycles: u32) -> Self {
        Self {
            window_start: now_cycles,
            runs: 0,
            sum: 0,
            worst: 0,
            worst_ever: 0,
        }
    }

    /// Records one task execution of `cycles`.
    #[inline]
    pub fn record(&mut self, cycles: u32) {
        self.runs = self.runs.saturating_add(1);
        self.sum = self.sum.saturating_add(u64::from(cycles));
        self.worst = self.worst.max(cycles);
        self.worst_ever = self.worst_ever.max(cycles);
    }

    /// Worst task time since start, cycles.
    pub fn worst_ever(&self) -> u32 {
        self.worst_ever
    }

    /// Closes the window at `now_cycles` and starts the next one. 32-bit
    /// divisions only: the mean saturates if a window holds more than 2^32
    /// busy cycles (60 s at 72 MHz), the load is computed per 1024 elapsed
    /// cycles.
    pub fn report(&mut self, now_cycles: u32) -> LoopReport {
        let elapsed = now_cycles.wrapping_sub(self.window_start);
        let sum = u32::try_from(self.sum).unwrap_or(u32::MAX);
        let mean = sum.checked_div(self.runs).unwrap_or(0);
        // load = sum · 1000 / elapsed, without overflow: scale both down.
        let load = if elapsed >= 1 << 22 {
            (sum >> 10)
                .saturating_mul(1000)
                .checked_div(elapsed >> 10)
                .unwrap_or(0)
        } else {
            sum.saturating_mul(1000).checked_div(elapsed).unwrap_or(0)
        };
        let r = LoopReport {
            runs: self.runs,
            mean_cycles: mean,
            worst_cycles: self.worst,
            load_permille: load,
        };
        self.window_start = now_cycles;
        self.runs = 0;
        self.sum = 0;
        self.worst = 0;
        r
    }
}

/// Feeds the watchdog only when the IMU loop made progress since the last
/// feed: a stalled loop (no data-ready, a hung bus) lets the IWDG reset the
/// MCU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WatchdogGate {
    last_seen: u32,
    starved: u32,
}

impl WatchdogGate {
    /// A gate that has seen sample count 0.
    pub const fn new() -> Self {
        Self {
            last_seen: 0,
            starved: 0,
        }
    }

    /// `true` if `imu_samples` (a wrapping count) advanced since the last
    /// call: feed the watchdog now.
    pub fn should_feed(&mut self, imu_samples: u32) -> bool {
        if imu_samples != self.last_seen {
            self.last_seen = imu_samples;
            true
        } else {
            self.starved = self.starved.saturating_add(1);
            false
        }
    }

    /// Calls that found no progress.
    pub fn starved(&self) -> u32 {
        self.starved
    }
}

/// A wrapping `u32` µs clock extended from a 32-bit cycle counter (which
/// itself wraps every 59.6 s at 72 MHz): call [`now_us`](Self::now_us) at
/// least once per counter wrap (the 1 kHz IMU task does).
///
/// ```
/// use sensor_stack::schedule::MicrosClock;
/// let mut c = MicrosClock::new(72_000_000, 0);
/// assert_eq!(c.now_us(72_000), 1_000);
/// assert_eq!(c.now_us(72_036), 1_000); // half a µs kept as remainder
/// assert_eq!(c.now_us(72_072), 1_001);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MicrosClock {
    cycles_per_us: NonZeroU32,
    last_cycles: u32,
    us: u32,
    rem_cycles: u32,
}

impl MicrosClock {
    /// Starts at 0 µs at counter value `now_cycles`.
    pub const fn new(cpu_hz: u32, now_cycles: u32) -> Self {
        Self {
            cycles_per_us: match NonZeroU32::new(cpu_hz / 1_000_000) {
                Some(n) => n,
                None => NonZeroU32::MIN,
            },
            last_cycles: now_cycles,
            us: 0,
            rem_cycles: 0,
        }
    }

    /// The µs timestamp at counter value `now_cycles` (wrapping at 2^32 µs).
    /// 32-bit arithmetic only (no 64-bit division on the M3).
    pub fn now_us(&mut self, now_cycles: u32) -> u32 {
        let d = now_cycles.wrapping_sub(self.last_cycles);
        self.last_cycles = now_cycles;
        let per = self.cycles_per_us;
        let mut q = d / per;
        let mut r = d % per + self.rem_cycles;
        if r >= per.get() {
            q = q.wrapping_add(1);
            r -= per.get();
        }
        self.us = self.us.wrapping_add(q);
        self.rem_cycles = r;
        self.us
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iwdg_timeout_holds_at_the_fastest_lsi() {
        for min_ms in [1, 10, 250, 500, 2_000, 10_000, 17_000] {
            let (pr, rlr) = iwdg_config(min_ms);
            assert!(pr <= 6 && rlr <= 4_095);
            let (lo, hi) = iwdg_timeout_range_ms(pr, rlr);
            assert!(lo >= min_ms, "{min_ms} ms -> {lo} ms at 60 kHz");
            // The smallest prescaler that fits: within one tick of the ask.
            assert!(lo <= min_ms + (4 << pr) / 60 + 1, "{min_ms} -> {lo}");
            // At 30 kHz the same count takes twice as long.
            assert!(hi >= 2 * lo && hi <= 2 * lo + 1, "{lo} {hi}");
        }
        // Beyond the counter's reach: capped at the longest timeout.
        assert_eq!(iwdg_config(60_000), (6, 4_095));
        assert_eq!(iwdg_timeout_range_ms(6, 4_095), (17_476, 34_952));
    }

    #[test]
    fn mag_every_tenth_sample() {
        let mut s = SampleScheduler::new(MAG_DIVIDER);
        let picks: [bool; 21] = core::array::from_fn(|_| s.on_imu_sample().read_mag);
        for (i, p) in picks.iter().enumerate() {
            assert_eq!(*p, i % 10 == 0, "sample {i}");
        }
        assert_eq!(s.samples(), 21);
        let mut every = SampleScheduler::new(0);
        assert!((0..5).all(|_| every.on_imu_sample().read_mag));
    }

    #[test]
    fn periodic_across_wrap_and_stall() {
        let start = u32::MAX - 15_000;
        let mut p = Periodic::new(start, 20_000);
        assert!(p.poll(start));
        assert!(!p.poll(start.wrapping_add(19_999)));
        assert!(p.poll(start.wrapping_add(20_000)));
        // The counter wraps between these two.
        assert_eq!(p.remaining_us(start.wrapping_add(30_000)), 10_000);
        assert!(p.poll(start.wrapping_add(40_500)));
        // A 1 s stall: one event, 49 intervals skipped, no burst.
        let t = start.wrapping_add(1_040_500);
        assert!(p.poll(t));
        assert!(!p.poll(t));
        assert_eq!(p.missed(), 49);
    }

    #[test]
    fn dt_from_cycles() {
        let mut c = DtClock::new(72_000_000, 1_000);
        assert_eq!(c.step_cycles(u32::MAX - 100), 72_000);
        // Wraps cleanly.
        assert_eq!(c.step_cycles(71_899), 72_000);
        assert_eq!(c.step_cycles(71_899 + 70_000), 70_000);
        assert_eq!(c.clamped(), 0);
        assert_eq!(c.step_cycles(71_899 + 70_000 + 10_000_000), 288_000);
        assert_eq!(c.clamped(), 1);
        assert_eq!(c.cycles_to_us(72_000), 1_000);
    }

    #[test]
    fn loop_stats_mean_worst_load() {
        let mut s = LoopStats::new(u32::MAX - 500);
        for c in [7_000u32, 9_000, 8_000, 20_000] {
            s.record(c);
        }
        // 4 runs over 88_000 cycles (across the wrap): load = 44000/88000.
        let r = s.report(87_499);
        assert_eq!(
            r,
            LoopReport {
                runs: 4,
                mean_cycles: 11_000,
                worst_cycles: 20_000,
                load_permille: 500
            }
        );
        let r2 = s.report(100_000);
        assert_eq!(r2, LoopReport::default());
        assert_eq!(s.worst_ever(), 20_000);
    }

    #[test]
    fn micros_clock_across_cycle_counter_wraps() {
        let start = u32::MAX - 1_000;
        let mut c = MicrosClock::new(72_000_000, start);
        let mut cyc = start;
        // 200 s in 10 ms steps: the cycle counter wraps three times.
        for _ in 0..20_000 {
            cyc = cyc.wrapping_add(720_000);
            c.now_us(cyc);
        }
        assert_eq!(c.now_us(cyc), 200_000_000);
    }

    #[test]
    fn watchdog_fed_only_on_progress() {
        let mut g = WatchdogGate::new();
        assert!(!g.should_feed(0));
        assert!(g.should_feed(5));
        assert!(!g.should_feed(5));
        assert!(g.should_feed(6));
        assert_eq!(g.starved(), 2);
    }
}
