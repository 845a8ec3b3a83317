//! PPM (pulse-position modulation, "CPPM", "PPM sum") decoding from timer
//! input-capture intervals.
//!
//! A PPM frame is a train of edges on one wire: the time between two
//! consecutive edges of the same polarity is one channel's pulse width
//! (about 1000..2000 µs), and a long gap with no edge (the sync gap)
//! separates frames. A typical 8-channel receiver repeats every 22.5 ms,
//! leaving a sync gap of at least 4 ms even with every stick at 2000 µs.
//!
//! Decoding rules, defaults in [`PpmConfig::DEFAULT`]:
//! * an interval longer than `sync_min_us` (2700 µs) is a sync gap: it ends
//!   the frame being received and starts the next one. No channel pulse is
//!   longer than 2250 µs, so 2700 µs cannot be a channel, and it is well
//!   below the ≥ 4 ms gap receivers leave;
//! * an interval inside `pulse_min_us..=pulse_max_us` (750..=2250 µs) is a
//!   channel; anything else (a glitch, a missed edge that merged two short
//!   pulses, an interval between 2250 and 2700 µs) drops the whole frame;
//! * a frame has 4..=16 channels, and it is delivered only when the frame
//!   before it was valid and had the same number of channels. A missed
//!   edge merges two channels into one long interval that may look like a
//!   sync gap; the two fragments it makes have channel counts that differ
//!   from the real frame's, so neither is delivered.

use crate::frame::{RcFrame, MAX_CHANNELS};
use crate::ConfigError;

/// Fewest channels a PPM frame may carry.
pub const MIN_PPM_CHANNELS: u8 = 4;

/// Interval thresholds of the PPM decoder, µs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PpmConfig {
    /// Shortest plausible channel interval, µs.
    pub pulse_min_us: u32,
    /// Longest plausible channel interval, µs.
    pub pulse_max_us: u32,
    /// An interval longer than this is a sync gap, µs.
    pub sync_min_us: u32,
}

impl PpmConfig {
    /// 750..=2250 µs channels, sync gap > 2700 µs.
    pub const DEFAULT: Self = Self {
        pulse_min_us: 750,
        pulse_max_us: 2250,
        sync_min_us: 2700,
    };

    /// Checks `0 < pulse_min_us < pulse_max_us < sync_min_us`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.pulse_min_us == 0
            || self.pulse_min_us >= self.pulse_max_us
            || self.pulse_max_us >= self.sync_min_us
        {
            return Err(ConfigError::PpmThresholds {
                pulse_min_us: self.pulse_min_us,
                pulse_max_us: self.pulse_max_us,
                sync_min_us: self.sync_min_us,
            });
        }
        Ok(())
    }
}

impl Default for PpmConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Counters of the PPM decoder; saturating.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PpmStats {
    /// Frames delivered.
    pub frames: u32,
    /// Frames dropped for an implausible interval.
    pub bad_pulse: u32,
    /// Frames dropped for a channel count outside 4..=16.
    pub bad_count: u32,
    /// Valid frames held back because the previous frame was invalid or
    /// had a different channel count.
    pub unconfirmed: u32,
}

impl PpmStats {
    /// Frames dropped for any reason.
    pub fn dropped(&self) -> u32 {
        self.bad_pulse
            .saturating_add(self.bad_count)
            .saturating_add(self.unconfirmed)
    }
}

fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

/// Streaming PPM decoder: feed it the interval between consecutive
/// captured edges of one polarity.
///
/// ```
/// use rc_input::ppm::PpmDecoder;
///
/// let mut ppm = PpmDecoder::new();
/// let frame = [1500, 1500, 1000, 1500, 2000, 1200, 1800, 1500];
/// for _ in 0..3 {
///     ppm.push_interval_us(10_000); // sync gap
///     for &ch in &frame {
///         ppm.push_interval_us(ch);
///     }
/// }
/// let got = ppm.push_interval_us(10_000);
/// assert_eq!(got.map(|f| f.count), Some(8));
/// ```
#[derive(Debug, Clone)]
pub struct PpmDecoder {
    config: PpmConfig,
    channels_us: [u16; MAX_CHANNELS],
    /// Channels received since the last sync; `None` before the first sync.
    received: Option<u8>,
    frame_bad: bool,
    /// Channel count of the previous frame if it was valid, else 0.
    previous_count: u8,
    stats: PpmStats,
}

impl Default for PpmDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl PpmDecoder {
    /// A decoder with [`PpmConfig::DEFAULT`].
    pub const fn new() -> Self {
        Self {
            config: PpmConfig::DEFAULT,
            channels_us: [0; MAX_CHANNELS],
            received: None,
            frame_bad: false,
            previous_count: 0,
            stats: PpmStats {
                frames: 0,
                bad_pulse: 0,
                bad_count: 0,
                unconfirmed: 0,
            },
        }
    }

