//! The calibration crate recovers the errors injected into the simulated
//! sensors, fed by the real drivers.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use calibration::{
    EllipsoidFit, EllipsoidFitConfig, GyroBiasConfig, GyroBiasEstimator, MagMinMax, MagMinMaxConfig,
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
    let mut rig = Rig::new(SimConfig {
        trajectory: Trajectory::FigureEight,
        errors,
        seed: 7,
        ..SimConfig::default()
    });
    let mut imu = Mpu9250::new(rig.bus.clone(), Address::Ad0Low);
    imu.set_bypass(true).unwrap();
    imu.init(&mut rig.delay, &Config::default()).unwrap();
    let mut mag = ak8963::Ak8963::new(rig.bus.clone());
    mag.init(&mut rig.delay, &ak8963::Config::default())
        .unwrap();
    let mut out = Vec::new();
    while rig.clock.now_s() < seconds {
        rig.delay.delay_ms(10);
        match mag.read() {
            Ok(s) => out.push(s.field_mpu_ut()),
            Err(ak8963::Error::NotReady) => {}
            Err(e) => panic!("{e:?}"),
        }
    }
    out
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
