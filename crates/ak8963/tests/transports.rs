//! The same traffic through the blocking and the async driver, and the
//! ST1..ST2 block the MPU-9250's internal master delivers, give the same
//! samples with the same checks.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use ak8963::*;
use common::*;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::Mock;

fn traffic() -> Vec<embedded_hal_mock::eh1::i2c::Transaction> {
    let mut t = init_seq([0xB0, 0x80, 0x80], 0x16);
    t.extend([
        st1(0x01),
        data([200, -100, 0], 0x10),
        st1(0x00),
        st1(0x03),
        data([0, 0, 300], 0x10),
        st1(0x01),
        data([0, 0, 300], 0x18),
        st1(0x01),
        data([0, 0, 300], 0x00),
    ]);
    t
}

type Reads = Vec<Result<RawMag, Error<embedded_hal::i2c::ErrorKind>>>;

fn expected() -> Reads {
    let raw = |counts, data_overrun| RawMag {
        counts,
        resolution: Resolution::Bits16,
        data_overrun,
    };
    vec![
        Ok(raw([200, -100, 0], false)),
        Err(Error::NotReady),
        Ok(raw([0, 0, 300], true)),
        Err(Error::Overflow),
        Err(Error::ResolutionMismatch {
            configured: Resolution::Bits16,
        }),
    ]
}

#[test]
fn blocking_and_async_read_the_same_samples() {
    let mut i2c = Mock::new(&traffic());
    let mut mag = Ak8963::new(i2c.clone());
    mag.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    let blocking: Reads = (0..5).map(|_| mag.read_raw()).collect();
    i2c.done();

    let mut i2c = Mock::new(&traffic());
    let mut mag = Ak8963Async::new(i2c.clone());
    let asynchronous: Reads = block_on(async {
        mag.init(&mut NoopDelay::new(), &Config::default())
            .await
            .unwrap();
        let mut v = Vec::new();
        for _ in 0..5 {
            v.push(mag.read_raw().await);
        }
        v
    });
    i2c.done();
    assert_eq!(mag.asa(), [0xB0, 0x80, 0x80]);

    assert_eq!(blocking, expected());
    assert_eq!(asynchronous, expected());
}

#[test]
fn status_block_applies_the_same_checks() {
    let block = |st1: u8, v: [i16; 3], st2: u8| -> [u8; 8] {
        let mut b = vec![st1];
        b.extend(le(v, st2));
        b.try_into().unwrap()
    };
    let blocks = [
        block(0x01, [200, -100, 0], 0x10),
        block(0x00, [200, -100, 0], 0x10),
        block(0x03, [0, 0, 300], 0x10),
        block(0x01, [0, 0, 300], 0x18),
        block(0x01, [0, 0, 300], 0x00),
    ];
    let parsed: Reads = blocks
        .iter()
        .map(|b| parse_status_block(b, Resolution::Bits16).map_err(Error::from))
        .collect();
    assert_eq!(parsed, expected());
}
