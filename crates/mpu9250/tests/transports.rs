//! The same chip traffic over each transport: blocking I2C, blocking SPI,
//! async I2C and async SPI give the same samples, and SPI sets I2C_IF_DIS.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::*;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::Mock as I2cMock;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;
use mpu9250::*;

/// Init, then two samples: face up at rest at ±4 g / ±1000 °/s, and one with
/// 10 °/s about x and a negative temperature count.
fn traffic(user_ctrl: u8) -> Vec<Op> {
    let mut ops = init_ops(&Config::default(), false, user_ctrl);
    ops.push(sample_op([0, 0, 8192], 0, [0, 0, 0]));
    ops.push(sample_op([-4096, 100, 8192], -334, [328, -1, 0]));
    ops
}

fn check(samples: [Sample; 2]) {
    assert_eq!(samples[0].accel_g, [0.0, 0.0, 1.0]);
    assert_eq!(samples[0].gyro_dps, [0.0; 3]);
    assert_eq!(samples[0].temp_c, 21.0);
    assert_eq!(samples[1].accel_g[0], -0.5);
    assert!((samples[1].gyro_dps[0] - 10.0).abs() < 1e-3);
    // -334 counts / 333.87 LSB/°C + 21 °C ≈ 20.0 °C
    assert!((samples[1].temp_c - 20.0).abs() < 0.01);
}

#[test]
fn blocking_i2c_and_spi_read_the_same_samples() {
    let mut bus = I2cMock::new(&i2c(&traffic(0)));
    let mut imu = Mpu9250::new_with_i2c(bus.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    let over_i2c = [imu.read().unwrap(), imu.read().unwrap()];
    bus.done();

    let mut dev = SpiMock::new(&spi(&traffic(I2C_IF_DIS)));
    let mut imu = Mpu9250::new_with_spi(dev.clone());
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    let over_spi = [imu.read().unwrap(), imu.read().unwrap()];
    dev.done();

    assert_eq!(over_i2c, over_spi);
    check(over_spi);
}

#[test]
fn spi_verify_config_expects_i2c_if_dis() {
    // The chip lost I2C_IF_DIS (it reset itself): USER_CTRL reads 0.
    let mut ops = traffic(I2C_IF_DIS);
    ops.truncate(ops.len() - 2);
    ops.push(Op::Read(0x19, vec![0x00, 0x03, 0x10, 0x08, 0x03]));
    ops.push(Op::Read(0x37, vec![0x00, 0x01]));
    ops.push(Op::Read(0x6A, vec![0x00, 0x01, 0x00]));
    let mut dev = SpiMock::new(&spi(&ops));
    let mut imu = Mpu9250::new_with_spi(dev.clone());
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    assert_eq!(
        imu.verify_config(),
        Err(Error::ConfigMismatch {
            register: 0x6A,
            expected: I2C_IF_DIS,
            found: 0
        })
    );
    dev.done();
}

#[test]
fn bypass_is_refused_on_spi_without_traffic() {
    let mut dev = SpiMock::new(&[]);
    let mut imu = Mpu9250::new_with_spi(dev.clone());
    assert_eq!(imu.set_bypass(true), Err(Error::BypassOnSpi));
    assert!(!imu.bypass());
    dev.done();
}

#[test]
fn async_i2c_and_spi_read_the_same_samples_as_blocking() {
    let mut bus = I2cMock::new(&i2c(&traffic(0)));
    let mut imu = Mpu9250Async::new_with_i2c(bus.clone(), Address::Ad0Low);
    let over_i2c = block_on(async {
        imu.init(&mut NoopDelay::new(), &Config::default())
            .await
            .unwrap();
        [imu.read().await.unwrap(), imu.read().await.unwrap()]
    });
    bus.done();

    let mut dev = SpiMock::new(&spi(&traffic(I2C_IF_DIS)));
    let mut imu = Mpu9250Async::new_with_spi(dev.clone());
    let over_spi = block_on(async {
        imu.init(&mut NoopDelay::new(), &Config::default())
            .await
            .unwrap();
        [imu.read().await.unwrap(), imu.read().await.unwrap()]
    });
    dev.done();

    assert_eq!(over_i2c, over_spi);
    check(over_i2c);
}

#[test]
fn async_bus_error_is_a_typed_error() {
    let mut t = i2c(&init_ops(&Config::default(), false, 0));
    t.push(
        embedded_hal_mock::eh1::i2c::Transaction::write_read(A, vec![0x3B], vec![0; 14])
            .with_error(NACK),
    );
    let mut bus = I2cMock::new(&t);
    let mut imu = Mpu9250Async::new(bus.clone(), Address::Ad0Low);
    block_on(async {
        imu.init(&mut NoopDelay::new(), &Config::default())
            .await
            .unwrap();
        assert_eq!(imu.read().await, Err(Error::Bus(NACK)));
    });
    bus.done();
}
