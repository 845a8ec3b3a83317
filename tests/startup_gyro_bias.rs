//! The firmware's start-up gyro bias (`sensor_stack::boot::StartupGyroBias`, set
//! up as `start_gyro_bias` does: one window of `IMU_RATE_HZ` samples = 1 s,
//! within 5 windows' worth of samples) on the simulated board: the
//! simulator's noise is the MPU-9250 datasheet's at the configured filters,
//! the measurement completes in its first window at that noise, it refuses
//! a board that is being moved by a few °/s, and a short knock costs its
//! duration, not the budget.
//!
//! Datasheet noise at the default configuration (DLPF 41 Hz gyro,
//! 44.8 Hz accelerometer, 1 kHz): per-sample σ = density · √(ENBW),
//! ENBW = π/2 · 3 dB bandwidth: gyro 0.01 °/s/√Hz · √64.4 Hz = 0.080 °/s
//! (2.6 counts at ±1000 °/s), accelerometer 300 µg/√Hz · √70.4 Hz =
//! 2.5 mg (21 counts at ±4 g). The stillness limits (gyro σ ≤ 0.3 °/s,
//! peak-to-peak ≤ 3 °/s; accelerometer σ ≤ 20 mg, peak-to-peak ≤ 100 mg)
//! are ≥ 3.7 σ on the standard deviations (whose estimate over 1000
//! samples scatters by ~6 %: the noise passes the chip's low-pass, so
//! samples within its ~4 ms correlation time are alike) and ≥ 37 σ on
//! the peak-to-peak (1000
//! Gaussian samples span ~6.5 σ): a false refusal at datasheet noise does
//! not happen, while a rate step of more than 0.6 °/s halfway through a
//! window already exceeds the gyro σ limit.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::f64::consts::PI;
use std::rc::Rc;

use e2e::Rig;
use sensor_stack::boot::{BiasStatus, StartupGyroBias};
use sensor_stack::schedule::IMU_RATE_HZ;
use sim::{Quat, SensorErrors, SimConfig, Trajectory};

/// Windows' worth of samples the firmware allows (`start_gyro_bias`).
const MAX_ATTEMPTS: u8 = 5;

struct Run {
    status: BiasStatus,
    /// Samples pushed until `status` was final (or the limit).
    samples: u32,
    /// Restarts seen (`Moved`).
    restarts: u32,
    /// The sim's gyro bias at the end, counts, MPU frame.
    true_bias_counts: [f64; 3],
    /// Per-axis standard deviation of the gyro and accelerometer samples
    /// of the first window (counts).
    gyro_sd: [f64; 3],
    accel_sd: [f64; 3],
    /// Simulated time when the measurement started (s).
    start_s: f64,
}

fn run(config: SimConfig, limit: u32) -> Run {
    let mut rig = Rig::new(config);
    let (mut s, report) = e2e::boot_sensors(&mut rig);
    assert!(report.failures().next().is_none(), "{report:?}");
    let scale = s.mpu_scale();
    let mut bias = StartupGyroBias::new(
        IMU_RATE_HZ,
        1.0 / scale.dps_per_lsb,
        1.0 / scale.g_per_lsb,
        MAX_ATTEMPTS,
    )
    .unwrap();
    let start_s = rig.clock.now_s();
    let (mut gyro, mut accel) = (Vec::new(), Vec::new());
    let mut status = BiasStatus::GaveUp;
    let mut restarts = 0;
    let mut samples = 0;
    while samples < limit {
        rig.bus.advance_to_next_mpu_sample();
        let raw = s.read_imu().unwrap();
        samples += 1;
        if gyro.len() < IMU_RATE_HZ as usize {
            gyro.push(raw.gyro.map(f64::from));
            accel.push(raw.accel.map(f64::from));
        }
        status = bias.push(raw.gyro, raw.accel);
        match status {
            BiasStatus::Moved { .. } => restarts += 1,
            BiasStatus::Done(_) | BiasStatus::GaveUp => break,
            BiasStatus::Collecting { .. } => {}
        }
    }
    let sd = |xs: &[[f64; 3]]| {
        [0, 1, 2].map(|i| e2e::mean_sd(&xs.iter().map(|x| x[i]).collect::<Vec<_>>()).1)
    };
    let st = rig.bus.state();
    let lsb_per_dps = st.mpu.gyro_lsb_per_dps();
    Run {
        status,
        samples,
        restarts,
        true_bias_counts: st.world.gyro_bias_dps().map(|b| b * lsb_per_dps),
        gyro_sd: sd(&gyro),
        accel_sd: sd(&accel),
        start_s,
    }
}

