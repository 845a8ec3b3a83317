//! Property tests: no input panics, and every `Ok` result is finite and valid.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::needless_range_loop
)]
mod common;

use calibration::{
    AccelCalibration, AccelSixPosition, AccelSixPositionConfig, EllipsoidFit, EllipsoidFitConfig,
    GyroBiasConfig, GyroBiasEstimator, MagCalibration, MagMinMax, MagMinMaxConfig, INPUT_LIMIT,
};
use common::*;
use proptest::prelude::*;

/// Any f32 at all: NaN, ±inf, subnormals, huge values.
fn any_vec() -> impl Strategy<Value = [f32; 3]> {
    prop::array::uniform3(prop::num::f32::ANY)
}

/// Mostly plausible values with occasional garbage.
fn mixed_vec() -> impl Strategy<Value = [f32; 3]> {
    prop_oneof![
        4 => prop::array::uniform3(-200.0f32..200.0),
        1 => any_vec(),
        1 => prop::array::uniform3(prop::sample::select(vec![0.0f32, 1.0, -1.0, 1e-30, 1e6, -1e6, 999_999.9])),
    ]
}

fn bounded_vec() -> impl Strategy<Value = [f32; 3]> {
    prop::array::uniform3(-1000.0f32..1000.0)
}

fn assert_finite(v: [f32; 3]) {
    assert!(v.iter().all(|x| x.is_finite()), "{v:?}");
}

/// Relaxed fit settings so random data reaches the solver.
const LOOSE_FIT: EllipsoidFitConfig = EllipsoidFitConfig {
    min_samples: 10,
    bins_needed: 0,
    min_range: 0.0,
    max_rms_error: f32::INFINITY,
    max_offset_std_error: f32::INFINITY,
};

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn gyro_never_panics_and_ok_is_finite(
        samples in prop::collection::vec((mixed_vec(), mixed_vec()), 0..60),
        n in 1u32..40,
        probe in bounded_vec(),
    ) {
        let config = GyroBiasConfig { samples: n, max_std: f32::INFINITY, max_spread: f32::INFINITY,
            max_accel_std: f32::INFINITY, max_accel_spread: f32::INFINITY };
        let mut est = GyroBiasEstimator::new(config).unwrap();
        for (w, a) in samples {
            let _ = est.push_with_accel(w, a);
        }
        if let Ok(b) = est.finish() {
            prop_assert!(b.is_finite());
            assert_finite(b.apply(probe));
        }
    }

    #[test]
    fn minmax_never_panics_and_ok_is_valid(
        samples in prop::collection::vec(mixed_vec(), 0..80),
        probe in bounded_vec(),
    ) {
        let mut mm = MagMinMax::new(MagMinMaxConfig { min_range: 0.0, min_samples: 2 }).unwrap();
        for m in samples {
            let _ = mm.push(m);
        }
        if let Ok(cal) = mm.finish() {
            prop_assert!(cal.validate().is_ok());
            assert_finite(cal.apply(probe));
        }
    }

    #[test]
    fn ellipsoid_never_panics_on_garbage(
        samples in prop::collection::vec(mixed_vec(), 0..120),
        probe in bounded_vec(),
    ) {
        let mut fit = EllipsoidFit::new(LOOSE_FIT).unwrap();
        for m in samples {
            let _ = fit.push(m);
        }
        let _ = fit.bins_hit();
        if let Ok(sol) = fit.finish() {
            prop_assert!(sol.calibration.validate().is_ok());
            prop_assert!(sol.radius.is_finite() && sol.rms_error.is_finite());
            assert_finite(sol.calibration.apply(probe));
        }
    }

    #[test]
    fn ellipsoid_random_geometry_ok_results_are_valid(
        seed in 1u64..u64::MAX,
        offset in prop::array::uniform3(-2000.0f64..2000.0),
        radius in prop_oneof![1e-3f64..1.0, 1.0f64..100.0, 100.0f64..100_000.0],
        gains in prop::array::uniform3(0.05f64..3.0),
        angle in -3.2f64..3.2,
        noise_rel in 0.0f64..0.3,
        cap_cos in -1.0f64..1.0,
        n in 10usize..400,
        probe in bounded_vec(),
    ) {
        let mut rng = common::Rng::new(seed);
        let d = mul(&rotation([0.4, -0.2, 0.9], angle), &diag(gains));
        let mut fit = EllipsoidFit::new(LOOSE_FIT).unwrap();
        for _ in 0..n {
            // Directions restricted to a cap of random size around +z.
            let h = loop {
                let u = rng.unit();
                if u[2] >= cap_cos { break u; }
            };
            let mut m = add(offset, mul_v(&d, scale(h, radius)));
            for c in &mut m {
                *c += noise_rel * radius * rng.gauss();
            }
            let _ = fit.push(to32(m));
        }
        if let Ok(sol) = fit.finish() {
            prop_assert!(sol.calibration.validate().is_ok());
            prop_assert!(sol.radius.is_finite() && sol.radius > 0.0);
            prop_assert!(sol.rms_error.is_finite() && sol.rms_error >= 0.0);
            assert_finite(sol.calibration.apply(probe));
        }
    }

    #[test]
    fn accel_never_panics_and_ok_is_valid(
        runs in prop::collection::vec(
            prop_oneof![
                // Three still samples in one face-up position (window = 3).
                3 => (0usize..6, -0.3f32..0.3, 0.5f32..1.5).prop_map(|(face, e, g)| {
                    let mut v = [e, -e, 0.5 * e];
                    let s = if face % 2 == 0 { g } else { -g };
                    v[face / 2] = s;
                    vec![v; 3]
                }),
                1 => prop::collection::vec(any_vec(), 1..4),
            ],
            0..40,
        ),
        probe in bounded_vec(),
    ) {
        let config = AccelSixPositionConfig { window: 3, ..AccelSixPositionConfig::G };
        let mut six = AccelSixPosition::new(config).unwrap();
        for a in runs.into_iter().flatten() {
            let _ = six.push(a);
        }
        if let Ok(cal) = six.finish() {
            prop_assert!(cal.validate().is_ok());
            assert_finite(cal.apply(probe));
        }
    }

    #[test]
    fn validated_corrections_map_bounded_inputs_to_finite_outputs(
        offset in prop::array::uniform3(-(INPUT_LIMIT)..INPUT_LIMIT),
        m in prop::array::uniform3(prop::array::uniform3(prop::num::f32::ANY)),
        scale_v in prop::array::uniform3(prop::num::f32::ANY),
        probe in prop::array::uniform3(-(INPUT_LIMIT)..INPUT_LIMIT),
    ) {
        let mag = MagCalibration { offset, soft_iron: m };
        if mag.validate().is_ok() {
            prop_assert!(mag.is_finite());
            // Gains ≤ 5 on the diagonal; off-diagonals are unbounded finite
            // values, so only check when they are moderate.
            if m.iter().flatten().all(|x| x.abs() <= 10.0) {
                assert_finite(mag.apply(probe));
            }
        }
        let acc = AccelCalibration { offset, scale: scale_v };
        if acc.validate().is_ok() {
            assert_finite(acc.apply(probe));
        }
    }
}

