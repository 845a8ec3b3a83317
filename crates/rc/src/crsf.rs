//! CRSF (TBS Crossfire / ExpressLRS) receiver-to-flight-controller frames.
//!
//! Wire format (420 000 baud, 8N1, no inversion):
//!
//! ```text
//! [address] [length] [type] [payload ...] [crc]
//!            \______ length counts type + payload + crc (2..=62) ______/
//! ```
//!
//! The CRC is CRC-8/DVB-S2 ([`crate::crc8_dvb_s2`]) over type and payload.
//! A frame is at most 64 bytes on the wire.

use crate::crc::crc8_dvb_s2;
use crate::frame::{RcFrame, MAX_CHANNELS};

/// UART speed of a CRSF receiver link (8 data bits, no parity, 1 stop bit).
pub const CRSF_BAUD: u32 = 420_000;

/// Address byte of frames sent to a flight controller (CRSF "sync" byte).
pub const ADDRESS_FLIGHT_CONTROLLER: u8 = 0xC8;
/// Address of a radio handset; some receivers use it when forwarding.
pub const ADDRESS_RADIO_TRANSMITTER: u8 = 0xEA;
/// Address of a CRSF transmitter module; some receivers send it.
pub const ADDRESS_CRSF_TRANSMITTER: u8 = 0xEE;

/// Frame type of packed RC channels (16 × 11 bit).
pub const FRAME_TYPE_RC_CHANNELS_PACKED: u8 = 0x16;
/// Frame type of link statistics (RSSI, LQ, SNR, RF mode, power).
pub const FRAME_TYPE_LINK_STATISTICS: u8 = 0x14;

/// Smallest legal length byte: type + CRC, no payload.
pub const MIN_LENGTH_BYTE: u8 = 2;
/// Largest legal length byte (the whole frame is then 64 bytes).
pub const MAX_LENGTH_BYTE: u8 = 62;
/// Largest frame on the wire: address + length byte + 62.
pub const MAX_FRAME_BYTES: usize = MAX_LENGTH_BYTE as usize + 2;

/// Payload bytes of [`FRAME_TYPE_RC_CHANNELS_PACKED`]: 16 × 11 bit.
pub const RC_CHANNELS_PAYLOAD_BYTES: usize = 22;
/// Payload bytes of [`FRAME_TYPE_LINK_STATISTICS`].
pub const LINK_STATISTICS_PAYLOAD_BYTES: usize = 10;

/// Time on the wire of one byte at [`CRSF_BAUD`] (start, 8 data, stop
/// bit), ns: 23 809 (23.8 µs).
pub const BYTE_TIME_NS: u32 = (10_000_000_000 / CRSF_BAUD as u64) as u32;

/// Default longest time from a frame's first byte to its last, µs: a
/// candidate frame not complete by then is abandoned, and its later bytes
/// are searched for a new frame start.
///
/// Betaflight's `CRSF_TIME_NEEDED_PER_FRAME_US`. The largest frame, 64
/// bytes, takes 1 524 µs on the wire, so pauses inside a frame may add up
/// to 226 µs for a 64-byte frame, 1 131 µs for a 26-byte channel frame
/// (619 µs on the wire) and 1 417 µs for a 14-byte link statistics frame:
/// a receiver that pauses for a few byte times mid-frame, or a DMA
/// handover split, does not lose the frame. A frame torn by noise or a
/// receiver reboot is dropped before the next one at up to 500 Hz
/// (ExpressLRS sends every 2 to 20 ms at 500..50 Hz); at 1000 Hz the next
/// frame begins within the limit, and the CRC check alone resynchronises.
pub const DEFAULT_MAX_FRAME_TIME_US: u32 = 1_750;

/// Channel value at the low stick end, CRSF ticks (988 µs).
pub const TICKS_MIN: u16 = 172;
/// Channel value at centre, CRSF ticks (1500 µs).
pub const TICKS_MID: u16 = 992;
/// Channel value at the high stick end, CRSF ticks (2012 µs).
pub const TICKS_MAX: u16 = 1811;

