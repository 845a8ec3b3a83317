//! Shared test helpers: the init sequence, measurement reads, NACK and a
//! minimal executor for the async API.
#![allow(dead_code, clippy::unwrap_used, missing_docs)]
// Shaped like the other drivers' tests/common on purpose: the crates share no test crate.

use ak8963::{Ak8963, Config, Error};
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};

/// The AK8963's address inside the MPU-9250.
pub const A: u8 = 0x0C;
/// An address NACK (bypass off).
pub const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);

/// Init with fuse ROM `asa` and CNTL1 `cntl1`, bytes from the datasheet: WIA,
/// CNTL2 SRST and its poll, power-down, fuse-ROM access, ASAX..ASAZ,
/// power-down, the mode, its read-back.
pub fn init_seq(asa: [u8; 3], cntl1: u8) -> Vec<T> {
    vec![
        T::write_read(A, vec![0x00], vec![0x48]),
        T::write(A, vec![0x0B, 0x01]),
        T::write_read(A, vec![0x0B], vec![0x00]),
        T::write(A, vec![0x0A, 0x00]),
        T::write(A, vec![0x0A, 0x0F]),
        T::write_read(A, vec![0x10], asa.to_vec()),
        T::write(A, vec![0x0A, 0x00]),
        T::write(A, vec![0x0A, cntl1]),
        T::write_read(A, vec![0x0A], vec![cntl1]),
    ]
}

/// A driver after the default init with fuse ROM `asa`, then `extra` on the bus.
pub fn inited(asa: [u8; 3], extra: impl IntoIterator<Item = T>) -> (Mock, Ak8963<Mock>) {
    let mut t = init_seq(asa, 0x16);
    t.extend(extra);
    let i2c = Mock::new(&t);
    let mut mag = Ak8963::new(i2c.clone());
    mag.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    (i2c, mag)
}

/// CNTL1 read back as 0x00 (a chip reset) where the default config wrote
/// 0x16 (continuous mode 2, 16-bit).
pub const CNTL1_CLEARED: Error<ErrorKind> = Error::ConfigMismatch {
    register: 0x0A,
    expected: 0x16,
    found: 0x00,
};

/// HXL..HZH little-endian, then ST2.
pub fn le(v: [i16; 3], st2: u8) -> Vec<u8> {
    v.into_iter()
        .flat_map(i16::to_le_bytes)
        .chain([st2])
        .collect()
}

/// An ST1 read answering `v`.
pub fn st1(v: u8) -> T {
    T::write_read(A, vec![0x02], vec![v])
}

/// The HXL..ST2 burst.
pub fn data(v: [i16; 3], st2: u8) -> T {
    T::write_read(A, vec![0x03], le(v, st2))
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
