//! Which telemetry frame goes out after which RC frame, and the rates and
//! wire time that follow.

use super::frames::{
    encode_attitude, encode_baro_altitude, encode_battery, encode_flight_mode, Attitude,
    BaroAltitude, Battery, FlightMode, FRAME_TYPE_ATTITUDE, FRAME_TYPE_BARO_ALTITUDE,
    FRAME_TYPE_BATTERY_SENSOR, FRAME_TYPE_FLIGHT_MODE, MAX_TELEMETRY_FRAME_BYTES,
};
use crate::crsf::{CRSF_BAUD, MAX_FRAME_BYTES, RC_CHANNELS_PAYLOAD_BYTES};

/// The telemetry frames the scheduler sends, in Betaflight's schedule
/// order (attitude, barometric altitude, battery, flight mode).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameKind {
    /// Attitude (0x1E).
    Attitude,
    /// Barometric altitude and vertical speed (0x09).
    BaroAltitude,
    /// Battery sensor (0x08).
    Battery,
    /// Flight mode text (0x21).
    FlightMode,
}

impl FrameKind {
    /// Every kind, in schedule order.
    pub const ALL: [FrameKind; 4] = [
        Self::Attitude,
        Self::BaroAltitude,
        Self::Battery,
        Self::FlightMode,
    ];

    /// The CRSF frame type byte.
    pub const fn frame_type(self) -> u8 {
        match self {
            Self::Attitude => FRAME_TYPE_ATTITUDE,
            Self::BaroAltitude => FRAME_TYPE_BARO_ALTITUDE,
            Self::Battery => FRAME_TYPE_BATTERY_SENSOR,
            Self::FlightMode => FRAME_TYPE_FLIGHT_MODE,
        }
    }

    const fn bit(self) -> u8 {
        1 << (self as u8)
    }
}

/// A set of [`FrameKind`]s: the frames a scheduler may send.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FrameSet(u8);

impl FrameSet {
    /// No frame.
    pub const NONE: Self = Self(0);
    /// All four frames.
    pub const ALL: Self = Self(0b1111);

    /// This set and `kind`.
    pub const fn with(self, kind: FrameKind) -> Self {
        Self(self.0 | kind.bit())
    }

    /// This set without `kind`.
    pub const fn without(self, kind: FrameKind) -> Self {
        Self(self.0 & !kind.bit())
    }

    /// Whether `kind` is in the set.
    pub const fn contains(self, kind: FrameKind) -> bool {
        self.0 & kind.bit() != 0
    }

    /// How many kinds the set holds.
    pub const fn count(self) -> u32 {
        self.0.count_ones()
    }
}

/// What the flight controller knows at the moment a telemetry frame is
/// built. A `None` field's frame is skipped (its slot goes to the next
/// frame in the schedule): no battery measured, no barometer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TelemetrySnapshot {
    /// The attitude estimate.
    pub attitude: Attitude,
    /// Height and vertical speed from the barometer, if there is one.
    pub baro: Option<BaroAltitude>,
    /// The battery, if measured.
    pub battery: Option<Battery>,
    /// Flight mode and arming state.
    pub flight_mode: FlightMode,
}

impl TelemetrySnapshot {
    /// Encodes the frame of `kind` into `out`; its size, or `None` when
    /// the snapshot lacks that frame's data.
    pub fn encode(&self, kind: FrameKind, out: &mut [u8; MAX_FRAME_BYTES]) -> Option<usize> {
        match kind {
            FrameKind::Attitude => Some(encode_attitude(&self.attitude, out)),
            FrameKind::BaroAltitude => self.baro.map(|b| encode_baro_altitude(&b, out)),
            FrameKind::Battery => self.battery.map(|b| encode_battery(&b, out)),
            FrameKind::FlightMode => Some(encode_flight_mode(&self.flight_mode, out)),
        }
    }
}

/// Betaflight's telemetry cycle (`CRSF_CYCLETIME_US`), µs: every enabled
/// frame at most once per 100 ms, so consecutive frames are at least
/// 100 ms / (number of enabled frames) apart.
pub const TELEMETRY_CYCLE_US: u32 = 100_000;

/// Time on the wire of `bytes` at [`CRSF_BAUD`] 8N1 (10 bits a byte), µs,
/// rounded up.
pub const fn wire_time_us(bytes: usize) -> u32 {
    let bits = bytes as u64 * 10;
    ((bits * 1_000_000).div_ceil(CRSF_BAUD as u64)) as u32
}

/// An RC channels frame on the wire: sync, length, type, 22 bytes, CRC.
pub const RC_FRAME_BYTES: usize = RC_CHANNELS_PAYLOAD_BYTES + 4;

/// Shortest RC frame period a CRSF receiver sends, µs: ExpressLRS's
/// 1000 Hz packet rate.
pub const FASTEST_RC_PERIOD_US: u32 = 1_000;

/// Time left in the fastest RC period after an RC frame (620 µs) and the
/// longest telemetry frame (286 µs), µs: 94 µs for the flight
/// controller's reaction from the RC frame's end to the telemetry frame's
/// start. On the receiver link's two wires the two frames do not share a
/// line; fitting the telemetry frame between RC frames is the
/// half-duplex rule (the TBS specification's single-wire link), kept
/// here so a frame never waits behind the next slot.
pub const SLOT_MARGIN_US: u32 =
    FASTEST_RC_PERIOD_US - wire_time_us(RC_FRAME_BYTES) - wire_time_us(MAX_TELEMETRY_FRAME_BYTES);

// The longest telemetry frame fits between two RC frames at 1000 Hz
// (evaluated by the compiler: `SLOT_MARGIN_US` above would not build
// either).
const _: () = assert!(
    wire_time_us(RC_FRAME_BYTES) + wire_time_us(MAX_TELEMETRY_FRAME_BYTES) < FASTEST_RC_PERIOD_US
);

