//! Pilot signal-loss detection and the recovery window.
//!
//! The rules, with their defaults:
//!
//! * **Loss**: no valid channel frame for longer than the timeout
//!   ([`CRSF_TIMEOUT_US`], [`PPM_TIMEOUT_US`]: 100 ms), or the receiver's
//!   own failsafe (CRSF link statistics with 0 % uplink link quality).
//! * **Recovery**: the link counts as up again only after frames have
//!   arrived without a break for [`LINK_RECOVERY_US`] (0.5 s): every gap
//!   between two frames at most the timeout, and no 0 % link quality in
//!   between. The same holds for the first link-up after power-on. Until
//!   then the status is [`LinkStatus::Recovering`] and the link counts as
//!   lost, so neither control nor arming comes back on the first good frame
//!   (Betaflight asks for the same 0.5 s of valid data before it leaves
//!   failsafe). A link flapping 100 ms on / 100 ms off (each off gap longer
//!   than the 100 ms timeout) therefore never gives control back.

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

/// Default recovery window, µs: frames must arrive without a break (each
/// gap at most the timeout) for this long before a link that was lost, or
/// never up, counts as up again.
///
/// 0.5 s is Betaflight's default (`failsafe_recovery_delay` = 5 × 0.1 s)
/// and 125 frames at ExpressLRS' common 250 Hz, 25 at a 50 Hz PPM
/// receiver: long enough that a link at the edge of its range, which
/// drops out for more than the timeout every few hundred ms, never hands
/// the sticks back, short enough that a pilot waits half a second.
pub const LINK_RECOVERY_US: u32 = 500_000;

/// Why the link is considered lost, or that it is not (the log says it in
/// words).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkStatus {
    /// A good frame arrived within the timeout.
    Ok,
    /// No good frame since start-up.
    NeverReceived,
    /// No good frame for longer than the timeout.
    TimedOut,
    /// The receiver reported 0 % uplink link quality (its failsafe).
    NoLinkQuality,
    /// Frames arrive, but not yet without a break for the recovery window
    /// ([`LINK_RECOVERY_US`] by default): still lost for control and
    /// arming.
    Recovering,
}

#[cfg(feature = "defmt")]
impl defmt::Format for LinkStatus {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Self::Ok => defmt::write!(f, "up"),
            Self::NeverReceived => defmt::write!(f, "no frame since start-up"),
            Self::TimedOut => defmt::write!(f, "no good frame within the timeout"),
            Self::NoLinkQuality => {
                defmt::write!(f, "the receiver reports 0 % link quality (its failsafe)")
            }
            Self::Recovering => {
                defmt::write!(f, "frames again, not yet for the whole recovery window")
            }
        }
    }
}

/// Where the current unbroken run of frames stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Run {
    /// No run: no frame yet, or the last frame came during 0 % link
    /// quality.
    None,
    /// Frames without a break since this time (µs).
    Since(u32),
    /// The run has lasted the recovery window (latched, so the µs counter
    /// wrapping around cannot undo it).
    Established,
}

/// Tracks when the last good pilot frame arrived, and since when frames
/// have arrived without a break (the module documentation has the rules).
///
/// Feed it the time of every valid channel frame ([`LinkMonitor::on_frame`])
/// and, for CRSF, every link statistics report; ask [`LinkMonitor::is_lost`]
/// from the control loop. Times are wrapping µs counters; the monitor
/// latches the timeout, so it stays lost even after the µs counter wraps
/// around (71.6 minutes) as long as it is asked at least once per wrap. A
/// gap longer than the timeout between two frames restarts the recovery
/// window even if nobody asked during the gap.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkMonitor {
    timeout_us: u32,
    recovery_us: u32,
    run: Run,
    last_frame_us: Option<u32>,
    timed_out: bool,
    no_link_quality: bool,
    losses: u32,
}

impl LinkMonitor {
    /// A monitor that declares loss `timeout_us` after the last good frame,
    /// with the default recovery window ([`LINK_RECOVERY_US`]).
    pub fn new(timeout_us: u32) -> Result<Self, ConfigError> {
        if timeout_us == 0 {
            return Err(ConfigError::ZeroTimeout);
        }
        let mut m = Self::crsf();
        m.timeout_us = timeout_us;
        Ok(m)
    }

