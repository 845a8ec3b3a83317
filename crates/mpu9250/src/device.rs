//! The bus-facing driver.

use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

use crate::config::{
    AccelBandwidth, AccelRange, Address, Config, ConfigError, GyroBandwidth, GyroRange,
    InterruptConfig, Variant,
};
use crate::data::{
    apply_gyro_bias, convert, parse_sample, rescale_gyro_bias, RawSample, Sample, Scale,
};
use crate::error::{Error, Motion};
#[cfg(feature = "async")]
use crate::interface::InterfaceAsync;
use crate::interface::{Interface, SpiInterface};
use crate::register as reg;

#[cfg(feature = "master")]
mod master;
#[cfg(feature = "ak8963")]
pub use master::AuxBus;
#[cfg(all(feature = "ak8963", feature = "async"))]
pub use master::AuxBusAsync;
#[cfg(feature = "master")]
pub use master::{SlaveRead, AUX_POLL_INTERVAL_US};

/// Interval between PWR_MGMT_1 polls while waiting for H_RESET to clear, ms.
pub const RESET_POLL_INTERVAL_MS: u32 = 10;
/// Maximum number of PWR_MGMT_1 polls after a reset (bounds the wait to 200 ms).
pub const RESET_MAX_POLLS: u8 = 20;

/// Samples averaged per self-test phase (the application note's 200).
pub const SELF_TEST_SAMPLES: u16 = 200;
/// Wait after switching the self-test on or off, ms.
pub const SELF_TEST_SETTLE_MS: u32 = 20;

/// Registers for the self-test: 1 kHz, gyro DLPF 92 Hz, ±250 °/s, accel
/// DLPF 99 Hz, ±2 g.
const SELF_TEST_SETUP: [(u8, u8); 5] = [
    (reg::SMPLRT_DIV, 0),
    (reg::CONFIG, 2),
    (reg::GYRO_CONFIG, 0),
    (reg::ACCEL_CONFIG2, 2),
    (reg::ACCEL_CONFIG, 0),
];

/// Self-test outcome in counts at ±250 °/s (131 LSB/(°/s)) and ±2 g
/// (16384 LSB/g).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SelfTest {
    /// Mean gyro output with the self-test off.
    pub gyro_offset_lsb: [i32; 3],
    /// Gyro self-test response (on − off).
    pub gyro_response_lsb: [i32; 3],
    /// Accel self-test response (on − off).
    pub accel_response_lsb: [i32; 3],
    /// Factory gyro response from the self-test codes (0 = no code).
    pub gyro_factory_lsb: [u32; 3],
    /// Factory accel response from the self-test codes (0 = no code).
    pub accel_factory_lsb: [u32; 3],
}

/// Which self-test criterion failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SelfTestCheck {
    /// Gyro response below half the factory trim (or below 60 °/s without a code).
    GyroResponse,
    /// Gyro output with the self-test off beyond 20 °/s.
    GyroOffset,
    /// Accel response outside 0.5..1.5 of the factory trim (or 225..675 mg without a code).
    AccelResponse,
}

impl SelfTest {
    /// The first failing criterion and its axis (0 = x), if any (see
    /// [`Mpu9250::self_test`]).
    pub fn first_failure(&self) -> Option<(SelfTestCheck, u8)> {
        const GYRO_MIN_LSB: i64 = 60 * 131;
        const GYRO_MAX_OFFSET_LSB: u32 = 20 * 131;
        // 225 mg and 675 mg at 16384 LSB/g.
        const ACCEL_MIN_LSB: i64 = 3686;
        const ACCEL_MAX_LSB: i64 = 11059;
        for axis in 0..3u8 {
            let i = usize::from(axis);
            let r = i64::from(self.gyro_response_lsb[i]);
            let f = i64::from(self.gyro_factory_lsb[i]);
            let ok = if f == 0 {
                r.abs() >= GYRO_MIN_LSB
            } else {
                2 * r > f
            };
            if !ok {
                return Some((SelfTestCheck::GyroResponse, axis));
            }
        }
        for axis in 0..3u8 {
            if self.gyro_offset_lsb[usize::from(axis)].unsigned_abs() > GYRO_MAX_OFFSET_LSB {
                return Some((SelfTestCheck::GyroOffset, axis));
            }
        }
        for axis in 0..3u8 {
            let i = usize::from(axis);
            let r = i64::from(self.accel_response_lsb[i]);
            let f = i64::from(self.accel_factory_lsb[i]);
            let ok = if f == 0 {
                (ACCEL_MIN_LSB..=ACCEL_MAX_LSB).contains(&r.abs())
            } else {
                2 * r > f && 2 * r < 3 * f
            };
            if !ok {
                return Some((SelfTestCheck::AccelResponse, axis));
            }
        }
        None
    }

    /// Whether every criterion passed.
    pub fn passed(&self) -> bool {
        self.first_failure().is_none()
    }
}

/// Factory self-test response in LSB at the self-test ranges for a
/// SELF_TEST_* code: `2620 × 1.01^(code − 1)`, 0 for code 0 (no trim).
pub fn factory_trim_lsb(code: u8) -> u32 {
    if code == 0 {
        return 0;
    }
    let mut v = 2620.0f32;
    for _ in 1..code {
        v *= 1.01;
    }
    // Below 2620 × 1.01^254 ≈ 32 800: the cast cannot saturate.
    (v + 0.5) as u32
}

fn sub3(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [
        a[0].saturating_sub(b[0]),
        a[1].saturating_sub(b[1]),
        a[2].saturating_sub(b[2]),
    ]
}

