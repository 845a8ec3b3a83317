//! Reading the four telemetry frames back, as a receiver or radio would:
//! for host tests and the emulated board's checks of the TX pin.

use super::frames::{
    FRAME_TYPE_ATTITUDE, FRAME_TYPE_BARO_ALTITUDE, FRAME_TYPE_BATTERY_SENSOR,
    FRAME_TYPE_FLIGHT_MODE,
};
use super::units::altitude_unpacked_dm;
use crate::crc::crc8_dvb_s2;
use crate::crsf::{MAX_LENGTH_BYTE, MIN_LENGTH_BYTE};

/// Longest flight mode text kept by [`decode_telemetry`], bytes (EdgeTX
/// keeps 16 with the terminator).
pub const FLIGHT_MODE_TEXT_BYTES: usize = 15;

/// A decoded telemetry frame, in the wire's units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TelemetryFrame {
    /// Battery sensor (0x08).
    Battery {
        /// Voltage, 0.1 V.
        voltage_dv: u16,
        /// Current, 0.1 A.
        current_da: i16,
        /// Capacity used, mAh.
        used_mah: u32,
        /// Remaining, %.
        remaining_pct: u8,
    },
    /// Attitude (0x1E), each angle in 1e-4 rad.
    Attitude {
        /// Pitch.
        pitch_e4_rad: i16,
        /// Roll.
        roll_e4_rad: i16,
        /// Yaw.
        yaw_e4_rad: i16,
    },
    /// Barometric altitude (0x09).
    BaroAltitude {
        /// Altitude, dm (the packed field unpacked).
        altitude_dm: i32,
        /// Vertical speed, cm/s, when the payload has the 16-bit field.
        vertical_speed_cmps: Option<i16>,
    },
    /// Flight mode (0x21): the text up to its NUL (at most
    /// [`FLIGHT_MODE_TEXT_BYTES`]).
    FlightMode {
        /// The text's bytes; `len` of them are used.
        text: [u8; FLIGHT_MODE_TEXT_BYTES],
        /// Bytes of text.
        len: usize,
    },
}

/// Why [`decode_telemetry`] rejected a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TelemetryDecodeError {
    /// The length byte is outside 2..=62 or disagrees with the slice.
    Length,
    /// The CRC does not match.
    Crc,
    /// A frame type other than the four telemetry frames.
    UnknownType(u8),
    /// The payload is shorter than the type's fields (or a flight mode
    /// text has no terminator).
    Payload,
}

/// Decodes one whole frame (sync byte to CRC, any sync byte). Bytes past
/// the fields a type defines are ignored, as the TBS specification asks.
pub fn decode_telemetry(frame: &[u8]) -> Result<TelemetryFrame, TelemetryDecodeError> {
    let &length = frame.get(1).ok_or(TelemetryDecodeError::Length)?;
    if !(MIN_LENGTH_BYTE..=MAX_LENGTH_BYTE).contains(&length)
        || frame.len() != usize::from(length) + 2
    {
        return Err(TelemetryDecodeError::Length);
    }
    let (&crc, head) = frame.split_last().ok_or(TelemetryDecodeError::Length)?;
    let body = head.get(2..).ok_or(TelemetryDecodeError::Length)?;
    if crc8_dvb_s2(body) != crc {
        return Err(TelemetryDecodeError::Crc);
    }
    let (&frame_type, p) = body.split_first().ok_or(TelemetryDecodeError::Length)?;
    match frame_type {
        FRAME_TYPE_BATTERY_SENSOR => battery(p),
        FRAME_TYPE_ATTITUDE => attitude(p),
        FRAME_TYPE_BARO_ALTITUDE => baro(p),
        FRAME_TYPE_FLIGHT_MODE => flight_mode(p),
        other => Err(TelemetryDecodeError::UnknownType(other)),
    }
}

fn be16(p: &[u8], at: usize) -> Result<[u8; 2], TelemetryDecodeError> {
    match (p.get(at), p.get(at + 1)) {
        (Some(&a), Some(&b)) => Ok([a, b]),
        _ => Err(TelemetryDecodeError::Payload),
    }
}

fn battery(p: &[u8]) -> Result<TelemetryFrame, TelemetryDecodeError> {
    let Some(&[v0, v1, c0, c1, u0, u1, u2, r]) = p.get(..8) else {
        return Err(TelemetryDecodeError::Payload);
    };
    Ok(TelemetryFrame::Battery {
        voltage_dv: u16::from_be_bytes([v0, v1]),
        current_da: i16::from_be_bytes([c0, c1]),
        used_mah: u32::from_be_bytes([0, u0, u1, u2]),
        remaining_pct: r,
    })
}

fn attitude(p: &[u8]) -> Result<TelemetryFrame, TelemetryDecodeError> {
    Ok(TelemetryFrame::Attitude {
        pitch_e4_rad: i16::from_be_bytes(be16(p, 0)?),
        roll_e4_rad: i16::from_be_bytes(be16(p, 2)?),
        yaw_e4_rad: i16::from_be_bytes(be16(p, 4)?),
    })
}

fn baro(p: &[u8]) -> Result<TelemetryFrame, TelemetryDecodeError> {
    Ok(TelemetryFrame::BaroAltitude {
        altitude_dm: altitude_unpacked_dm(u16::from_be_bytes(be16(p, 0)?)),
        vertical_speed_cmps: be16(p, 2).ok().map(i16::from_be_bytes),
    })
}

fn flight_mode(p: &[u8]) -> Result<TelemetryFrame, TelemetryDecodeError> {
    let len = p
        .iter()
        .position(|&b| b == 0)
        .ok_or(TelemetryDecodeError::Payload)?;
    let mut text = [0u8; FLIGHT_MODE_TEXT_BYTES];
    let kept = len.min(FLIGHT_MODE_TEXT_BYTES);
    for (d, &s) in text.iter_mut().zip(p.iter().take(kept)) {
        *d = s;
    }
    Ok(TelemetryFrame::FlightMode { text, len: kept })
}