/// Converts an 11-bit CRSF channel value to a pulse width in µs.
///
/// The CRSF specification's `(x - 992) * 5 / 8 + 1500`, rounded to the
/// nearest µs (halves upward), so the ends 172 and 1811 land on 988 and
/// 2012 µs. Values above 2047 are masked to 11 bits.
///
/// ```
/// use rc_input::crsf::ticks_to_us;
/// assert_eq!(ticks_to_us(172), 988);
/// assert_eq!(ticks_to_us(992), 1500);
/// assert_eq!(ticks_to_us(1811), 2012);
/// ```
pub fn ticks_to_us(ticks: u16) -> u16 {
    let x = i32::from(ticks & 0x7FF);
    let us = ((x - 992) * 5 + 4).div_euclid(8) + 1500;
    // 0..=2047 ticks map to 880..=2159 µs, always inside u16.
    u16::try_from(us).unwrap_or(0)
}

/// Converts a pulse width in µs to the nearest CRSF channel value,
/// clamped to 0..=2047 (the inverse of [`ticks_to_us`] on 988..=2012 µs).
pub fn us_to_ticks(us: u16) -> u16 {
    let x = (i32::from(us) - 1500) * 8;
    // Round half away from zero so ticks_to_us(us_to_ticks(u)) == u.
    let t = if x >= 0 { (x + 2) / 5 } else { (x - 2) / 5 } + 992;
    u16::try_from(t.clamp(0, 2047)).unwrap_or(0)
}

/// Unpacks 16 little-endian bit-packed 11-bit channel values (channel 1
/// in the low bits of the first byte).
pub fn unpack_channels(payload: &[u8; RC_CHANNELS_PAYLOAD_BYTES]) -> [u16; MAX_CHANNELS] {
    let mut out = [0u16; MAX_CHANNELS];
    let mut acc: u32 = 0;
    let mut bits: u32 = 0;
    let mut slots = out.iter_mut();
    for &byte in payload {
        acc |= u32::from(byte) << bits;
        bits += 8;
        if bits >= 11 {
            if let Some(slot) = slots.next() {
                *slot = (acc & 0x7FF) as u16;
            }
            acc >>= 11;
            bits -= 11;
        }
    }
    out
}

/// Packs 16 channel values (11 bits each, higher bits ignored) the way
/// [`unpack_channels`] reads them.
pub fn pack_channels(ticks: &[u16; MAX_CHANNELS]) -> [u8; RC_CHANNELS_PAYLOAD_BYTES] {
    let mut out = [0u8; RC_CHANNELS_PAYLOAD_BYTES];
    let mut acc: u32 = 0;
    let mut bits: u32 = 0;
    let mut bytes = out.iter_mut();
    for &t in ticks {
        acc |= u32::from(t & 0x7FF) << bits;
        bits += 11;
        while bits >= 8 {
            if let Some(b) = bytes.next() {
                *b = (acc & 0xFF) as u8;
            }
            acc >>= 8;
            bits -= 8;
        }
    }
    out
}

/// Builds a complete RC_CHANNELS_PACKED frame (26 bytes) from channel
/// values in ticks: for simulators, tests and loopback checks.
pub fn encode_rc_channels(address: u8, ticks: &[u16; MAX_CHANNELS]) -> [u8; 26] {
    let mut frame = [0u8; 26];
    frame[0] = address;
    frame[1] = (RC_CHANNELS_PAYLOAD_BYTES + 2) as u8;
    frame[2] = FRAME_TYPE_RC_CHANNELS_PACKED;
    frame[3..25].copy_from_slice(&pack_channels(ticks));
    frame[25] = crc8_dvb_s2(&frame[2..25]);
    frame
}

/// Builds a complete LINK_STATISTICS frame (14 bytes).
pub fn encode_link_statistics(address: u8, stats: &LinkStatistics) -> [u8; 14] {
    let mut frame = [0u8; 14];
    frame[0] = address;
    frame[1] = (LINK_STATISTICS_PAYLOAD_BYTES + 2) as u8;
    frame[2] = FRAME_TYPE_LINK_STATISTICS;
    frame[3..13].copy_from_slice(&stats.to_payload());
    frame[13] = crc8_dvb_s2(&frame[2..13]);
    frame
}

