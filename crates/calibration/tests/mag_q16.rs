//! The integer magnetometer correction against its f32 definition.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use calibration::{Error, MagCalibrationQ16};
use proptest::prelude::*;

/// Exact `m · (raw − offset)` in f64.
fn exact(m: &[[f32; 3]; 3], offset: [f32; 3], raw: [i32; 3]) -> [f64; 3] {
    m.map(|row| {
        (0..3)
            .map(|j| f64::from(row[j]) * (f64::from(raw[j]) - f64::from(offset[j])))
            .sum()
    })
}

proptest! {
    /// Within the documented 2.25 output units for every 16-bit input.
    #[test]
    fn within_the_stated_bound(
        m in prop::array::uniform3(prop::array::uniform3(-12.0f32..12.0)),
        offset in prop::array::uniform3(-3000.0f32..3000.0),
        raw in prop::array::uniform3(-32768i32..=32767),
    ) {
        let q = MagCalibrationQ16::from_affine(m, offset).unwrap();
        let got = q.apply(raw);
        let want = exact(&m, offset, raw);
        for i in 0..3 {
            // f32 rounding of the bias itself adds a few ulp of |M·offset|.
            let slack = 2.25 + 1e-6 * want[i].abs().max(1.0) + 4e-7 * 36_000.0 * 3.0;
            prop_assert!((f64::from(got[i]) - want[i]).abs() <= slack,
                "{i}: {} vs {}", got[i], want[i]);
        }
    }
}

#[test]
fn refuses_what_does_not_fit() {
    let ok = [[1.0; 3]; 3];
    let mut nan = ok;
    nan[1][2] = f32::NAN;
    assert_eq!(
        MagCalibrationQ16::from_affine(nan, [0.0; 3]),
        Err(Error::OutOfRange)
    );
    let mut big = ok;
    big[0][0] = 2.0e4;
    assert_eq!(
        MagCalibrationQ16::from_affine(big, [0.0; 3]),
        Err(Error::OutOfRange)
    );
    assert_eq!(
        MagCalibrationQ16::from_affine(ok, [1.0e9, 1.0e9, 0.0]),
        Err(Error::OutOfRange)
    );
    assert_eq!(
        MagCalibrationQ16::from_affine(ok, [0.0, f32::INFINITY, 0.0]),
        Err(Error::OutOfRange)
    );
}

#[test]
fn identity_passes_counts_through_and_saturates() {
    let q = MagCalibrationQ16::identity();
    assert_eq!(q.apply([1, -2, 32_767]), [1, -2, 32_767]);
    let big = MagCalibrationQ16::from_affine([[10_000.0, 0.0, 0.0], [0.0; 3], [0.0; 3]], [0.0; 3])
        .unwrap();
    assert_eq!(big.apply([i32::MAX, 0, 0])[0], i32::MAX);
}
