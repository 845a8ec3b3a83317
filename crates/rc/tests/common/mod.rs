//! Frames from published sources, and helpers to feed a parser.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
#![allow(dead_code)]

use rc_input::{CrsfParser, Event};

/// Byte time at 420 kbaud 8N1 (10 bits), rounded up, µs.
pub const BYTE_US: u32 = 24;

/// Two RC_CHANNELS_PACKED frames captured from a receiver, from Betaflight's
/// `src/test/unit/rx_crsf_unittest.cc` (`capturedData`). The capture's
/// address byte is 0x00 (broadcast); the CRC does not cover it.
pub const BETAFLIGHT_CAPTURED: [[u8; 26]; 2] = [
    [
        0x00, 0x18, 0x16, 0xBD, 0x08, 0x9F, 0xF4, 0xAE, 0xF7, 0xBD, 0xEF, 0x7D, 0xEF, 0xFB, 0xAD,
        0xFD, 0x45, 0x2B, 0x5A, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x6C,
    ],
    [
        0x00, 0x18, 0x16, 0xBD, 0x08, 0x9F, 0xF4, 0xAA, 0xF7, 0xBD, 0xEF, 0x7D, 0xEF, 0xFB, 0xAD,
        0xFD, 0x45, 0x2B, 0x5A, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x94,
    ],
];

/// The baud-rate negotiation command (type 0x32) from the same Betaflight
/// test (`buadrateNegotiationFrame`): a real frame of a type this crate
/// does not decode.
pub const BETAFLIGHT_BAUD_NEGOTIATION: [u8; 14] = [
    0xC8, 0x0C, 0x32, 0xC8, 0xEC, 0x0A, 0x70, 0x01, 0x00, 0x1E, 0x84, 0x80, 0x22, 0x72,
];

/// The SUBSET_RC_CHANNELS_PACKED frame (type 0x17) from the same test
/// (`capturedSubsetData`).
pub const BETAFLIGHT_SUBSET: [u8; 11] = [
    0xC8, 0x09, 0x17, 0x24, 0x00, 0xA0, 0xD9, 0xE9, 0xFF, 0x0F, 0xD1,
];

/// An ExpressLRS RC frame with the transmitter-module address 0xEE, from
/// the README of github.com/kielerrr/CRSFv2-elrs ("An example frame").
pub const ELRS_EE_FRAME: [u8; 26] = [
    0xEE, 0x18, 0x16, 0xE1, 0xE3, 0xDE, 0x09, 0xC7, 0xD7, 0x8A, 0x56, 0x80, 0x0F, 0x7C, 0xE0, 0x03,
    0x1F, 0xF8, 0xC0, 0x07, 0x3E, 0xF0, 0x81, 0x0F, 0x7C, 0x36,
];

/// LINK_STATISTICS test vector of github.com/Tellicious/ADV-RCProtocols
/// `tests/test_CRSF.c` (`test_linkstats_packet`): −65/−66 dBm, LQ 98 %,
/// SNR −7 dB, antenna 1, RF mode 3, power index 5, downlink −70 dBm, 99 %,
/// −9 dB.
pub const ADV_LINK_STATISTICS: [u8; 14] = [
    0xC8, 0x0C, 0x14, 0x41, 0x42, 0x62, 0xF9, 0x01, 0x03, 0x05, 0x46, 0x63, 0xF7, 0xEB,
];

/// RC_CHANNELS_PACKED test vector from the same file
/// (`test_rc_channels_packet`): all 16 channels at 992 ticks (1500 µs).
pub const ADV_RC_CENTRED: [u8; 26] = [
    0xC8, 0x18, 0x16, 0xE0, 0x03, 0x1F, 0xF8, 0xC0, 0x07, 0x3E, 0xF0, 0x81, 0x0F, 0x7C, 0xE0, 0x03,
    0x1F, 0xF8, 0xC0, 0x07, 0x3E, 0xF0, 0x81, 0x0F, 0x7C, 0xAD,
];

/// Feeds `bytes` one per byte time starting at `t0_us`; returns the events
/// and the time after the last byte.
pub fn feed(parser: &mut CrsfParser, bytes: &[u8], t0_us: u32) -> (Vec<Event>, u32) {
    let mut t = t0_us;
    let mut events = Vec::new();
    for &b in bytes {
        if let Some(e) = parser.push(b, t) {
            events.push(e);
        }
        t = t.wrapping_add(BYTE_US);
    }
    (events, t)
}

/// Betaflight's capture with the flight-controller address in place of 0x00.
pub fn betaflight_as_fc(i: usize) -> [u8; 26] {
    let mut f = BETAFLIGHT_CAPTURED[i];
    f[0] = 0xC8;
    f
}
