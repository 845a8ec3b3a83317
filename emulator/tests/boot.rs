//! Boot on the emulated board with all chips or one missing, the 1 kHz
//! IMU task, the start-up gyro bias, and the logged attitude against the
//! simulator's truth.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use sim::{Fault, Trajectory};

/// All three chips answer: the probe lines, full capabilities (≤ 1 s
/// simulated), then the health lines report samples (2 s simulated).
#[test]
fn boots_with_all_chips_and_full_capabilities() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    assert_logged(&b, "boot: ");
    for chip in ["MPU-9250", "AK8963", "MS5611"] {
        assert_logged(&b, &format!("probe {chip}: ok"));
    }
    assert_logged(
        &b,
        "capabilities: AHRS gyro, accelerometer and magnetometer",
    );
    assert_logged(&b, "altitude true");
    run_until(&mut b, 2 * S);
    assert!(health(&b, "mpu", "ok").unwrap_or(0) > 0, "{}", tail(&b, 30));
    assert_no_reset(&b);
}

/// At rest with the simulator's default (datasheet) sensor noise, the
/// start-up gyro bias completes in its first 1 s window: the health line
/// at ~2.4 s reports it done, none reports giving up.
#[test]
fn startup_gyro_bias_completes_at_datasheet_noise() {
    let Some(mut b) = board() else { return };
    run_until(&mut b, 3 * S);
    let lines = lines_with(&b, "gyro bias:");
    assert!(
        lines.iter().any(|l| l.contains("gyro bias: done: [")),
        "{}",
        tail(&b, 30)
    );
    assert!(
        !lines.iter().any(|l| l.contains("gyro bias: gave up")),
        "{lines:?}"
    );
    assert_no_reset(&b);
}

/// The IMU task runs once per MPU-9250 data-ready edge on PB5: 2000 ± 10
/// EXTI9_5 entries over 2 s simulated (after 1 s of boot).
#[test]
fn imu_task_runs_at_1khz_from_exti() {
    let Some(mut b) = board() else { return };
    run_until(&mut b, S);
    let n = imu_updates_during(&mut b, 2 * S);
    assert!(
        (1990..=2010).contains(&n),
        "{n} EXTI updates in 2 s\n{}",
        tail(&b, 30)
    );
    assert_no_reset(&b);
}

/// Slow rotations (≤ 40°/s) after the 3 s rest: from 6 s to 10 s simulated,
/// every logged roll and pitch is within 5° of the truth at the time the
/// host read the line, and yaw within 10° (wrapped).
#[test]
fn logged_attitude_tracks_truth() {
    let Some(mut b) = board_with(|c| c.sim.trajectory = Trajectory::SlowRotations) else {
        return;
    };
    run_until(&mut b, 10 * S);
    let traj = Trajectory::SlowRotations;
    let mut checked = 0;
    for l in b.log_lines().iter().filter(|l| l.host_time_ns >= 6 * S) {
        let Some(att) = attitude(&l.text) else {
            continue;
        };
        let truth = traj
            .sample(l.host_time_ns as f64 * 1e-9)
            .q_ned_from_body
            .to_euler();
        let t = truth.map(f64::to_degrees);
        let wrap = |d: f64| (d + 540.0).rem_euclid(360.0) - 180.0;
        let err = [
            wrap(att[0] - t[0]),
            wrap(att[1] - t[1]),
            wrap(att[2] - t[2]),
        ];
        assert!(
            err[0].abs() < 5.0 && err[1].abs() < 5.0 && err[2].abs() < 10.0,
            "at {:.3} s: logged {att:?} truth {t:?}\n{}",
            l.host_time_ns as f64 * 1e-9,
            tail(&b, 20)
        );
        checked += 1;
    }
    assert!(
        checked >= 60,
        "only {checked} attitude lines in 4 s\n{}",
        tail(&b, 30)
    );
}

fn missing_at_boot(address: u8, chip: &str, caps: &str) {
    let Some(mut b) = board() else { return };
    b.sim().inject(Fault::Nack {
        address,
        transactions: None,
    });
    boot_ok(&mut b);
    assert_logged(&b, &format!("probe {chip}: FAILED"));
    assert_logged(&b, caps);
    // The board keeps running (log at 20 Hz) without a watchdog reset.
    run_until(&mut b, 3 * S);
    assert!(
        lines_after(&b, 2 * S, "att r=").len() >= 15,
        "{}",
        tail(&b, 30)
    );
    assert_no_reset(&b);
}

/// MPU-9250 absent (its address NACKed from power-up, 3 s simulated).
#[test]
fn mpu_missing_at_boot() {
    missing_at_boot(0x68, "MPU-9250", "capabilities: AHRS none (no IMU)");
}

/// AK8963 absent (address 0x0C NACKed, 3 s simulated): IMU-only AHRS.
#[test]
fn magnetometer_missing_at_boot() {
    missing_at_boot(
        sim::AK8963_ADDRESS,
        "AK8963",
        "capabilities: AHRS gyro and accelerometer",
    );
}

/// MS5611 absent (address 0x77 NACKed, 3 s simulated): no altitude.
#[test]
fn barometer_missing_at_boot() {
    missing_at_boot(0x77, "MS5611", "altitude false");
}
