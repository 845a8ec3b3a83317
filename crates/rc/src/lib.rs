//! Pilot input for a flight controller: CRSF and PPM receivers decoded into
//! channel pulse widths, mapped to sticks and switches, with signal-loss
//! detection.
//!
//! ```no_run
//! use rc_input::{ChannelMap, CrsfParser, Event, LinkMonitor};
//!
//! # fn usart_byte() -> u8 { 0 }
//! # fn micros() -> u32 { 0 }
//! let mut parser = CrsfParser::new();
//! let mut link = LinkMonitor::crsf();
//! let map = ChannelMap::DEFAULT; // AETR, arm on channel 5 high
//!
//! // USART RX interrupt (420 000 baud 8N1):
//! let now_us = micros();
//! match parser.push(usart_byte(), now_us) {
//!     Some(Event::Channels(frame)) => {
//!         link.on_frame(now_us);
//!         let sticks = map.sticks(&frame); // roll/pitch/yaw −1..1, throttle 0..1
//!         let arm = map.arm_switch(&frame);
//!     }
//!     Some(Event::LinkStatistics(stats)) => link.on_link_quality(stats.uplink_link_quality_pct),
//!     None => {}
//! }
//! // Control loop (lost until frames have come for 0.5 s without a break):
//! if link.is_lost(micros()) { /* failsafe */ }
//! ```
//!
//! What it does:
//!
//! * [`CrsfParser`]: byte-at-a-time CRSF parser for a USART receive
//!   interrupt: address 0xC8/0xEE/0xEA, length 2..=62, CRC-8/DVB-S2,
//!   RC_CHANNELS_PACKED (16 × 11 bit, converted to µs) and LINK_STATISTICS.
//!   Garbage, CRC failures, bad lengths and unknown types are skipped and
//!   counted ([`CrsfStats`]); a frame not complete 1 750 µs after its first
//!   byte is abandoned (pauses inside a frame are fine up to that).
//! * [`PpmDecoder`]: PPM sum signal from timer input-capture intervals,
//!   sync-gap detection, plausibility checks, and a frame is delivered only
//!   when it confirms the channel count of the one before ([`PpmStats`]).
//! * [`ChannelMap`]: channel order (AETR, TAER, ...), per-stick calibration,
//!   deadband, reversing, normalised [`Sticks`], switch positions, the arm
//!   switch; configuration is validated ([`ConfigError`]).
//! * [`LinkMonitor`]: signal loss after a stated timeout or on a receiver's
//!   0 % link quality; the link counts as up only after frames have come
//!   without a break for a recovery window ([`LINK_RECOVERY_US`], 0.5 s).
//!
//! * [`telemetry`]: CRSF telemetry frames to the receiver (battery,
//!   barometric altitude, attitude, flight mode) from integer inputs, and
//!   [`TelemetryScheduler`], Betaflight's schedule: at most one frame after
//!   each RC frame, in turn, at least 100 ms / (frames) apart.
//!
//! What it does not do: touch hardware (the firmware feeds bytes and
//! capture intervals), expo/rates, arming decisions or failsafe actions.
//!
//! Times are `u32` microseconds from a free-running counter; every
//! difference is taken with wrapping arithmetic. Nothing here panics,
//! allocates or uses `unsafe`, whatever bytes arrive.
#![no_std]
#![deny(unsafe_code)]

mod crc;
pub mod crsf;
mod error;
mod frame;
mod link;
mod map;
pub mod ppm;
pub mod telemetry;

pub use crc::{crc8_dvb_s2, crc8_dvb_s2_update, CRC8_DVB_S2_POLY};
pub use crsf::{CrsfParser, CrsfStats, Event, LinkStatistics};
pub use error::{ConfigError, MissingChannel};
pub use frame::{RcFrame, MAX_CHANNELS};
pub use link::{LinkMonitor, LinkStatus, CRSF_TIMEOUT_US, LINK_RECOVERY_US, PPM_TIMEOUT_US};
pub use map::{Axis, ChannelMap, ChannelOrder, ChannelRange, Sticks, SwitchPosition};
pub use ppm::{CaptureIntervals, PpmConfig, PpmDecoder, PpmStats};
pub use telemetry::{TelemetryScheduler, TelemetrySnapshot};
