//! Shared test helpers: the chip's command traffic written once as [`Op`]s
//! and turned into I2C or SPI mock transactions, and a minimal executor for
//! the async API.
#![allow(dead_code, clippy::unwrap_used, missing_docs)]
// Shaped like the other drivers' tests/common on purpose: the crates share no test crate.

use embedded_hal_mock::eh1::i2c::Transaction as I2cT;
use embedded_hal_mock::eh1::spi::Transaction as SpiT;
use ms5611::Prom;

/// The datasheet's example coefficients C1..C6.
pub const DATASHEET_C: [u16; 6] = [40127, 36924, 23317, 23282, 33464, 28312];
/// The datasheet's example D1 (pressure) raw value.
pub const D1: u32 = 9_085_466;
/// The datasheet's example D2 (temperature) raw value.
pub const D2: u32 = 8_569_150;

/// The datasheet's PROM with a valid CRC.
pub fn datasheet_prom() -> Prom {
    Prom::from_coefficients(DATASHEET_C)
}

/// One command as the chip sees it, whatever the transport.
#[derive(Clone, Debug)]
pub enum Op {
    /// A command byte alone (reset, conversion start).
    Command(u8),
    /// A command byte and the chip's answer.
    CommandRead(u8, Vec<u8>),
}

/// Reset, then the eight PROM word reads answering `words`.
pub fn init_ops(words: &[u16; 8]) -> Vec<Op> {
    let mut ops = vec![Op::Command(0x1E)];
    for (i, w) in (0u8..).zip(words) {
        ops.push(Op::CommandRead(0xA0 + 2 * i, w.to_be_bytes().to_vec()));
    }
    ops
}

/// A conversion start and the ADC read answering `value` (24 bit).
pub fn conversion_ops(cmd: u8, value: u32) -> Vec<Op> {
    vec![
        Op::Command(cmd),
        Op::CommandRead(0x00, value.to_be_bytes()[1..].to_vec()),
    ]
}

/// A 24-bit ADC value as the chip sends it (big-endian).
pub fn be24(v: u32) -> Vec<u8> {
    v.to_be_bytes()[1..].to_vec()
}

/// The 16 I2C transactions of a PROM read answering `words`.
pub fn prom_reads(addr: u8, words: &[u16; 8]) -> Vec<I2cT> {
    i2c(addr, &init_ops(words)[1..])
}

/// A conversion start and the ADC read answering `value`, as I2C transactions.
pub fn conversion(addr: u8, cmd: u8, value: u32) -> Vec<I2cT> {
    i2c(addr, &conversion_ops(cmd, value))
}

/// The ops as I2C transactions at `addr`: the answer is a separate read.
pub fn i2c(addr: u8, ops: &[Op]) -> Vec<I2cT> {
    let mut t = Vec::new();
    for op in ops {
        match op {
            Op::Command(c) => t.push(I2cT::write(addr, vec![*c])),
            Op::CommandRead(c, bytes) => {
                t.push(I2cT::write(addr, vec![*c]));
                t.push(I2cT::read(addr, bytes.clone()));
            }
        }
    }
    t
}

/// The ops as SPI device transactions: the answer is clocked in under the
/// same chip select as its command.
pub fn spi(ops: &[Op]) -> Vec<SpiT<u8>> {
    let mut t = Vec::new();
    for op in ops {
        t.push(SpiT::transaction_start());
        match op {
            Op::Command(c) => t.push(SpiT::write_vec(vec![*c])),
            Op::CommandRead(c, bytes) => {
                t.push(SpiT::write_vec(vec![*c]));
                t.push(SpiT::read_vec(bytes.clone()));
            }
        }
        t.push(SpiT::transaction_end());
    }
    t
}

/// Run a future that only waits on the (always ready) mocks.
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
