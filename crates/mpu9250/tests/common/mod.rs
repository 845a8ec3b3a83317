//! Shared test helpers: the chip's register traffic written once as [`Op`]s
//! and turned into I2C or SPI mock transactions, sample bursts, NACK, and a
//! minimal executor for the async API.
#![allow(dead_code, clippy::unwrap_used, missing_docs)]
// Shaped like the other drivers' tests/common on purpose: the crates share no test crate.

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock as I2cMock, Transaction as I2cT};
use embedded_hal_mock::eh1::spi::Transaction as SpiT;
use mpu9250::{Address, Config, Error, Mpu9250, Variant};

/// Default 7-bit address (AD0 low).
pub const A: u8 = 0x68;
/// A data NACK.
pub const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data);

/// One register access as the chip sees it, whatever the transport.
#[derive(Clone, Debug)]
pub enum Op {
    /// Write one register.
    Write(u8, u8),
    /// Burst read from a start register; the chip answers these bytes.
    Read(u8, Vec<u8>),
}

/// USER_CTRL I2C_IF_DIS, set by the driver on SPI.
pub const I2C_IF_DIS: u8 = 0x10;

/// WHO_AM_I, H_RESET, one reset poll, the configuration writes and the three
/// read-backs, for `config`; `user_ctrl` are the extra USER_CTRL bits
/// (I2C_IF_DIS on SPI).
pub fn init_ops(config: &Config, bypass: bool, user_ctrl: u8) -> Vec<Op> {
    let mut values = config.register_values(bypass);
    for (r, v) in values.iter_mut() {
        if *r == 0x6A {
            *v |= user_ctrl;
        }
    }
    let get = |r: u8| values.iter().find(|(x, _)| *x == r).unwrap().1;
    let mut ops = vec![
        Op::Read(0x75, vec![0x71]),
        Op::Write(0x6B, 0x80),
        Op::Read(0x6B, vec![0x01]),
    ];
    ops.extend(values.iter().map(|&(r, v)| Op::Write(r, v)));
    ops.push(Op::Read(0x19, (0x19..=0x1D).map(get).collect()));
    ops.push(Op::Read(0x37, vec![get(0x37), get(0x38)]));
    ops.push(Op::Read(0x6A, vec![get(0x6A), get(0x6B), get(0x6C)]));
    ops
}

/// The configuration bytes of `config` worked out from the register map, not
/// from the driver's `register_values`: SMPLRT_DIV, CONFIG, GYRO_CONFIG,
/// ACCEL_CONFIG, ACCEL_CONFIG2, and INT_PIN_CFG (BYPASS_EN with `bypass`),
/// INT_ENABLE.
pub fn config_bytes(config: &Config, bypass: bool) -> ([u8; 5], [u8; 2]) {
    let int_pin = config.interrupt.int_pin_cfg_bits() | if bypass { 0x02 } else { 0x00 };
    let int_en = u8::from(config.interrupt.data_ready);
    (
        [
            config.sample_rate_divider,
            config.gyro_bandwidth.dlpf_cfg(),
            config.gyro_range.fs_sel() << 3,
            config.accel_range.fs_sel() << 3,
            config.accel_bandwidth.accel_config2_bits(),
        ],
        [int_pin, int_en],
    )
}

/// The init sequence at address `a` written out from the register map:
/// WHO_AM_I, H_RESET, one reset poll, PWR_MGMT_1/2 and USER_CTRL, the
/// configuration bytes `config` (SMPLRT_DIV..ACCEL_CONFIG2) and `int`
/// (INT_PIN_CFG, INT_ENABLE), then [`readback_by_hand`].
pub fn init_by_hand(a: u8, config: [u8; 5], int: [u8; 2]) -> Vec<I2cT> {
    let mut t = vec![
        I2cT::write_read(a, vec![0x75], vec![0x71]),
        I2cT::write(a, vec![0x6B, 0x80]),
        I2cT::write_read(a, vec![0x6B], vec![0x01]),
        I2cT::write(a, vec![0x6B, 0x01]),
        I2cT::write(a, vec![0x6C, 0x00]),
        I2cT::write(a, vec![0x6A, 0x00]),
    ];
    t.extend(
        (0x19..=0x1D)
            .zip(config)
            .map(|(r, v)| I2cT::write(a, vec![r, v])),
    );
    t.extend(
        (0x37..=0x38)
            .zip(int)
            .map(|(r, v)| I2cT::write(a, vec![r, v])),
    );
    t.extend(readback_by_hand(a, config, int));
    t
}

