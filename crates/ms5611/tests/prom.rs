//! PROM CRC-4 (AN520) vectors and properties.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use ms5611::{crc4, with_valid_crc, Prom, PromError};
use proptest::prelude::*;

/// AN520's test coefficient table; the CRC "should be 0xB".
const AN520: [u16; 8] = [
    0x3132, 0x3334, 0x3536, 0x3738, 0x3940, 0x4142, 0x4344, 0x4500,
];

/// AN520's C routine transcribed literally, with `unsigned int` as a 32-bit
/// host integer (so the remainder is NOT truncated to 16 bits as in the
/// driver): an independent check of the u16 implementation.
fn an520_c(n_prom_in: &[u16; 8]) -> u8 {
    let mut n_prom: [u32; 8] = n_prom_in.map(u32::from);
    let mut n_rem: u32 = 0;
    let crc_read = n_prom[7];
    n_prom[7] &= 0xFF00;
    for cnt in 0..16 {
        if cnt % 2 == 1 {
            n_rem ^= n_prom[cnt >> 1] & 0x00FF;
        } else {
            n_rem ^= n_prom[cnt >> 1] >> 8;
        }
        for _ in 0..8 {
            if n_rem & 0x8000 != 0 {
                n_rem = (n_rem << 1) ^ 0x3000;
            } else {
                n_rem <<= 1;
            }
        }
    }
    n_rem = 0x000F & (n_rem >> 12);
    n_prom[7] = crc_read;
    let _ = n_prom;
    n_rem as u8
}

#[test]
fn an520_test_vector() {
    assert_eq!(crc4(&AN520), 0xB);
    assert_eq!(an520_c(&AN520), 0xB);
    let mut sealed = AN520;
    sealed[7] = 0x450B;
    let prom = Prom::from_words(&sealed).unwrap();
    assert_eq!(prom.words(), sealed);
    assert_eq!(prom.crc(), 0xB);
    assert_eq!(prom.factory(), 0x3132);
    assert_eq!(
        [
            prom.c1(),
            prom.c2(),
            prom.c3(),
            prom.c4(),
            prom.c5(),
            prom.c6()
        ],
        [0x3334, 0x3536, 0x3738, 0x3940, 0x4142, 0x4344]
    );
    assert_eq!(
        prom.coefficients(),
        [0x3334, 0x3536, 0x3738, 0x3940, 0x4142, 0x4344]
    );
    assert_eq!(
        Prom::from_words(&AN520),
        Err(PromError::Crc {
            expected: 0,
            computed: 0xB
        })
    );
}

#[test]
fn word7_low_byte_is_not_crc_input() {
    for low in 0..=0xFFu16 {
        let mut w = AN520;
        w[7] = 0x4500 | low;
        assert_eq!(crc4(&w), 0xB);
    }
}

#[test]
fn every_single_bit_flip_of_a_covered_bit_is_detected() {
    // Words 0..=6 entirely, word 7's high byte, and the CRC nibble itself.
    let base = with_valid_crc(&AN520);
    assert!(Prom::from_words(&base).is_ok());
    for word in 0..8 {
        for bit in 0..16 {
            if word == 7 && (4..8).contains(&bit) {
                continue; // word 7 bits 7..4: not covered by AN520's CRC
            }
            let mut w = base;
            w[word] ^= 1 << bit;
            assert!(
                matches!(Prom::from_words(&w), Err(PromError::Crc { .. })),
                "flip of word {word} bit {bit} not detected"
            );
        }
    }
}

#[test]
fn blank_proms_rejected_before_crc() {
    assert_eq!(Prom::from_words(&[0; 8]), Err(PromError::Blank));
    assert_eq!(Prom::from_words(&[0xFFFF; 8]), Err(PromError::Blank));
    // Nearly blank but not quite: judged by the CRC.
    let mut w = [0u16; 8];
    w[3] = 1;
    assert!(matches!(Prom::from_words(&w), Err(PromError::Crc { .. })));
    assert!(Prom::from_words(&with_valid_crc(&w)).is_ok());
}

#[test]
fn error_display() {
    let s = PromError::Crc {
        expected: 3,
        computed: 0xB,
    }
    .to_string();
    assert!(s.contains("0x3") && s.contains("0xb"), "{s}");
    assert!(PromError::Blank.to_string().contains("blank"));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn matches_literal_an520_transcription(words: [u16; 8]) {
        prop_assert_eq!(crc4(&words), an520_c(&words));
    }

    #[test]
    fn sealed_images_validate_and_round_trip(words: [u16; 8]) {
        let sealed = with_valid_crc(&words);
        // Only the CRC nibble changed.
        prop_assert_eq!(&sealed[..7], &words[..7]);
        prop_assert_eq!(sealed[7] & 0xFFF0, words[7] & 0xFFF0);
        let blank = sealed.iter().all(|&w| w == 0) || sealed.iter().all(|&w| w == 0xFFFF);
        match Prom::from_words(&sealed) {
            Ok(p) => { prop_assert!(!blank); prop_assert_eq!(p.words(), sealed); }
            Err(e) => { prop_assert!(blank); prop_assert_eq!(e, PromError::Blank); }
        }
    }

    /// Flipping any single bit of any coefficient C1..C6 (or the factory
    /// word) of any valid PROM is detected.
    #[test]
    fn coefficient_bit_flip_detected(words: [u16; 8], word in 0usize..7, bit in 0u32..16) {
        let sealed = with_valid_crc(&words);
        let mut corrupted = sealed;
        corrupted[word] ^= 1 << bit;
        prop_assert_ne!(crc4(&corrupted), crc4(&sealed));
        let rejected = Prom::from_words(&corrupted).is_err();
        prop_assert!(rejected);
    }

    #[test]
    fn from_coefficients_is_valid(c: [u16; 6]) {
        let p = Prom::from_coefficients(c);
        prop_assert_eq!(p.coefficients(), c);
        prop_assert_eq!(crc4(&p.words()), p.crc());
    }
}
