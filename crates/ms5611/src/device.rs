//! The bus driver.

use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

#[cfg(feature = "async")]
use crate::interface::InterfaceAsync;
use crate::interface::{Interface, SpiInterface};
use crate::{command, compensate, Address, Channel, Error, Measurement, Osr, Prom};

/// MS5611 driver on an I2C bus or an SPI device ([`Interface`]).
///
/// On I2C every transfer is a separate write of the command byte followed,
/// for PROM and ADC reads, by a separate read (with a STOP in between), as
/// in the datasheet's I²C timing figures; on SPI the answer follows the
/// command under one chip select.
///
/// The validated PROM is kept once read; measurements need it
/// ([`Error::NotInitialised`] otherwise).
///
/// With the `async` feature, `Ms5611Async` is the same driver over
/// `embedded-hal-async`, generated from the same source.
#[maybe_async_cfg::maybe(sync(keep_self), async(feature = "async"))]
#[derive(Debug)]
pub struct Ms5611<DI> {
    bus: DI,
    address: Address,
    prom: Option<Prom>,
}

#[maybe_async_cfg::maybe(
    idents(Ms5611(sync, async = "Ms5611Async")),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI> Ms5611<DI> {
    /// A driver for the chip at `address`. Does not touch the bus; call
    /// [`Ms5611::init`] (blocking) or [`Ms5611::reset`] +
    /// [`Ms5611::read_prom`] (non-blocking) next.
    pub fn new(i2c: DI, address: Address) -> Self {
        Self {
            bus: i2c,
            address,
            prom: None,
        }
    }

    /// Same as [`new`](Self::new): the driver on an I2C bus at `address`.
    pub fn new_with_i2c(i2c: DI, address: Address) -> Self {
        Self::new(i2c, address)
    }

    /// A driver with an already validated PROM (e.g. kept across a bus
    /// re-initialisation), ready to measure without reading it again.
    pub fn with_prom(i2c: DI, address: Address, prom: Prom) -> Self {
        Self {
            bus: i2c,
            address,
            prom: Some(prom),
        }
    }

    /// Give the bus back (on SPI the [`SpiInterface`]).
    pub fn release(self) -> DI {
        self.bus
    }

    /// The configured bus address (meaningless on SPI).
    pub fn address(&self) -> Address {
        self.address
    }

    /// The PROM, once [`Ms5611::read_prom`] or [`Ms5611::init`] succeeded.
    pub fn prom(&self) -> Option<&Prom> {
        self.prom.as_ref()
    }
}

#[maybe_async_cfg::maybe(
    idents(Ms5611(sync, async = "Ms5611Async")),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<SPI> Ms5611<SpiInterface<SPI>> {
    /// The driver on an SPI device (PS pin low; CSB is the device's chip select).
    pub fn new_with_spi(spi: SPI) -> Self {
        Self::new(SpiInterface::new(spi), Address::CsbHigh)
    }
}

#[maybe_async_cfg::maybe(
    idents(
        Ms5611(sync, async = "Ms5611Async"),
        Interface(sync, async = "InterfaceAsync"),
        DelayNs(sync, async = "AsyncDelayNs")
    ),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI, E> Ms5611<DI>