#[test]
fn sim_noise_is_the_datasheet_noise_at_the_configured_filters() {
    // Eight seeds pooled: the low-passed noise of one 1000-sample window
    // estimates σ to ~6 % (1 σ), eight windows to ~2 %.
    let (mut g2, mut a2) = ([0.0; 3], [0.0; 3]);
    for seed in 1..=8 {
        let r = run(
            SimConfig {
                seed,
                ..SimConfig::default()
            },
            IMU_RATE_HZ,
        );
        for i in 0..3 {
            g2[i] += r.gyro_sd[i].powi(2) / 8.0;
            a2[i] += r.accel_sd[i].powi(2) / 8.0;
        }
    }
    // ENBW = π/2 · 3 dB bandwidth (DLPF_CFG 3: 41 Hz; A_DLPF_CFG 3: 44.8 Hz).
    let gyro_counts = 0.01 * (41.0 * PI / 2.0).sqrt() * 32.8;
    let accel_counts = 300e-6 * (44.8 * PI / 2.0).sqrt() * 8192.0;
    for i in 0..3 {
        let (g, a) = (g2[i].sqrt(), a2[i].sqrt());
        // Quantisation adds 1/12 count² (negligible here).
        assert!(
            (g / gyro_counts - 1.0).abs() < 0.1,
            "gyro σ {g} vs {gyro_counts}"
        );
        assert!(
            (a / accel_counts - 1.0).abs() < 0.1,
            "accel σ {a} vs {accel_counts}"
        );
    }
}

#[test]
fn completes_in_its_first_window_at_datasheet_noise() {
    for seed in 1..=12 {
        // Datasheet noise plus a board's datasheet-sized bias (±3 °/s),
        // bias walk and scale errors.
        let config = SimConfig {
            seed,
            errors: SensorErrors::datasheet(seed),
            ..SimConfig::default()
        };
        let r = run(config, u32::from(MAX_ATTEMPTS) * IMU_RATE_HZ);
        let BiasStatus::Done(b) = r.status else {
            panic!("seed {seed}: {:?} after {} samples", r.status, r.samples)
        };
        assert_eq!(r.restarts, 0, "seed {seed}");
        assert_eq!(r.samples, IMU_RATE_HZ, "seed {seed}: done in 1 s");
        for i in 0..3 {
            // Mean of 1000 samples: σ ≈ 0.1 count; rounding 0.5; bias
            // walk over 1 s ≈ 0.2 count.
            let err = f64::from(b[i]) - r.true_bias_counts[i];
            assert!(
                err.abs() < 1.5,
                "seed {seed} axis {i}: {b:?} vs {:?}",
                r.true_bias_counts
            );
        }
    }
}

/// Level and still, then yawing back and forth with `peak_dps` at 0.5 Hz
/// from `from_s` on (yaw: the accelerometer cannot see it, so the gyro
/// checks alone must).
fn yawing(peak_dps: f64, from_s: f64) -> Trajectory {
    let w = 2.0 * PI * 0.5;
    let peak_rps = peak_dps.to_radians();
    Trajectory::Custom(Rc::new(move |t: f64| {
        let tau = (t - from_s).max(0.0);
        // Rate peak·sin(w·τ): the angle is its integral.
        let yaw = peak_rps / w * (1.0 - (w * tau).cos());
        ([0.0; 3], Quat::from_axis_angle([0.0, 0.0, 1.0], yaw))
    }))
}

