//! Gyro bias at rest.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::needless_range_loop
)]
mod common;

use calibration::{Error, GyroBiasConfig, GyroBiasEstimator, MotionCheck};
use common::Rng;

const BIAS_RPS: [f64; 3] = [0.021, -0.0135, 0.0047];
const NOISE_RPS: f64 = 0.0015; // MPU-9250 at 41 Hz bandwidth
const ACCEL_NOISE_G: f64 = 0.003;

fn still_sample(rng: &mut Rng) -> ([f32; 3], [f32; 3]) {
    let w = [
        (BIAS_RPS[0] + NOISE_RPS * rng.gauss()) as f32,
        (BIAS_RPS[1] + NOISE_RPS * rng.gauss()) as f32,
        (BIAS_RPS[2] + NOISE_RPS * rng.gauss()) as f32,
    ];
    let a = [
        (0.01 + ACCEL_NOISE_G * rng.gauss()) as f32,
        (-0.02 + ACCEL_NOISE_G * rng.gauss()) as f32,
        (1.0 + ACCEL_NOISE_G * rng.gauss()) as f32,
    ];
    (w, a)
}

#[test]
fn recovers_known_bias_from_noisy_still_data() {
    let mut rng = Rng::new(1);
    let config = GyroBiasConfig {
        samples: 1000,
        ..GyroBiasConfig::RPS_AND_G
    };
    let mut est = GyroBiasEstimator::new(config).unwrap();
    let mut done = false;
    let mut pushed = 0;
    while !done {
        let (w, a) = still_sample(&mut rng);
        done = est.push_with_accel(w, a).unwrap();
        pushed += 1;
    }
    assert_eq!(pushed, 1000);
    assert!(est.is_complete());
    // Extra samples are ignored.
    assert_eq!(est.push([9.0, 9.0, 9.0]), Ok(true));
    let bias = est.finish().unwrap();
    // Standard error of the mean is 0.0015/sqrt(1000) = 4.7e-5; allow 5 sigma.
    for (got, want) in bias.bias.iter().zip(BIAS_RPS) {
        assert!((f64::from(*got) - want).abs() < 2.4e-4, "{got} vs {want}");
    }
    let corrected = bias.apply([BIAS_RPS[0] as f32, BIAS_RPS[1] as f32, BIAS_RPS[2] as f32]);
    assert!(corrected.iter().all(|c| c.abs() < 2.4e-4));
    assert!(bias.validate(0.1).is_ok());
    assert_eq!(bias.validate(0.01), Err(Error::OutOfRange));
}

#[test]
fn rotation_burst_is_reported_as_moved_immediately_and_at_finish() {
    let mut rng = Rng::new(2);
    let mut est = GyroBiasEstimator::new(GyroBiasConfig::RPS_AND_G).unwrap();
    for _ in 0..200 {
        let (w, a) = still_sample(&mut rng);
        assert_eq!(est.push_with_accel(w, a), Ok(false));
    }
    // Someone nudges the board: 0.3 rad/s about y for a moment.
    let (mut w, a) = still_sample(&mut rng);
    w[1] += 0.3;
    match est.push_with_accel(w, a) {
        Err(Error::Moved {
            check: MotionCheck::GyroSpread,
            axis: 1,
            value,
            limit,
        }) => {
            assert!(value > 0.29 && value < 0.33, "{value}");
            assert_eq!(limit, 0.05);
        }
        other => panic!("expected Moved on y, got {other:?}"),
    }
    for _ in 0..400 {
        let (w, a) = still_sample(&mut rng);
        let _ = est.push_with_accel(w, a);
    }
    assert!(est.is_complete());
    assert!(matches!(est.finish(), Err(Error::Moved { axis: 1, .. })));
    // After a reset, a clean window succeeds.
    est.reset();
    for _ in 0..500 {
        let (w, a) = still_sample(&mut rng);
        est.push_with_accel(w, a).unwrap();
    }
    assert!(est.finish().is_ok());
}

