//! Shared test helpers: the chip's register traffic written once as [`Op`]s
//! and turned into I2C or SPI mock transactions, sample bursts, NACK, and a
//! minimal executor for the async API.
#![allow(dead_code, clippy::unwrap_used, missing_docs)]

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::i2c::Transaction as I2cT;
use embedded_hal_mock::eh1::spi::Transaction as SpiT;
use mpu9250::Config;

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
pub fn block_on<F: core::future::Future>(f: F) -> F::Output {
    let mut f = core::pin::pin!(f);
    let mut cx = core::task::Context::from_waker(core::task::Waker::noop());
    loop {
        if let core::task::Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
    }
}