/// Samples per FIFO burst read (bounds the stack buffer to 112 bytes).
pub const FIFO_BURST_SAMPLES: usize = 8;

/// INT_STATUS contents.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IntStatus(pub u8);

impl IntStatus {
    /// RAW_DATA_RDY_INT: a new sample is in the data registers.
    pub const fn data_ready(self) -> bool {
        self.0 & reg::INT_STATUS_RAW_DATA_RDY_INT != 0
    }
    /// WOM_INT: wake-on-motion.
    pub const fn wake_on_motion(self) -> bool {
        self.0 & reg::INT_STATUS_WOM_INT != 0
    }
    /// FIFO_OFLOW_INT: FIFO overflow.
    pub const fn fifo_overflow(self) -> bool {
        self.0 & reg::INT_STATUS_FIFO_OFLOW_INT != 0
    }
    /// FSYNC_INT: FSYNC interrupt.
    pub const fn fsync(self) -> bool {
        self.0 & reg::INT_STATUS_FSYNC_INT != 0
    }
}

/// Gyro-bias calibration settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BiasCalibration {
    /// Number of samples averaged (one per output-data period).
    pub samples: u16,
    /// Largest allowed max − min of any gyro axis over the window, °/s.
    pub max_gyro_peak_to_peak_dps: f32,
    /// Allowed deviation of every sample's |accel| from 1 g, in g.
    pub accel_tolerance_g: f32,
}

impl BiasCalibration {
    /// `samples` samples, 3 °/s peak-to-peak gyro limit (the 41 Hz DLPF noise is
    /// about 0.1 °/s rms), |a| within 1 g ± 0.1 g.
    pub const fn new(samples: u16) -> Self {
        Self {
            samples,
            max_gyro_peak_to_peak_dps: 3.0,
            accel_tolerance_g: 0.1,
        }
    }
}

/// MPU-9250 driver over an I2C bus or an SPI device ([`Interface`]).
///
/// Holds the configuration, the gyro bias (raw counts at the configured gyro
/// range) and the bypass state; all three survive [`init`](Self::init), which
/// resets the chip and rewrites every register from them.
///
/// With the `async` feature, `Mpu9250Async` is the same driver over
/// `embedded-hal-async` (every bus method is an `async fn`), generated from
/// the same source.
#[maybe_async_cfg::maybe(sync(keep_self), async(feature = "async"))]
#[derive(Debug)]
pub struct Mpu9250<DI> {
    bus: DI,
    address: u8,
    config: Config,
    scale: Scale,
    bypass: bool,
    #[cfg(feature = "fifo")]
    fifo: bool,
    #[cfg(feature = "master")]
    master: bool,
    #[cfg(feature = "master")]
    slave0: Option<master::SlaveRead>,
    gyro_bias: [i16; 3],
    variant: Option<Variant>,
    initialized: bool,
}

#[maybe_async_cfg::maybe(
    idents(Mpu9250(sync, async = "Mpu9250Async")),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<DI> Mpu9250<DI> {
    /// Create the driver. No bus traffic; call [`init`](Self::init) next.
    ///
    /// ```
    /// use embedded_hal_mock::eh1::i2c::Mock;
    /// use mpu9250::{Address, Mpu9250};
    /// let mut i2c = Mock::new(&[]);
    /// let imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    /// assert_eq!(imu.address(), 0x68);
    /// i2c.done();
    /// ```
    pub fn new(i2c: DI, address: Address) -> Self {
        let config = Config::new();
        Self {
            bus: i2c,
            address: address.addr(),
            scale: Scale::from_config(&config),
            config,
            bypass: false,
            #[cfg(feature = "fifo")]
            fifo: false,
            #[cfg(feature = "master")]
            master: false,
            #[cfg(feature = "master")]
            slave0: None,
            gyro_bias: [0; 3],
            variant: None,
            initialized: false,
        }
    }

    /// Same as [`new`](Self::new): the driver on an I2C bus at `address`.
    pub fn new_with_i2c(i2c: DI, address: Address) -> Self {
        Self::new(i2c, address)
    }

    /// Give the bus back (on SPI the [`SpiInterface`]; its `release` gives
    /// the SPI device).
    pub fn release(self) -> DI {
        self.bus
    }

    /// The 7-bit bus address in use (meaningless on SPI).
    pub fn address(&self) -> u8 {
        self.address
    }

    /// The configuration of the last [`init`](Self::init) (the default before).
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// Conversion factors of the current configuration.
    pub fn scale(&self) -> Scale {
        self.scale
    }

    /// The chip found by the last [`init`](Self::init).
    pub fn variant(&self) -> Option<Variant> {
        self.variant
    }

    /// Whether I2C bypass (AK8963 on the host bus) is requested.
    pub fn bypass(&self) -> bool {
        self.bypass
    }

    /// Whether the FIFO records samples (see [`set_fifo`](Self::set_fifo)).
    #[cfg(feature = "fifo")]
    pub fn fifo(&self) -> bool {
        self.fifo
    }

    /// FIFO on: always `false` without the `fifo` feature, so a build that
    /// does not use the FIFO carries none of its code.
    fn fifo_on(&self) -> bool {
        #[cfg(feature = "fifo")]
        return self.fifo;
        #[cfg(not(feature = "fifo"))]
        return false;
    }

    /// Internal I2C master on (always `false` without the `master` feature).
    fn master_on(&self) -> bool {
        #[cfg(feature = "master")]
        return self.master;
        #[cfg(not(feature = "master"))]
        return false;
    }

    /// The stored gyro bias, counts at the configured gyro range (MPU frame).
    pub fn gyro_bias(&self) -> [i16; 3] {
        self.gyro_bias
    }

    /// The stored gyro bias in °/s.
    pub fn gyro_bias_dps(&self) -> [f32; 3] {
        let k = self.scale.dps_per_lsb;
        [
            f32::from(self.gyro_bias[0]) * k,
            f32::from(self.gyro_bias[1]) * k,
            f32::from(self.gyro_bias[2]) * k,
        ]
    }

    /// Set the gyro bias, counts at the configured gyro range. It is a driver
    /// field (never written to the chip's offset registers) and survives `init`.
    pub fn set_gyro_bias(&mut self, bias_counts: [i16; 3]) {
        self.gyro_bias = bias_counts;
    }
}

