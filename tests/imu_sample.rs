//! What the firmware's 1 kHz task does with one sample
//! (`sensor_stack::sample::SampleStep`), host-tested against the simulated
//! board: the start-up gyro bias applied once, the magnetometer and
//! accelerometer samples handed out only when a calibration wants them,
//! and raw-log rows at 100 Hz on the magnetometer's tick with the column
//! values the pipeline computes.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use e2e::Rig;
use sensor_stack::boot::{BiasStatus, StartupGyroBias};
use sensor_stack::calmode::CalWants;
use sensor_stack::pipeline::{Pipeline, PipelineConfig};
use sensor_stack::sample::{SampleIn, SampleStep};
use sensor_stack::schedule::SampleScheduler;
use sensor_stack::sensors::{MagRead, Sensors, SensorsConfig};
use sensor_stack::storage::CalibrationRecord;
use sim::{SimBus, SimConfig};

fn setup(rig: &mut Rig) -> (Sensors<SimBus>, Pipeline, SampleStep) {
    let (s, report) = Sensors::boot(
        rig.bus.clone(),
        rig.bus.clone(),
        rig.bus.clone(),
        &mut rig.delay,
        SensorsConfig::default(),
    );
    assert!(report.failures().next().is_none());
    let scale = s.mpu_scale();
    let cfg = PipelineConfig {
        gyro_dps_per_lsb: scale.dps_per_lsb,
        accel_g_per_lsb: scale.g_per_lsb,
        mag_ut_per_lsb: s.mag_ut_per_lsb(),
        ..PipelineConfig::new()
    };
    let p = Pipeline::new(cfg, &CalibrationRecord::default()).unwrap();
    let bias =
        StartupGyroBias::new(200, 1.0 / scale.dps_per_lsb, 1.0 / scale.g_per_lsb, 3).unwrap();
    (s, p, SampleStep::new(Some(bias)))
}

#[test]
fn sample_step_feeds_bias_calibration_and_raw_log() {
    let mut rig = Rig::new(SimConfig::default());
    let (mut s, mut p, mut step) = setup(&mut rig);
    let mut sched = SampleScheduler::new(10);
    let mut wants = CalWants::default();
    let (mut rows, mut mags, mut accels, mut done_at) = (Vec::new(), 0, 0, None);
    for i in 0..1_000u32 {
        if i == 500 {
            wants = CalWants {
                mag_ut: true,
                accel_g: true,
                raw_log: true,
            };
        }
        let t = rig.bus.advance_to_next_mpu_sample();
        let tick = sched.on_imu_sample();
        let (raw, mag) = s.read_sample(tick.read_mag);
        let input = SampleIn {
            raw: raw.unwrap(),
            mag,
            read_mag: tick.read_mag,
            dt_cycles: 72_000,
            now_us: (t / 1_000) as u32,
        };
        let out = step.run(&mut p, &input, wants);
        if let BiasStatus::Done(b) = out.bias {
            done_at.get_or_insert((i, b));
        }
        if out.mag_ut.is_some() {
            assert!(wants.mag_ut && matches!(mag, MagRead::Sample(_)));
            mags += 1;
        }
        if let Some(a) = out.accel_g {
            assert!(wants.accel_g && tick.read_mag);
            // At rest, face up: ≈ +1 g on z.
            assert!((a[2] - 1.0).abs() < 0.1, "{a:?}");
            accels += 1;
        }
        if let Some(r) = out.row {
            rows.push(r);
        }
    }
    // The bias window (200 samples) finished and reached the pipeline.
    let (at, b) = done_at.expect("bias measured");
    assert!((199..=210).contains(&at), "{at}");
    assert_eq!(p.gyro_bias_counts(), b.map(i32::from));
    // Calibration samples only while wanted: 100 Hz for the last 500.
    assert!((48..=50).contains(&mags), "{mags}");
    assert_eq!(accels, 50);
    // Raw-log rows every 10th sample, bias removed (≈ 0 rad/s at rest),
    // g on z, time stamps 10 ms apart.
    assert_eq!(rows.len(), 50);
    for w in rows.windows(2) {
        let dt = w[1].t_s - w[0].t_s;
        assert!((dt - 0.01).abs() < 1e-4, "{dt}");
    }
    for r in &rows {
        assert!(r.gyr_rps.iter().all(|g| g.abs() < 0.02), "{r:?}");
        assert!((r.acc_mps2[2] - 9.81).abs() < 0.5, "{r:?}");
    }
    // The magnetometer column holds the latest reading (≈ 50 µT field).
    for r in &rows {
        let n = r.mag_ut.iter().map(|m| m * m).sum::<f32>().sqrt();
        assert!((20.0..80.0).contains(&n), "{r:?}");
    }
}
