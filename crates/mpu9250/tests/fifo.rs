//! FIFO: configuration bytes, whole-sample bursts, overflow and torn-queue
//! detection with reset, state kept across `init`; over I2C and SPI.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::*;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::Mock as I2cMock;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;
use mpu9250::*;

/// `set_fifo(true)` after a default init: pause, FIFO_RST, then CONFIG with
/// FIFO_MODE, USER_CTRL FIFO_EN, FIFO_EN = accel + temp + gyro, each verified.
fn enable_ops(user_ctrl: u8) -> Vec<Op> {
    vec![
        Op::Write(0x23, 0x00),
        Op::Write(0x6A, user_ctrl | 0x04),
        Op::Write(0x1A, 0x43),
        Op::Read(0x1A, vec![0x43]),
        Op::Write(0x6A, user_ctrl | 0x40),
        Op::Read(0x6A, vec![user_ctrl | 0x40]),
        Op::Write(0x23, 0xF8),
        Op::Read(0x23, vec![0xF8]),
    ]
}

fn reset_ops(user_ctrl: u8) -> Vec<Op> {
    vec![
        Op::Write(0x23, 0x00),
        Op::Write(0x6A, user_ctrl | 0x44),
        Op::Write(0x23, 0xF8),
    ]
}

fn count(n: u16) -> Op {
    Op::Read(0x72, n.to_be_bytes().to_vec())
}

fn samples(n: i16) -> Vec<[i16; 7]> {
    (0..n)
        .map(|i| [i, -i, 8192, 100 * i, 3 * i, -3 * i, 7])
        .collect()
}

fn fifo_bytes(s: &[[i16; 7]]) -> Vec<u8> {
    s.iter()
        .flat_map(|v| sample_bytes([v[0], v[1], v[2]], v[3], [v[4], v[5], v[6]]))
        .collect()
}

fn raw(v: [i16; 7]) -> RawSample {
    RawSample {
        accel: [v[0], v[1], v[2]],
        temp: v[3],
        gyro: [v[4], v[5], v[6]],
    }
}

/// Enable, then: 10 queued, room for 4 (one burst of 4); 6 queued, 6 read in
/// bursts of 8 at most; an overflow; a torn queue.
fn traffic(user_ctrl: u8) -> Vec<Op> {
    let s = samples(10);
    let mut ops = init_ops(&Config::default(), false, user_ctrl);
    ops.extend(enable_ops(user_ctrl));
    ops.push(count(140));
    ops.push(Op::Read(0x74, fifo_bytes(&s[..4])));
    ops.push(count(84));
    ops.push(Op::Read(0x74, fifo_bytes(&s[4..])));
    ops.push(count(500));
    ops.extend(reset_ops(user_ctrl));
    ops.push(count(20));
    ops.extend(reset_ops(user_ctrl));
    ops.push(count(0));
    ops
}

type Outcome = Vec<Result<Vec<RawSample>, Error<()>>>;

fn run<DI, E>(imu: &mut Mpu9250<DI>) -> Outcome
where
    DI: Interface<Error = E>,
    E: core::fmt::Debug,
{
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    assert!(!imu.fifo());
    imu.set_fifo(true).unwrap();
    assert!(imu.fifo());
    let mut out = Vec::new();
    for room in [4, 20, 20, 20, 20] {
        let mut buf = vec![RawSample::default(); room];
        out.push(
            imu.read_fifo(&mut buf)
                .map(|n| buf[..n].to_vec())
                .map_err(|e| match e {
                    Error::FifoOverflow { count_bytes } => Error::FifoOverflow { count_bytes },
                    Error::FifoMisaligned { count_bytes } => Error::FifoMisaligned { count_bytes },
                    _ => Error::Bus(()),
                }),
        );
    }
    out
}

