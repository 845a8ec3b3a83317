//! The calibration crate recovers the errors injected into the simulated
//! sensors, fed by the real drivers.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use calibration::{
    AccelSixPosition, AccelSixPositionConfig, EllipsoidFit, EllipsoidFitConfig, EllipsoidFitF32,
    GyroBiasConfig, GyroBiasEstimator, MagMinMax, MagMinMaxConfig, Position, SixPositionEvent,
};
use e2e::Rig;
use embedded_hal::delay::DelayNs;
use mpu9250::{Address, Config, Mpu9250};
use sim::errors::random_soft_iron;
use sim::rng::Rng;
use sim::{SensorErrors, SimConfig, Trajectory};

#[test]
fn gyro_bias_estimator_recovers_injected_bias() {
    let mut errors = SensorErrors::noise_only();
    errors.gyro_dps.bias = [-2.2, 1.3, 0.45];
    let mut rig = Rig::new(SimConfig {
        errors,
        ..SimConfig::default()
    });
    let mut imu = Mpu9250::new(rig.bus.clone(), Address::Ad0Low);
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    let mut est = GyroBiasEstimator::new(GyroBiasConfig::RPS_AND_G).unwrap();
    loop {
        rig.bus.advance_to_next_mpu_sample();
        let s = imu.read().unwrap();
        if est.push_with_accel(s.gyro_rps(), s.accel_g).unwrap() {
            break;
        }
    }
    let b = est.finish().unwrap();
    for i in 0..3 {
        let truth = errors.gyro_dps.bias[i].to_radians();
        // 500 samples of ≈0.0015 rad/s noise: σ_mean ≈ 7e-5 rad/s; quantisation 5e-4 rad/s/LSB is dithered.
        assert!(
            (f64::from(b.bias[i]) - truth).abs() < 4e-4,
            "axis {i}: {} vs {truth}",
            b.bias[i]
        );
    }
}

/// Hard and soft iron in the AK8963 frame as seen in the MPU frame:
/// m_mpu = P·(S·P⁻¹·B_mpu + h) with P the AK→MPU permutation.
fn ak_to_mpu_matrix(s: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let p = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]; // P = P⁻¹ = Pᵀ
    let ps = sim::math::mat_mul(&p, s);
    sim::math::mat_mul(&ps, &p)
}

fn dance_samples(errors: SensorErrors, seconds: f64) -> Vec<[f32; 3]> {
    e2e::mag_samples(errors, Trajectory::FigureEight, 7, seconds)
}

#[test]
fn ellipsoid_fit_recovers_hard_and_soft_iron_on_the_figure_eight() {
    let mut errors = SensorErrors::noise_only();
    errors.mag.hard_iron_ut = [25.0, -18.0, 32.0];
    errors.mag.soft_iron = random_soft_iron(&mut Rng::new(3), 0.12);
    let samples = dance_samples(errors, 40.0);
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    for m in &samples {
        fit.push(*m).unwrap();
    }
    let sol = fit.finish().unwrap();
    let h = sim::math::ak_to_mpu(errors.mag.hard_iron_ut);
    for i in 0..3 {
        assert!(
            (f64::from(sol.calibration.offset[i]) - h[i]).abs() < 1.0,
            "{:?} vs {h:?}",
            sol.calibration.offset
        );
    }
    // The correction undoes the soft iron up to a scale: C·S_mpu ≈ k·I.
    let s_mpu = ak_to_mpu_matrix(&errors.mag.soft_iron);
    let c = sol.calibration.soft_iron.map(|r| r.map(f64::from));
    let cs = sim::math::mat_mul(&c, &s_mpu);
    let k = (cs[0][0] + cs[1][1] + cs[2][2]) / 3.0;
    for (i, row) in cs.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            let expect = if i == j { k } else { 0.0 };
            assert!((v - expect).abs() < 0.02 * k, "C·S = {cs:?}");
        }
    }
    // Corrected samples lie on a sphere.
    let norms: Vec<f64> = samples
        .iter()
        .map(|m| {
            let v = sol.calibration.apply(*m).map(f64::from);
            (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
        })
        .collect();
    let (mean, sd) = e2e::mean_sd(&norms);
    assert!(sd / mean < 0.015, "{sd} / {mean}");
}

