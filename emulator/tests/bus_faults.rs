//! The I2C bus misbehaving at power-up and in flight: SDA held low, a chip
//! resetting itself, NACK storms, a stuck bus, the errata's BUSY lock-up.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::i2c1::PeripheralFault;
use emulator::BoardFault;
use sim::{Chip, Fault};

/// The MPU-9250 holds SDA low at power-up (left mid-read by a reset):
/// the firmware recovers the bus and finds all chips (≤ 1 s simulated).
#[test]
fn sda_held_low_at_power_up_is_recovered() {
    let Some(mut b) = board() else { return };
    b.sim().inject(Fault::SlaveHoldsSda(Chip::Mpu9250));
    boot_ok(&mut b);
    for chip in ["MPU-9250", "AK8963", "MS5611"] {
        assert_logged(&b, &format!("probe {chip}: ok"));
    }
    assert_logged(
        &b,
        "capabilities: AHRS gyro, accelerometer and magnetometer",
    );
}

/// Errata BUSY lock-up of I2C1's analog filter at power-up: all chips
/// found (≤ 1 s simulated).
#[test]
fn busy_lockup_at_boot_is_unlocked() {
    let Some(mut b) = board() else { return };
    b.apply(BoardFault::I2c(PeripheralFault::BusyLockup));
    boot_ok(&mut b);
    for chip in ["MPU-9250", "AK8963", "MS5611"] {
        assert_logged(&b, &format!("probe {chip}: ok"));
    }
}

/// Boots, flies 3 s, applies `fault`, flies `secs` more: no MCU reset and
/// the IMU loop is back at ≥ 900 updates in the last simulated second.
fn in_flight(fault: impl FnOnce(&mut emulator::Board), secs: u64) -> Option<emulator::Board> {
    let mut b = board()?;
    boot_ok(&mut b);
    run_until(&mut b, 3 * S);
    fault(&mut b);
    run_until(&mut b, (3 + secs) * S);
    let n = imu_updates_during(&mut b, S);
    assert!(
        n >= 900,
        "IMU loop not recovered: {n} updates in 1 s\n{}",
        tail(&b, 40)
    );
    assert_no_reset(&b);
    Some(b)
}

/// The MPU-9250 resets itself at 3 s: re-initialised (5 s simulated).
#[test]
fn chip_reset_in_flight_is_reinitialised() {
    let Some(b) = in_flight(|b| b.sim().inject(Fault::ChipReset(Chip::Mpu9250)), 2) else {
        return;
    };
    assert!(
        health(&b, "mpu", "reinit").unwrap_or(0) >= 1,
        "{}",
        tail(&b, 40)
    );
}

/// 300 NACKs from the MPU-9250 at 3 s: errors counted, loop recovered
/// (6 s simulated).
#[test]
fn nack_storm_in_flight_is_counted_and_survived() {
    let Some(b) = in_flight(
        |b| {
            b.sim().inject(Fault::Nack {
                address: 0x68,
                transactions: Some(300),
            })
        },
        2,
    ) else {
        return;
    };
    assert!(
        health(&b, "mpu", "err").unwrap_or(0) >= 1,
        "{}",
        tail(&b, 40)
    );
}

/// A slave left holding SDA low in flight (at 3 s): the firmware clocks
/// SCL, recovers and logs it (6 s simulated).
#[test]
fn stuck_bus_in_flight_is_recovered() {
    // A chip left holding SDA is released by the next transfer's clocks
    // when it strikes mid-read: injected again every 0.13 ms over one
    // sample period, it also strikes an idle bus, which only a recovery
    // frees (with the cycle model's timing, 3.0 s itself is mid-read).
    let hold = |b: &mut emulator::Board| {
        let t0 = b.now_ns();
        for k in 0..8u64 {
            b.sim().inject(Fault::SlaveHoldsSda(Chip::Ms5611));
            run_until(b, t0 + (k + 1) * 130_000);
        }
    };
    let Some(b) = in_flight(hold, 2) else {
        return;
    };
    assert_logged(&b, "I2C stuck: recovered");
}

/// Errata BUSY lock-up in flight (at 3 s): unlocked, loop back (6 s).
#[test]
fn busy_lockup_in_flight_is_unlocked() {
    let Some(b) = in_flight(|b| b.apply(BoardFault::I2c(PeripheralFault::BusyLockup)), 2) else {
        return;
    };
    assert_logged(&b, "I2C stuck: recovered");
}

/// A fault applied to a running board.
type Injection = Box<dyn Fn(&mut emulator::Board)>;

/// Transient register-level faults in flight on one board, one every 2.5 s
/// from 3 s: after each, 1 s later, the IMU loop runs at ≥ 900 updates/s
/// and the MCU never reset (18 s simulated).
#[test]
fn transient_faults_in_flight_are_survived() {
    let faults: [(&str, Injection); 6] = [
        (
            "arbitration loss",
            Box::new(|b| b.sim().inject(Fault::ArbitrationLoss { transactions: 20 })),
        ),
        (
            "bus error mid-transfer",
            Box::new(|b| {
                b.sim()
                    .inject(Fault::BusErrorMidTransfer { after_bytes: 3 })
            }),
        ),
        (
            "spurious BERR",
            Box::new(|b| b.apply(BoardFault::I2c(PeripheralFault::SpuriousBerr))),
        ),
        (
            "magnetometer overflow",
            Box::new(|b| b.sim().inject(Fault::MagOverflow)),
        ),
        (
            "barometer frozen",
            Box::new(|b| b.sim().inject(Fault::Frozen(Chip::Ms5611))),
        ),
        (
            "SCL held low 5 ms",
            Box::new(|b| {
                b.sim().inject(Fault::SclStuckLow);
                run_for(b, 5 * MS);
                b.sim().clear_faults();
            }),
        ),
    ];
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, 3 * S);
    for (name, f) in faults {
        f(&mut b);
        run_for(&mut b, 1_500 * MS);
        let n = imu_updates_during(&mut b, S);
        assert!(
            n >= 900,
            "after {name}: {n} IMU updates in 1 s\n{}",
            tail(&b, 40)
        );
        b.sim().clear_faults();
    }
    assert_no_reset(&b);
}

/// MCU resets (as by the watchdog) at ten instants 37 µs apart inside the
/// 1 kHz burst reads: whenever a chip is left holding SDA, the rebooted
/// firmware frees the bus and finds all three chips (≈ 15 s simulated).
#[test]
fn reset_mid_transfer_is_recovered_at_the_next_boot() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, 2 * S);
    for k in 0..10u64 {
        // Just after a data-ready edge the burst read is on the wire.
        let t = b.sim().next_mpu_sample_ns() + 20_000 + k * 37_000;
        run_until(&mut b, t);
        b.reset(emulator::ResetCause::Watchdog).expect("reset");
        let at = b.now_ns();
        run_until(&mut b, at + 1_500 * MS);
        for chip in ["MPU-9250", "AK8963", "MS5611"] {
            assert!(
                !lines_after(&b, at, &format!("probe {chip}: ok")).is_empty(),
                "reset {k}: {chip} not found after the reboot\n{}",
                tail(&b, 40)
            );
        }
    }
}