#[test]
fn refuses_a_board_moved_by_a_few_degrees_per_second() {
    let config = SimConfig {
        trajectory: yawing(2.0, 0.0),
        ..SimConfig::default()
    };
    let r = run(config, (u32::from(MAX_ATTEMPTS) + 1) * IMU_RATE_HZ);
    assert_eq!(r.status, BiasStatus::GaveUp, "after {} samples", r.samples);
    assert_eq!(r.restarts, u32::from(MAX_ATTEMPTS) - 1);
}

#[test]
fn a_nudge_restarts_the_window_and_the_next_one_completes() {
    // Moved for one 2 s period (0.5 s into the first window), still after.
    let probe = run(SimConfig::default(), 1);
    let from_s = probe.start_s + 0.5;
    let w = 2.0 * PI * 0.5;
    let peak_rps = 3.0f64.to_radians();
    let config = SimConfig {
        trajectory: Trajectory::Custom(Rc::new(move |t: f64| {
            let tau = (t - from_s).clamp(0.0, 2.0);
            let yaw = peak_rps / w * (1.0 - (w * tau).cos());
            ([0.0; 3], Quat::from_axis_angle([0.0, 0.0, 1.0], yaw))
        })),
        ..SimConfig::default()
    };
    let r = run(config, u32::from(MAX_ATTEMPTS) * IMU_RATE_HZ);
    assert!(r.restarts >= 1, "{:?}", r.status);
    let BiasStatus::Done(b) = r.status else {
        panic!("{:?} after {} samples", r.status, r.samples)
    };
    // Noise only, no bias: within 1 count (0.03 °/s) of zero.
    assert!(b.iter().all(|c| c.abs() <= 1), "{b:?}");
    // The window that completed ended after the motion did: the windows
    // taken while the board turned were all refused.
    let end_s = r.start_s + f64::from(r.samples) / f64::from(IMU_RATE_HZ);
    assert!(end_s > from_s + 2.0, "ended at {end_s} s");
}

#[test]
fn a_knock_restarts_the_window_without_spending_the_budget() {
    // A 0.2 s, 2° roll knock (peak 31 °/s) 0.5 s into the first window:
    // every sample past the peak-to-peak limit restarts the window, many
    // more restarts than the 5 windows of the budget, yet the window after
    // the knock completes.
    let probe = run(SimConfig::default(), 1);
    let from_s = probe.start_s + 0.5;
    let amplitude = 2.0f64.to_radians();
    let config = SimConfig {
        seed: 3,
        errors: SensorErrors::datasheet(3),
        trajectory: Trajectory::Custom(Rc::new(move |t: f64| {
            let tau = (t - from_s).clamp(0.0, 0.2);
            let roll = amplitude * 0.5 * (1.0 - (2.0 * PI * tau / 0.2).cos());
            ([0.0; 3], Quat::from_axis_angle([1.0, 0.0, 0.0], roll))
        })),
        ..SimConfig::default()
    };
    let r = run(config, u32::from(MAX_ATTEMPTS) * IMU_RATE_HZ);
    assert!(
        r.restarts > u32::from(MAX_ATTEMPTS),
        "{} restarts",
        r.restarts
    );
    let BiasStatus::Done(b) = r.status else {
        panic!("{:?} after {} samples", r.status, r.samples)
    };
    // The window that completed started as the knock's rate fell back
    // within the limit (its last few ms): it ended about 1 s after the knock.
    let end_s = r.start_s + f64::from(r.samples) / f64::from(IMU_RATE_HZ);
    assert!(end_s > from_s + 0.2 + 0.9, "ended at {end_s} s");
    for i in 0..3 {
        let err = f64::from(b[i]) - r.true_bias_counts[i];
        assert!(
            err.abs() < 1.5,
            "axis {i}: {b:?} vs {:?}",
            r.true_bias_counts
        );
    }
}