/// The board's fit (integer moments, f32 solve) against the host's f64
/// fit on the simulator's distortions: several hard/soft-iron draws (soft
/// iron ±15 %, and ±30 % for the last two; hard iron up to 83 µT), the same
/// samples into both.
#[test]
fn board_ellipsoid_fit_agrees_with_the_host_fit() {
    for (seed, soft) in [
        (3u64, 0.15),
        (5, 0.15),
        (8, 0.15),
        (13, 0.15),
        (17, 0.3),
        (21, 0.3),
    ] {
        let mut rng = Rng::new(seed);
        let mut errors = SensorErrors::noise_only();
        errors.mag.hard_iron_ut = [25.0, -18.0, 32.0].map(|h: f64| h * (0.5 + seed as f64 / 10.0));
        errors.mag.soft_iron = random_soft_iron(&mut rng, soft);
        let samples = dance_samples(errors, 40.0);
        let mut host = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
        let mut board = EllipsoidFitF32::new(EllipsoidFitConfig::MICROTESLA, 0.125).unwrap();
        for m in &samples {
            host.push(*m).unwrap();
            board.push(*m).unwrap();
        }
        let (h, b) = (host.finish().unwrap(), board.finish().unwrap());
        for i in 0..3 {
            let d = (h.calibration.offset[i] - b.calibration.offset[i]).abs();
            assert!(
                d < 0.05,
                "seed {seed}: offset {:?} vs {:?}",
                h.calibration.offset,
                b.calibration.offset
            );
            for j in 0..3 {
                let d = (h.calibration.soft_iron[i][j] - b.calibration.soft_iron[i][j]).abs();
                assert!(
                    d < 1e-3,
                    "seed {seed}: W {:?} vs {:?}",
                    h.calibration.soft_iron,
                    b.calibration.soft_iron
                );
            }
        }
        assert!(
            (h.radius - b.radius).abs() < 0.02,
            "{} vs {}",
            h.radius,
            b.radius
        );
        // The figure is a small difference of O(1) moment sums; f32 and the
        // 0.125 µT quantum keep it within 0.5 % here (0.00792 vs 0.00796).
        assert!(
            (h.rms_error - b.rms_error).abs() < 0.01 * h.rms_error,
            "{} vs {}",
            h.rms_error,
            b.rms_error
        );
        assert_eq!(h.bins_hit, b.bins_hit);
    }
}

/// Half a figure-eight (the samples above the middle of the z range only)
/// is refused by both fits with the same coverage count.
#[test]
fn board_ellipsoid_fit_refuses_a_hemisphere_like_the_host() {
    let mut rng = Rng::new(7);
    let mut errors = SensorErrors::noise_only();
    errors.mag.hard_iron_ut = [12.0, -20.0, 30.0];
    errors.mag.soft_iron = random_soft_iron(&mut rng, 0.15);
    let mut host = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    let mut board = EllipsoidFitF32::new(EllipsoidFitConfig::MICROTESLA, 0.125).unwrap();
    let samples = dance_samples(errors, 40.0);
    let (lo, hi) = samples.iter().fold((f32::MAX, f32::MIN), |(lo, hi), m| {
        (lo.min(m[2]), hi.max(m[2]))
    });
    let mid = 0.5 * (lo + hi);
    for m in samples.iter().filter(|m| m[2] > mid) {
        host.push(*m).unwrap();
        board.push(*m).unwrap();
    }
    let (h, b) = (host.finish(), board.finish());
    assert!(
        matches!(h, Err(calibration::Error::InsufficientCoverage { .. })),
        "{h:?}"
    );
    assert_eq!(format!("{:?}", h.err()), format!("{:?}", b.err()));
}

/// The board's fit refuses what the host fit refuses: a flat (planar)
/// sweep is insufficient coverage for both.
#[test]
fn board_ellipsoid_fit_refuses_a_planar_sweep_like_the_host() {
    let mut host = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    let mut board = EllipsoidFitF32::new(EllipsoidFitConfig::MICROTESLA, 0.125).unwrap();
    for k in 0..600 {
        let a = k as f32 * 0.05;
        let m = [
            10.0 + 40.0 * a.cos(),
            -5.0 + 40.0 * a.sin(),
            20.0 + 0.3 * (k % 3) as f32,
        ];
        host.push(m).unwrap();
        board.push(m).unwrap();
    }
    let (h, b) = (host.finish(), board.finish());
    assert!(h.is_err() && b.is_err(), "{h:?} {b:?}");
    assert_eq!(format!("{:?}", h.err()), format!("{:?}", b.err()));
}

