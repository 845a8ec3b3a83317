//! The real drivers initialise against the simulated chips and read values
//! matching the truth within the injected noise.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use e2e::{f64x3, mean3, mean_sd, Rig};
use embedded_hal::delay::DelayNs;
use mpu9250::{Address, Config, Mpu9250};
use sim::physics::G0_MPS2;
use sim::{SensorErrors, SimConfig, Trajectory};

fn mpu_rig(config: SimConfig) -> (Rig, Mpu9250<sim::SimBus>) {
    let mut rig = Rig::new(config);
    let mut imu = Mpu9250::new(rig.bus.clone(), Address::Ad0Low);
    let variant = imu.init(&mut rig.delay, &Config::default()).unwrap();
    assert_eq!(variant, mpu9250::Variant::Mpu9250);
    (rig, imu)
}

#[test]
fn mpu9250_at_rest_reads_gravity_on_z() {
    let (mut rig, mut imu) = mpu_rig(SimConfig::default());
    let mut acc = Vec::new();
    let mut temps = Vec::new();
    for _ in 0..500 {
        rig.delay.delay_ms(1);
        let s = imu.read().unwrap();
        acc.push(f64x3(s.accel_g));
        temps.push(f64::from(s.temp_c));
    }
    let m = mean3(&acc);
    // Noise only: 300 µg/√Hz over ~70 Hz ≈ 2.5 mg RMS per sample; mean of 500 ≪ 1 mg.
    assert!(m[0].abs() < 1e-3 && m[1].abs() < 1e-3, "{m:?}");
    assert!((m[2] - 1.0).abs() < 1e-3, "{m:?}");
    let (_, sd) = mean_sd(&acc.iter().map(|a| a[2]).collect::<Vec<_>>());
    assert!(sd > 1.5e-3 && sd < 4e-3, "per-sample noise {sd} g");
    // ISA sea level: 15 °C.
    let (t, _) = mean_sd(&temps);
    assert!((t - 15.0).abs() < 0.05, "{t}");
}

