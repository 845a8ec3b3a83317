//! What each telemetry frame carries, in the flight stack's units, and its
//! encoder into a complete CRSF frame.

use super::units::{
    altitude_packed, attitude_e4_rad, current_da, used_mah_u24, vertical_speed_cmps_i16, voltage_dv,
};
use crate::crc::crc8_dvb_s2_update;
use crate::crsf::{ADDRESS_FLIGHT_CONTROLLER, MAX_FRAME_BYTES};

/// Frame type of the battery sensor frame.
pub const FRAME_TYPE_BATTERY_SENSOR: u8 = 0x08;
/// Frame type of the barometric altitude (and vertical speed) frame.
pub const FRAME_TYPE_BARO_ALTITUDE: u8 = 0x09;
/// Frame type of the attitude frame.
pub const FRAME_TYPE_ATTITUDE: u8 = 0x1E;
/// Frame type of the flight mode text frame.
pub const FRAME_TYPE_FLIGHT_MODE: u8 = 0x21;

/// Payload bytes of the battery frame: voltage (2), current (2), used
/// capacity (3), remaining (1).
pub const BATTERY_PAYLOAD_BYTES: usize = 8;
/// Payload bytes of the attitude frame: pitch, roll, yaw (2 each).
pub const ATTITUDE_PAYLOAD_BYTES: usize = 6;
/// Payload bytes of the barometric altitude frame as sent here: packed
/// altitude (2) and vertical speed in cm/s (2).
pub const BARO_ALTITUDE_PAYLOAD_BYTES: usize = 4;
/// Longest flight mode payload sent here: four letters, the arming
/// suffix and the terminating NUL.
pub const FLIGHT_MODE_MAX_PAYLOAD_BYTES: usize = 6;

/// Longest telemetry frame this module sends (the battery frame):
/// sync, length, type, 8 payload bytes, CRC.
pub const MAX_TELEMETRY_FRAME_BYTES: usize = BATTERY_PAYLOAD_BYTES + 4;

/// The battery as measured, for the battery sensor frame (0x08).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Battery {
    /// Pack voltage, mV (sent in 0.1 V).
    pub voltage_mv: u32,
    /// Current drawn, mA, positive discharging (sent in 0.1 A).
    pub current_ma: i32,
    /// Capacity drawn since the pack was connected, mAh.
    pub used_mah: u32,
    /// Estimated charge left, % (values above 100 are sent as 100).
    pub remaining_pct: u8,
}

/// The attitude estimate, for the attitude frame (0x1E): ZYX Euler
/// angles of the AHRS quaternion `q_ned_from_body` (body FRD, earth NED)
/// in Q16 radians, as `sensor_stack::angles::euler_q16` gives them.
///
/// Sent with that sign convention (ArduPilot's): roll positive right side
/// down, pitch positive nose up, yaw positive clockwise seen from above,
/// 0 = north, wrapped into ±π.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Attitude {
    /// Roll, Q16 rad.
    pub roll_rad_q16: i32,
    /// Pitch, Q16 rad.
    pub pitch_rad_q16: i32,
    /// Yaw (heading), Q16 rad.
    pub yaw_rad_q16: i32,
}

/// The barometric height, for the barometric altitude frame (0x09).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BaroAltitude {
    /// Height above the take-off (reference pressure) point, cm, up
    /// positive.
    pub altitude_cm: i32,
    /// Vertical speed, cm/s, up positive.
    pub vertical_speed_cmps: i32,
}

/// The flight mode the pilot sees on the radio (Betaflight's strings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModeName {
    /// Rate mode: "ACRO".
    Acro,
    /// Self-level: "ANGL".
    #[default]
    Angle,
    /// Self-level with altitude hold: "ALTH".
    AltitudeHold,
    /// Failsafe active: "!FS!" (no arming suffix, as Betaflight).
    Failsafe,
}

impl ModeName {
    /// The text sent, without suffix or terminator.
    pub const fn text(self) -> &'static [u8] {
        match self {
            Self::Acro => b"ACRO",
            Self::Angle => b"ANGL",
            Self::AltitudeHold => b"ALTH",
            Self::Failsafe => b"!FS!",
        }
    }
}

/// Whether the craft is armed, and if not whether it could be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Arming {
    /// Armed: no suffix.
    Armed,
    /// Disarmed and every arming check passes: suffix '*'.
    #[default]
    Ready,
    /// Disarmed and an arming check refuses: suffix '!'.
    Blocked,
}

/// The flight mode frame's content (0x21).
///
/// Betaflight's form: the mode's name, then, while disarmed and not in
/// failsafe, '*' (ready to arm) or '!' (arming refused), then NUL.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightMode {
    /// The active mode.
    pub mode: ModeName,
    /// The arming state.
    pub arming: Arming,
}

impl FlightMode {
    /// The arming suffix sent after the name, if any.
    pub const fn suffix(&self) -> Option<u8> {
        match (self.mode, self.arming) {
            (ModeName::Failsafe, _) | (_, Arming::Armed) => None,
            (_, Arming::Ready) => Some(b'*'),
            (_, Arming::Blocked) => Some(b'!'),
        }
    }
}

/// Writes one frame into a 64-byte buffer: sync byte, length, type,
/// payload, CRC. Writes past the end are dropped (never reached: every
/// frame here is at most [`MAX_TELEMETRY_FRAME_BYTES`]).
struct FrameWriter<'a> {
    out: &'a mut [u8; MAX_FRAME_BYTES],
    len: usize,
    crc: u8,
}

