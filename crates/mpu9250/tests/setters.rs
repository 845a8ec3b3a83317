//! Per-setting setters: one register written and read back, the scale and
//! the bias follow, invalid settings and bus errors change nothing.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::*;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
use mpu9250::*;

fn inited(extra: &[Op]) -> (Mock, Mpu9250<Mock>) {
    let mut ops = init_ops(&Config::default(), false, 0);
    ops.extend_from_slice(extra);
    let bus = Mock::new(&i2c(&ops));
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    (bus, imu)
}

/// Each setter touches exactly its register with the register map's value.
#[test]
fn each_setter_writes_and_verifies_one_register() {
    let (mut bus, mut imu) = inited(&[
        Op::Write(0x1C, 0x18),
        Op::Read(0x1C, vec![0x18]),
        Op::Write(0x1B, 0x18),
        Op::Read(0x1B, vec![0x18]),
        Op::Write(0x1A, 0x05),
        Op::Read(0x1A, vec![0x05]),
        Op::Write(0x1D, 0x01),
        Op::Read(0x1D, vec![0x01]),
        Op::Write(0x19, 0x04),
        Op::Read(0x19, vec![0x04]),
    ]);
    imu.set_gyro_bias([100, -100, 0]);
    imu.set_accel_range(AccelRange::G16).unwrap();
    assert_eq!(imu.scale().g_per_lsb, 1.0 / 2048.0);
    imu.set_gyro_range(GyroRange::Dps2000).unwrap();
    // ±1000 -> ±2000 °/s: the same physical bias is half the counts.
    assert_eq!(imu.gyro_bias(), [50, -50, 0]);
    imu.set_gyro_bandwidth(GyroBandwidth::Hz10).unwrap();
    imu.set_accel_bandwidth(AccelBandwidth::Hz218_1).unwrap();
    imu.set_sample_rate_divider(4).unwrap();
    assert_eq!(imu.config().sample_period_us(), 5000);
    assert_eq!(
        *imu.config(),
        Config::new()
            .accel_range(AccelRange::G16)
            .gyro_range(GyroRange::Dps2000)
            .gyro_bandwidth(GyroBandwidth::Hz10)
            .accel_bandwidth(AccelBandwidth::Hz218_1)
            .sample_rate_divider(4)
    );
    bus.done();
}

#[test]
fn readback_mismatch_is_reported() {
    let (mut bus, mut imu) = inited(&[Op::Write(0x1C, 0x10), Op::Read(0x1C, vec![0x08])]);
    assert_eq!(
        imu.set_accel_range(AccelRange::G8),
        Err(Error::ConfigMismatch {
            register: 0x1C,
            expected: 0x10,
            found: 0x08
        })
    );
    bus.done();
}

#[test]
fn bus_error_on_the_write_keeps_the_previous_setting() {
    let mut t = i2c(&init_ops(&Config::default(), false, 0));
    t.push(T::write(A, vec![0x1B, 0x00]).with_error(NACK));
    let mut bus = Mock::new(&t);
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    imu.set_gyro_bias([10, 0, 0]);
    assert_eq!(imu.set_gyro_range(GyroRange::Dps250), Err(Error::Bus(NACK)));
    assert_eq!(imu.config().gyro_range, GyroRange::Dps1000);
    assert_eq!(imu.gyro_bias(), [10, 0, 0]);
    bus.done();
}

#[test]
fn invalid_or_uninitialised_changes_nothing_and_sends_nothing() {
    let (mut bus, mut imu) = inited(&[Op::Write(0x19, 0x01), Op::Read(0x19, vec![0x01])]);
    imu.set_sample_rate_divider(1).unwrap();
    // 250 Hz runs at 8 kHz and would ignore the divider.
    assert_eq!(
        imu.set_gyro_bandwidth(GyroBandwidth::Hz250),
        Err(Error::InvalidConfig(ConfigError::DividerIgnored))
    );
    assert_eq!(imu.config().gyro_bandwidth, GyroBandwidth::Hz41);
    bus.done();

    let mut bus = Mock::new(&[]);
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    assert_eq!(
        imu.set_accel_range(AccelRange::G2),
        Err(Error::NotInitialized)
    );
    bus.done();
}
