//! How commands reach the chip: I2C or SPI, blocking or async.
//!
//! The MS5611 has no registers: every transfer is a one-byte command,
//! optionally followed by a read of its answer (2 bytes for a PROM word,
//! 3 for the ADC). [`Interface`] (blocking) and, with the `async` feature,
//! `InterfaceAsync` are that seam. Every `embedded-hal` I2C bus is an
//! interface by itself (the driver passes the address); an SPI device is
//! wrapped in [`SpiInterface`].
//!
//! On I2C the command and the read are separate transfers with a STOP in
//! between (datasheet I²C timing figures). On SPI (PS pin low, mode 0 or 3,
//! up to 20 MHz) the answer is clocked out under the same chip select as the
//! command; a reset or a conversion start is the command byte alone.

// Same shape as the other drivers' interface.rs on purpose: each driver is an
// independently publishable crate with no helper crate in common.

#[cfg(feature = "async")]
use embedded_hal_async::{i2c::I2c as AsyncI2c, spi::SpiDevice as AsyncSpiDevice};

use embedded_hal::i2c::I2c;
use embedded_hal::spi::{Operation, SpiDevice};

/// A transport that sends MS5611 commands (blocking; with the `async`
/// feature the same trait exists as `InterfaceAsync` with `async fn`s).
#[maybe_async_cfg::maybe(sync(keep_self), async(feature = "async"))]
#[allow(async_fn_in_trait)]
pub trait Interface {
    /// The transport's error.
    type Error;
    /// Send one command byte. `address` is the I2C address (unused on SPI).
    async fn command(&mut self, address: u8, command: u8) -> Result<(), Self::Error>;
    /// Send one command byte and read its answer into `buf`.
    async fn command_read(
        &mut self,
        address: u8,
        command: u8,
        buf: &mut [u8],
    ) -> Result<(), Self::Error>;
}

/// An MS5611 on an SPI bus (chip select handled by the `SpiDevice`).
#[derive(Debug)]
pub struct SpiInterface<SPI> {
    spi: SPI,
}

impl<SPI> SpiInterface<SPI> {
    /// Wrap an SPI device.
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

    async fn command(&mut self, address: u8, command: u8) -> Result<(), Self::Error> {
        self.write(address, &[command]).await
    }

    async fn command_read(
        &mut self,
        address: u8,
        command: u8,
        buf: &mut [u8],
    ) -> Result<(), Self::Error> {
        self.write(address, &[command]).await?;
        self.read(address, buf).await
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

    async fn command(&mut self, _address: u8, command: u8) -> Result<(), Self::Error> {
        self.spi.write(&[command]).await
    }

    async fn command_read(
        &mut self,
        _address: u8,
        command: u8,
        buf: &mut [u8],
    ) -> Result<(), Self::Error> {
        self.spi
            .transaction(&mut [Operation::Write(&[command]), Operation::Read(buf)])
            .await
    }
}
