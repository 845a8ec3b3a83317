//! The internal I2C master: the AK8963 driver runs unchanged through slave 4
//! when the MPU-9250 is on SPI, slave 0 then delivers ST1..ST2 with every
//! sample, and the sample parses to what the bypass path reads.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::*;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;
use mpu9250::*;

const MAG: u8 = 0x0C;

/// One slave-4 write: clear stale status, address, register, data, enable,
/// then the status poll sees SLV4_DONE.
fn aux_write(register: u8, value: u8) -> Vec<Op> {
    vec![
        Op::Read(0x36, vec![0x00]),
        Op::Write(0x31, MAG),
        Op::Write(0x32, register),
        Op::Write(0x33, value),
        Op::Write(0x34, 0x80),
        Op::Read(0x36, vec![0x40]),
    ]
}

/// One slave-4 read answering `value` from I2C_SLV4_DI.
fn aux_read(register: u8, value: u8) -> Vec<Op> {
    vec![
        Op::Read(0x36, vec![0x00]),
        Op::Write(0x31, MAG | 0x80),
        Op::Write(0x32, register),
        Op::Write(0x34, 0x80),
        Op::Read(0x36, vec![0x40]),
        Op::Read(0x35, vec![value]),
    ]
}

fn master_on() -> Vec<Op> {
    vec![
        Op::Write(0x24, 0x1D),
        Op::Read(0x24, vec![0x1D]),
        Op::Write(0x67, 0x80),
        Op::Read(0x67, vec![0x80]),
        Op::Write(0x6A, 0x30),
        Op::Read(0x6A, vec![0x30]),
    ]
}

/// The AK8963's own init sequence (WIA, SRST, fuse ROM, mode), each access
/// one slave-4 transfer.
fn ak8963_init() -> Vec<Op> {
    [
        aux_read(0x00, 0x48),
        aux_write(0x0B, 0x01),
        aux_read(0x0B, 0x00),
        aux_write(0x0A, 0x00),
        aux_write(0x0A, 0x0F),
        aux_read(0x10, 0xB0),
        aux_read(0x11, 0x80),
        aux_read(0x12, 0x80),
        aux_write(0x0A, 0x00),
        aux_write(0x0A, 0x16),
        aux_read(0x0A, 0x16),
    ]
    .concat()
}

#[test]
fn ak8963_over_spi_through_the_internal_master() {
    let mut ops = init_ops(&Config::default(), false, I2C_IF_DIS);
    ops.extend(master_on());
    ops.extend(ak8963_init());
    ops.extend([
        Op::Write(0x25, 0x8C),
        Op::Read(0x25, vec![0x8C]),
        Op::Write(0x26, 0x02),
        Op::Read(0x26, vec![0x02]),
        Op::Write(0x27, 0x88),
        Op::Read(0x27, vec![0x88]),
    ]);
    // One burst: the IMU sample, then EXT_SENS_DATA_00..07 = ST1, HX, HY, HZ, ST2.
    let mut burst = sample_bytes([0, 0, 8192], 0, [0, 0, 0]);
    burst.extend([0x01, 200, 0, 0x9C, 0xFF, 0, 0, 0x10]);
    ops.push(Op::Read(0x3B, burst));

    let mut dev = SpiMock::new(&spi(&ops));
    let mut imu = Mpu9250::new_with_spi(dev.clone());
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    imu.set_i2c_master(true).unwrap();

    let mut mag = ak8963::Ak8963::new(imu.aux_bus(NoopDelay::new()));
    mag.init(&mut NoopDelay::new(), &ak8963::Config::default())
        .unwrap();
    let ut_per_lsb = mag.ut_per_lsb();
    assert_eq!(mag.asa(), [0xB0, 0x80, 0x80]);
    // Give the borrowed IMU back: the scale is all the fast path needs.
    let _ = mag.release();

    imu.start_slave0_read(SlaveRead::AK8963_STATUS_BLOCK)
        .unwrap();
    let mut block = [0u8; 8];
    let sample = imu.read_raw_with_external(&mut block).unwrap();
    dev.done();

    assert_eq!(sample.accel, [0, 0, 8192]);
    let raw = ak8963::parse_status_block(&block, ak8963::Resolution::Bits16).unwrap();
    assert_eq!(raw.counts, [200, -100, 0]);
    // ASAX 0xB0: 200 counts × 0.15 µT × 1.1875 = 35.625 µT.
    let field = ak8963::counts_to_ut(raw.counts, &ut_per_lsb);
    assert!((field[0] - 35.625).abs() < 1e-4);
    assert!((field[1] + 15.0).abs() < 1e-4);
}

#[test]
fn aux_nack_timeout_and_exclusions() {
    let mut ops = init_ops(&Config::default(), false, I2C_IF_DIS);
    ops.extend(master_on());
    // WIA read NACKed by the AK8963.
    ops.extend([
        Op::Read(0x36, vec![0x00]),
        Op::Write(0x31, MAG | 0x80),
        Op::Write(0x32, 0x00),
        Op::Write(0x34, 0x80),
        Op::Read(0x36, vec![0x00]),
        Op::Read(0x36, vec![0x10]),
    ]);
    // A write that never completes: 30 polls (two 1 ms periods + 1 ms, 100 µs each).
    ops.extend([
        Op::Read(0x36, vec![0x00]),
        Op::Write(0x31, MAG),
        Op::Write(0x32, 0x0A),
        Op::Write(0x33, 0x00),
        Op::Write(0x34, 0x80),
    ]);
    ops.extend((0..30).map(|_| Op::Read(0x36, vec![0x00])));

    let mut dev = SpiMock::new(&spi(&ops));
    let mut imu = Mpu9250::new_with_spi(dev.clone());
    let mut delay = NoopDelay::new();
    assert_eq!(
        imu.aux_write(&mut delay, MAG, 0x0A, 0),
        Err(Error::MasterDisabled)
    );
    imu.init(&mut delay, &Config::default()).unwrap();
    imu.set_i2c_master(true).unwrap();
    let mut mag = ak8963::Ak8963::new(imu.aux_bus(NoopDelay::new()));
    assert_eq!(
        mag.init(&mut NoopDelay::new(), &ak8963::Config::default()),
        Err(ak8963::Error::Bus(Error::AuxNack))
    );
    let _ = mag.release();
    assert_eq!(
        imu.aux_write(&mut delay, MAG, 0x0A, 0),
        Err(Error::AuxTimeout)
    );
    assert_eq!(
        imu.start_slave0_read(SlaveRead {
            address: MAG,
            register: 0x02,
            len: 16
        }),
        Err(Error::InvalidConfig(ConfigError::SlaveReadLength))
    );
    assert_eq!(imu.set_bypass(true), Err(Error::BypassOnSpi));
    dev.done();
}

#[test]
fn master_and_bypass_exclude_each_other() {
    use embedded_hal_mock::eh1::i2c::Mock;
    let mut ops = init_ops(&Config::default(), false, 0);
    // Bypass on: USER_CTRL 0, INT_PIN_CFG with BYPASS_EN.
    ops.extend([Op::Write(0x6A, 0x00), Op::Write(0x37, 0x02)]);
    let mut bus = Mock::new(&i2c(&ops));
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    imu.set_bypass(true).unwrap();
    assert_eq!(imu.set_i2c_master(true), Err(Error::MasterWithBypass));
    assert!(!imu.i2c_master());
    bus.done();
}
