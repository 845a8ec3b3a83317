//! The pilot's transmitter as the board's receiver pin sees it: CRSF
//! RC_CHANNELS_PACKED frames (type 0x16) addressed to the flight
//! controller (0xC8), 16 channels of 11 bits, little-endian, LSB first,
//! closed by CRC-8/DVB-S2 — as a CRSF receiver (ExpressLRS, TBS Crossfire)
//! sends them at 420 000 baud.
//!
//! Written from the TBS CRSF specification on purpose, not from
//! `rc_input::crsf`: the frames the board receives must not come from the
//! crate whose parser they test.

/// CRSF's UART rate (baud).
pub const BAUD: u32 = 420_000;

/// CRC-8/DVB-S2 (polynomial 0xD5), the CRSF frame check, over `bytes`.
pub fn crc8_dvb_s2(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |mut crc, &b| {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ 0xD5
            } else {
                crc << 1
            };
        }
        crc
    })
}

/// An RC_CHANNELS_PACKED frame carrying `ticks` (0..=2047 each).
pub fn rc_frame(ticks: [u16; 16]) -> Vec<u8> {
    let mut payload = vec![0u8; 22];
    for (i, &t) in ticks.iter().enumerate() {
        for bit in 0..11 {
            if t & (1 << bit) != 0 {
                let at = i * 11 + bit;
                payload[at / 8] |= 1 << (at % 8);
            }
        }
    }
    let mut body = vec![0x16];
    body.extend_from_slice(&payload);
    let crc = crc8_dvb_s2(&body);
    let mut f = vec![0xC8, (body.len() + 1) as u8];
    f.extend_from_slice(&body);
    f.push(crc);
    f
}

/// CRSF ticks for a pulse width in µs: the specification's
/// `us = (ticks − 992) · 5/8 + 1500`, inverted (exact for multiples of
/// 5 µs from 1500).
pub fn ticks(us: u16) -> u16 {
    let t = (i32::from(us) - 1500) * 8 / 5 + 992;
    t.clamp(0, 2047) as u16
}

/// The frame for channels given as pulse widths (µs) from channel 1;
/// channels not given sit at the centre (1500 µs).
pub fn frame_from_us(channels_us: &[u16]) -> Vec<u8> {
    let mut t = [ticks(1500); 16];
    for (slot, &us) in t.iter_mut().zip(channels_us) {
        *slot = ticks(us);
    }
    rc_frame(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_of_the_check_string_is_the_catalogue_value() {
        // CRC-8/DVB-S2's check value over "123456789" (CRC catalogue).
        assert_eq!(crc8_dvb_s2(b"123456789"), 0xBC);
    }

    #[test]
    fn centre_and_ends_map_to_the_specification_ticks() {
        assert_eq!(ticks(1500), 992);
        assert_eq!(ticks(1000), 192);
        assert_eq!(ticks(2000), 1792);
    }

    #[test]
    fn a_frame_is_26_bytes_with_its_crc() {
        let f = frame_from_us(&[1000, 2000]);
        assert_eq!((f.len(), f[0], f[1], f[2]), (26, 0xC8, 24, 0x16));
        assert_eq!(crc8_dvb_s2(&f[2..25]), f[25]);
        // Channel 1 = 192 in the first 11 bits.
        assert_eq!(u16::from(f[3]) | (u16::from(f[4] & 0x07) << 8), 192);
    }
}