/// The three configuration read-backs that end init and make up
/// `verify_config`: SMPLRT_DIV..ACCEL_CONFIG2, INT_PIN_CFG..INT_ENABLE,
/// USER_CTRL..PWR_MGMT_2 (0x00, 0x01, 0x00).
pub fn readback_by_hand(a: u8, config: [u8; 5], int: [u8; 2]) -> Vec<I2cT> {
    vec![
        I2cT::write_read(a, vec![0x19], config.to_vec()),
        I2cT::write_read(a, vec![0x37], int.to_vec()),
        I2cT::write_read(a, vec![0x6A], vec![0x00, 0x01, 0x00]),
    ]
}

/// [`init_by_hand`] for `config`, through [`config_bytes`].
pub fn init_for(a: u8, config: &Config, bypass: bool) -> Vec<I2cT> {
    let (c, i) = config_bytes(config, bypass);
    init_by_hand(a, c, i)
}

/// The 14 bytes of ACCEL_XOUT_H..GYRO_ZOUT_L (big-endian).
pub fn sample_bytes(accel: [i16; 3], temp: i16, gyro: [i16; 3]) -> Vec<u8> {
    accel
        .into_iter()
        .chain([temp])
        .chain(gyro)
        .flat_map(i16::to_be_bytes)
        .collect()
}

/// A sample burst read.
pub fn sample_op(accel: [i16; 3], temp: i16, gyro: [i16; 3]) -> Op {
    Op::Read(0x3B, sample_bytes(accel, temp, gyro))
}

/// A driver at [`A`] on a mock bus that answers with `t` (its init sequence
/// first), initialised with `config`; the mock is returned for `done()`.
pub fn inited_with(t: &[I2cT], config: &Config) -> (I2cMock, Mpu9250<I2cMock>) {
    let i2c = I2cMock::new(t);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), config).unwrap();
    (i2c, imu)
}

/// What `init` with `config` returns at [`A`] on a mock bus that answers with
/// `t`; the test fails unless every transaction of `t` was used.
pub fn init_result(t: &[I2cT], config: &Config) -> Result<Variant, Error<ErrorKind>> {
    let mut i2c = I2cMock::new(t);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    let result = imu.init(&mut NoopDelay::new(), config);
    i2c.done();
    result
}

/// The ops as I2C transactions at address [`A`].
pub fn i2c(ops: &[Op]) -> Vec<I2cT> {
    ops.iter()
        .map(|op| match op {
            Op::Write(r, v) => I2cT::write(A, vec![*r, *v]),
            Op::Read(r, bytes) => I2cT::write_read(A, vec![*r], bytes.clone()),
        })
        .collect()
}

/// The ops as SPI device transactions: a write is one 2-byte frame with bit 7
/// clear; a read sends the address with bit 7 set, then clocks the data in,
/// under one chip select.
pub fn spi(ops: &[Op]) -> Vec<SpiT<u8>> {
    let mut t = Vec::new();
    for op in ops {
        t.push(SpiT::transaction_start());
        match op {
            Op::Write(r, v) => t.push(SpiT::write_vec(vec![*r, *v])),
            Op::Read(r, bytes) => {
                t.push(SpiT::write_vec(vec![*r | 0x80]));
                t.push(SpiT::read_vec(bytes.clone()));
            }
        }
        t.push(SpiT::transaction_end());
    }
    t
}

/// Run a future that never waits on anything but the mocks (which are
/// always ready) to completion.
// Tests run on the workspace's pinned toolchain, not the crate's MSRV.
#[allow(clippy::incompatible_msrv)]
pub fn block_on<F: core::future::Future>(f: F) -> F::Output {
    let mut f = core::pin::pin!(f);
    let mut cx = core::task::Context::from_waker(core::task::Waker::noop());
    loop {
        if let core::task::Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
    }
}
