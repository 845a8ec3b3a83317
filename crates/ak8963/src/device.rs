//! The bus-facing driver.

use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

use crate::interface::Interface;
#[cfg(feature = "async")]
use crate::interface::InterfaceAsync;

use crate::config::{Config, Mode, Resolution};
use crate::data::{
    adjustment_q8, asa_valid, convert, parse_measurement, parse_st1, ut_per_lsb, HardSoftIron,
    RawMag, Sample, St1,
};
use crate::error::Error;
use crate::register as reg;

/// Wait after every CNTL1 write (datasheet: at least 100 µs in power-down
/// before setting another mode), µs.
pub const MODE_CHANGE_DELAY_US: u32 = 100;
/// Interval between CNTL2 polls after a soft reset, µs.
pub const RESET_POLL_INTERVAL_US: u32 = 1_000;
/// Maximum CNTL2 polls after a soft reset (bounds the wait to 10 ms).
pub const RESET_MAX_POLLS: u8 = 10;
/// Interval between ST1 polls during the self-test, µs.
pub const SELF_TEST_POLL_INTERVAL_US: u32 = 1_000;
/// Maximum ST1 polls during the self-test (single measurement takes ≤ 9 ms).
pub const SELF_TEST_MAX_POLLS: u8 = 20;

/// AK8963 driver over an I2C bus (through the MPU-9250's I2C bypass) or any
/// other [`Interface`].
///
/// Holds the configuration, the fuse-ROM adjustment and the hard/soft-iron
/// calibration; the calibration survives [`init`](Self::init).
///
/// With the `async` feature, `Ak8963Async` is the same driver over
/// `embedded-hal-async`, generated from the same source.
#[maybe_async_cfg::maybe(sync(keep_self), async(feature = "async"))]
#[derive(Debug)]
pub struct Ak8963<DI> {
    bus: DI,
    address: u8,
    config: Config,
    asa: [u8; 3],
    ut_per_lsb: [f32; 3],
    calibration: HardSoftIron,
    initialized: bool,
}

#[maybe_async_cfg::maybe(
    idents(Ak8963(sync, async = "Ak8963Async")),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI> Ak8963<DI> {
    /// Create the driver at address 0x0C. No bus traffic; call [`init`](Self::init) next.
    ///
    /// ```
    /// use embedded_hal_mock::eh1::i2c::Mock;
    /// let mut i2c = Mock::new(&[]);
    /// let mag = ak8963::Ak8963::new(i2c.clone());
    /// assert_eq!(mag.address(), 0x0C);
    /// i2c.done();
    /// ```
    pub fn new(i2c: DI) -> Self {
        Self::new_with_address(i2c, reg::ADDRESS)
    }

    /// Create the driver at another address (stand-alone AK8963 with CAD pins set).
    pub fn new_with_address(i2c: DI, address: u8) -> Self {
        let config = Config::new();
        Self {
            bus: i2c,
            address,
            config,
            asa: [128; 3],
            ut_per_lsb: ut_per_lsb([128; 3], config.resolution),
            calibration: HardSoftIron::IDENTITY,
            initialized: false,
        }
    }

    /// Give the bus back.
    pub fn release(self) -> DI {
        self.bus
    }

    /// The 7-bit bus address in use.
    pub fn address(&self) -> u8 {
        self.address
    }

    /// The current configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Fuse-ROM ASAX, ASAY, ASAZ read by [`init`](Self::init) (128 before).
    pub fn asa(&self) -> [u8; 3] {
        self.asa
    }

    /// Factory adjustment in Q8 (`ASA + 128`), per axis.
    pub fn adjustment_q8(&self) -> [u16; 3] {
        [
            adjustment_q8(self.asa[0]),
            adjustment_q8(self.asa[1]),
            adjustment_q8(self.asa[2]),
        ]
    }

    /// µT per count per axis (sensitivity × factory adjustment).
    pub fn ut_per_lsb(&self) -> [f32; 3] {
        self.ut_per_lsb
    }

    /// The hard/soft-iron correction in use (AK8963 frame).
    pub fn calibration(&self) -> &HardSoftIron {
        &self.calibration
    }

    /// Replace the hard/soft-iron correction (AK8963 frame). No bus traffic;
    /// kept across [`init`](Self::init).
    pub fn set_calibration(&mut self, calibration: HardSoftIron) {
        self.calibration = calibration;
    }
}

