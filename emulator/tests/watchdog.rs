//! The independent watchdog resets the MCU when the IMU loop stops.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::{BoardFault, ResetCause};

/// The MPU-9250 INT line stops at 3 s: the watchdog resets the MCU within
/// 1 s and the log shows the firmware booting again (5 s simulated).
#[test]
fn imu_interrupt_stop_resets_the_mcu() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, 3 * S);
    assert_no_reset(&b);
    b.apply(BoardFault::ImuIntStops);
    run_until(&mut b, 4 * S);
    let resets = resets_after_power_on(&b);
    assert_eq!(
        resets.first(),
        Some(&ResetCause::Watchdog),
        "{}",
        tail(&b, 40)
    );
    let reset_at = b.resets()[1].0;
    run_until(&mut b, 5 * S);
    assert!(
        !lines_after(&b, reset_at, "boot: ").is_empty(),
        "no boot line after the reset\n{}",
        tail(&b, 40)
    );
}

/// With the LSI at the datasheet's fastest 60 kHz (the watchdog times out
/// 1.5× sooner than at 40 kHz), a healthy board is never reset while it
/// boots, probes and flies (5 s simulated).
#[test]
fn watchdog_margin_holds_at_the_fastest_lsi() {
    let Some(mut b) = board_with(|c| c.lsi_hz = 60_000) else {
        return;
    };
    boot_ok(&mut b);
    run_until(&mut b, 5 * S);
    assert_logged(
        &b,
        "capabilities: AHRS gyro, accelerometer and magnetometer",
    );
    assert_no_reset(&b);
}