#[maybe_async_cfg::maybe(
    idents(Mpu9250(sync, async = "Mpu9250Async")),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl<SPI> Mpu9250<SpiInterface<SPI>> {
    /// The driver on an SPI device (mode 0 or 3). [`init`](Self::init) sets
    /// USER_CTRL I2C_IF_DIS so the chip ignores I2C traffic; the I2C bypass is
    /// then unavailable (reach the AK8963 through the internal I2C master).
    pub fn new_with_spi(spi: SPI) -> Self {
        Self::new(SpiInterface::new(spi), Address::Ad0Low)
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
    /// Read WHO_AM_I and classify it.
    pub async fn who_am_i(&mut self) -> Result<Variant, Error<E>> {
        classify(self.read_reg(reg::WHO_AM_I).await?)
    }

    /// Check the chip, reset it, configure it and read every configuration
    /// register back.
    ///
    /// Sequence: WHO_AM_I; PWR_MGMT_1 = 0x80 (H_RESET); poll PWR_MGMT_1 every
    /// [`RESET_POLL_INTERVAL_MS`] until H_RESET clears (at most
    /// [`RESET_MAX_POLLS`] polls, bus errors while the chip reboots count as
    /// "not yet"; else [`Error::ResetTimeout`]); then the writes of
    /// [`Config::register_values`] (PWR_MGMT_1 CLKSEL = PLL, PWR_MGMT_2 = 0,
    /// USER_CTRL = 0, SMPLRT_DIV, CONFIG, GYRO_CONFIG, ACCEL_CONFIG,
    /// ACCEL_CONFIG2, INT_PIN_CFG (with BYPASS_EN if [`set_bypass`](Self::set_bypass)
    /// asked for it), INT_ENABLE); then three burst reads comparing them
    /// ([`Error::ConfigMismatch`]). The gyro bias is kept (rescaled if the gyro
    /// range changes). An invalid `config` fails before any bus traffic.
    ///
    /// ```
    /// use embedded_hal_mock::eh1::delay::NoopDelay;
    /// use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
    /// use mpu9250::{Address, Config, Mpu9250, Variant};
    /// let a = 0x68;
    /// let mut i2c = Mock::new(&[
    ///     T::write_read(a, vec![0x75], vec![0x71]),          // WHO_AM_I
    ///     T::write(a, vec![0x6B, 0x80]),                     // H_RESET
    ///     T::write_read(a, vec![0x6B], vec![0x01]),          // reset done
    ///     T::write(a, vec![0x6B, 0x01]),                     // CLKSEL = PLL
    ///     T::write(a, vec![0x6C, 0x00]),                     // accel + gyro on
    ///     T::write(a, vec![0x6A, 0x00]),                     // USER_CTRL
    ///     T::write(a, vec![0x19, 0x00]),                     // SMPLRT_DIV
    ///     T::write(a, vec![0x1A, 0x03]),                     // gyro DLPF 41 Hz
    ///     T::write(a, vec![0x1B, 0x10]),                     // ±1000 °/s
    ///     T::write(a, vec![0x1C, 0x08]),                     // ±4 g
    ///     T::write(a, vec![0x1D, 0x03]),                     // accel DLPF 44.8 Hz
    ///     T::write(a, vec![0x37, 0x00]),                     // INT pin
    ///     T::write(a, vec![0x38, 0x01]),                     // data-ready INT
    ///     T::write_read(a, vec![0x19], vec![0x00, 0x03, 0x10, 0x08, 0x03]),
    ///     T::write_read(a, vec![0x37], vec![0x00, 0x01]),
    ///     T::write_read(a, vec![0x6A], vec![0x00, 0x01, 0x00]),
    /// ]);
    /// let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    /// assert_eq!(imu.init(&mut NoopDelay::new(), &Config::default()), Ok(Variant::Mpu9250));
    /// i2c.done();
    /// ```
    pub async fn init<D: DelayNs>(
        &mut self,
        delay: &mut D,
        config: &Config,
    ) -> Result<Variant, Error<E>> {
        let variant = self.start_reset(config).await?;
        self.wait_reset(delay).await?;
        self.write_config().await?;
        self.finish_init().await?;
        Ok(variant)
    }

    /// [`init`](Self::init) in steps that never wait, for a caller that
    /// must not block (re-initialising in flight): step 1 validates and
    /// adopts `config`, reads WHO_AM_I and writes H_RESET. Then call
    /// [`reset_done`](Self::reset_done) until it says `true` (the chip
    /// takes ~1 ms; poll at most for 200 ms), then
    /// [`write_config`](Self::write_config), then
    /// [`finish_init`](Self::finish_init). Until that succeeds the driver
    /// counts as not initialised.
    pub async fn start_reset(&mut self, config: &Config) -> Result<Variant, Error<E>> {
        config.validate()?;
        self.initialized = false;
        // Keep the bias meaning the same physical rate under the new range.
        self.gyro_bias =
            rescale_gyro_bias(self.gyro_bias, self.config.gyro_range, config.gyro_range);
        self.config = *config;
        self.scale = Scale::from_config(config);

        let variant = self.who_am_i().await?;
        self.variant = Some(variant);
        self.write_reg(reg::PWR_MGMT_1, reg::PWR_MGMT_1_H_RESET)
            .await?;
        Ok(variant)
    }

    /// One PWR_MGMT_1 poll after [`start_reset`](Self::start_reset):
    /// `true` once H_RESET cleared. A bus error (the chip may NACK while it
    /// reboots) reads as "not yet".
    pub async fn reset_done(&mut self) -> bool {
        let r = self.read_reg(reg::PWR_MGMT_1).await;
        r.is_ok_and(|v| v & reg::PWR_MGMT_1_H_RESET == 0)
    }

    /// Writes every configuration register as [`init`](Self::init) does
    /// after the reset (no read-back: [`finish_init`](Self::finish_init)).
    pub async fn write_config(&mut self) -> Result<(), Error<E>> {
        for (register, value) in self.register_values() {
            self.write_reg(register, value).await?;
        }
        if self.fifo_on() {
            self.write_reg(reg::FIFO_EN, reg::FIFO_EN_SAMPLE).await?;
        }
        #[cfg(feature = "master")]
        for (register, value) in self.master_values().into_iter().flatten() {
            self.write_reg(register, value).await?;
        }
        Ok(())
    }

    /// Reads the configuration back after [`write_config`](Self::write_config);
    /// on success the driver is initialised.
    pub async fn finish_init(&mut self) -> Result<(), Error<E>> {
        self.check_registers().await?;
        self.initialized = true;
        Ok(())
    }

    async fn wait_reset<D: DelayNs>(&mut self, delay: &mut D) -> Result<(), Error<E>> {
        for _ in 0..RESET_MAX_POLLS {
            delay.delay_ms(RESET_POLL_INTERVAL_MS).await;
            if self.reset_done().await {
                return Ok(());
            }
        }
        Err(Error::ResetTimeout)
    }

    /// Read every configuration register back and compare it with what
    /// [`init`](Self::init) wrote (and later [`set_bypass`](Self::set_bypass) /
    /// [`set_interrupts`](Self::set_interrupts) changed). Call it periodically
    /// to detect a chip that reset itself in flight; on
    /// [`Error::ConfigMismatch`] re-run `init`.
    pub async fn verify_config(&mut self) -> Result<(), Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        self.check_registers().await
    }

    /// [`Config::register_values`] with the transport's and the driver's
    /// own bits: USER_CTRL I2C_IF_DIS on SPI, FIFO_EN and CONFIG FIFO_MODE
    /// with the FIFO on.
    fn register_values(&self) -> [(u8, u8); 10] {
        let mut values = self.config.register_values(self.bypass);
        for (register, value) in values.iter_mut() {
            if *register == reg::USER_CTRL {
                *value |= self.user_ctrl();
            } else if *register == reg::CONFIG && self.fifo_on() {
                *value |= reg::CONFIG_FIFO_MODE;
            }
        }
        values
    }

    /// USER_CTRL bits this driver keeps set besides the configuration's.
    fn user_ctrl(&self) -> u8 {
        let mut bits = 0;
        if DI::SPI {
            bits |= reg::USER_CTRL_I2C_IF_DIS;
        }
        if self.fifo_on() {
            bits |= reg::USER_CTRL_FIFO_EN;
        }
        if self.master_on() {
            bits |= reg::USER_CTRL_I2C_MST_EN;
        }
        bits
    }

    async fn check_registers(&mut self) -> Result<(), Error<E>> {
        let expected = self.register_values();
        let mut a = [0u8; 5];
        self.read_regs(reg::SMPLRT_DIV, &mut a).await?;
        compare(reg::SMPLRT_DIV, &a, &expected)?;
        let mut b = [0u8; 2];
        self.read_regs(reg::INT_PIN_CFG, &mut b).await?;
        compare(reg::INT_PIN_CFG, &b, &expected)?;
        let mut c = [0u8; 3];
        self.read_regs(reg::USER_CTRL, &mut c).await?;
        compare(reg::USER_CTRL, &c, &expected)?;
        if self.fifo_on() {
            let found = self.read_reg(reg::FIFO_EN).await?;
            compare(
                reg::FIFO_EN,
                &[found],
                &[(reg::FIFO_EN, reg::FIFO_EN_SAMPLE)],
            )?;
        }
        Ok(())
    }

    /// Write one configuration register and read it back.
    #[cfg(any(feature = "fifo", feature = "master"))]
    async fn write_verified(&mut self, register: u8, value: u8) -> Result<(), Error<E>> {
        self.write_reg(register, value).await?;
        let found = self.read_reg(register).await?;
        compare(register, &[found], &[(register, value)])
    }

    /// Adopt `config` after writing and verifying the one register it
    /// changes. A bus error on the write keeps the previous configuration; a
    /// read-back mismatch is reported with the new configuration adopted (the
    /// chip may run it), so [`verify_config`](Self::verify_config) keeps
    /// reporting it until a re-`init`.
    async fn set_one(&mut self, config: Config, register: u8) -> Result<(), Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        config.validate()?;
        let previous = self.config;
        self.config = config;
        let value = self
            .register_values()
            .iter()
            .find(|(r, _)| *r == register)
            .map_or(0, |&(_, v)| v);
        self.config = previous;
        self.write_reg(register, value).await?;
        self.gyro_bias =
            rescale_gyro_bias(self.gyro_bias, self.config.gyro_range, config.gyro_range);
        self.config = config;
        self.scale = Scale::from_config(&config);
        let found = self.read_reg(register).await?;
        compare(register, &[found], &[(register, value)])
    }

    /// Change the accelerometer range: writes and verifies ACCEL_CONFIG only.
    pub async fn set_accel_range(&mut self, range: AccelRange) -> Result<(), Error<E>> {
        self.set_one(self.config.accel_range(range), reg::ACCEL_CONFIG)
            .await
    }

    /// Change the gyroscope range: writes and verifies GYRO_CONFIG only; the
    /// gyro bias is rescaled to keep its meaning in °/s.
    pub async fn set_gyro_range(&mut self, range: GyroRange) -> Result<(), Error<E>> {
        self.set_one(self.config.gyro_range(range), reg::GYRO_CONFIG)
            .await
    }

    /// Change the gyroscope/temperature DLPF: writes and verifies CONFIG only.
    /// A bandwidth at which a non-zero divider would be ignored is refused
    /// before any bus traffic ([`ConfigError::DividerIgnored`]).
    pub async fn set_gyro_bandwidth(&mut self, bandwidth: GyroBandwidth) -> Result<(), Error<E>> {
        self.set_one(self.config.gyro_bandwidth(bandwidth), reg::CONFIG)
            .await
    }

    /// Change the accelerometer DLPF: writes and verifies ACCEL_CONFIG2 only.
    pub async fn set_accel_bandwidth(&mut self, bandwidth: AccelBandwidth) -> Result<(), Error<E>> {
        self.set_one(self.config.accel_bandwidth(bandwidth), reg::ACCEL_CONFIG2)
            .await
    }

    /// Change SMPLRT_DIV (output rate 1 kHz / (1 + divider)): writes and
    /// verifies SMPLRT_DIV only.
    pub async fn set_sample_rate_divider(&mut self, divider: u8) -> Result<(), Error<E>> {
        self.set_one(self.config.sample_rate_divider(divider), reg::SMPLRT_DIV)
            .await
    }

    /// Turn the FIFO on or off. On: every sample (accel, temperature, gyro:
    /// the 14 bytes of [`read_raw`](Self::read_raw), in the same order) is
    /// queued; CONFIG FIFO_MODE makes a full FIFO drop new samples rather
    /// than overwrite old ones, so the queue never holds a torn sample.
    /// The FIFO is emptied, then CONFIG, FIFO_EN and USER_CTRL are written
    /// and verified. The state survives `init`. Read with
    /// [`read_fifo`](Self::read_fifo).
    #[cfg(feature = "fifo")]
    pub async fn set_fifo(&mut self, enable: bool) -> Result<(), Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        // Stop recording and empty the queue first so that no partial
        // sample is left at the head.
        self.write_reg(reg::FIFO_EN, 0).await?;
        self.write_reg(
            reg::USER_CTRL,
            self.user_ctrl() & !reg::USER_CTRL_FIFO_EN | reg::USER_CTRL_FIFO_RST,
        )
        .await?;
        self.fifo = enable;
        let config = self
            .register_values()
            .iter()
            .find(|(r, _)| *r == reg::CONFIG)
            .map_or(0, |&(_, v)| v);
        self.write_verified(reg::CONFIG, config).await?;
        if enable {
            self.write_verified(reg::USER_CTRL, self.user_ctrl())
                .await?;
            self.write_verified(reg::FIFO_EN, reg::FIFO_EN_SAMPLE).await
        } else {
            self.write_verified(reg::USER_CTRL, self.user_ctrl()).await
        }
    }

    /// Bytes queued in the FIFO (FIFO_COUNTH/L).
    #[cfg(feature = "fifo")]
    pub async fn fifo_count(&mut self) -> Result<u16, Error<E>> {
        let mut b = [0u8; 2];
        self.read_regs(reg::FIFO_COUNTH, &mut b).await?;
        Ok(u16::from_be_bytes([b[0] & reg::FIFO_COUNTH_MASK, b[1]]))
    }

    /// Empty the FIFO (FIFO recording paused, FIFO_RST, recording resumed).
    #[cfg(feature = "fifo")]
    pub async fn reset_fifo(&mut self) -> Result<(), Error<E>> {
        self.write_reg(reg::FIFO_EN, 0).await?;
        self.write_reg(reg::USER_CTRL, self.user_ctrl() | reg::USER_CTRL_FIFO_RST)
            .await?;
        self.write_reg(reg::FIFO_EN, reg::FIFO_EN_SAMPLE).await
    }

    /// Pop whole samples from the FIFO into `out` (oldest first; counts, MPU
    /// frame, no bias removed), in bursts of whole samples. Returns how many
    /// were stored; samples beyond `out.len()` stay queued.
    ///
    /// A FIFO that cannot take one more sample counts as overflowed (samples
    /// were or are about to be dropped, as PX4 treats it), and a byte count
    /// that is not a whole number of samples means the queue is torn: both
    /// empty the FIFO and return [`Error::FifoOverflow`] /
    /// [`Error::FifoMisaligned`], so a host that missed its deadline always
    /// learns that samples were lost.
    #[cfg(feature = "fifo")]
    pub async fn read_fifo(&mut self, out: &mut [RawSample]) -> Result<usize, Error<E>> {
        if !self.fifo {
            return Err(Error::FifoDisabled);
        }
        let count_bytes = self.fifo_count().await?;
        let sample_len = reg::SAMPLE_LEN as u16;
        if count_bytes > reg::FIFO_SIZE - sample_len {
            self.reset_fifo().await?;
            return Err(Error::FifoOverflow { count_bytes });
        }
        if count_bytes % sample_len != 0 {
            self.reset_fifo().await?;
            return Err(Error::FifoMisaligned { count_bytes });
        }
        let wanted = usize::from(count_bytes / sample_len).min(out.len());
        let mut buf = [0u8; FIFO_BURST_SAMPLES * reg::SAMPLE_LEN];
        let mut stored = 0;
        while stored < wanted {
            let n = (wanted - stored).min(FIFO_BURST_SAMPLES);
            let Some(bytes) = buf.get_mut(..n * reg::SAMPLE_LEN) else {
                break;
            };
            // A bus error here loses the popped bytes and may leave a torn
            // sample at the head; the next call sees the count misaligned.
            self.read_regs(reg::FIFO_R_W, bytes).await?;
            for (slot, sample) in out
                .iter_mut()
                .skip(stored)
                .zip(bytes.chunks_exact(reg::SAMPLE_LEN))
            {
                if let Ok(sample) = <&[u8; reg::SAMPLE_LEN]>::try_from(sample) {
                    *slot = parse_sample(sample);
                }
            }
            stored += n;
        }
        Ok(stored)
    }

    /// Read the 14-byte ACCEL_XOUT_H..GYRO_ZOUT_L block in one burst: counts,
    /// no bias removed, MPU sensor frame.
    pub async fn read_raw(&mut self) -> Result<RawSample, Error<E>> {
        let mut buf = [0u8; reg::SAMPLE_LEN];
        self.read_regs(reg::ACCEL_XOUT_H, &mut buf).await?;
        Ok(parse_sample(&buf))
    }

    /// Read one sample, remove the gyro bias and convert with the configured
    /// scale (g, °/s, °C; MPU sensor frame).
    ///
    /// ```
    /// use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
    /// use mpu9250::{Address, Mpu9250};
    /// # use embedded_hal_mock::eh1::delay::NoopDelay;
    /// # let a = 0x68;
    /// # let mut init = vec![
    /// #     T::write_read(a, vec![0x75], vec![0x71]), T::write(a, vec![0x6B, 0x80]),
    /// #     T::write_read(a, vec![0x6B], vec![0x01]),
    /// # ];
    /// # for (r, v) in mpu9250::Config::default().register_values(false) { init.push(T::write(a, vec![r, v])); }
    /// # init.push(T::write_read(a, vec![0x19], vec![0x00, 0x03, 0x10, 0x08, 0x03]));
    /// # init.push(T::write_read(a, vec![0x37], vec![0x00, 0x01]));
    /// # init.push(T::write_read(a, vec![0x6A], vec![0x00, 0x01, 0x00]));
    /// // Face up at rest, ±4 g / ±1000 °/s: z = 8192 counts = 1 g, gyro x = 328 counts = 10 °/s.
    /// init.push(T::write_read(a, vec![0x3B], vec![0, 0, 0, 0, 0x20, 0x00, 0, 0, 0x01, 0x48, 0, 0, 0, 0]));
    /// let mut i2c = Mock::new(&init);
    /// let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    /// imu.init(&mut NoopDelay::new(), &Default::default())?;
    /// let s = imu.read()?;
    /// assert_eq!(s.accel_g, [0.0, 0.0, 1.0]);
    /// assert!((s.gyro_dps[0] - 10.0).abs() < 1e-4);
    /// assert_eq!(s.temp_c, 21.0);
    /// i2c.done();
    /// # Ok::<(), mpu9250::Error<embedded_hal::i2c::ErrorKind>>(())
    /// ```
    pub async fn read(&mut self) -> Result<Sample, Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        let raw = self.read_raw().await?;
        Ok(convert(&apply_gyro_bias(raw, self.gyro_bias), &self.scale))
    }

    /// Read one sample with the gyro bias removed, still in counts (for an
    /// integer pipeline; see [`GyroRange::lsb_per_dps_x10`](crate::GyroRange::lsb_per_dps_x10)).
    pub async fn read_raw_unbiased(&mut self) -> Result<RawSample, Error<E>> {
        let raw = self.read_raw().await?;
        Ok(apply_gyro_bias(raw, self.gyro_bias))
    }

    /// Average `n_samples` gyro samples at rest and store the mean as the gyro
    /// bias, with the default motion limits of [`BiasCalibration::new`].
    pub async fn calibrate_gyro_bias<D: DelayNs>(
        &mut self,
        delay: &mut D,
        n_samples: u16,
    ) -> Result<[i16; 3], Error<E>> {
        self.calibrate_gyro_bias_with(delay, &BiasCalibration::new(n_samples))
            .await
    }

    /// Average `settings.samples` raw gyro samples, one per sample period
    /// (waiting [`Config::sample_period_us`] before each read), and store the
    /// rounded mean as the bias. Fails with [`Error::Moved`] (bias unchanged)
    /// when any gyro axis' max − min exceeds the limit or any sample's
    /// accelerometer magnitude is outside 1 g ± the tolerance.
    pub async fn calibrate_gyro_bias_with<D: DelayNs>(
        &mut self,
        delay: &mut D,
        settings: &BiasCalibration,
    ) -> Result<[i16; 3], Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        let n = settings.samples;
        if n == 0 {
            return Err(Error::InvalidConfig(ConfigError::NoSamples));
        }
        let lsb_per_g = f32::from(self.config.accel_range.lsb_per_g());
        let lo = (1.0 - settings.accel_tolerance_g) * lsb_per_g;
        let hi = (1.0 + settings.accel_tolerance_g) * lsb_per_g;
        // f32 -> i64 casts saturate; squares of |x| <= 2^17 fit easily.
        let lo_sq = if lo > 0.0 { (lo * lo) as i64 } else { 0 };
        let hi_sq = (hi * hi) as i64;
        let limit_counts =
            (settings.max_gyro_peak_to_peak_dps * self.config.gyro_range.lsb_per_dps()) as u16;
        let period_us = self.config.sample_period_us();

        let mut sum = [0i64; 3];
        let mut min = [i16::MAX; 3];
        let mut max = [i16::MIN; 3];
        for _ in 0..n {
            delay.delay_us(period_us).await;
            let raw = self.read_raw().await?;
            let mag_sq: i64 = raw.accel.iter().map(|&c| i64::from(c) * i64::from(c)).sum();
            if mag_sq < lo_sq || mag_sq > hi_sq {
                let mag = u64::try_from(mag_sq).unwrap_or(0).isqrt();
                let mg = mag.saturating_mul(1000) / u64::from(self.config.accel_range.lsb_per_g());
                return Err(Error::Moved(Motion::AccelMagnitude {
                    magnitude_mg: u16::try_from(mg).unwrap_or(u16::MAX),
                }));
            }
            for (i, &g) in raw.gyro.iter().enumerate() {
                if let (Some(s), Some(lo), Some(hi)) =
                    (sum.get_mut(i), min.get_mut(i), max.get_mut(i))
                {
                    *s += i64::from(g);
                    *lo = (*lo).min(g);
                    *hi = (*hi).max(g);
                }
            }
        }
        for axis in 0..3u8 {
            let i = usize::from(axis);
            let (lo, hi) = (
                min.get(i).copied().unwrap_or(0),
                max.get(i).copied().unwrap_or(0),
            );
            let p2p = u16::try_from(i32::from(hi) - i32::from(lo)).unwrap_or(u16::MAX);
            if p2p > limit_counts {
                return Err(Error::Moved(Motion::GyroSpread {
                    axis,
                    peak_to_peak_counts: p2p,
                    limit_counts,
                }));
            }
        }
        let n = i64::from(n);
        let mean = |s: i64| -> i16 {
            // Nearest integer, ties towards +inf: floor((2s + n) / 2n).
            let m = (2 * s + n).div_euclid(2 * n);
            i16::try_from(m).unwrap_or(if m < 0 { i16::MIN } else { i16::MAX })
        };
        let bias = [mean(sum[0]), mean(sum[1]), mean(sum[2])];
        self.gyro_bias = bias;
        Ok(bias)
    }

    /// Factory self-test (MPU-9250 self-test application note,
    /// AN-MPU-9250A-03): at ±250 °/s / ±2 g, 1 kHz, DLPF 92 Hz / 99 Hz,
    /// average [`SELF_TEST_SAMPLES`] samples with the self-test off and again
    /// with it on (after [`SELF_TEST_SETTLE_MS`]); the difference on each
    /// axis is the self-test response, compared with the factory trim
    /// `2620 × 1.01^(code − 1)` LSB from SELF_TEST_X/Y/Z_GYRO/ACCEL. Passes when
    /// every gyro response is above half its trim (at least 60 °/s when the
    /// code is 0) and the gyro offset is within 20 °/s, and every accel
    /// response is within 0.5..1.5 of its trim (225..675 mg when the code is
    /// 0); otherwise [`Error::SelfTestFailed`] names the first failing check
    /// (the numbers: [`self_test_report`](Self::self_test_report)). Keep the
    /// board still while it runs (about 0.5 s).
    pub async fn self_test<D: DelayNs>(&mut self, delay: &mut D) -> Result<SelfTest, Error<E>> {
        let report = self.self_test_report(delay).await?;
        match report.first_failure() {
            None => Ok(report),
            Some((check, axis)) => Err(Error::SelfTestFailed { check, axis }),
        }
    }

    /// The self-test measurements of [`self_test`](Self::self_test) without
    /// the verdict. Afterwards the configuration registers are rewritten from
    /// the driver's configuration and read back, also after a bus error
    /// mid-way (the first error is returned).
    pub async fn self_test_report<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<SelfTest, Error<E>> {
        if !self.initialized {
            return Err(Error::NotInitialized);
        }
        let measured = self.self_test_measure(delay).await;
        let mut restored = Ok(());
        for (register, value) in self.register_values() {
            if let Err(e) = self.write_reg(register, value).await {
                restored = Err(e);
            }
        }
        if restored.is_ok() {
            restored = self.check_registers().await;
        }
        let report = measured?;
        restored?;
        Ok(report)
    }

    async fn self_test_measure<D: DelayNs>(&mut self, delay: &mut D) -> Result<SelfTest, Error<E>> {
        for (register, value) in SELF_TEST_SETUP {
            self.write_reg(register, value).await?;
        }
        delay.delay_ms(SELF_TEST_SETTLE_MS).await;
        let (gyro_os, accel_os) = self.self_test_average(delay).await?;
        self.write_reg(reg::GYRO_CONFIG, reg::SELF_TEST_XYZ).await?;
        self.write_reg(reg::ACCEL_CONFIG, reg::SELF_TEST_XYZ)
            .await?;
        delay.delay_ms(SELF_TEST_SETTLE_MS).await;
        let (gyro_st, accel_st) = self.self_test_average(delay).await?;
        self.write_reg(reg::GYRO_CONFIG, 0).await?;
        self.write_reg(reg::ACCEL_CONFIG, 0).await?;
        delay.delay_ms(SELF_TEST_SETTLE_MS).await;
        let mut gyro_code = [0u8; 3];
        self.read_regs(reg::SELF_TEST_X_GYRO, &mut gyro_code)
            .await?;
        let mut accel_code = [0u8; 3];
        self.read_regs(reg::SELF_TEST_X_ACCEL, &mut accel_code)
            .await?;
        Ok(SelfTest {
            gyro_offset_lsb: gyro_os,
            gyro_response_lsb: sub3(gyro_st, gyro_os),
            accel_response_lsb: sub3(accel_st, accel_os),
            gyro_factory_lsb: gyro_code.map(factory_trim_lsb),
            accel_factory_lsb: accel_code.map(factory_trim_lsb),
        })
    }

    /// Mean gyro and accel counts over [`SELF_TEST_SAMPLES`] samples, 1 ms apart.
    async fn self_test_average<D: DelayNs>(
        &mut self,
        delay: &mut D,
    ) -> Result<([i32; 3], [i32; 3]), Error<E>> {
        let mut gyro = [0i32; 3];
        let mut accel = [0i32; 3];
        for _ in 0..SELF_TEST_SAMPLES {
            delay.delay_ms(1).await;
            let raw = self.read_raw().await?;
            for (sum, v) in gyro.iter_mut().zip(raw.gyro) {
                *sum += i32::from(v);
            }
            for (sum, v) in accel.iter_mut().zip(raw.accel) {
                *sum += i32::from(v);
            }
        }
        let n = i32::from(SELF_TEST_SAMPLES);
        Ok((gyro.map(|s| s / n), accel.map(|s| s / n)))
    }

    /// Write the interrupt configuration (INT_PIN_CFG, keeping BYPASS_EN as
    /// set; then INT_ENABLE). It is kept for later `init`/`verify_config`.
    pub async fn set_interrupts(&mut self, interrupt: InterruptConfig) -> Result<(), Error<E>> {
        self.config.interrupt = interrupt;
        self.write_reg(reg::INT_PIN_CFG, interrupt.int_pin_cfg(self.bypass))
            .await?;
        self.write_reg(reg::INT_ENABLE, interrupt.int_enable_bits())
            .await
    }

    /// Read INT_STATUS (this clears the latched flags and, with
    /// [`IntClear::OnStatusRead`](crate::IntClear::OnStatusRead), the INT pin).
    pub async fn read_int_status(&mut self) -> Result<IntStatus, Error<E>> {
        Ok(IntStatus(self.read_reg(reg::INT_STATUS).await?))
    }

    /// Whether a new sample is ready (reads INT_STATUS, see [`read_int_status`](Self::read_int_status)).
    pub async fn data_ready(&mut self) -> Result<bool, Error<E>> {
        Ok(self.read_int_status().await?.data_ready())
    }

    /// Enable or disable I2C bypass so the host reaches the AK8963 (0x0C) directly.
    ///
    /// Enabling writes USER_CTRL = 0 (I2C_MST_EN cleared: the bypass and the
    /// internal I2C master exclude each other) and then INT_PIN_CFG with
    /// BYPASS_EN plus the interrupt bits of the current configuration;
    /// disabling writes INT_PIN_CFG without BYPASS_EN. The state survives
    /// `init`. On SPI the bypass would connect the AK8963 to pins that carry
    /// SPI: [`Error::BypassOnSpi`], nothing written.
    pub async fn set_bypass(&mut self, enable: bool) -> Result<(), Error<E>> {
        if enable && DI::SPI {
            return Err(Error::BypassOnSpi);
        }
        if enable && self.master_on() {
            return Err(Error::MasterWithBypass);
        }
        self.bypass = enable;
        if enable {
            self.write_reg(reg::USER_CTRL, self.user_ctrl()).await?;
        }
        self.write_reg(reg::INT_PIN_CFG, self.config.interrupt.int_pin_cfg(enable))
            .await
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

/// The chip a WHO_AM_I value names.
fn classify<E>(id: u8) -> Result<Variant, Error<E>> {
    match id {
        reg::WHO_AM_I_MPU9250 => Ok(Variant::Mpu9250),
        reg::WHO_AM_I_MPU9255 => Ok(Variant::Mpu9255),
        reg::WHO_AM_I_MPU6500 => Err(Error::Mpu6500Detected),
        other => Err(Error::WrongChipId(other)),
    }
}

/// Compare a burst read starting at `start` with the expected `(register, value)` pairs it covers.
fn compare<E>(start: u8, read: &[u8], expected: &[(u8, u8)]) -> Result<(), Error<E>> {
    for (i, &found) in read.iter().enumerate() {
        let register = start.wrapping_add(i as u8);
        if let Some(&(_, value)) = expected.iter().find(|(r, _)| *r == register) {
            if value != found {
                return Err(Error::ConfigMismatch {
                    register,
                    expected: value,
                    found,
                });
            }
        }
    }
    Ok(())
}