/// Link quality and signal figures a receiver reports (frame type 0x14).
///
/// "Uplink" is handset → receiver (the pilot's commands), "downlink" is
/// receiver → handset (telemetry). RSSI is sent as a positive byte meaning
/// −dBm and is stored here in dBm (≤ 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkStatistics {
    /// Uplink RSSI at antenna 1, dBm.
    pub uplink_rssi_ant1_dbm: i16,
    /// Uplink RSSI at antenna 2, dBm.
    pub uplink_rssi_ant2_dbm: i16,
    /// Uplink link quality: share of packets received, %.
    pub uplink_link_quality_pct: u8,
    /// Uplink signal-to-noise ratio, dB.
    pub uplink_snr_db: i8,
    /// Antenna in use (0 = antenna 1, 1 = antenna 2).
    pub active_antenna: u8,
    /// RF mode index (packet rate; meaning depends on the system).
    pub rf_mode: u8,
    /// Transmitter power index (see [`LinkStatistics::uplink_tx_power_mw`]).
    pub uplink_tx_power_index: u8,
    /// Downlink RSSI, dBm.
    pub downlink_rssi_dbm: i16,
    /// Downlink link quality, %.
    pub downlink_link_quality_pct: u8,
    /// Downlink signal-to-noise ratio, dB.
    pub downlink_snr_db: i8,
}

/// Transmitter power for each CRSF power index, mW.
const TX_POWER_MW: [u16; 9] = [0, 10, 25, 100, 500, 1000, 2000, 250, 50];

fn rssi_dbm(byte: u8) -> i16 {
    -i16::from(byte)
}

fn rssi_byte(dbm: i16) -> u8 {
    u8::try_from(dbm.saturating_neg().clamp(0, 255)).unwrap_or(u8::MAX)
}

impl LinkStatistics {
    /// Decodes the 10-byte payload.
    pub fn from_payload(p: &[u8; LINK_STATISTICS_PAYLOAD_BYTES]) -> Self {
        Self {
            uplink_rssi_ant1_dbm: rssi_dbm(p[0]),
            uplink_rssi_ant2_dbm: rssi_dbm(p[1]),
            uplink_link_quality_pct: p[2],
            uplink_snr_db: p[3] as i8,
            active_antenna: p[4],
            rf_mode: p[5],
            uplink_tx_power_index: p[6],
            downlink_rssi_dbm: rssi_dbm(p[7]),
            downlink_link_quality_pct: p[8],
            downlink_snr_db: p[9] as i8,
        }
    }

    /// Encodes the 10-byte payload (RSSI clamped to 0..=−255 dBm).
    pub fn to_payload(&self) -> [u8; LINK_STATISTICS_PAYLOAD_BYTES] {
        [
            rssi_byte(self.uplink_rssi_ant1_dbm),
            rssi_byte(self.uplink_rssi_ant2_dbm),
            self.uplink_link_quality_pct,
            self.uplink_snr_db as u8,
            self.active_antenna,
            self.rf_mode,
            self.uplink_tx_power_index,
            rssi_byte(self.downlink_rssi_dbm),
            self.downlink_link_quality_pct,
            self.downlink_snr_db as u8,
        ]
    }

    /// Transmitter power in mW, or `None` for an index the specification
    /// does not define.
    pub fn uplink_tx_power_mw(&self) -> Option<u16> {
        TX_POWER_MW
            .get(usize::from(self.uplink_tx_power_index))
            .copied()
    }

    /// RSSI of the antenna in use, dBm.
    pub fn uplink_rssi_dbm(&self) -> i16 {
        if self.active_antenna == 1 {
            self.uplink_rssi_ant2_dbm
        } else {
            self.uplink_rssi_ant1_dbm
        }
    }
}

/// What a complete, CRC-checked frame carried.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// 16 channels, converted to µs.
    Channels(RcFrame),
    /// Link statistics.
    LinkStatistics(LinkStatistics),
}