/// The rate each of `frames` scheduled frames reaches, mHz, when RC frames
/// come every `rc_period_us` without a miss and the scheduler keeps
/// `min_interval_us` between telemetry frames: a frame goes out after
/// every `⌈min_interval / rc_period⌉`-th RC frame (at least every one),
/// and the frames take turns.
///
/// With the four frames and Betaflight's 25 ms: 25 Hz RC (40 ms) → every
/// RC frame → 6 250 mHz each; 50 Hz (20 ms) → every 2nd → 6 250 mHz;
/// 150 Hz (6 667 µs) → every 4th → 9 374 mHz; 250 Hz → every 7th →
/// 8 928 mHz; 500 Hz → every 13th → 9 615 mHz; 1000 Hz → every 25th →
/// 10 000 mHz (rounded down). Below 25 Hz each frame gets a quarter of the
/// RC rate (TBS Crossfire's 4 Hz mode: 1 Hz).
pub const fn per_frame_rate_mhz(rc_period_us: u32, frames: u32, min_interval_us: u32) -> u32 {
    if rc_period_us == 0 || frames == 0 {
        return 0;
    }
    let every = if min_interval_us > rc_period_us {
        min_interval_us.div_ceil(rc_period_us)
    } else {
        1
    };
    let cycle_us = every as u64 * rc_period_us as u64 * frames as u64;
    (1_000_000_000 / cycle_us) as u32
}

/// Betaflight's CRSF telemetry schedule: after a received RC frame (the
/// receiver's cue that the flight controller may answer), at most one
/// telemetry frame, the enabled frames in turn, and at least
/// `min_interval_us` between two frames (by default Betaflight's
/// [`TELEMETRY_CYCLE_US`] divided among the enabled frames).
///
/// The caller sends the returned bytes on the receiver's RX line (USART
/// TX) and calls only when the previous frame has left: a frame is at most
/// [`MAX_TELEMETRY_FRAME_BYTES`] (286 µs), far less than the interval.
/// How many frames reach the radio is the link's telemetry ratio, set in
/// the receiver; an ExpressLRS receiver queues one frame per broadcast
/// type and replaces it with a newer one (`RXOTAConnector::forwardMessage`),
/// so a faster schedule than the link carries loses old values, not new
/// ones.
///
/// ```
/// use rc_input::telemetry::{FrameSet, TelemetryScheduler, TelemetrySnapshot};
///
/// let mut sched = TelemetryScheduler::new(FrameSet::ALL);
/// let snapshot = TelemetrySnapshot::default(); // no barometer, no battery
/// let mut out = [0u8; 64];
/// // RC frames at 50 Hz: the attitude frame at once, 20 ms later nothing
/// // (25 ms not yet over), 40 ms later the flight mode frame.
/// assert_eq!(sched.on_rc_frame(0, &snapshot, &mut out), Some(10));
/// assert_eq!(out[2], 0x1E);
/// assert_eq!(sched.on_rc_frame(20_000, &snapshot, &mut out), None);
/// assert!(sched.on_rc_frame(40_000, &snapshot, &mut out).is_some());
/// assert_eq!(out[2], 0x21);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TelemetryScheduler {
    enabled: FrameSet,
    min_interval_us: u32,
    /// Index in [`FrameKind::ALL`] of the next frame to try.
    next: u8,
    last_sent_us: Option<u32>,
}

impl TelemetryScheduler {
    /// A scheduler for `enabled` with Betaflight's spacing:
    /// [`TELEMETRY_CYCLE_US`] / the number of enabled frames (25 ms for
    /// four).
    pub const fn new(enabled: FrameSet) -> Self {
        let n = if enabled.count() == 0 {
            1
        } else {
            enabled.count()
        };
        Self::with_min_interval_us(enabled, TELEMETRY_CYCLE_US / n)
    }

    /// A scheduler for `enabled` that keeps at least `min_interval_us`
    /// between frames (0: one frame after every RC frame).
    pub const fn with_min_interval_us(enabled: FrameSet, min_interval_us: u32) -> Self {
        Self {
            enabled,
            min_interval_us,
            next: 0,
            last_sent_us: None,
        }
    }

    /// The least time between two frames, µs.
    pub const fn min_interval_us(&self) -> u32 {
        self.min_interval_us
    }

    /// Called when a valid frame from the receiver has been received at
    /// `now_us` (µs, wrapping): an RC channels frame, which sets the rates
    /// stated at [`per_frame_rate_mhz`] (Betaflight answers any CRC-valid
    /// frame; the interval keeps link statistics frames from adding
    /// more). Returns the size of the frame written to `out`, to be sent
    /// now, or `None` when it is not yet time or no enabled frame has data
    /// in `snapshot`.
    pub fn on_rc_frame(
        &mut self,
        now_us: u32,
        snapshot: &TelemetrySnapshot,
        out: &mut [u8; MAX_FRAME_BYTES],
    ) -> Option<usize> {
        if let Some(last) = self.last_sent_us {
            if now_us.wrapping_sub(last) < self.min_interval_us {
                return None;
            }
        }
        let kinds = FrameKind::ALL.len();
        for step in 0..kinds {
            let i = (usize::from(self.next) + step) % kinds;
            let Some(&kind) = FrameKind::ALL.get(i) else {
                continue;
            };
            if !self.enabled.contains(kind) {
                continue;
            }
            if let Some(len) = snapshot.encode(kind, out) {
                self.next = ((i + 1) % kinds) as u8;
                self.last_sent_us = Some(now_us);
                return Some(len);
            }
        }
        None
    }
}