#[test]
fn excess_noise_fails_the_std_dev_test() {
    let mut rng = Rng::new(3);
    let config = GyroBiasConfig {
        max_spread: f32::INFINITY,
        ..GyroBiasConfig::RPS_AND_G
    };
    let mut est = GyroBiasEstimator::new(config).unwrap();
    for _ in 0..500 {
        // Vibration: std 0.01 rad/s on z, twice the 0.005 limit.
        let w = [0.0, 0.0, (0.01 * rng.gauss()) as f32];
        est.push(w).unwrap();
    }
    match est.finish() {
        Err(Error::Moved {
            check: MotionCheck::GyroStdDev,
            axis: 2,
            value,
            ..
        }) => assert!((value - 0.01).abs() < 0.0015, "{value}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn accelerometer_motion_is_detected_even_with_a_quiet_gyro() {
    let mut rng = Rng::new(4);
    let mut est = GyroBiasEstimator::new(GyroBiasConfig::RPS_AND_G).unwrap();
    let mut saw = None;
    for i in 0..500 {
        let (w, mut a) = still_sample(&mut rng);
        if i > 300 {
            a[0] += 0.2; // slid across the table
        }
        if let Err(e) = est.push_with_accel(w, a) {
            saw.get_or_insert(e);
        }
    }
    assert!(matches!(
        saw,
        Some(Error::Moved {
            check: MotionCheck::AccelSpread,
            axis: 0,
            ..
        })
    ));
    assert!(matches!(
        est.finish(),
        Err(Error::Moved {
            check: MotionCheck::AccelSpread,
            ..
        })
    ));
}

#[test]
fn non_finite_and_oversized_samples_are_skipped_without_effect() {
    let mut rng = Rng::new(5);
    let config = GyroBiasConfig {
        samples: 300,
        ..GyroBiasConfig::RPS_AND_G
    };
    let mut clean = GyroBiasEstimator::new(config).unwrap();
    let mut dirty = GyroBiasEstimator::new(config).unwrap();
    for i in 0..300 {
        let (w, a) = still_sample(&mut rng);
        clean.push_with_accel(w, a).unwrap();
        if i % 50 == 0 {
            assert_eq!(dirty.push([f32::NAN, 0.0, 0.0]), Err(Error::NonFinite));
            assert_eq!(
                dirty.push_with_accel(w, [0.0, f32::INFINITY, 1.0]),
                Err(Error::NonFinite)
            );
            assert_eq!(dirty.push([0.0, 2.0e6, 0.0]), Err(Error::InputOutOfRange));
        }
        dirty.push_with_accel(w, a).unwrap();
    }
    assert_eq!(dirty.rejected(), 18);
    assert_eq!(dirty.count(), 300);
    assert_eq!(clean.finish().unwrap(), dirty.finish().unwrap());
}

#[test]
fn too_few_samples_and_bad_config_are_typed_errors() {
    let mut est = GyroBiasEstimator::new(GyroBiasConfig::RPS_AND_G).unwrap();
    est.push([0.0; 3]).unwrap();
    assert_eq!(
        est.finish(),
        Err(Error::TooFewSamples { have: 1, need: 500 })
    );
    let zero = GyroBiasConfig {
        samples: 0,
        ..GyroBiasConfig::RPS_AND_G
    };
    assert!(matches!(
        GyroBiasEstimator::new(zero),
        Err(Error::InvalidConfig)
    ));
    let nan = GyroBiasConfig {
        max_std: f32::NAN,
        ..GyroBiasConfig::RPS_AND_G
    };
    assert!(matches!(
        GyroBiasEstimator::new(nan),
        Err(Error::InvalidConfig)
    ));
}

#[test]
fn large_mean_small_spread_keeps_variance_accurate() {
    // Raw counts: bias of 2000 LSB with ±3 LSB noise. A naive Σx²−(Σx)²/n in
    // f32 would lose the variance entirely; shifted sums keep it.
    let mut rng = Rng::new(6);
    let config = GyroBiasConfig {
        samples: 2000,
        max_std: 1.5,
        max_spread: 40.0,
        ..GyroBiasConfig::RPS_AND_G
    };
    let mut est = GyroBiasEstimator::new(config).unwrap();
    for _ in 0..2000 {
        est.push([(2000.0 + 2.0 * rng.gauss()) as f32, -1500.0, 20.0])
            .unwrap();
    }
    match est.finish() {
        Err(Error::Moved {
            check: MotionCheck::GyroStdDev,
            axis: 0,
            value,
            ..
        }) => assert!((value - 2.0).abs() < 0.15, "{value}"),
        other => panic!("{other:?}"),
    }
}