/// Counters of everything the parser accepted or threw away.
///
/// All counters saturate at `u32::MAX` instead of wrapping.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CrsfStats {
    /// RC channel frames delivered.
    pub rc_frames: u32,
    /// Link statistics frames delivered.
    pub link_statistics_frames: u32,
    /// Frames with a valid CRC but a type this parser does not decode
    /// (telemetry, commands, device info, ...).
    pub unknown_type: u32,
    /// Frames dropped for a CRC mismatch.
    pub crc_errors: u32,
    /// Length bytes outside 2..=62 (the start was taken as garbage).
    pub bad_length: u32,
    /// Frames of a known type whose payload had the wrong size.
    pub bad_payload_length: u32,
    /// Partial frames (or false starts) abandoned because their last byte
    /// had not arrived within the frame time of their first.
    pub frame_timeouts: u32,
    /// Bytes skipped while looking for an address byte.
    pub skipped_bytes: u32,
}

impl CrsfStats {
    /// All counters at zero (what `Default` gives, usable in `const fn`s).
    pub const ZERO: Self = Self {
        rc_frames: 0,
        link_statistics_frames: 0,
        unknown_type: 0,
        crc_errors: 0,
        bad_length: 0,
        bad_payload_length: 0,
        frame_timeouts: 0,
        skipped_bytes: 0,
    };

    /// Frames dropped for any reason (CRC, length, payload size, frame
    /// time).
    pub fn dropped(&self) -> u32 {
        self.crc_errors
            .saturating_add(self.bad_length)
            .saturating_add(self.bad_payload_length)
            .saturating_add(self.frame_timeouts)
    }
}

fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

/// Whether `byte` may start a frame addressed to a flight controller.
pub fn is_address(byte: u8) -> bool {
    matches!(
        byte,
        ADDRESS_FLIGHT_CONTROLLER | ADDRESS_RADIO_TRANSMITTER | ADDRESS_CRSF_TRANSMITTER
    )
}

/// Byte-at-a-time CRSF frame parser, meant to be fed from a USART receive
/// interrupt.
///
/// It keeps the bytes of the frame in progress (at most 64). When a
/// candidate frame fails (length byte out of range, CRC mismatch) only its
/// first byte is discarded and the remaining buffered bytes are searched
/// again, so a valid frame that follows garbage containing an address byte
/// is still found. The cost of that search is bounded by the buffer: at
/// most 64 candidate starts, each checked once.
///
/// Each byte is stamped with its arrival time (`now_us`, a wrapping µs
/// counter), which keeps the parser pure and testable. A frame is accepted
/// when its last byte arrived at most the frame time (default
/// [`DEFAULT_MAX_FRAME_TIME_US`], 1 750 µs) after its first, whatever the
/// pauses between its bytes; a candidate still incomplete that long after
/// its first byte is abandoned (counted in [`CrsfStats::frame_timeouts`]).
///
/// ```
/// use rc_input::crsf::{encode_rc_channels, CrsfParser, Event, ADDRESS_FLIGHT_CONTROLLER};
///
/// let bytes = encode_rc_channels(ADDRESS_FLIGHT_CONTROLLER, &[992; 16]);
/// let mut parser = CrsfParser::new();
/// let mut events = bytes.iter().enumerate().filter_map(|(i, &b)| parser.push(b, 24 * i as u32));
/// match events.next() {
///     Some(Event::Channels(frame)) => assert_eq!(frame.channels_us, [1500; 16]),
///     other => panic!("{other:?}"),
/// }
/// ```
#[derive(Debug, Clone)]
pub struct CrsfParser {
    buf: [u8; MAX_FRAME_BYTES],
    /// When each byte in `buf` arrived, µs.
    arrived_us: [u32; MAX_FRAME_BYTES],
    start: usize,
    end: usize,
    max_frame_time_us: u32,
    stats: CrsfStats,
}

impl Default for CrsfParser {
    fn default() -> Self {
        Self::new()
    }
}

