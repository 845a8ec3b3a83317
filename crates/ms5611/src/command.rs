//! MS5611 command bytes and timing (datasheet MS5611-01BA03, "Commands" and
//! "Operating characteristics").
//!
//! The MS5611 has no registers: every I²C transfer starts with a one-byte
//! command. These constants are what the driver sends; they are public so a
//! simulator or a bus analyser can decode the traffic.

/// Reset: reloads the PROM into the internal registers. Wait
/// [`RESET_TIME_US`] before the next command.
pub const RESET: u8 = 0x1E;

/// ADC read: the following 3-byte read returns the last conversion result
/// (24 bits, big-endian). It returns 0 if no conversion was started since the
/// last ADC read or if the conversion has not finished.
pub const ADC_READ: u8 = 0x00;

/// Start a D1 (pressure) conversion; OR with [`crate::Osr::command_bits`].
pub const CONVERT_D1: u8 = 0x40;

/// Start a D2 (temperature) conversion; OR with [`crate::Osr::command_bits`].
pub const CONVERT_D2: u8 = 0x50;

/// PROM read of word 0; word `n` (0..=7) is at `PROM_READ_BASE + 2 * n`
/// (0xA0, 0xA2, ..., 0xAE). The following 2-byte read returns the word
/// big-endian.
pub const PROM_READ_BASE: u8 = 0xA0;

/// Number of 16-bit PROM words (factory word, C1..C6, serial/CRC word).
pub const PROM_WORDS: usize = 8;

/// Time the chip needs after [`RESET`] to reload its PROM, in µs (2.8 ms,
/// datasheet). A non-blocking caller must not send anything to the chip
/// before this has elapsed.
pub const RESET_TIME_US: u32 = 2_800;

/// Maximum conversion time over all oversampling ratios (OSR 4096), µs.
pub const MAX_CONVERSION_TIME_US: u32 = 9_040;

/// The PROM-read command for word `index` (0..=7). Indices above 7 wrap into
/// 0..=7 (only the low three bits are used), so the result is always one of
/// the eight valid PROM commands.
pub const fn prom_read(index: u8) -> u8 {
    PROM_READ_BASE | ((index & 0x07) << 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prom_commands_are_a0_to_ae() {
        let all: [u8; 8] = core::array::from_fn(|i| prom_read(i as u8));
        assert_eq!(all, [0xA0, 0xA2, 0xA4, 0xA6, 0xA8, 0xAA, 0xAC, 0xAE]);
        assert_eq!(prom_read(8), 0xA0);
    }
}
