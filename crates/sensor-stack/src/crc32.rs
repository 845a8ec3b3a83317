//! CRC-32 (IEEE 802.3, reflected polynomial 0xEDB8_8320, initial value and
//! final XOR 0xFFFF_FFFF) with a 16-entry nibble table: 64 bytes of flash,
//! two table look-ups per byte. Check value: `crc32(b"123456789")` is
//! `0xCBF4_3926`.

/// CRC of each nibble value (reflected polynomial 0xEDB8_8320).
const NIBBLE_TABLE: [u32; 16] = [
    0x0000_0000,
    0x1DB7_1064,
    0x3B6E_20C8,
    0x26D9_30AC,
    0x76DC_4190,
    0x6B6B_51F4,
    0x4DB2_6158,
    0x5005_713C,
    0xEDB8_8320,
    0xF00F_9344,
    0xD6D6_A3E8,
    0xCB61_B38C,
    0x9B64_C2B0,
    0x86D3_D2D4,
    0xA00A_E278,
    0xBDBD_F21C,
];

/// Feeds `data` into a running (non-inverted) CRC register.
fn update(mut crc: u32, data: &[u8]) -> u32 {
    for &byte in data {
        crc ^= u32::from(byte);
        // `& 0xF` keeps both indices in 0..16.
        crc = (crc >> 4) ^ NIBBLE_TABLE[(crc & 0xF) as usize];
        crc = (crc >> 4) ^ NIBBLE_TABLE[(crc & 0xF) as usize];
    }
    crc
}

/// CRC-32/IEEE of `data`.
///
/// ```
/// assert_eq!(sensor_stack::crc32::crc32(b"123456789"), 0xCBF4_3926);
/// ```
pub fn crc32(data: &[u8]) -> u32 {
    !update(0xFFFF_FFFF, data)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit-at-a-time reference implementation.
    fn reference(data: &[u8]) -> u32 {
        let mut crc = 0xFFFF_FFFFu32;
        for &b in data {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 != 0 {
                    (crc >> 1) ^ 0xEDB8_8320
                } else {
                    crc >> 1
                };
            }
        }
        !crc
    }

    #[test]
    fn check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        // zlib.crc32(b"The quick brown fox jumps over the lazy dog")
        assert_eq!(
            crc32(b"The quick brown fox jumps over the lazy dog"),
            0x414F_A339
        );
    }

    #[test]
    fn table_matches_bitwise() {
        let data: [u8; 256] = core::array::from_fn(|i| (i as u8).wrapping_mul(37).wrapping_add(11));
        for len in [0, 1, 2, 7, 100, 256] {
            assert_eq!(crc32(&data[..len]), reference(&data[..len]));
        }
    }
}