impl CrsfParser {
    /// A parser with the default frame time
    /// ([`DEFAULT_MAX_FRAME_TIME_US`]).
    pub const fn new() -> Self {
        Self::with_max_frame_time_us(DEFAULT_MAX_FRAME_TIME_US)
    }

    /// A parser that abandons a candidate frame whose last byte has not
    /// arrived `max_frame_time_us` after its first. `u32::MAX` disables the
    /// rule (for bytes with no arrival times, e.g. a file). A caller
    /// draining a DMA buffer stamps each byte with an upper bound of its
    /// arrival: the drain time less one byte time per byte that came after
    /// it, as the firmware does.
    pub const fn with_max_frame_time_us(max_frame_time_us: u32) -> Self {
        Self {
            buf: [0; MAX_FRAME_BYTES],
            arrived_us: [0; MAX_FRAME_BYTES],
            start: 0,
            end: 0,
            max_frame_time_us,
            stats: CrsfStats::ZERO,
        }
    }

    /// Counters since creation (or the last [`CrsfParser::reset_stats`]).
    pub fn stats(&self) -> &CrsfStats {
        &self.stats
    }

    /// Clears the counters.
    pub fn reset_stats(&mut self) {
        self.stats = CrsfStats::default();
    }

    /// Forgets any partial frame (e.g. after a USART overrun or framing
    /// error, when bytes are known to be missing).
    pub fn clear(&mut self) {
        self.start = 0;
        self.end = 0;
    }

    /// Feeds one received byte, stamped with the time it arrived (µs,
    /// wrapping). Returns the decoded content when the byte completes a
    /// valid frame.
    ///
    /// A candidate frame whose bytes would span more than the frame time
    /// is abandoned and its later bytes are searched again; frames already
    /// complete in the buffer are still delivered. One call returns at most
    /// one event; if the buffer holds more (only after garbage announced a
    /// long frame that swallowed real ones), the following calls return
    /// them.
    pub fn push(&mut self, byte: u8, now_us: u32) -> Option<Event> {
        self.append(byte, now_us);
        self.scan(now_us)
    }

    /// Delivers frames that are complete in the buffer but wait behind a
    /// false start, once the false start's frame time has passed at
    /// `now_us`. Call it from a periodic task so that the last frames before
    /// a pause are not held until the next byte; it returns at most one
    /// event per call.
    pub fn poll(&mut self, now_us: u32) -> Option<Event> {
        self.scan(now_us)
    }

    /// Whether more than the frame time lies between `first_us` and
    /// `last_us`. A `last_us` before `first_us` (by less than half the
    /// counter's range) is no time at all.
    fn too_slow(&self, first_us: u32, last_us: u32) -> bool {
        let span = last_us.wrapping_sub(first_us);
        span > self.max_frame_time_us && span <= u32::MAX / 2
    }

    fn append(&mut self, byte: u8, now_us: u32) {
        if self.end >= MAX_FRAME_BYTES {
            self.compact();
        }
        if let (Some(slot), Some(at)) = (
            self.buf.get_mut(self.end),
            self.arrived_us.get_mut(self.end),
        ) {
            *slot = byte;
            *at = now_us;
            self.end += 1;
        }
    }

    /// Moves the pending bytes and their times to the front of the buffer.
    fn compact(&mut self) {
        if self.start == 0 {
            // Unreachable: a 64-byte candidate is complete and resolved by
            // scan(). Dropping its first byte keeps the invariant without a
            // panic path.
            self.start = 1;
            bump(&mut self.stats.skipped_bytes);
        }
        // Forwards, one byte at a time (the destination is below the
        // source): `copy_within` would link the general `memmove`, 1.6 KiB
        // of flash on a Cortex-M3, for at most 63 bytes once per frame.
        let mut i = 0;
        while self.start + i < self.end {
            let from = self.start + i;
            if let (Some(&b), Some(&t)) = (self.buf.get(from), self.arrived_us.get(from)) {
                if let (Some(d), Some(dt)) = (self.buf.get_mut(i), self.arrived_us.get_mut(i)) {
                    *d = b;
                    *dt = t;
                }
            }
            i += 1;
        }
        self.end -= self.start;
        self.start = 0;
    }

