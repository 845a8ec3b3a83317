//! ADC counts → pack voltage, and the scale from one multimeter reading,
//! against hand-worked figures.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use battery::*;

#[test]
fn default_scale_is_the_11_to_1_divider_on_3v3() {
    // 10 kΩ over 1 kΩ: 11 · 3300 mV at 4096 counts.
    assert_eq!(Scale::DEFAULT.full_scale_mv(), 36_300);
    // The last code: 4095 · 36 300 / 4096 = 36 291.1 mV.
    assert_eq!(Scale::DEFAULT.counts_to_mv(4095), 36_291);
    // One count: 8.86 mV.
    assert_eq!(Scale::DEFAULT.counts_to_mv(1), 9);
    assert_eq!(Scale::DEFAULT.counts_to_mv(0), 0);
    // Beyond the 12-bit range reads as the last code.
    assert_eq!(Scale::DEFAULT.counts_to_mv(u16::MAX), 36_291);
}

#[test]
fn two_to_eight_cells_fit_below_the_last_code() {
    // Full charge, 4.2 V a cell: 6S 25.2 V = 2844 counts, 8S 33.6 V = 3791.
    let counts = |mv: u64| (mv * 4096 + 36_300 / 2) / 36_300;
    assert_eq!(counts(25_200), 2844);
    assert_eq!(counts(33_600), 3791);
    assert!(counts(33_600) < u64::from(ADC_MAX_COUNT));
    // 2S empty (6.0 V) still has 677 counts: 9 mV steps are 0.15 % of it.
    assert_eq!(counts(6_000), 677);
    assert_eq!(Scale::DEFAULT.counts_to_mv(2844), 25_204);
}

#[test]
fn q16_counts_read_as_whole_counts() {
    let s = Scale::DEFAULT;
    for c in [0u16, 1, 677, 1715, 2844, 4095] {
        assert_eq!(s.counts_q16_to_mv(i32::from(c) << 16), s.counts_to_mv(c));
    }
    // Half a count between them rounds.
    let half = (1715 << 16) + (1 << 15);
    let mid = (u64::from(s.counts_to_mv(1715)) + u64::from(s.counts_to_mv(1716))) / 2;
    assert!(u64::from(s.counts_q16_to_mv(half)).abs_diff(mid) <= 1);
    assert_eq!(s.counts_q16_to_mv(-5), 0);
}

#[test]
fn scale_from_a_multimeter_reading() {
    // 12.000 V on the meter while the ADC reads 1354:
    // 12 000 · 4096 / 1354 = 36 301.3 → 36 301.
    let s = scale_from_reading(1354, 12_000).unwrap();
    assert_eq!(s.full_scale_mv(), 36_301);
    assert_eq!(s.counts_to_mv(1354), 12_000);
    // A divider 5 % high (10.5 kΩ): the same pack reads fewer counts.
    let s = scale_from_reading(1292, 12_000).unwrap();
    assert_eq!(s.full_scale_mv(), 38_043); // 49 152 000 / 1292 = 38 043.3
}

#[test]
fn calibration_readings_out_of_range_are_refused() {
    assert_eq!(
        scale_from_reading(299, 2_600),
        Err(Error::CountsTooLow { counts: 299 })
    );
    assert_eq!(
        scale_from_reading(4095, 36_000),
        Err(Error::CountsSaturated { counts: 4095 })
    );
    // 40 V on 300 counts would be a 44:1 divider.
    assert_eq!(
        scale_from_reading(300, 40_000),
        Err(Error::ScaleOutOfRange {
            full_scale_mv: 546_133
        })
    );
    // A meter reading of 0 (probe not on the pack).
    assert_eq!(
        scale_from_reading(1354, 0),
        Err(Error::ScaleOutOfRange { full_scale_mv: 0 })
    );
    assert_eq!(
        scale_from_reading(300, u32::MAX).unwrap_err(),
        Error::ScaleOutOfRange {
            full_scale_mv: u32::MAX
        }
    );
}

#[test]
fn scale_range() {
    assert!(Scale::new(Scale::MIN_FULL_SCALE_MV).is_ok());
    assert!(Scale::new(Scale::MAX_FULL_SCALE_MV).is_ok());
    assert!(Scale::new(Scale::MIN_FULL_SCALE_MV - 1).is_err());
    assert!(Scale::new(Scale::MAX_FULL_SCALE_MV + 1).is_err());
    assert!(Error::ScaleOutOfRange { full_scale_mv: 5 }
        .to_string()
        .contains("10000..=80000"));
}