    /// A decoder with custom thresholds, validated.
    pub fn with_config(config: PpmConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let mut d = Self::new();
        d.config = config;
        Ok(d)
    }

    /// The thresholds in use.
    pub fn config(&self) -> &PpmConfig {
        &self.config
    }

    /// Counters since creation.
    pub fn stats(&self) -> &PpmStats {
        &self.stats
    }

    /// Forgets the frame in progress and the previous frame's channel count
    /// (e.g. after a capture overflow, when an edge is known to be lost).
    pub fn clear(&mut self) {
        self.received = None;
        self.frame_bad = false;
        self.previous_count = 0;
    }

    /// Feeds the time between two consecutive captured edges, µs. Returns
    /// a frame when a sync gap completes a frame that passes every check.
    pub fn push_interval_us(&mut self, interval_us: u32) -> Option<RcFrame> {
        if interval_us > self.config.sync_min_us {
            let frame = self.finish_frame();
            self.received = Some(0);
            self.frame_bad = false;
            return frame;
        }
        let received = self.received?;
        if self.frame_bad {
            return None;
        }
        let plausible =
            (self.config.pulse_min_us..=self.config.pulse_max_us).contains(&interval_us);
        match (plausible, self.channels_us.get_mut(usize::from(received))) {
            (true, Some(slot)) => {
                // Plausible intervals are at most sync_min_us, far below u16::MAX.
                *slot = u16::try_from(interval_us).unwrap_or(u16::MAX);
                self.received = Some(received + 1);
            }
            (true, None) => {
                bump(&mut self.stats.bad_count);
                self.frame_bad = true;
            }
            (false, _) => {
                bump(&mut self.stats.bad_pulse);
                self.frame_bad = true;
            }
        }
        None
    }

    fn finish_frame(&mut self) -> Option<RcFrame> {
        let count = self.received?;
        let previous = core::mem::replace(&mut self.previous_count, 0);
        if self.frame_bad {
            return None;
        }
        if !(MIN_PPM_CHANNELS..=MAX_CHANNELS as u8).contains(&count) {
            bump(&mut self.stats.bad_count);
            return None;
        }
        self.previous_count = count;
        if previous != count {
            bump(&mut self.stats.unconfirmed);
            return None;
        }
        bump(&mut self.stats.frames);
        Some(RcFrame::new(self.channels_us, count))
    }
}

/// Coarse elapsed time (µs) from which a 16-bit capture difference is no
/// longer trusted: half the counter's 65 536 µs wrap. An interval comes out
/// exact while it plus the difference of the two interrupt latencies stays
/// below this (a 2.25 ms channel with up to 30 ms of latency), and a pause
/// of whole wraps is seen as long while the latencies differ by less than
/// 32 ms.
pub const CAPTURE_WRAP_GUARD_US: u32 = 32_768;

/// Intervals between input captures of a free-running 16-bit timer counting
/// at 1 MHz (0..=0xFFFF, wrapping every 65.536 ms), for
/// [`PpmDecoder::push_interval_us`].
///
/// Within one wrap the interval is the wrapping 16-bit difference of the
/// two captures, exact to the timer's tick. A longer pause (the receiver
/// unplugged and back) wraps the counter more than once, which the 16-bit
/// difference cannot see; a coarse clock read in the capture interrupt
/// tells the two apart: from [`CAPTURE_WRAP_GUARD_US`] on, the interval is
/// the coarse elapsed time, which is far longer than any channel pulse and
/// so is treated as the sync gap it is.
///
/// ```
/// use rc_input::ppm::CaptureIntervals;
///
/// let mut c = CaptureIntervals::new();
/// assert_eq!(c.push(65_000, 1_000), None); // first edge: no interval yet
/// assert_eq!(c.push(1_464, 3_000), Some(2_000)); // across the wrap
/// assert_eq!(c.push(1_464, 500_000), Some(497_000)); // long pause
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CaptureIntervals {
    /// The previous capture (timer ticks) and the coarse time it was read.
    last: Option<(u16, u32)>,
}

impl CaptureIntervals {
    /// No capture yet.
    pub const fn new() -> Self {
        Self { last: None }
    }

    /// A capture `capture_us` (the timer's 1 µs count) read at coarse time
    /// `now_us`: the interval since the previous capture, µs; `None` for
    /// the first capture (or the first after [`CaptureIntervals::restart`]).
    pub fn push(&mut self, capture_us: u16, now_us: u32) -> Option<u32> {
        let last = self.last.replace((capture_us, now_us));
        let (prev_capture, prev_now) = last?;
        let coarse_us = now_us.wrapping_sub(prev_now);
        if coarse_us >= CAPTURE_WRAP_GUARD_US {
            return Some(coarse_us);
        }
        Some(u32::from(capture_us.wrapping_sub(prev_capture)))
    }

    /// Forgets the previous capture: the next interval would span an edge
    /// the timer lost (an over-capture).
    pub fn restart(&mut self) {
        self.last = None;
    }
}
