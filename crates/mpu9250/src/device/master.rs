//! The internal I2C master: the only way to the AK8963 when the host talks
//! SPI (the bypass would put the AK8963 on the SPI pins).
//!
//! Register map §§ I2C_MST_CTRL, I2C_SLV0_*, I2C_SLV4_*, I2C_MST_STATUS,
//! EXT_SENS_DATA, I2C_MST_DELAY_CTRL. The master runs at 400 kHz with a STOP
//! between slave reads. Slave 0 repeats a read of up to 15 bytes at every
//! sample and the chip copies them into EXT_SENS_DATA_00.. (shadowed so a
//! host read never sees half an update); slave 4 does one byte-wide transfer
//! when asked, for configuration (CNTL1, CNTL2, the fuse ROM). Slave 4 only
//! starts at the next sample tick, so its completion is polled for up to two
//! sample periods plus 1 ms.

use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

use super::Mpu9250;
#[cfg(feature = "async")]
use super::Mpu9250Async;
use crate::config::ConfigError;
use crate::data::{parse_sample, RawSample};
use crate::error::Error;
use crate::interface::Interface;
#[cfg(feature = "async")]
use crate::interface::InterfaceAsync;
use crate::register as reg;

/// Interval between I2C_MST_STATUS polls while slave 4 transfers, µs.
pub const AUX_POLL_INTERVAL_US: u32 = 100;

/// Most bytes EXT_SENS_DATA holds.
pub const EXT_SENS_DATA_LEN: usize = 24;

/// A read that slave 0 repeats at every sample into EXT_SENS_DATA_00...
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SlaveRead {
    /// 7-bit address of the chip on the auxiliary bus.
    pub address: u8,
    /// First register read.
    pub register: u8,
    /// Bytes read, 1..=15.
    pub len: u8,
}

impl SlaveRead {
    /// The AK8963 block ST1, HXL..HZH, ST2 (8 bytes from 0x02 at 0x0C):
    /// reading through ST2 releases the AK8963's data lock every sample.
    pub const AK8963_STATUS_BLOCK: SlaveRead = SlaveRead {
        address: 0x0C,
        register: 0x02,
        len: 8,
    };
}

#[maybe_async_cfg::maybe(
    idents(Mpu9250(sync, async = "Mpu9250Async")),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI> Mpu9250<DI> {
    /// Whether the internal I2C master is on.
    pub fn i2c_master(&self) -> bool {
        self.master
    }

    /// The periodic slave-0 read in force.
    pub fn slave0(&self) -> Option<SlaveRead> {
        self.slave0
    }

    /// The master's registers as `init` writes and verifies them.
    pub(super) fn master_values(&self) -> [Option<(u8, u8)>; 5] {
        if !self.master {
            return [None; 5];
        }
        let s0 = self.slave0;
        [
            Some((
                reg::I2C_MST_CTRL,
                reg::I2C_MST_CTRL_P_NSR | reg::I2C_MST_CLK_400KHZ,
            )),
            Some((reg::I2C_MST_DELAY_CTRL, reg::I2C_MST_DELAY_ES_SHADOW)),
            s0.map(|s| (reg::I2C_SLV0_ADDR, s.address | reg::I2C_SLV_READ)),
            s0.map(|s| (reg::I2C_SLV0_REG, s.register)),
            s0.map(|s| (reg::I2C_SLV0_CTRL, reg::I2C_SLV_EN | s.len)),
        ]
    }

    /// Polls allowed for one slave-4 transfer: two sample periods plus 1 ms.
    fn aux_max_polls(&self) -> u32 {
        (2 * self.config.sample_period_us() + 1_000) / AUX_POLL_INTERVAL_US
    }
}

#[maybe_async_cfg::maybe(
    idents(
        Mpu9250(sync, async = "Mpu9250Async"),
        Interface(sync, async = "InterfaceAsync"),
        DelayNs(sync, async = "AsyncDelayNs")
    ),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI, E> Mpu9250<DI>