impl<'a> FrameWriter<'a> {
    fn new(out: &'a mut [u8; MAX_FRAME_BYTES], frame_type: u8) -> Self {
        let mut w = Self {
            out,
            len: 0,
            crc: 0,
        };
        w.raw(ADDRESS_FLIGHT_CONTROLLER);
        w.raw(0); // length, filled in by `finish`
        w.u8(frame_type);
        w
    }

    fn raw(&mut self, byte: u8) {
        if let Some(slot) = self.out.get_mut(self.len) {
            *slot = byte;
            self.len += 1;
        }
    }

    /// A byte covered by the CRC.
    fn u8(&mut self, byte: u8) {
        self.crc = crc8_dvb_s2_update(self.crc, byte);
        self.raw(byte);
    }

    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.u8(b);
        }
    }

    /// Writes the length byte and the CRC; returns the frame's size.
    fn finish(mut self) -> usize {
        let crc = self.crc;
        self.raw(crc);
        // Length counts type, payload and CRC: all but the first two bytes.
        if let Some(slot) = self.out.get_mut(1) {
            *slot = self.len.saturating_sub(2) as u8;
        }
        self.len
    }
}

/// Encodes the battery sensor frame (0x08) into `out`; returns its size
/// (12 bytes).
///
/// Payload, big-endian (TBS CRSF specification, crsf-wg "CRSF_FRAMETYPE_
/// BATTERY_SENSOR", Betaflight's `crsfFrameBatterySensor`): voltage u16 in
/// 0.1 V, current i16 in 0.1 A, used capacity u24 in mAh, remaining u8 in
/// %. (The TBS document's "LSB = 10 µV / 10 µA" is not what any sender or
/// reader does: all use 0.1 V and 0.1 A, e.g. 25.2 V sent as 252.)
pub fn encode_battery(battery: &Battery, out: &mut [u8; MAX_FRAME_BYTES]) -> usize {
    let mut w = FrameWriter::new(out, FRAME_TYPE_BATTERY_SENSOR);
    w.bytes(&voltage_dv(battery.voltage_mv).to_be_bytes());
    w.bytes(&current_da(battery.current_ma).to_be_bytes());
    let [_, high, mid, low] = used_mah_u24(battery.used_mah).to_be_bytes();
    w.bytes(&[high, mid, low]);
    w.u8(battery.remaining_pct.min(100));
    w.finish()
}

/// Encodes the attitude frame (0x1E) into `out`; returns its size
/// (10 bytes).
///
/// Payload, big-endian (TBS CRSF specification, crsf-wg "CRSF_FRAMETYPE_
/// ATTITUDE"): pitch, roll, yaw, each i16 in 100 µrad, within ±π
/// ([`attitude_e4_rad`](super::attitude_e4_rad)).
pub fn encode_attitude(attitude: &Attitude, out: &mut [u8; MAX_FRAME_BYTES]) -> usize {
    let mut w = FrameWriter::new(out, FRAME_TYPE_ATTITUDE);
    w.bytes(&attitude_e4_rad(attitude.pitch_rad_q16).to_be_bytes());
    w.bytes(&attitude_e4_rad(attitude.roll_rad_q16).to_be_bytes());
    w.bytes(&attitude_e4_rad(attitude.yaw_rad_q16).to_be_bytes());
    w.finish()
}

/// Encodes the flight mode frame (0x21) into `out`; returns its size
/// (8 to 10 bytes).
///
/// Payload: the NUL-terminated ASCII text (TBS CRSF specification), built
/// as Betaflight's `crsfFrameFlightMode` builds it (see [`FlightMode`]).
pub fn encode_flight_mode(mode: &FlightMode, out: &mut [u8; MAX_FRAME_BYTES]) -> usize {
    let mut w = FrameWriter::new(out, FRAME_TYPE_FLIGHT_MODE);
    w.bytes(mode.mode.text());
    if let Some(s) = mode.suffix() {
        w.u8(s);
    }
    w.u8(0);
    w.finish()
}

/// Encodes the barometric altitude frame (0x09) into `out`; returns its
/// size (8 bytes).
///
/// Payload, big-endian: the packed altitude u16
/// ([`altitude_packed`](super::altitude_packed)), then the vertical speed
/// i16 in cm/s: the 4-byte form of the crsf-wg description, which
/// ExpressLRS sends (`crsf_sensor_baro_vario_t`) and EdgeTX reads (both
/// fields when the payload has 4 bytes). The TBS document's other form,
/// the speed as one log-scaled byte (3-byte payload, Betaflight's), is
/// not used: EdgeTX shows no vertical speed from it, and packing it needs
/// a logarithm. A reader of that form still gets the altitude (readers
/// ignore bytes past the fields they know); its speed byte would be the
/// high byte of the cm/s value.
pub fn encode_baro_altitude(baro: &BaroAltitude, out: &mut [u8; MAX_FRAME_BYTES]) -> usize {
    let mut w = FrameWriter::new(out, FRAME_TYPE_BARO_ALTITUDE);
    w.bytes(&altitude_packed(baro.altitude_cm).to_be_bytes());
    w.bytes(&vertical_speed_cmps_i16(baro.vertical_speed_cmps).to_be_bytes());
    w.finish()
}