    /// The same monitor with a recovery window of `recovery_us` (0: the
    /// first good frame gives the link back).
    pub const fn with_recovery_us(mut self, recovery_us: u32) -> Self {
        self.recovery_us = recovery_us;
        self
    }

    /// A monitor with [`CRSF_TIMEOUT_US`] and [`LINK_RECOVERY_US`].
    pub const fn crsf() -> Self {
        Self {
            timeout_us: CRSF_TIMEOUT_US,
            recovery_us: LINK_RECOVERY_US,
            run: Run::None,
            last_frame_us: None,
            timed_out: false,
            no_link_quality: false,
            losses: 0,
        }
    }

    /// A monitor with [`PPM_TIMEOUT_US`] and [`LINK_RECOVERY_US`].
    pub const fn ppm() -> Self {
        let mut m = Self::crsf();
        m.timeout_us = PPM_TIMEOUT_US;
        m
    }

    /// The loss timeout, µs.
    pub fn timeout_us(&self) -> u32 {
        self.timeout_us
    }

    /// The recovery window, µs.
    pub fn recovery_us(&self) -> u32 {
        self.recovery_us
    }

    /// Records a valid channel frame received at `now_us`: it continues the
    /// current run of frames if it came within the timeout of the one
    /// before (and no loss was declared since), else it starts a new run.
    /// Frames during 0 % link quality start no run.
    pub fn on_frame(&mut self, now_us: u32) {
        let gap_ok = self
            .last_frame_us
            .is_some_and(|last| self.fresh(last, now_us));
        if !gap_ok && !self.timed_out && self.last_frame_us.is_some() {
            // A timeout nobody asked about during the gap.
            self.losses = self.losses.saturating_add(1);
        }
        self.run = if self.no_link_quality {
            Run::None
        } else if !gap_ok || self.timed_out || self.run == Run::None {
            Run::Since(now_us)
        } else {
            self.run
        };
        self.last_frame_us = Some(now_us);
        self.timed_out = false;
        self.settle_run(now_us);
    }

    /// Whether a frame at `last_us` is within the timeout at `now_us`. A
    /// frame stamped slightly after `now_us` (the receive interrupt
    /// pre-empted the caller between its clock read and this call) is a
    /// negative age, i.e. fresh.
    fn fresh(&self, last_us: u32, now_us: u32) -> bool {
        let age = now_us.wrapping_sub(last_us);
        age <= self.timeout_us || age > u32::MAX / 2
    }

    /// Latches the run as established once it has lasted the window.
    fn settle_run(&mut self, now_us: u32) {
        if let Run::Since(start) = self.run {
            let age = now_us.wrapping_sub(start);
            if age >= self.recovery_us && age <= u32::MAX / 2 {
                self.run = Run::Established;
            }
        }
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
        if lost {
            // The recovery window starts again with the first frame after
            // the receiver reports a link again.
            self.run = Run::None;
        }
        self.no_link_quality = lost;
    }

    /// Why the link is or is not lost at `now_us`.
    pub fn status(&mut self, now_us: u32) -> LinkStatus {
        let Some(last) = self.last_frame_us else {
            return LinkStatus::NeverReceived;
        };
        if !self.fresh(last, now_us) && !self.timed_out {
            self.timed_out = true;
            self.run = Run::None;
            self.losses = self.losses.saturating_add(1);
        }
        self.settle_run(now_us);
        if self.timed_out {
            LinkStatus::TimedOut
        } else if self.no_link_quality {
            LinkStatus::NoLinkQuality
        } else if self.run == Run::Established {
            LinkStatus::Ok
        } else {
            LinkStatus::Recovering
        }
    }

    /// Whether the pilot link is lost at `now_us` (any status but
    /// [`LinkStatus::Ok`]).
    pub fn is_lost(&mut self, now_us: u32) -> bool {
        self.status(now_us) != LinkStatus::Ok
    }

    /// Timeouts (a frame, then none for longer than the timeout, whether
    /// or not the link had recovered in between) plus reports of 0 % link
    /// quality that followed a good one.
    pub fn losses(&self) -> u32 {
        self.losses
    }
}

impl Default for LinkMonitor {
    fn default() -> Self {
        Self::crsf()
    }
}
