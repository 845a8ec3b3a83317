//! Factory calibration PROM and its CRC-4 (application note AN520).

use core::fmt;

/// PROM contents failed validation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PromError {
    /// Every word read 0x0000 or every word read 0xFFFF: the chip did not
    /// answer with data (bus stuck low/high, or a chip without PROM).
    /// An all-zero PROM would otherwise pass the CRC.
    Blank,
    /// The CRC-4 stored in the low nibble of word 7 does not match the one
    /// computed over the PROM.
    Crc {
        /// CRC stored in the PROM (word 7 bits 3..0).
        expected: u8,
        /// CRC computed with [`crc4`].
        computed: u8,
    },
}

impl fmt::Display for PromError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PromError::Blank => f.write_str("MS5611 PROM is blank (all 0x0000 or all 0xFFFF)"),
            PromError::Crc { expected, computed } => write!(
                f,
                "MS5611 PROM CRC mismatch: stored {expected:#x}, computed {computed:#x}"
            ),
        }
    }
}

impl core::error::Error for PromError {}

/// The CRC-4 of a PROM image, exactly as application note AN520 computes it.
///
/// Word 7's low byte (which holds the CRC in bits 3..0) is treated as 0x00;
/// the 16 bytes are fed MSB first through a 16-bit remainder register with
/// the polynomial constant 0x3000, and the CRC is the register's top nibble.
/// The result is compared against `words[7] & 0x000F`.
///
/// ```
/// // AN520's test vector: CRC = 0xB.
/// let prom = [0x3132, 0x3334, 0x3536, 0x3738, 0x3940, 0x4142, 0x4344, 0x4500];
/// assert_eq!(ms5611::crc4(&prom), 0xB);
/// ```
pub fn crc4(words: &[u16; 8]) -> u8 {
    let mut n_rem: u16 = 0;
    for (index, &word) in words.iter().enumerate() {
        // AN520: n_prom[7] = 0xFF00 & n_prom[7] (the CRC byte is replaced by 0).
        let word = if index == 7 { word & 0xFF00 } else { word };
        // AN520 feeds the high byte first (cnt even), then the low byte.
        for byte in word.to_be_bytes() {
            n_rem ^= u16::from(byte);
            for _ in 0..8 {
                n_rem = if n_rem & 0x8000 != 0 {
                    (n_rem << 1) ^ 0x3000
                } else {
                    n_rem << 1
                };
            }
        }
    }
    // The top nibble of a u16 always fits in a u8.
    ((n_rem >> 12) & 0x000F) as u8
}

/// `words` with the low nibble of word 7 replaced by the correct CRC-4.
/// Handy to build valid PROM images for tests and simulators.
///
/// ```
/// let words = ms5611::with_valid_crc(&[0, 40127, 36924, 23317, 23282, 33464, 28312, 0]);
/// assert!(ms5611::Prom::from_words(&words).is_ok());
/// ```
pub fn with_valid_crc(words: &[u16; 8]) -> [u16; 8] {
    let mut out = *words;
    out[7] = (out[7] & 0xFFF0) | u16::from(crc4(words));
    out
}

/// A validated factory calibration PROM (8 words).
///
/// Word 0 is factory data, words 1..=6 are the coefficients C1..C6, word 7
/// holds the serial code and, in bits 3..0, the CRC-4.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Prom {
    words: [u16; 8],
}