fn expected() -> Outcome {
    let s: Vec<RawSample> = samples(10).into_iter().map(raw).collect();
    vec![
        Ok(s[..4].to_vec()),
        Ok(s[4..].to_vec()),
        Err(Error::FifoOverflow { count_bytes: 500 }),
        Err(Error::FifoMisaligned { count_bytes: 20 }),
        Ok(vec![]),
    ]
}

#[test]
fn fifo_over_i2c_and_spi() {
    let mut bus = I2cMock::new(&i2c(&traffic(0)));
    let over_i2c = run(&mut Mpu9250::new(bus.clone(), Address::Ad0Low));
    bus.done();
    let mut dev = SpiMock::new(&spi(&traffic(I2C_IF_DIS)));
    let over_spi = run(&mut Mpu9250::new_with_spi(dev.clone()));
    dev.done();
    assert_eq!(over_i2c, expected());
    assert_eq!(over_spi, expected());
}

#[test]
fn fifo_burst_is_whole_samples_in_chunks() {
    // 20 queued, room for 20: bursts of 8, 8 and 4 samples.
    let s = samples(20);
    let mut ops = init_ops(&Config::default(), false, 0);
    ops.extend(enable_ops(0));
    ops.push(count(280));
    for chunk in s.chunks(FIFO_BURST_SAMPLES) {
        ops.push(Op::Read(0x74, fifo_bytes(chunk)));
    }
    let mut bus = I2cMock::new(&i2c(&ops));
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    imu.set_fifo(true).unwrap();
    let mut buf = [RawSample::default(); 20];
    assert_eq!(imu.read_fifo(&mut buf), Ok(20));
    assert_eq!(buf[19], raw(s[19]));
    bus.done();
}

#[test]
fn fifo_survives_init_and_is_verified() {
    let mut ops = init_ops(&Config::default(), false, 0);
    ops.extend(enable_ops(0));
    // Re-init: CONFIG carries FIFO_MODE, USER_CTRL FIFO_EN, then FIFO_EN is
    // written and read back.
    ops.extend([
        Op::Read(0x75, vec![0x71]),
        Op::Write(0x6B, 0x80),
        Op::Read(0x6B, vec![0x01]),
        Op::Write(0x6B, 0x01),
        Op::Write(0x6C, 0x00),
        Op::Write(0x6A, 0x40),
        Op::Write(0x19, 0x00),
        Op::Write(0x1A, 0x43),
        Op::Write(0x1B, 0x10),
        Op::Write(0x1C, 0x08),
        Op::Write(0x1D, 0x03),
        Op::Write(0x37, 0x00),
        Op::Write(0x38, 0x01),
        Op::Write(0x23, 0xF8),
        Op::Read(0x19, vec![0x00, 0x43, 0x10, 0x08, 0x03]),
        Op::Read(0x37, vec![0x00, 0x01]),
        Op::Read(0x6A, vec![0x40, 0x01, 0x00]),
        Op::Read(0x23, vec![0xF8]),
    ]);
    // verify_config: a chip that lost its FIFO_EN bits is a mismatch.
    ops.extend([
        Op::Read(0x19, vec![0x00, 0x43, 0x10, 0x08, 0x03]),
        Op::Read(0x37, vec![0x00, 0x01]),
        Op::Read(0x6A, vec![0x40, 0x01, 0x00]),
        Op::Read(0x23, vec![0x00]),
    ]);
    let mut bus = I2cMock::new(&i2c(&ops));
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    imu.set_fifo(true).unwrap();
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    assert_eq!(
        imu.verify_config(),
        Err(Error::ConfigMismatch {
            register: 0x23,
            expected: 0xF8,
            found: 0x00
        })
    );
    bus.done();
}

#[test]
fn fifo_read_when_off_or_before_init() {
    let mut bus = I2cMock::new(&[]);
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    assert_eq!(imu.set_fifo(true), Err(Error::NotInitialized));
    assert_eq!(imu.read_fifo(&mut []), Err(Error::FifoDisabled));
    bus.done();
}