#[maybe_async_cfg::maybe(
    idents(
        Ak8963(sync, async = "Ak8963Async"),
        Interface(sync, async = "InterfaceAsync"),
        DelayNs(sync, async = "AsyncDelayNs")
    ),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI, E> Ak8963<DI>
where
    DI: Interface<Error = E>,
{
    /// Read WIA.
    pub async fn who_am_i(&mut self) -> Result<u8, Error<E>> {
        self.read_reg(reg::WIA).await
    }

    /// Check WIA, soft-reset, read the fuse ROM and start `config`.
    ///
    /// Sequence: WIA (0x48, else [`Error::WrongId`]); CNTL2 = 0x01 (SRST);
    /// poll CNTL2 every [`RESET_POLL_INTERVAL_US`] until SRST clears (at most
    /// [`RESET_MAX_POLLS`]; bus errors during the reset count as "not yet");
    /// CNTL1 = power-down, wait; CNTL1 = 0x0F fuse-ROM access, wait; read
    /// ASAX..ASAZ in one burst; CNTL1 = power-down, wait; reject ASA 0x00/0xFF
    /// ([`Error::BadFuseRom`]); CNTL1 = `config.cntl1()`, wait; read CNTL1
    /// back ([`Error::ConfigMismatch`]). Every wait is [`MODE_CHANGE_DELAY_US`].
    ///
    /// ```
    /// use embedded_hal_mock::eh1::delay::NoopDelay;
    /// use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
    /// use ak8963::{Ak8963, Config};
    /// let a = 0x0C;
    /// let mut i2c = Mock::new(&[
    ///     T::write_read(a, vec![0x00], vec![0x48]),             // WIA
    ///     T::write(a, vec![0x0B, 0x01]),                        // soft reset
    ///     T::write_read(a, vec![0x0B], vec![0x00]),             // reset done
    ///     T::write(a, vec![0x0A, 0x00]),                        // power-down
    ///     T::write(a, vec![0x0A, 0x0F]),                        // fuse ROM access
    ///     T::write_read(a, vec![0x10], vec![0xB0, 0x80, 0xAA]), // ASAX..ASAZ
    ///     T::write(a, vec![0x0A, 0x00]),                        // power-down
    ///     T::write(a, vec![0x0A, 0x16]),                        // 16-bit, 100 Hz
    ///     T::write_read(a, vec![0x0A], vec![0x16]),             // read back
    /// ]);
    /// let mut mag = Ak8963::new(i2c.clone());
    /// mag.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    /// assert_eq!(mag.asa(), [0xB0, 0x80, 0xAA]);
    /// i2c.done();
    /// ```
    pub async fn init<D: DelayNs>(
        &mut self,
        delay: &mut D,
        config: &Config,
    ) -> Result<(), Error<E>> {
        self.initialized = false;
        let id = self.who_am_i().await?;
        if id != reg::WIA_VALUE {
            return Err(Error::WrongId(id));
        }
        self.write_reg(reg::CNTL2, reg::CNTL2_SRST).await?;
        self.wait_reset(delay).await?;

        self.write_cntl1(delay, reg::MODE_POWER_DOWN).await?;
        self.write_cntl1(delay, reg::MODE_FUSE_ROM).await?;
        let mut asa = [0u8; 3];
        self.read_regs(reg::ASAX, &mut asa).await?;
        self.write_cntl1(delay, reg::MODE_POWER_DOWN).await?;
        if !asa.iter().all(|&a| asa_valid(a)) {
            return Err(Error::BadFuseRom { asa });
        }
        self.asa = asa;
        self.apply_config(config);

        self.write_cntl1(delay, config.cntl1()).await?;
        self.check_cntl1().await?;
        self.initialized = true;
        Ok(())
    }

    async fn wait_reset<D: DelayNs>(&mut self, delay: &mut D) -> Result<(), Error<E>> {
        for _ in 0..RESET_MAX_POLLS {
            delay.delay_us(RESET_POLL_INTERVAL_US).await;
            if let Ok(v) = self.read_reg(reg::CNTL2).await {
                if v & reg::CNTL2_SRST == 0 {
                    return Ok(());
                }
            }
        }
        Err(Error::ResetTimeout)
    }

    fn apply_config(&mut self, config: &Config) {
        self.config = *config;
        self.ut_per_lsb = ut_per_lsb(self.asa, config.resolution);
    }

    /// Change mode and/or resolution: CNTL1 = power-down, wait, CNTL1 = new
    /// value, wait (the datasheet requires passing through power-down for
    /// every mode change), then read CNTL1 back.
    ///
    /// The driver adopts `config` (and its µT scale) only once the new CNTL1
    /// value was written; on a bus error before that it keeps the previous
    /// configuration.
    pub async fn set_config<D: DelayNs>(
        &mut self,
        delay: &mut D,
        config: &Config,
    ) -> Result<(), Error<E>> {
        self.write_cntl1(delay, reg::MODE_POWER_DOWN).await?;
        self.write_cntl1(delay, config.cntl1()).await?;
        // Only now does the chip run `config`: adopting it earlier would
        // convert the old mode's data with the new resolution's scale after
        // a failed write. If the power-down went through but the new value
        // did not, the chip idles and `verify_config` reports the mismatch.
        self.apply_config(config);
        self.check_cntl1().await
    }

    /// Change only the mode (see [`set_config`](Self::set_config)).
    pub async fn set_mode<D: DelayNs>(
        &mut self,
        delay: &mut D,
        mode: Mode,
    ) -> Result<(), Error<E>> {
        let config = self.config.mode(mode);
        self.set_config(delay, &config).await
    }

    /// Change only the resolution (see [`set_config`](Self::set_config)).
    pub async fn set_resolution<D: DelayNs>(
        &mut self,
        delay: &mut D,
        resolution: Resolution,
    ) -> Result<(), Error<E>> {
        let config = self.config.resolution(resolution);
        self.set_config(delay, &config).await
    }

    /// Start one measurement in [`Mode::Single`] (ready after at most 9 ms;
    /// the chip then returns to power-down by itself). The chip must be in
    /// power-down, which it is after a previous single measurement; from any
    /// other mode use [`set_mode`](Self::set_mode)`(Mode::Single)` instead.
    pub async fn trigger_single(&mut self) -> Result<(), Error<E>> {
        self.config = self.config.mode(Mode::Single);
        self.write_reg(reg::CNTL1, self.config.cntl1()).await
    }

    /// Read CNTL1 and compare it with the configuration (single mode may
    /// read as power-down). Call it periodically to detect a chip that reset
    /// itself; on [`Error::ConfigMismatch`] re-run [`init`](Self::init).
    pub async fn verify_config(&mut self) -> Result<(), Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        self.check_cntl1().await
    }

    async fn check_cntl1(&mut self) -> Result<(), Error<E>> {
        let found = self.read_reg(reg::CNTL1).await?;
        if self.config.cntl1_matches(found) {
            Ok(())
        } else {
            Err(Error::ConfigMismatch {
                register: reg::CNTL1,
                expected: self.config.cntl1(),
                found,
            })
        }
    }

    /// Read and decode ST1 (does not consume a measurement).
    pub async fn status(&mut self) -> Result<St1, Error<E>> {
        Ok(parse_st1(self.read_reg(reg::ST1).await?))
    }

    /// Read one measurement in counts (AK8963 frame, no adjustment).
    ///
    /// Reads ST1: DRDY clear gives [`Error::NotReady`] with nothing else read
    /// (the pending state is untouched). Otherwise reads HXL..ST2 in one
    /// 7-byte burst (which also tells the chip the read is finished); ST2 HOFL
    /// gives [`Error::Overflow`] and the sample is dropped. ST1 DOR is returned
    /// as [`RawMag::data_overrun`] (the data is still valid). If the burst
    /// fails, ST2 is read once more on its own so that the chip's data
    /// protection is released, and the burst's bus error is returned.
    pub async fn read_raw(&mut self) -> Result<RawMag, Error<E>> {
        let st1 = self.status().await?;
        if !st1.data_ready {
            return Err(Error::NotReady);
        }
        let mut buf = [0u8; reg::MEASUREMENT_LEN];
        if let Err(e) = self.read_regs(reg::HXL, &mut buf).await {
            // The burst may have died after the chip saw the start of the
            // data read: DRDY is then cleared and the data registers stay
            // protected until ST2 is read, so DRDY would never rise again.
            // Reading ST2 ends that read (best effort; the burst's own error
            // is the one reported).
            let _ = self.end_data_read().await;
            return Err(e);
        }
        let mut raw = parse_measurement(&buf, self.config.resolution)?;
        raw.data_overrun = st1.data_overrun;
        Ok(raw)
    }

    /// Read ST2 alone: ends a data read that a failed HXL..ST2 burst left
    /// open. From the first data byte read until ST2 is read the chip keeps
    /// its data registers protected and DRDY low, so without this no new
    /// measurement would ever be reported. For callers that read the
    /// measurement block themselves (an interrupt-driven transfer, parsed
    /// with [`parse_status_block`](crate::parse_status_block)).
    pub async fn end_data_read(&mut self) -> Result<(), Error<E>> {
        self.read_reg(reg::ST2).await.map(|_| ())
    }

    /// Read one measurement in µT: factory adjustment, then the hard/soft-iron
    /// correction; AK8963 frame (see [`Sample::field_mpu_ut`]). Errors as
    /// [`read_raw`](Self::read_raw).
    ///
    /// ```
    /// use embedded_hal_mock::eh1::delay::NoopDelay;
    /// use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
    /// # let a = 0x0C;
    /// # let mut t = vec![
    /// #     T::write_read(a, vec![0x00], vec![0x48]), T::write(a, vec![0x0B, 0x01]),
    /// #     T::write_read(a, vec![0x0B], vec![0x00]), T::write(a, vec![0x0A, 0x00]),
    /// #     T::write(a, vec![0x0A, 0x0F]), T::write_read(a, vec![0x10], vec![0x80, 0x80, 0x80]),
    /// #     T::write(a, vec![0x0A, 0x00]), T::write(a, vec![0x0A, 0x16]),
    /// #     T::write_read(a, vec![0x0A], vec![0x16]),
    /// # ];
    /// // ST1: DRDY; then HX = 200, HY = -100, HZ = 0 counts, ST2 = BITM (16-bit)
    /// t.push(T::write_read(a, vec![0x02], vec![0x01]));
    /// t.push(T::write_read(a, vec![0x03], vec![200, 0, 0x9C, 0xFF, 0, 0, 0x10]));
    /// let mut i2c = Mock::new(&t);
    /// let mut mag = ak8963::Ak8963::new(i2c.clone());
    /// mag.init(&mut NoopDelay::new(), &Default::default())?;
    /// let s = mag.read()?;
    /// assert!((s.field_ut[0] - 30.0).abs() < 1e-4 && (s.field_ut[1] + 15.0).abs() < 1e-4);
    /// assert!(!s.data_overrun);
    /// assert_eq!(ak8963::to_mpu_frame(s.field_ut), s.field_mpu_ut());
    /// i2c.done();
    /// # Ok::<(), ak8963::Error<embedded_hal::i2c::ErrorKind>>(())
    /// ```
    pub async fn read(&mut self) -> Result<Sample, Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        let raw = self.read_raw().await?;
        Ok(convert(&raw, &self.ut_per_lsb, &self.calibration))
    }

    /// Datasheet self-test: power-down, ASTC SELF = 1, self-test mode, poll
    /// ST1 DRDY, read HXL..ST2, ASTC SELF = 0, power-down, then restore the
    /// configured mode. Passes when the adjusted readings are within
    /// X, Y ∈ [−200, 200], Z ∈ [−3200, −800] (16-bit) or
    /// X, Y ∈ [−50, 50], Z ∈ [−800, −200] (14-bit). Returns the adjusted counts.
    ///
    /// The clean-up (SELF = 0, power-down, configured mode) is attempted even
    /// after a bus error earlier in the sequence, so the self-test field is
    /// never left on; the first error is returned. If clearing SELF itself
    /// fails, the chip is left in power-down (not measuring with the
    /// self-test field on) and [`verify_config`](Self::verify_config) reports
    /// it; re-run [`init`](Self::init).
    pub async fn self_test<D: DelayNs>(&mut self, delay: &mut D) -> Result<[i32; 3], Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        let res = self.config.resolution;
        let measured = self.self_test_measure(delay, res).await;
        let cleaned = self.self_test_cleanup(delay).await;
        let buf = measured?;
        cleaned?;
        let Some(buf) = buf else {
            return Err(Error::SelfTestTimeout);
        };
        let raw = parse_measurement(&buf, res)?;
        let q8 = self.adjustment_q8();
        let adj = [
            i32::from(raw.counts[0]) * i32::from(q8[0]) / 256,
            i32::from(raw.counts[1]) * i32::from(q8[1]) / 256,
            i32::from(raw.counts[2]) * i32::from(q8[2]) / 256,
        ];
        let (xy, z_lo, z_hi) = match res {
            Resolution::Bits16 => (200, -3200, -800),
            Resolution::Bits14 => (50, -800, -200),
        };
        let ok = adj[0].abs() <= xy && adj[1].abs() <= xy && (z_lo..=z_hi).contains(&adj[2]);
        if ok {
            Ok(adj)
        } else {
            Err(Error::SelfTestFailed {
                adjusted_counts: adj,
            })
        }
    }

    /// Self-test steps up to the data read; `None` when DRDY never came.
    async fn self_test_measure<D: DelayNs>(
        &mut self,
        delay: &mut D,
        res: Resolution,
    ) -> Result<Option<[u8; reg::MEASUREMENT_LEN]>, Error<E>> {
        self.write_cntl1(delay, reg::MODE_POWER_DOWN).await?;
        self.write_reg(reg::ASTC, reg::ASTC_SELF).await?;
        self.write_cntl1(delay, res.bits() | reg::MODE_SELF_TEST)
            .await?;
        for _ in 0..SELF_TEST_MAX_POLLS {
            if self.status().await?.data_ready {
                let mut buf = [0u8; reg::MEASUREMENT_LEN];
                self.read_regs(reg::HXL, &mut buf).await?;
                return Ok(Some(buf));
            }
            delay.delay_us(SELF_TEST_POLL_INTERVAL_US).await;
        }
        Ok(None)
    }

    /// ASTC SELF = 0, power-down, configured mode (the last only if SELF was
    /// cleared). Every step is attempted; the first error is returned.
    async fn self_test_cleanup<D: DelayNs>(&mut self, delay: &mut D) -> Result<(), Error<E>> {
        let self_off = self.write_reg(reg::ASTC, 0).await;
        let power_down = self.write_cntl1(delay, reg::MODE_POWER_DOWN).await;
        let restore = if self_off.is_ok() {
            let cntl1 = self.config.cntl1();
            self.write_cntl1(delay, cntl1).await
        } else {
            Ok(())
        };
        self_off.and(power_down).and(restore)
    }

    /// Write CNTL1 = `value`, then wait [`MODE_CHANGE_DELAY_US`].
    async fn write_cntl1<D: DelayNs>(&mut self, delay: &mut D, value: u8) -> Result<(), Error<E>> {
        self.write_reg(reg::CNTL1, value).await?;
        delay.delay_us(MODE_CHANGE_DELAY_US).await;
        Ok(())
    }

    async fn write_reg(&mut self, register: u8, value: u8) -> Result<(), Error<E>> {
        self.bus
            .write_register(self.address, register, value)
            .await
            .map_err(Error::Bus)
    }

    async fn read_reg(&mut self, register: u8) -> Result<u8, Error<E>> {
        let mut b = [0u8; 1];
        self.read_regs(register, &mut b).await?;
        Ok(b[0])
    }

    async fn read_regs(&mut self, start: u8, buf: &mut [u8]) -> Result<(), Error<E>> {
        self.bus
            .read_registers(self.address, start, buf)
            .await
            .map_err(Error::Bus)
    }
}
