//! Magnetometer min/max method.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::needless_range_loop
)]
mod common;

use calibration::{Error, MagMinMax, MagMinMaxConfig};
use common::*;

#[test]
fn recovers_injected_per_axis_offset_and_scale() {
    let mut rng = Rng::new(11);
    let offset = [23.0, -41.5, 12.25];
    let gains = [1.10, 0.90, 1.25];
    let mut mm = MagMinMax::new(MagMinMaxConfig::MICROTESLA).unwrap();
    for _ in 0..20_000 {
        let h = rng.unit();
        let m = [
            offset[0] + gains[0] * R_UT * h[0] + 0.05 * rng.gauss(),
            offset[1] + gains[1] * R_UT * h[1] + 0.05 * rng.gauss(),
            offset[2] + gains[2] * R_UT * h[2] + 0.05 * rng.gauss(),
        ];
        mm.push(to32(m)).unwrap();
    }
    let cal = mm.finish().unwrap();
    cal.validate().unwrap();
    for (got, want) in cal.offset.iter().zip(offset) {
        assert!(
            (f64::from(*got) - want).abs() < 0.1,
            "offset {got} vs {want}"
        );
    }
    // soft_iron = diag(avg_gain / gain_i): off-diagonals exactly zero.
    let avg = gains.iter().sum::<f64>() / 3.0;
    for i in 0..3 {
        for j in 0..3 {
            let want = if i == j { avg / gains[i] } else { 0.0 };
            assert!(
                (f64::from(cal.soft_iron[i][j]) - want).abs() < 2e-3,
                "[{i}][{j}]"
            );
        }
    }
    // Corrected field is a sphere of radius avg_gain · R.
    for _ in 0..200 {
        let h = rng.unit();
        let m = [
            offset[0] + gains[0] * R_UT * h[0],
            offset[1] + gains[1] * R_UT * h[1],
            offset[2] + gains[2] * R_UT * h[2],
        ];
        let c = cal.apply(to32(m));
        assert!((norm32(c) / (avg * R_UT) - 1.0).abs() < 0.005);
    }
}

#[test]
fn rotation_about_one_axis_only_is_refused() {
    let mut rng = Rng::new(12);
    let mut mm = MagMinMax::new(MagMinMaxConfig::MICROTESLA).unwrap();
    // Yawing a level board: z barely changes (field inclination 60°).
    for i in 0..500 {
        let yaw = i as f64 * 0.05;
        let m = [
            24.0 * yaw.cos() + 0.1 * rng.gauss(),
            24.0 * yaw.sin() + 0.1 * rng.gauss(),
            41.6 + 0.1 * rng.gauss(),
        ];
        mm.push(to32(m)).unwrap();
    }
    match mm.finish() {
        Err(Error::RangeTooSmall {
            axis: 2,
            range,
            min,
        }) => {
            assert!(range < 1.0);
            assert_eq!(min, 30.0);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn too_few_samples_and_bad_input_are_refused_without_corruption() {
    let mut mm = MagMinMax::new(MagMinMaxConfig::MICROTESLA).unwrap();
    assert_eq!(mm.finish(), Err(Error::TooFewSamples { have: 0, need: 50 }));
    mm.push([1.0, 2.0, 3.0]).unwrap();
    assert_eq!(mm.push([f32::NAN, 0.0, 0.0]), Err(Error::NonFinite));
    assert_eq!(
        mm.push([f32::NEG_INFINITY, 0.0, 0.0]),
        Err(Error::NonFinite)
    );
    assert_eq!(mm.push([0.0, 0.0, -5.0e6]), Err(Error::InputOutOfRange));
    assert_eq!(mm.count(), 1);
    assert_eq!(mm.rejected(), 3);
    assert_eq!(mm.ranges(), [0.0, 0.0, 0.0]);
    let bad = MagMinMaxConfig {
        min_range: f32::NAN,
        ..MagMinMaxConfig::MICROTESLA
    };
    assert!(matches!(MagMinMax::new(bad), Err(Error::InvalidConfig)));
}

#[test]
fn wildly_unequal_ranges_give_out_of_range_not_a_silly_gain() {
    let mut mm = MagMinMax::new(MagMinMaxConfig {
        min_range: 1.0,
        min_samples: 2,
    })
    .unwrap();
    mm.push([-100.0, -100.0, -1.0]).unwrap();
    mm.push([100.0, 100.0, 1.0]).unwrap();
    assert_eq!(mm.finish(), Err(Error::OutOfRange));
}