#[test]
fn mpu9250_tilted_and_spinning() {
    // Rolled 90° right (right wing down): the specific force points up = body −y;
    // the MPU's y axis (left when face up) points up and reads +1 g.
    let q = sim::Quat::from_euler(90f64.to_radians(), 0.0, 0.0);
    let cfg = SimConfig {
        trajectory: Trajectory::AtRest { q_ned_from_body: q },
        errors: SensorErrors::ideal(),
        ..SimConfig::default()
    };
    let (mut rig, mut imu) = mpu_rig(cfg);
    rig.delay.delay_ms(2);
    let s = imu.read().unwrap();
    assert!(
        (f64::from(s.accel_g[1]) - 1.0).abs() < 1e-3,
        "{:?}",
        s.accel_g
    );
    assert!(f64::from(s.accel_g[2]).abs() < 1e-3);

    // Yawing right at 90 °/s (FRD z down) → MPU z reads −90 °/s.
    let cfg = SimConfig {
        trajectory: Trajectory::ConstantRate {
            omega_body_rps: [0.0, 0.0, 90f64.to_radians()],
        },
        ..SimConfig::default()
    };
    let (mut rig, mut imu) = mpu_rig(cfg);
    let mut g = Vec::new();
    for _ in 0..200 {
        rig.delay.delay_ms(1);
        g.push(f64x3(imu.read().unwrap().gyro_dps));
    }
    let m = mean3(&g);
    assert!(
        (m[2] + 90.0).abs() < 0.1 && m[0].abs() < 0.1 && m[1].abs() < 0.1,
        "{m:?}"
    );
    // Centripetal-free spin about z: the accelerometer still reads 1 g.
    let s = imu.read().unwrap();
    let a = f64x3(s.accel_g);
    assert!(((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() - 1.0).abs() < 0.02);
}

#[test]
fn mpu9250_gyro_bias_calibration_recovers_injected_bias() {
    let mut errors = SensorErrors::noise_only();
    errors.gyro_dps.bias = [2.5, -1.75, 0.8];
    let cfg = SimConfig {
        errors,
        ..SimConfig::default()
    };
    let (mut rig, mut imu) = mpu_rig(cfg);
    imu.calibrate_gyro_bias(&mut rig.delay, 500).unwrap();
    let b = f64x3(imu.gyro_bias_dps());
    for i in 0..3 {
        // Mean of 500 samples with ≈0.08 °/s noise, plus ±½ count rounding (1/32.8 °/s).
        assert!((b[i] - errors.gyro_dps.bias[i]).abs() < 0.03, "{b:?}");
    }
    // After calibration the gyro reads ≈ 0 at rest.
    let mut g = Vec::new();
    for _ in 0..200 {
        rig.delay.delay_ms(1);
        g.push(f64x3(imu.read().unwrap().gyro_dps));
    }
    let m = mean3(&g);
    assert!(m.iter().all(|v| v.abs() < 0.03), "{m:?}");
    let _ = G0_MPS2;
}

#[test]
fn mpu9250_gyro_calibration_refuses_motion() {
    let cfg = SimConfig {
        trajectory: Trajectory::SlowRotations,
        ..SimConfig::default()
    };
    let (mut rig, mut imu) = mpu_rig(cfg);
    // Skip the rest phase at the start of the trajectory.
    rig.delay.delay_ms(6_000);
    let e = imu.calibrate_gyro_bias(&mut rig.delay, 500).unwrap_err();
    assert!(matches!(e, mpu9250::Error::Moved(_)), "{e:?}");
    assert_eq!(imu.gyro_bias(), [0, 0, 0], "bias unchanged");
}

#[test]
fn ms5611_reads_isa_pressure_and_temperature_at_altitude() {
    use ms5611::{Ms5611, Osr};
    for &alt in &[0.0, 500.0, 1500.0, 3000.0] {
        let env = sim::Environment {
            ground_altitude_m: alt,
            ..sim::Environment::default()
        };
        let mut rig = Rig::new(SimConfig {
            env,
            ..SimConfig::default()
        });
        let mut baro = Ms5611::new(rig.bus.clone(), ms5611::Address::CsbLow);
        let prom = baro.init(&mut rig.delay).unwrap();
        let _ = prom;
        let (mut ps, mut ts) = (Vec::new(), Vec::new());
        for _ in 0..20 {
            let m = baro.measure(&mut rig.delay, Osr::Osr4096).unwrap();
            ps.push(f64::from(m.pressure_pa));
            ts.push(f64::from(m.temperature_centi_c) / 100.0);
        }
        let (p, p_sd) = mean_sd(&ps);
        let (t, _) = mean_sd(&ts);
        let p_true = sim::physics::isa_pressure_pa(alt);
        // OSR 4096: 0.012 mbar = 1.2 Pa RMS; mean of 20 → ±1 Pa, + 1 Pa truncation.
        assert!((p - p_true).abs() < 2.0, "alt {alt}: {p} vs {p_true}");
        assert!(p_sd < 3.0, "{p_sd}");
        assert!(
            (t - sim::physics::isa_temperature_c(alt)).abs() < 0.02,
            "alt {alt}: {t}"
        );
    }
}

#[test]
fn ms5611_cold_second_order_compensation_matches_truth() {
    use ms5611::{Ms5611, Osr};
    // −25 °C chip temperature exercises both second-order branches (< 20 °C and < −15 °C).
    let env = sim::Environment {
        chip_temp_offset_c: -40.0,
        ..sim::Environment::default()
    };
    let mut rig = Rig::new(SimConfig {
        env,
        errors: SensorErrors::ideal(),
        ..SimConfig::default()
    });
    let mut baro = Ms5611::new(rig.bus.clone(), ms5611::Address::CsbLow);
    baro.init(&mut rig.delay).unwrap();
    let m = baro.measure(&mut rig.delay, Osr::Osr1024).unwrap();
    assert!((m.temperature_centi_c + 2500).abs() <= 1, "{m:?}");
    assert!((f64::from(m.pressure_pa) - 101_325.0).abs() <= 1.0, "{m:?}");
}

#[test]
fn ms5611_each_osr_has_datasheet_noise() {
    use ms5611::{Ms5611, Osr};
    let mut rig = Rig::new(SimConfig::default());
    let mut baro = Ms5611::new(rig.bus.clone(), ms5611::Address::CsbLow);
    baro.init(&mut rig.delay).unwrap();
    for (osr, rms_pa) in [(Osr::Osr256, 6.5), (Osr::Osr1024, 2.7), (Osr::Osr4096, 1.2)] {
        let ps: Vec<f64> = (0..200)
            .map(|_| f64::from(baro.measure(&mut rig.delay, osr).unwrap().pressure_pa))
            .collect();
        let (_, sd) = mean_sd(&ps);
        // Integer Pa output adds ≈0.3 Pa of quantisation noise.
        assert!(
            sd > 0.7 * rms_pa && sd < 1.3 * rms_pa + 0.3,
            "{osr:?}: {sd}"
        );
    }
}

fn mag_rig(config: SimConfig) -> (Rig, ak8963::Ak8963<sim::SimBus>) {
    let (mut rig, mut imu) = mpu_rig(config);
    imu.set_bypass(true).unwrap();
    let mut mag = ak8963::Ak8963::new(rig.bus.clone());
    mag.init(&mut rig.delay, &ak8963::Config::default())
        .unwrap();
    (rig, mag)
}

fn read_mag_blocking(rig: &mut Rig, mag: &mut ak8963::Ak8963<sim::SimBus>) -> ak8963::Sample {
    for _ in 0..100 {
        match mag.read() {
            Ok(s) => return s,
            Err(ak8963::Error::NotReady) => rig.delay.delay_ms(1),
            Err(e) => panic!("{e:?}"),
        }
    }
    panic!("no magnetometer sample in 100 ms");
}

#[test]
fn ak8963_reads_the_earth_field_in_the_mpu_frame() {
    // Level, facing east (yaw 90°): NED field (25, 0, 43.3) µT → body (0, −25, 43.3)
    // → MPU (0, 25, −43.3).
    let q = sim::Quat::from_euler(0.0, 0.0, 90f64.to_radians());
    let cfg = SimConfig {
        trajectory: Trajectory::AtRest { q_ned_from_body: q },
        ..SimConfig::default()
    };
    let (mut rig, mut mag) = mag_rig(cfg);
    assert_eq!(mag.asa(), sim::ak8963::DEFAULT_ASA);
    let samples: Vec<[f64; 3]> = (0..50)
        .map(|_| f64x3(read_mag_blocking(&mut rig, &mut mag).field_mpu_ut()))
        .collect();
    let m = mean3(&samples);
    let expect = [0.0, 25.0, -43.301];
    for i in 0..3 {
        // 0.4 µT noise / √50 + 0.15 µT quantisation.
        assert!((m[i] - expect[i]).abs() < 0.3, "{m:?}");
    }
}

#[test]
fn ak8963_self_test_passes() {
    let (mut rig, mut mag) = mag_rig(SimConfig::default());
    let adj = mag.self_test(&mut rig.delay).unwrap();
    assert!(adj[2] < -800 && adj[2] > -3200, "{adj:?}");
    // Back in continuous mode afterwards.
    let _ = read_mag_blocking(&mut rig, &mut mag);
}

#[test]
fn ak8963_data_overrun_is_reported() {
    let (mut rig, mut mag) = mag_rig(SimConfig::default());
    let _ = read_mag_blocking(&mut rig, &mut mag);
    rig.delay.delay_ms(35); // three 100 Hz measurements, none read
    let s = mag.read().unwrap();
    assert!(s.data_overrun);
    rig.delay.delay_ms(10);
    assert!(!mag.read().unwrap().data_overrun);
}