impl Prom {
    /// Validate a PROM image read from the chip.
    ///
    /// Rejects an all-0x0000 or all-0xFFFF image ([`PromError::Blank`]) and a
    /// CRC mismatch ([`PromError::Crc`]).
    ///
    /// ```
    /// use ms5611::{Prom, PromError};
    /// let good = [0x3132, 0x3334, 0x3536, 0x3738, 0x3940, 0x4142, 0x4344, 0x450B];
    /// assert_eq!(Prom::from_words(&good).unwrap().c1(), 0x3334);
    /// let bad = [0x3132, 0x3334, 0x3536, 0x3738, 0x3940, 0x4142, 0x4344, 0x4500];
    /// assert_eq!(Prom::from_words(&bad), Err(PromError::Crc { expected: 0x0, computed: 0xB }));
    /// assert_eq!(Prom::from_words(&[0; 8]), Err(PromError::Blank));
    /// ```
    pub fn from_words(words: &[u16; 8]) -> Result<Prom, PromError> {
        if words.iter().all(|&w| w == 0) || words.iter().all(|&w| w == 0xFFFF) {
            return Err(PromError::Blank);
        }
        let computed = crc4(words);
        let expected = (words[7] & 0x000F) as u8;
        if computed != expected {
            return Err(PromError::Crc { expected, computed });
        }
        Ok(Prom { words: *words })
    }

    /// A PROM with the given coefficients C1..C6, factory word 0, serial 0
    /// and a correct CRC. Not validated against [`PromError::Blank`], so any
    /// coefficients (even all zero) can be used for compensation tests.
    ///
    /// ```
    /// // The datasheet's typical coefficients.
    /// let prom = ms5611::Prom::from_coefficients([40127, 36924, 23317, 23282, 33464, 28312]);
    /// assert_eq!(prom.c6(), 28312);
    /// assert_eq!(ms5611::Prom::from_words(&prom.words()), Ok(prom));
    /// ```
    pub fn from_coefficients(c: [u16; 6]) -> Prom {
        let [c1, c2, c3, c4, c5, c6] = c;
        Prom {
            words: with_valid_crc(&[0, c1, c2, c3, c4, c5, c6, 0]),
        }
    }

    /// The raw 8 words (as read from the chip).
    pub const fn words(&self) -> [u16; 8] {
        self.words
    }

    /// C1..C6 in order.
    pub const fn coefficients(&self) -> [u16; 6] {
        let w = self.words;
        [w[1], w[2], w[3], w[4], w[5], w[6]]
    }

    /// Word 0: factory data and setup.
    pub const fn factory(&self) -> u16 {
        self.words[0]
    }

    /// C1: pressure sensitivity, SENS_T1.
    pub const fn c1(&self) -> u16 {
        self.words[1]
    }

    /// C2: pressure offset, OFF_T1.
    pub const fn c2(&self) -> u16 {
        self.words[2]
    }

    /// C3: temperature coefficient of pressure sensitivity, TCS.
    pub const fn c3(&self) -> u16 {
        self.words[3]
    }

    /// C4: temperature coefficient of pressure offset, TCO.
    pub const fn c4(&self) -> u16 {
        self.words[4]
    }

    /// C5: reference temperature, T_REF.
    pub const fn c5(&self) -> u16 {
        self.words[5]
    }

    /// C6: temperature coefficient of the temperature, TEMPSENS.
    pub const fn c6(&self) -> u16 {
        self.words[6]
    }

    /// The CRC-4 stored in word 7 bits 3..0.
    pub const fn crc(&self) -> u8 {
        (self.words[7] & 0x000F) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const AN520: [u16; 8] = [
        0x3132, 0x3334, 0x3536, 0x3738, 0x3940, 0x4142, 0x4344, 0x4500,
    ];

    #[test]
    fn an520_vector() {
        assert_eq!(crc4(&AN520), 0xB);
        // The CRC nibble itself (and the rest of word 7's low byte) is not
        // part of the CRC input.
        let mut w = AN520;
        w[7] = 0x45FF;
        assert_eq!(crc4(&w), 0xB);
        assert_eq!(with_valid_crc(&AN520)[7], 0x450B);
    }

    #[test]
    fn blank_images() {
        assert_eq!(Prom::from_words(&[0; 8]), Err(PromError::Blank));
        assert_eq!(Prom::from_words(&[0xFFFF; 8]), Err(PromError::Blank));
        // All zero passes the CRC, which is why Blank exists.
        assert_eq!(crc4(&[0; 8]), 0);
    }
}