#[test]
fn min_max_recovers_hard_iron_and_axis_gains() {
    let mut errors = SensorErrors::noise_only();
    errors.mag.hard_iron_ut = [-30.0, 12.0, 5.0];
    errors.mag.soft_iron = [[1.1, 0.0, 0.0], [0.0, 0.92, 0.0], [0.0, 0.0, 1.0]];
    let samples = dance_samples(errors, 40.0);
    let mut mm = MagMinMax::new(MagMinMaxConfig::MICROTESLA).unwrap();
    for m in &samples {
        mm.push(*m).unwrap();
    }
    let cal = mm.finish().unwrap();
    let h = sim::math::ak_to_mpu(errors.mag.hard_iron_ut);
    for i in 0..3 {
        // Extremes of a 40 s dance: within ~1.5 µT of the true centre.
        assert!(
            (f64::from(cal.offset[i]) - h[i]).abs() < 1.5,
            "{:?} vs {h:?}",
            cal.offset
        );
    }
    // MPU x = AK y (gain 0.92), MPU y = AK x (gain 1.1): corrections ∝ 1/gain.
    let ratio = f64::from(cal.soft_iron[0][0] / cal.soft_iron[1][1]);
    assert!((ratio - 1.1 / 0.92).abs() < 0.03, "{ratio}");
}

/// The board held on each face in turn (`Trajectory::SixPosition`), read
/// through the MPU-9250 driver every 10 ms (g, MPU frame) into the
/// six-position calibration with its default settings. Returns the
/// calibration and the faces in the order they were captured.
fn six_position(
    errors: SensorErrors,
    seed: u64,
) -> (
    calibration::AccelCalibration,
    Vec<Position>,
    AccelSixPosition,
) {
    let mut rig = Rig::new(SimConfig {
        trajectory: Trajectory::SixPosition,
        errors,
        seed,
        ..SimConfig::default()
    });
    let mut imu = Mpu9250::new(rig.bus.clone(), Address::Ad0Low);
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    let mut six = AccelSixPosition::new(AccelSixPositionConfig::G).unwrap();
    let mut order = Vec::new();
    while !six.progress().is_complete() {
        assert!(
            rig.clock.now_s() < Trajectory::six_position_duration_s() + 5.0,
            "only {:?} captured",
            six.progress()
        );
        rig.delay.delay_ms(10);
        let s = imu.read().unwrap();
        if let Ok(SixPositionEvent::Captured(p)) = six.push(s.accel_g) {
            order.push(p);
        }
    }
    (six.finish().unwrap(), order, six)
}

#[test]
fn six_position_recovers_injected_accel_offset_and_scale() {
    let g = sim::physics::G0_MPS2;
    let mut errors = SensorErrors::noise_only();
    // Offsets of datasheet size (±80 mg), scale errors of a few %, and
    // cross-axis coupling, which the per-axis model does not estimate but
    // which must not disturb the offsets (it cancels in a₊ + a₋).
    errors.accel_mps2.bias = [0.055 * g, -0.032 * g, 0.071 * g];
    errors.accel_mps2.misalignment = [
        [1.025, 0.008, -0.006],
        [-0.005, 0.978, 0.009],
        [0.007, -0.004, 1.012],
    ];
    let (cal, order, six) = six_position(errors, 11);
    // Captured in the order the board was turned, each face once.
    let expected: Vec<Position> = Trajectory::SIX_POSITION_POSES
        .iter()
        .map(|&(axis, sign)| match (axis, sign > 0) {
            (0, true) => Position::XUp,
            (0, false) => Position::XDown,
            (1, true) => Position::YUp,
            (1, false) => Position::YDown,
            (_, true) => Position::ZUp,
            (_, false) => Position::ZDown,
        })
        .collect();
    assert_eq!(order, expected);
    for i in 0..3 {
        let offset_g = errors.accel_mps2.bias[i] / g;
        let scale = 1.0 / errors.accel_mps2.misalignment[i][i];
        // 200 samples of ≈2 mg noise: σ_mean ≈ 0.15 mg; quantisation 0.12 mg.
        assert!(
            (f64::from(cal.offset[i]) - offset_g).abs() < 1e-3,
            "axis {i}: offset {} g vs {offset_g} g",
            cal.offset[i]
        );
        assert!(
            (f64::from(cal.scale[i]) - scale).abs() < 1e-3,
            "axis {i}: scale {} vs {scale}",
            cal.scale[i]
        );
    }
    // Every captured face, corrected, reads 1 g (to the cross-axis terms:
    // √(1 + 0.009²) − 1 ≈ 4e-5).
    for p in Position::ALL {
        let c = cal.apply(six.captured(p).unwrap());
        let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        assert!((n - 1.0).abs() < 1e-3, "{p:?}: |a| = {n} g");
    }
}

#[test]
fn six_position_on_an_ideal_accelerometer_is_the_identity() {
    let (cal, _, _) = six_position(SensorErrors::noise_only(), 12);
    for i in 0..3 {
        assert!(cal.offset[i].abs() < 1e-3, "{cal:?}");
        assert!((cal.scale[i] - 1.0).abs() < 1e-3, "{cal:?}");
    }
}