#[test]
fn identities_do_nothing() {
    let v = [1.5f32, -2.25, 1e5];
    assert_eq!(MagCalibration::identity().apply(v), v);
    assert_eq!(AccelCalibration::identity().apply(v), v);
    assert_eq!(calibration::GyroBias::identity().apply(v), v);
    assert!(MagCalibration::identity().validate().is_ok());
    assert!(AccelCalibration::identity().validate().is_ok());
    let mut flipped = MagCalibration::identity();
    flipped.soft_iron[1][1] = -1.0;
    assert!(flipped.validate().is_err());
    let mut skew = MagCalibration::identity();
    skew.soft_iron[0][1] = 3.0; // symmetric part not positive definite
    assert!(skew.validate().is_err());
    let mut nan = AccelCalibration::identity();
    nan.offset[2] = f32::NAN;
    assert!(!nan.is_finite() && nan.validate().is_err());
}

#[test]
fn documented_state_sizes_hold() {
    use core::mem::size_of;
    assert_eq!(size_of::<GyroBiasEstimator>(), 152);
    assert_eq!(size_of::<MagMinMax>(), 40);
    assert_eq!(size_of::<EllipsoidFit>(), 704);
    assert_eq!(size_of::<AccelSixPosition>(), 168);
    assert_eq!(size_of::<MagCalibration>(), 48);
    assert_eq!(size_of::<AccelCalibration>(), 24);
    assert_eq!(size_of::<calibration::GyroBias>(), 12);
}
