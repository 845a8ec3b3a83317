//! CRSF telemetry from the flight controller to the receiver: battery
//! (0x08), barometric altitude (0x09), attitude (0x1E) and flight mode
//! (0x21) frames, and Betaflight's schedule for sending them.
//!
//! Every frame is
//!
//! ```text
//! [0xC8] [length] [type] [payload ...] [crc]
//!         \____ type + payload + crc ____/
//! ```
//!
//! with the flight controller's address 0xC8 as the sync byte (as
//! Betaflight's `crsfInitializeFrame` writes `CRSF_SYNC_BYTE`), fields
//! big-endian, and the CRC-8/DVB-S2 over type and payload. Layouts and
//! units are the TBS CRSF specification's (`tbs-crsf-spec`, crsf.md),
//! cross-checked with the crsf-wg description's worked examples, ExpressLRS's
//! `crsf_protocol.h`, Betaflight's `telemetry/crsf.c` and EdgeTX's reader
//! (`telemetry/crossfire.cpp`); each encoder states its layout and where
//! the sources differ.
//!
//! Inputs are the flight stack's integers with their units in the names
//! (mV, mA, mAh, Q16 rad, cm, cm/s): nothing here uses floating point, as
//! the Cortex-M3 has no FPU. Conversions round to nearest and saturate at
//! the field's range ([`voltage_dv`], [`current_da`], [`attitude_e4_rad`],
//! [`altitude_packed`]). Nothing allocates, panics or uses `unsafe`.
//!
//! ```
//! use rc_input::telemetry::{encode_battery, Battery};
//!
//! let mut out = [0u8; 64];
//! let battery = Battery { voltage_mv: 25_200, current_ma: 18_900, used_mah: 2_199, remaining_pct: 20 };
//! let n = encode_battery(&battery, &mut out);
//! // 25.2 V as 252 (0x00FC), 18.9 A as 189 (0x00BD), 2199 mAh, 20 %.
//! assert_eq!(&out[..n - 1], &[0xC8, 0x0A, 0x08, 0x00, 0xFC, 0x00, 0xBD, 0x00, 0x08, 0x97, 0x14]);
//! ```

mod decode;
mod frames;
mod schedule;
mod units;

pub use decode::{decode_telemetry, TelemetryDecodeError, TelemetryFrame, FLIGHT_MODE_TEXT_BYTES};
pub use frames::{
    encode_attitude, encode_baro_altitude, encode_battery, encode_flight_mode, Arming, Attitude,
    BaroAltitude, Battery, FlightMode, ModeName, ATTITUDE_PAYLOAD_BYTES,
    BARO_ALTITUDE_PAYLOAD_BYTES, BATTERY_PAYLOAD_BYTES, FLIGHT_MODE_MAX_PAYLOAD_BYTES,
    FRAME_TYPE_ATTITUDE, FRAME_TYPE_BARO_ALTITUDE, FRAME_TYPE_BATTERY_SENSOR,
    FRAME_TYPE_FLIGHT_MODE, MAX_TELEMETRY_FRAME_BYTES,
};
pub use schedule::{
    per_frame_rate_mhz, wire_time_us, FrameKind, FrameSet, TelemetryScheduler, TelemetrySnapshot,
    FASTEST_RC_PERIOD_US, RC_FRAME_BYTES, SLOT_MARGIN_US, TELEMETRY_CYCLE_US,
};
pub use units::{
    altitude_packed, altitude_unpacked_dm, attitude_e4_rad, current_da, used_mah_u24,
    vertical_speed_cmps_i16, voltage_dv, ATTITUDE_LIMIT_E4_RAD, PI_RAD_Q16, USED_MAH_LIMIT,
};