where
    DI: Interface<Error = E>,
{
    async fn write_command(&mut self, cmd: u8) -> Result<(), Error<E>> {
        self.bus
            .command(self.address.addr(), cmd)
            .await
            .map_err(Error::Bus)
    }

    async fn command_read(&mut self, cmd: u8, buf: &mut [u8]) -> Result<(), Error<E>> {
        self.bus
            .command_read(self.address.addr(), cmd, buf)
            .await
            .map_err(Error::Bus)
    }

    /// Reset and PROM read, blocking for [`command::RESET_TIME_US`] in
    /// between. Returns (and keeps) the validated PROM.
    ///
    /// ```
    /// # use embedded_hal_mock::eh1::{i2c::{Mock, Transaction as T}, delay::NoopDelay};
    /// # let words = ms5611::Prom::from_coefficients([40127, 36924, 23317, 23282, 33464, 28312]).words();
    /// # let mut ex = vec![T::write(0x77, vec![0x1E])];
    /// # for (i, w) in words.iter().enumerate() {
    /// #     ex.push(T::write(0x77, vec![0xA0 + 2 * i as u8]));
    /// #     ex.push(T::read(0x77, w.to_be_bytes().to_vec()));
    /// # }
    /// # let i2c = Mock::new(&ex);
    /// use ms5611::{Address, Ms5611};
    /// let mut baro = Ms5611::new(i2c, Address::CsbLow);
    /// let prom = baro.init(&mut NoopDelay::new())?;
    /// assert_eq!(prom.c1(), 40127);
    /// # baro.release().done();
    /// # Ok::<(), ms5611::Error<embedded_hal::i2c::ErrorKind>>(())
    /// ```
    pub async fn init<D: DelayNs>(&mut self, delay: &mut D) -> Result<Prom, Error<E>> {
        self.reset().await?;
        delay.delay_us(command::RESET_TIME_US).await;
        self.read_prom().await
    }

    /// Send the reset command. Non-blocking: the caller must wait
    /// [`command::RESET_TIME_US`] before the next command. A conversion in
    /// progress is aborted. The kept PROM stays valid.
    pub async fn reset(&mut self) -> Result<(), Error<E>> {
        self.write_command(command::RESET).await
    }

    /// Read the 8 PROM words without validating them.
    pub async fn read_prom_words(&mut self) -> Result<[u16; 8], Error<E>> {
        let mut words = [0u16; command::PROM_WORDS];
        for (index, word) in (0u8..).zip(words.iter_mut()) {
            let mut buf = [0u8; 2];
            self.command_read(command::prom_read(index), &mut buf)
                .await?;
            *word = u16::from_be_bytes(buf);
        }
        Ok(words)
    }

    /// Read and validate the PROM (blank check and CRC-4); on success keep it
    /// for compensation. On failure the previously kept PROM (if any) stays.
    pub async fn read_prom(&mut self) -> Result<Prom, Error<E>> {
        let words = self.read_prom_words().await?;
        let prom = Prom::from_words(&words)?;
        self.prom = Some(prom);
        Ok(prom)
    }

    /// Start a D1 (pressure) or D2 (temperature) conversion. Non-blocking:
    /// read the result with [`Ms5611::read_adc`] after at least
    /// [`Osr::conversion_time_us`]; any command sent earlier corrupts it.
    pub async fn start_conversion(&mut self, channel: Channel, osr: Osr) -> Result<(), Error<E>> {
        self.write_command(channel.convert_command(osr)).await
    }

    /// The ADC read command and its 3-byte big-endian answer, 0 included.
    pub(crate) async fn read_adc_raw(&mut self) -> Result<u32, Error<E>> {
        let mut buf = [0u8; 3];
        self.command_read(command::ADC_READ, &mut buf).await?;
        let [b0, b1, b2] = buf;
        Ok(u32::from_be_bytes([0, b0, b1, b2]))
    }

    /// Read the result of the last conversion (24 bits). A result of 0
    /// (conversion not started, not finished, or already read) is
    /// [`Error::AdcNotReady`].
    pub async fn read_adc(&mut self) -> Result<u32, Error<E>> {
        match self.read_adc_raw().await? {
            0 => Err(Error::AdcNotReady),
            raw => Ok(raw),
        }
    }

    /// One blocking conversion: start, wait the maximum conversion time,
    /// read.
    pub async fn convert<D: DelayNs>(
        &mut self,
        delay: &mut D,
        channel: Channel,
        osr: Osr,
    ) -> Result<u32, Error<E>> {
        self.start_conversion(channel, osr).await?;
        delay.delay_us(osr.conversion_time_us()).await;
        self.read_adc().await
    }

    /// Blocking measurement: a D1 then a D2 conversion at `osr`, compensated
    /// (about 2 × [`Osr::conversion_time_us`]). Needs the PROM.
    ///
    /// For flight use prefer the non-blocking [`crate::Sampler`].
    ///
    /// ```
    /// # use embedded_hal_mock::eh1::{i2c::{Mock, Transaction as T}, delay::NoopDelay};
    /// # let i2c = Mock::new(&[
    /// #     T::write(0x77, vec![0x48]), T::write(0x77, vec![0x00]), T::read(0x77, vec![0x8A, 0xA2, 0x1A]),
    /// #     T::write(0x77, vec![0x58]), T::write(0x77, vec![0x00]), T::read(0x77, vec![0x82, 0xC1, 0x3E]),
    /// # ]);
    /// use ms5611::{Address, Ms5611, Osr, Prom};
    /// let prom = Prom::from_coefficients([40127, 36924, 23317, 23282, 33464, 28312]);
    /// let mut baro = Ms5611::with_prom(i2c, Address::CsbLow, prom);
    /// let m = baro.measure(&mut NoopDelay::new(), Osr::Osr4096)?;
    /// assert_eq!((m.pressure_pa, m.temperature_centi_c), (100_009, 2007));
    /// # baro.release().done();
    /// # Ok::<(), ms5611::Error<embedded_hal::i2c::ErrorKind>>(())
    /// ```
    pub async fn measure<D: DelayNs>(
        &mut self,
        delay: &mut D,
        osr: Osr,
    ) -> Result<Measurement, Error<E>> {
        let prom = self.prom.ok_or(Error::NotInitialised)?;
        let d1 = self.convert(delay, Channel::Pressure, osr).await?;
        let d2 = self.convert(delay, Channel::Temperature, osr).await?;
        Ok(compensate(&prom, d1, d2)?)
    }
}