where
    DI: Interface<Error = E>,
{
    /// Turn the internal I2C master on or off. On: I2C_MST_CTRL (400 kHz,
    /// STOP between reads), I2C_MST_DELAY_CTRL (DELAY_ES_SHADOW) and USER_CTRL
    /// I2C_MST_EN, each written and read back. Off: slave 0 stopped, I2C_MST_EN
    /// cleared. The state (and a slave-0 read) survives `init`. Refused while
    /// the bypass is on ([`Error::MasterWithBypass`]): the two exclude each other.
    pub async fn set_i2c_master(&mut self, enable: bool) -> Result<(), Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        if enable && self.bypass {
            return Err(Error::MasterWithBypass);
        }
        if enable {
            self.master = true;
            for (register, value) in self.master_values().into_iter().flatten() {
                self.write_verified(register, value).await?;
            }
        } else {
            self.write_reg(reg::I2C_SLV0_CTRL, 0).await?;
            self.slave0 = None;
            self.master = false;
        }
        self.write_verified(reg::USER_CTRL, self.user_ctrl()).await
    }

    /// Start (or replace) the periodic slave-0 read. `len` must be 1..=15
    /// ([`ConfigError::SlaveReadLength`], nothing written).
    pub async fn start_slave0_read(&mut self, read: SlaveRead) -> Result<(), Error<E>> {
        if !self.master {
            return Err(Error::MasterDisabled);
        }
        if read.len == 0 || read.len > reg::I2C_SLV_LENG_MASK {
            return Err(Error::InvalidConfig(ConfigError::SlaveReadLength));
        }
        self.slave0 = Some(read);
        self.write_verified(reg::I2C_SLV0_ADDR, read.address | reg::I2C_SLV_READ)
            .await?;
        self.write_verified(reg::I2C_SLV0_REG, read.register)
            .await?;
        self.write_verified(reg::I2C_SLV0_CTRL, reg::I2C_SLV_EN | read.len)
            .await
    }

    /// Stop the periodic slave-0 read.
    pub async fn stop_slave0_read(&mut self) -> Result<(), Error<E>> {
        self.slave0 = None;
        self.write_verified(reg::I2C_SLV0_CTRL, 0).await
    }

    /// Read EXT_SENS_DATA_00.. into `buf` (at most 24 bytes;
    /// [`ConfigError::SlaveReadLength`] beyond).
    pub async fn read_external(&mut self, buf: &mut [u8]) -> Result<(), Error<E>> {
        if buf.len() > EXT_SENS_DATA_LEN {
            return Err(Error::InvalidConfig(ConfigError::SlaveReadLength));
        }
        self.read_regs(reg::EXT_SENS_DATA_00, buf).await
    }

    /// One burst from ACCEL_XOUT_H through EXT_SENS_DATA: the raw sample and
    /// `external.len()` (at most 24) bytes of slave data taken at the same
    /// sample.
    pub async fn read_raw_with_external(
        &mut self,
        external: &mut [u8],
    ) -> Result<RawSample, Error<E>> {
        let mut buf = [0u8; reg::SAMPLE_LEN + EXT_SENS_DATA_LEN];
        let Some(all) = buf.get_mut(..reg::SAMPLE_LEN + external.len()) else {
            return Err(Error::InvalidConfig(ConfigError::SlaveReadLength));
        };
        self.read_regs(reg::ACCEL_XOUT_H, all).await?;
        let (sample, ext) = all.split_at(reg::SAMPLE_LEN);
        external.copy_from_slice(ext);
        let sample = <&[u8; reg::SAMPLE_LEN]>::try_from(sample)
            .map_err(|_| Error::InvalidConfig(ConfigError::SlaveReadLength))?;
        Ok(parse_sample(sample))
    }

    /// Write one register of a chip on the auxiliary bus through slave 4.
    pub async fn aux_write<D: DelayNs>(
        &mut self,
        delay: &mut D,
        address: u8,
        register: u8,
        value: u8,
    ) -> Result<(), Error<E>> {
        self.aux_start(address, register).await?;
        self.write_reg(reg::I2C_SLV4_DO, value).await?;
        self.aux_run(delay).await
    }

    /// Read one register of a chip on the auxiliary bus through slave 4.
    pub async fn aux_read<D: DelayNs>(
        &mut self,
        delay: &mut D,
        address: u8,
        register: u8,
    ) -> Result<u8, Error<E>> {
        self.aux_start(address | reg::I2C_SLV_READ, register)
            .await?;
        self.aux_run(delay).await?;
        self.read_reg(reg::I2C_SLV4_DI).await
    }

    async fn aux_start(&mut self, address: u8, register: u8) -> Result<(), Error<E>> {
        if !self.master {
            return Err(Error::MasterDisabled);
        }
        // Reading the status clears flags a previous transfer left behind.
        self.read_reg(reg::I2C_MST_STATUS).await?;
        self.write_reg(reg::I2C_SLV4_ADDR, address).await?;
        self.write_reg(reg::I2C_SLV4_REG, register).await
    }

    /// Enable slave 4 and poll I2C_MST_STATUS until it is done.
    async fn aux_run<D: DelayNs>(&mut self, delay: &mut D) -> Result<(), Error<E>> {
        self.write_reg(reg::I2C_SLV4_CTRL, reg::I2C_SLV_EN).await?;
        for _ in 0..self.aux_max_polls() {
            delay.delay_us(AUX_POLL_INTERVAL_US).await;
            let status = self.read_reg(reg::I2C_MST_STATUS).await?;
            if status & reg::I2C_MST_STATUS_SLV4_NACK != 0 {
                return Err(Error::AuxNack);
            }
            if status & reg::I2C_MST_STATUS_LOST_ARB != 0 {
                return Err(Error::AuxLostArbitration);
            }
            if status & reg::I2C_MST_STATUS_SLV4_DONE != 0 {
                return Ok(());
            }
        }
        Err(Error::AuxTimeout)
    }
}

