//! The same command traffic over each transport: blocking I2C, blocking SPI,
//! async I2C and async SPI give the same PROM and the same measurements.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::*;
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::i2c::Mock as I2cMock;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;
use ms5611::{Address, Measurement, Ms5611, Ms5611Async, Osr, Sampler, SamplerConfig};

/// Reset, PROM, then one blocking measurement at OSR 4096 (D1 0x48, D2 0x58).
fn traffic() -> Vec<Op> {
    let mut ops = init_ops(&datasheet_prom().words());
    ops.extend(conversion_ops(0x48, D1));
    ops.extend(conversion_ops(0x58, D2));
    ops
}

/// The datasheet's worked example: 2007 (20.07 °C) and 100009 Pa.
const EXPECTED: (i32, i32) = (100_009, 2007);

fn pair(m: Measurement) -> (i32, i32) {
    (m.pressure_pa, m.temperature_centi_c)
}

#[test]
fn blocking_i2c_and_spi_give_the_datasheet_example() {
    let mut bus = I2cMock::new(&i2c(0x77, &traffic()));
    let mut baro = Ms5611::new_with_i2c(bus.clone(), Address::CsbLow);
    let prom_i2c = baro.init(&mut NoopDelay::new()).unwrap();
    let m_i2c = baro.measure(&mut NoopDelay::new(), Osr::Osr4096).unwrap();
    bus.done();

    let mut dev = SpiMock::new(&spi(&traffic()));
    let mut baro = Ms5611::new_with_spi(dev.clone());
    // The reset wait is the same on SPI.
    let mut delay = CheckedDelay::new(&[D::delay_us(2_800)]);
    let prom_spi = baro.init(&mut delay).unwrap();
    delay.done();
    let m_spi = baro.measure(&mut NoopDelay::new(), Osr::Osr4096).unwrap();
    dev.done();

    assert_eq!(prom_i2c, prom_spi);
    assert_eq!(pair(m_i2c), EXPECTED);
    assert_eq!(pair(m_spi), EXPECTED);
}

#[test]
fn async_i2c_and_spi_give_the_datasheet_example() {
    let mut bus = I2cMock::new(&i2c(0x76, &traffic()));
    let mut baro = Ms5611Async::new(bus.clone(), Address::CsbHigh);
    let m_i2c = block_on(async {
        baro.init(&mut NoopDelay::new()).await.unwrap();
        baro.measure(&mut NoopDelay::new(), Osr::Osr4096)
            .await
            .unwrap()
    });
    bus.done();

    let mut dev = SpiMock::new(&spi(&traffic()));
    let mut baro = Ms5611Async::new_with_spi(dev.clone());
    let m_spi = block_on(async {
        baro.init(&mut NoopDelay::new()).await.unwrap();
        baro.measure(&mut NoopDelay::new(), Osr::Osr4096)
            .await
            .unwrap()
    });
    dev.done();

    assert_eq!(pair(m_i2c), EXPECTED);
    assert_eq!(pair(m_spi), EXPECTED);
}

/// The non-blocking schedule drives an SPI chip and an async chip exactly as
/// an I2C one: D2 first, then D1, and the first pressure comes out.
#[test]
fn sampler_over_spi_and_async() {
    let config = SamplerConfig::new()
        .with_pressure_osr(Osr::Osr4096)
        .with_temperature_osr(Osr::Osr4096);
    let mut ops = conversion_ops(0x58, D2);
    ops.extend(conversion_ops(0x48, D1));
    // After the D1 read the schedule starts the next D1 at once.
    ops.push(Op::Command(0x48));
    let times = [0u32, 20_000, 40_000];

    let mut dev = SpiMock::new(&spi(&ops));
    let mut baro = Ms5611::with_prom(
        ms5611::SpiInterface::new(dev.clone()),
        Address::CsbHigh,
        datasheet_prom(),
    );
    let mut sampler = Sampler::new(config);
    let out: Vec<_> = times
        .iter()
        .map(|&t| sampler.poll(&mut baro, t).unwrap())
        .collect();
    dev.done();
    assert_eq!(out[0], None);
    assert_eq!(out[1], None);
    assert_eq!(out[2].map(pair), Some(EXPECTED));

    let mut bus = I2cMock::new(&i2c(0x77, &ops));
    let mut baro = Ms5611Async::with_prom(bus.clone(), Address::CsbLow, datasheet_prom());
    let mut sampler = Sampler::new(config);
    let last = block_on(async {
        let mut last = None;
        for t in times {
            last = sampler.poll_async(&mut baro, t).await.unwrap();
        }
        last
    });
    bus.done();
    assert_eq!(last.map(pair), Some(EXPECTED));
}
