//! How register reads and writes reach the chip, blocking or async.
//!
//! The driver only ever writes one register or reads a run of consecutive
//! registers; [`Interface`] (blocking) and, with the `async` feature,
//! `InterfaceAsync` are that seam. Every `embedded-hal` I2C bus is an
//! interface by itself (through the MPU-9250's bypass, or a stand-alone
//! AK8963); another transport, such as the MPU-9250's internal I2C master
//! when the MPU-9250 is on SPI, implements the trait.

// Same shape as the other drivers' interface.rs on purpose: each driver is an
// independently publishable crate with no helper crate in common.

#[cfg(feature = "async")]
use embedded_hal_async::i2c::I2c as AsyncI2c;

use embedded_hal::i2c::I2c;

/// A transport that reads and writes AK8963 registers (blocking; with the
/// `async` feature the same trait exists as `InterfaceAsync` with `async fn`s).
#[maybe_async_cfg::maybe(sync(keep_self), async(feature = "async"))]
#[allow(async_fn_in_trait)]
pub trait Interface {
    /// The transport's error.
    type Error;
    /// Write `value` to `register` of the chip at I2C `address`.
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