/// The auxiliary bus behind the internal master, as an `ak8963::Interface`:
/// the AK8963 driver (`init`, `self_test`, ...) runs unchanged on it, one
/// byte per slave-4 transfer. Made by [`Mpu9250::aux_bus`]; owns the delay
/// it polls with.
#[cfg(feature = "ak8963")]
#[maybe_async_cfg::maybe(
    idents(Mpu9250(sync, async = "Mpu9250Async")),
    sync(keep_self),
    async(feature = "async")
)]
#[derive(Debug)]
pub struct AuxBus<'a, DI, D> {
    mpu: &'a mut Mpu9250<DI>,
    delay: D,
}

#[cfg(feature = "ak8963")]
#[maybe_async_cfg::maybe(
    idents(
        Mpu9250(sync, async = "Mpu9250Async"),
        AuxBus(sync, async = "AuxBusAsync")
    ),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI> Mpu9250<DI> {
    /// Borrow the auxiliary bus for a driver of a chip behind the master
    /// (turn the master on first). `delay` paces the slave-4 polls.
    pub fn aux_bus<D>(&mut self, delay: D) -> AuxBus<'_, DI, D> {
        AuxBus { mpu: self, delay }
    }
}

#[cfg(feature = "ak8963")]
#[maybe_async_cfg::maybe(
    idents(
        AuxBus(sync, async = "AuxBusAsync"),
        Interface(sync, async = "InterfaceAsync"),
        DelayNs(sync, async = "AsyncDelayNs")
    ),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI, D, E> ak8963::Interface for AuxBus<'_, DI, D>
where
    DI: Interface<Error = E>,
    D: DelayNs,
{
    type Error = Error<E>;

    async fn write_register(
        &mut self,
        address: u8,
        register: u8,
        value: u8,
    ) -> Result<(), Self::Error> {
        self.mpu
            .aux_write(&mut self.delay, address, register, value)
            .await
    }

    async fn read_registers(
        &mut self,
        address: u8,
        start: u8,
        buf: &mut [u8],
    ) -> Result<(), Self::Error> {
        let mut register = start;
        for byte in buf.iter_mut() {
            *byte = self
                .mpu
                .aux_read(&mut self.delay, address, register)
                .await?;
            register = register.wrapping_add(1);
        }
        Ok(())
    }
}
