//! How register reads and writes reach the chip: I2C or SPI, blocking or async.
//!
//! The driver only ever writes one register or reads a run of consecutive
//! registers; [`Interface`] (blocking) and, with the `async` feature,
//! `InterfaceAsync` are that seam. Every `embedded-hal` I2C bus is an
//! interface by itself (the driver passes the 7-bit address); an SPI device
//! is wrapped in [`SpiInterface`].
//!
//! On SPI (datasheet §7.5, register map "SPI interface"): the first byte is the
//! register address with bit 7 set for a read and clear for a write; reads
//! auto-increment like I2C bursts. The chip accepts up to 1 MHz for every
//! register and up to 20 MHz for the sensor and interrupt registers: the bus
//! speed belongs to the `SpiDevice` the caller builds.

// Same shape as the other drivers' interface.rs on purpose: each driver is an
// independently publishable crate with no helper crate in common.

#[cfg(feature = "async")]
use embedded_hal_async::{i2c::I2c as AsyncI2c, spi::SpiDevice as AsyncSpiDevice};

use embedded_hal::i2c::I2c;
use embedded_hal::spi::{Operation, SpiDevice};

/// Bit 7 of the first SPI byte: 1 = read.
pub const SPI_READ: u8 = 0x80;

/// A transport that reads and writes MPU-9250 registers (blocking; with the
/// `async` feature the same trait exists as `InterfaceAsync` with `async fn`s).
#[maybe_async_cfg::maybe(sync(keep_self), async(feature = "async"))]
#[allow(async_fn_in_trait)]
pub trait Interface {
    /// The transport's error.
    type Error;
    /// `true` when the chip is on SPI: the driver then sets USER_CTRL
    /// I2C_IF_DIS and refuses the I2C bypass.
    const SPI: bool;
    /// Write `value` to `register`. `address` is the I2C address (unused on SPI).
    async fn write_register(
        &mut self,
        address: u8,
        register: u8,
        value: u8,
    ) -> Result<(), Self::Error>;
    /// Read `buf.len()` consecutive registers starting at `start`.
    async fn read_registers(
        &mut self,
        address: u8,
        start: u8,
        buf: &mut [u8],
    ) -> Result<(), Self::Error>;
}

/// An MPU-9250 on an SPI bus (chip select handled by the `SpiDevice`).
#[derive(Debug)]
pub struct SpiInterface<SPI> {
    spi: SPI,
}

impl<SPI> SpiInterface<SPI> {
    /// Wrap an SPI device (mode 0 or 3, at most 1 MHz for configuration).
    pub const fn new(spi: SPI) -> Self {
        Self { spi }
    }

    /// Give the SPI device back.
    pub fn release(self) -> SPI {
        self.spi
    }
}

#[maybe_async_cfg::maybe(
    idents(
        I2c(sync, async = "AsyncI2c"),
        Interface(sync, async = "InterfaceAsync")
    ),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<B: I2c> Interface for B {
    type Error = B::Error;
    const SPI: bool = false;

    async fn write_register(
        &mut self,
        address: u8,
        register: u8,
        value: u8,
    ) -> Result<(), Self::Error> {
        self.write(address, &[register, value]).await
    }

    async fn read_registers(
        &mut self,
        address: u8,
        start: u8,
        buf: &mut [u8],
    ) -> Result<(), Self::Error> {
        self.write_read(address, &[start], buf).await
    }
}

#[maybe_async_cfg::maybe(
    idents(
        SpiDevice(sync, async = "AsyncSpiDevice"),
        Interface(sync, async = "InterfaceAsync")
    ),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<SPI: SpiDevice> Interface for SpiInterface<SPI> {
    type Error = SPI::Error;
    const SPI: bool = true;

    async fn write_register(
        &mut self,
        _address: u8,
        register: u8,
        value: u8,
    ) -> Result<(), Self::Error> {
        self.spi.write(&[register & !SPI_READ, value]).await
    }

    async fn read_registers(
        &mut self,
        _address: u8,
        start: u8,
        buf: &mut [u8],
    ) -> Result<(), Self::Error> {
        self.spi
            .transaction(&mut [Operation::Write(&[start | SPI_READ]), Operation::Read(buf)])
            .await
    }
}
