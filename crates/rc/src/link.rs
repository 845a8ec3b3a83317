//! Pilot signal-loss detection.

use crate::ConfigError;

/// Default loss timeout for CRSF, µs.
///
/// ExpressLRS and Crossfire send channels at 50..1000 Hz (every 20..1 ms)
/// and stop sending when their own link fails. 100 ms is five frames at
/// the slowest rate: a couple of lost packets do not trip it, and a quad
/// falling for 100 ms has dropped 5 cm before the failsafe acts.
pub const CRSF_TIMEOUT_US: u32 = 100_000;

/// Default loss timeout for PPM, µs.
///
/// PPM frames come every ~20..22.5 ms (~45..50 Hz), and a frame counts only
/// when it confirms the previous one, so one glitch costs two frames. 100 ms
/// is four to five frames: a single glitch does not trip it.
pub const PPM_TIMEOUT_US: u32 = 100_000;

/// Why the link is considered lost, or that it is not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkStatus {
    /// A good frame arrived within the timeout.
    Ok,
    /// No good frame since start-up.
    NeverReceived,
    /// No good frame for longer than the timeout.
    TimedOut,
    /// The receiver reported 0 % uplink link quality (its failsafe).
    NoLinkQuality,
}

/// Tracks when the last good pilot frame arrived.
///
/// Feed it the time of every valid channel frame ([`LinkMonitor::on_frame`])
/// and, for CRSF, every link statistics report; ask [`LinkMonitor::is_lost`]
/// from the control loop. Times are wrapping µs counters; the monitor
/// latches the timeout, so it stays lost even after the µs counter wraps
/// around (71.6 minutes) as long as it is asked at least once per wrap.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkMonitor {
    timeout_us: u32,
    last_frame_us: Option<u32>,
    timed_out: bool,
    no_link_quality: bool,
    losses: u32,
}

impl LinkMonitor {
    /// A monitor that declares loss `timeout_us` after the last good frame.
    pub fn new(timeout_us: u32) -> Result<Self, ConfigError> {
        if timeout_us == 0 {
            return Err(ConfigError::ZeroTimeout);
        }
        Ok(Self {
            timeout_us,
            last_frame_us: None,
            timed_out: false,
            no_link_quality: false,
            losses: 0,
        })
    }

    /// A monitor with [`CRSF_TIMEOUT_US`].
    pub const fn crsf() -> Self {
        Self {
            timeout_us: CRSF_TIMEOUT_US,
            last_frame_us: None,
            timed_out: false,
            no_link_quality: false,
            losses: 0,
        }
    }

    /// A monitor with [`PPM_TIMEOUT_US`].
    pub const fn ppm() -> Self {
        let mut m = Self::crsf();
        m.timeout_us = PPM_TIMEOUT_US;
        m
    }

    /// The loss timeout, µs.
    pub fn timeout_us(&self) -> u32 {
        self.timeout_us
    }

    /// Records a valid channel frame received at `now_us`.
    pub fn on_frame(&mut self, now_us: u32) {
        self.last_frame_us = Some(now_us);
        self.timed_out = false;
    }

    /// Records the receiver's uplink link quality (CRSF link statistics).
    /// 0 % is the receiver's own failsafe: the link counts as lost until a
    /// report above 0 %, whatever the channel frames do (Crossfire keeps
    /// sending its failsafe channel values while the link is down).
    pub fn on_link_quality(&mut self, uplink_link_quality_pct: u8) {
        let lost = uplink_link_quality_pct == 0;
        if lost && !self.no_link_quality {
            self.losses = self.losses.saturating_add(1);
        }
        self.no_link_quality = lost;
    }

    /// Why the link is or is not lost at `now_us`.
    pub fn status(&mut self, now_us: u32) -> LinkStatus {
        let Some(last) = self.last_frame_us else {
            return LinkStatus::NeverReceived;
        };
        // A frame stamped slightly after `now_us` (the receive interrupt
        // pre-empted the caller between its clock read and this call) is a
        // negative age, i.e. fresh.
        let age = now_us.wrapping_sub(last);
        let fresh = age <= self.timeout_us || age > u32::MAX / 2;
        if !fresh && !self.timed_out {
            self.timed_out = true;
            self.losses = self.losses.saturating_add(1);
        }
        if self.timed_out {
            LinkStatus::TimedOut
        } else if self.no_link_quality {
            LinkStatus::NoLinkQuality
        } else {
            LinkStatus::Ok
        }
    }

    /// Whether the pilot link is lost at `now_us` (any status but
    /// [`LinkStatus::Ok`]).
    pub fn is_lost(&mut self, now_us: u32) -> bool {
        self.status(now_us) != LinkStatus::Ok
    }

    /// Times the link went from good to lost (timeout or 0 % LQ).
    pub fn losses(&self) -> u32 {
        self.losses
    }
}

impl Default for LinkMonitor {
    fn default() -> Self {
        Self::crsf()
    }
}