    /// Resolves buffered candidates until one yields an event or more bytes
    /// are needed.
    // Inlined, as are `resolve` and `check_and_decode`: at opt-level "z"
    // every by-value return of the 36-byte event is otherwise a memcpy
    // (measured: a third of the cost of the byte that completes a frame).
    #[inline(always)]
    fn scan(&mut self, now_us: u32) -> Option<Event> {
        loop {
            let pending = self.buf.get(self.start..self.end).unwrap_or(&[]);
            let Some(&address) = pending.first() else {
                self.clear();
                return None;
            };
            if !is_address(address) {
                bump(&mut self.stats.skipped_bytes);
                self.start += 1;
                continue;
            }
            let total = match pending.get(1) {
                Some(&length) if (MIN_LENGTH_BYTE..=MAX_LENGTH_BYTE).contains(&length) => {
                    usize::from(length) + 2
                }
                Some(_) => {
                    bump(&mut self.stats.bad_length);
                    self.start += 1;
                    continue;
                }
                // Only the address byte so far: the length byte must follow.
                None => 2,
            };
            // Complete: its last byte's time; else the time now, and the
            // candidate waits while that is within the frame time.
            let complete = pending.len() >= total;
            let first_us = self.arrived_us.get(self.start).copied().unwrap_or(now_us);
            let last_us = match self.arrived_us.get(self.start + total - 1) {
                Some(&t) if complete => t,
                _ => now_us,
            };
            if self.too_slow(first_us, last_us) {
                // Too slow for one frame: the later bytes start a new one.
                bump(&mut self.stats.frame_timeouts);
                self.start += 1;
                continue;
            }
            let frame = pending.get(..total)?;
            let checked = check_and_decode(frame);
            if let Some(event) = self.resolve(checked, total) {
                return Some(event);
            }
        }
    }

    /// Acts on a complete candidate of `total` bytes at `start`.
    #[inline(always)]
    fn resolve(&mut self, checked: Checked, total: usize) -> Option<Event> {
        let s = &mut self.stats;
        match checked {
            Checked::CrcError => {
                bump(&mut s.crc_errors);
                // Only the first byte is known bad: search the rest again.
                self.start += 1;
                None
            }
            Checked::BadPayloadLength => {
                bump(&mut s.bad_payload_length);
                self.start += total;
                None
            }
            Checked::Unknown => {
                bump(&mut s.unknown_type);
                self.start += total;
                None
            }
            Checked::Event(event) => {
                match event {
                    Event::Channels(_) => bump(&mut s.rc_frames),
                    Event::LinkStatistics(_) => bump(&mut s.link_statistics_frames),
                }
                self.start += total;
                Some(event)
            }
        }
    }
}

enum Checked {
    CrcError,
    BadPayloadLength,
    Unknown,
    Event(Event),
}

/// `frame` is a whole frame: address, length, type, payload, CRC.
#[inline(always)]
fn check_and_decode(frame: &[u8]) -> Checked {
    let Some((&crc, head)) = frame.split_last() else {
        return Checked::CrcError;
    };
    let body = head.get(2..).unwrap_or(&[]);
    if crc8_dvb_s2(body) != crc {
        return Checked::CrcError;
    }
    let Some((&frame_type, payload)) = body.split_first() else {
        return Checked::CrcError;
    };
    match frame_type {
        FRAME_TYPE_RC_CHANNELS_PACKED => match payload.try_into() {
            Ok(p) => {
                let mut channels_us = unpack_channels(p);
                for ch in channels_us.iter_mut() {
                    *ch = ticks_to_us(*ch);
                }
                Checked::Event(Event::Channels(RcFrame {
                    channels_us,
                    count: MAX_CHANNELS as u8,
                }))
            }
            Err(_) => Checked::BadPayloadLength,
        },
        FRAME_TYPE_LINK_STATISTICS => match payload.try_into() {
            Ok(p) => Checked::Event(Event::LinkStatistics(LinkStatistics::from_payload(p))),
            Err(_) => Checked::BadPayloadLength,
        },
        _ => Checked::Unknown,
    }
}
