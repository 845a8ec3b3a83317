//! Typed configuration: ranges, digital low-pass filters, sample-rate divider, interrupt pin.

use crate::register as reg;

/// I2C address of the MPU-9250, selected by the AD0 pin.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Address {
    /// AD0 tied low: 0x68.
    #[default]
    Ad0Low,
    /// AD0 tied high: 0x69.
    Ad0High,
}

impl Address {
    /// The 7-bit bus address.
    pub const fn addr(self) -> u8 {
        match self {
            Address::Ad0Low => 0x68,
            Address::Ad0High => 0x69,
        }
    }
}

/// Which chip answered WHO_AM_I.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Variant {
    /// MPU-9250 (WHO_AM_I = 0x71).
    Mpu9250,
    /// MPU-9255 (WHO_AM_I = 0x73), register compatible.
    Mpu9255,
}

/// Gyroscope full-scale range (GYRO_CONFIG GYRO_FS_SEL).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroRange {
    /// ±250 °/s, 131 LSB/(°/s).
    Dps250,
    /// ±500 °/s, 65.5 LSB/(°/s).
    Dps500,
    /// ±1000 °/s, 32.8 LSB/(°/s).
    #[default]
    Dps1000,
    /// ±2000 °/s, 16.4 LSB/(°/s).
    Dps2000,
}

impl GyroRange {
    /// GYRO_FS_SEL field value (0..=3).
    pub const fn fs_sel(self) -> u8 {
        match self {
            GyroRange::Dps250 => 0,
            GyroRange::Dps500 => 1,
            GyroRange::Dps1000 => 2,
            GyroRange::Dps2000 => 3,
        }
    }

    /// Full-scale value in °/s. `counts * full_scale_dps / 32768` is the exact
    /// (nominal) rate, which a fixed-point pipeline can use without f32.
    pub const fn full_scale_dps(self) -> u16 {
        match self {
            GyroRange::Dps250 => 250,
            GyroRange::Dps500 => 500,
            GyroRange::Dps1000 => 1000,
            GyroRange::Dps2000 => 2000,
        }
    }

    /// Sensitivity scale factor from the datasheet (table 1), LSB per °/s.
    pub const fn lsb_per_dps(self) -> f32 {
        match self {
            GyroRange::Dps250 => 131.0,
            GyroRange::Dps500 => 65.5,
            GyroRange::Dps1000 => 32.8,
            GyroRange::Dps2000 => 16.4,
        }
    }

    /// Sensitivity ×10 as an integer (1310, 655, 328, 164 LSB per 10 °/s),
    /// for integer pipelines that want the datasheet factor exactly.
    pub const fn lsb_per_dps_x10(self) -> u16 {
        match self {
            GyroRange::Dps250 => 1310,
            GyroRange::Dps500 => 655,
            GyroRange::Dps1000 => 328,
            GyroRange::Dps2000 => 164,
        }
    }

    /// °/s per LSB (reciprocal of [`lsb_per_dps`](Self::lsb_per_dps)).
    pub const fn dps_per_lsb(self) -> f32 {
        1.0 / self.lsb_per_dps()
    }

    /// GYRO_CONFIG register value for this range with FCHOICE_B = 0b00 (DLPF table in use).
    pub const fn gyro_config_bits(self) -> u8 {
        self.fs_sel() << reg::GYRO_CONFIG_FS_SEL_SHIFT
    }
}

/// Accelerometer full-scale range (ACCEL_CONFIG ACCEL_FS_SEL).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelRange {
    /// ±2 g, 16384 LSB/g.
    G2,
    /// ±4 g, 8192 LSB/g.
    #[default]
    G4,
    /// ±8 g, 4096 LSB/g.
    G8,
    /// ±16 g, 2048 LSB/g.
    G16,
}

impl AccelRange {
    /// ACCEL_FS_SEL field value (0..=3).
    pub const fn fs_sel(self) -> u8 {
        match self {
            AccelRange::G2 => 0,
            AccelRange::G4 => 1,
            AccelRange::G8 => 2,
            AccelRange::G16 => 3,
        }
    }

    /// Full-scale value in g.
    pub const fn full_scale_g(self) -> u8 {
        match self {
            AccelRange::G2 => 2,
            AccelRange::G4 => 4,
            AccelRange::G8 => 8,
            AccelRange::G16 => 16,
        }
    }

    /// Sensitivity scale factor, LSB per g (exact integer: 32768 / full scale).
    pub const fn lsb_per_g(self) -> u16 {
        match self {
            AccelRange::G2 => 16384,
            AccelRange::G4 => 8192,
            AccelRange::G8 => 4096,
            AccelRange::G16 => 2048,
        }
    }

    /// g per LSB.
    pub const fn g_per_lsb(self) -> f32 {
        1.0 / self.lsb_per_g() as f32
    }

    /// ACCEL_CONFIG register value for this range (self-test off).
    pub const fn accel_config_bits(self) -> u8 {
        self.fs_sel() << reg::ACCEL_CONFIG_FS_SEL_SHIFT
    }
}

/// Gyroscope (and temperature) digital low-pass filter, CONFIG DLPF_CFG with
/// GYRO_CONFIG FCHOICE_B = 0b00. Names follow the register map's 3-dB bandwidth
/// column (register map rev 1.6, CONFIG table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroBandwidth {
    /// DLPF_CFG 0: 250 Hz, delay 0.97 ms, internal rate 8 kHz (divider not applied).
    Hz250,
    /// DLPF_CFG 1: 184 Hz, delay 2.9 ms, 1 kHz.
    Hz184,
    /// DLPF_CFG 2: 92 Hz, delay 3.9 ms, 1 kHz.
    Hz92,
    /// DLPF_CFG 3: 41 Hz, delay 5.9 ms, 1 kHz.
    #[default]
    Hz41,
    /// DLPF_CFG 4: 20 Hz, delay 9.9 ms, 1 kHz.
    Hz20,
    /// DLPF_CFG 5: 10 Hz, delay 17.85 ms, 1 kHz.
    Hz10,
    /// DLPF_CFG 6: 5 Hz, delay 33.48 ms, 1 kHz.
    Hz5,
    /// DLPF_CFG 7: 3600 Hz, delay 0.17 ms, internal rate 8 kHz (divider not applied).
    Hz3600,
}

impl GyroBandwidth {
    /// DLPF_CFG value (0..=7), also the CONFIG register value (FIFO_MODE and EXT_SYNC_SET 0).
    pub const fn dlpf_cfg(self) -> u8 {
        match self {
            GyroBandwidth::Hz250 => 0,
            GyroBandwidth::Hz184 => 1,
            GyroBandwidth::Hz92 => 2,
            GyroBandwidth::Hz41 => 3,
            GyroBandwidth::Hz20 => 4,
            GyroBandwidth::Hz10 => 5,
            GyroBandwidth::Hz5 => 6,
            GyroBandwidth::Hz3600 => 7,
        }
    }

    /// 3-dB bandwidth in Hz.
    pub const fn bandwidth_hz(self) -> f32 {
        match self {
            GyroBandwidth::Hz250 => 250.0,
            GyroBandwidth::Hz184 => 184.0,
            GyroBandwidth::Hz92 => 92.0,
            GyroBandwidth::Hz41 => 41.0,
            GyroBandwidth::Hz20 => 20.0,
            GyroBandwidth::Hz10 => 10.0,
            GyroBandwidth::Hz5 => 5.0,
            GyroBandwidth::Hz3600 => 3600.0,
        }
    }

    /// Internal sample rate in Hz before SMPLRT_DIV (8 kHz for DLPF_CFG 0 and 7, else 1 kHz).
    pub const fn internal_rate_hz(self) -> u32 {
        match self {
            GyroBandwidth::Hz250 | GyroBandwidth::Hz3600 => 8000,
            _ => 1000,
        }
    }

    /// Whether SMPLRT_DIV is applied at this setting (0 < DLPF_CFG < 7).
    pub const fn divider_applies(self) -> bool {
        !matches!(self, GyroBandwidth::Hz250 | GyroBandwidth::Hz3600)
    }
}

/// Accelerometer digital low-pass filter, ACCEL_CONFIG2 (ACCEL_FCHOICE_B, A_DLPF_CFG).
/// Names follow the register map's 3-dB bandwidth column (rev 1.6, ACCEL_CONFIG 2 table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelBandwidth {
    /// A_DLPF_CFG 1 (0 is identical): 218.1 Hz, delay 1.88 ms, 1 kHz.
    Hz218_1,
    /// A_DLPF_CFG 2: 99 Hz, delay 2.88 ms, 1 kHz.
    Hz99,
    /// A_DLPF_CFG 3: 44.8 Hz, delay 4.88 ms, 1 kHz.
    #[default]
    Hz44_8,
    /// A_DLPF_CFG 4: 21.2 Hz, delay 8.87 ms, 1 kHz.
    Hz21_2,
    /// A_DLPF_CFG 5: 10.2 Hz, delay 16.83 ms, 1 kHz.
    Hz10_2,
    /// A_DLPF_CFG 6: 5.05 Hz, delay 32.48 ms, 1 kHz.
    Hz5_05,
    /// A_DLPF_CFG 7: 420 Hz, delay 1.38 ms, 1 kHz.
    Hz420,
    /// ACCEL_FCHOICE_B = 1 (DLPF bypassed): 1046 Hz, delay 0.503 ms, 4 kHz.
    Hz1046Bypass,
}

impl AccelBandwidth {
    /// ACCEL_CONFIG2 register value (ACCEL_FCHOICE_B in bit 3, A_DLPF_CFG in bits 2:0).
    pub const fn accel_config2_bits(self) -> u8 {
        match self {
            AccelBandwidth::Hz218_1 => 1,
            AccelBandwidth::Hz99 => 2,
            AccelBandwidth::Hz44_8 => 3,
            AccelBandwidth::Hz21_2 => 4,
            AccelBandwidth::Hz10_2 => 5,
            AccelBandwidth::Hz5_05 => 6,
            AccelBandwidth::Hz420 => 7,
            AccelBandwidth::Hz1046Bypass => reg::ACCEL_CONFIG2_FCHOICE_B,
        }
    }

    /// 3-dB bandwidth in Hz.
    pub const fn bandwidth_hz(self) -> f32 {
        match self {
            AccelBandwidth::Hz218_1 => 218.1,
            AccelBandwidth::Hz99 => 99.0,
            AccelBandwidth::Hz44_8 => 44.8,
            AccelBandwidth::Hz21_2 => 21.2,
            AccelBandwidth::Hz10_2 => 10.2,
            AccelBandwidth::Hz5_05 => 5.05,
            AccelBandwidth::Hz420 => 420.0,
            AccelBandwidth::Hz1046Bypass => 1046.0,
        }
    }
}

/// INT pin active level (INT_PIN_CFG ACTL).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IntLevel {
    /// Active high (ACTL = 0).
    #[default]
    ActiveHigh,
    /// Active low (ACTL = 1).
    ActiveLow,
}

/// INT pin output driver (INT_PIN_CFG OPEN).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IntDrive {
    /// Push-pull (OPEN = 0).
    #[default]
    PushPull,
    /// Open drain (OPEN = 1).
    OpenDrain,
}

/// INT pin pulse shape (INT_PIN_CFG LATCH_INT_EN).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IntLatch {
    /// 50 µs pulse per event (LATCH_INT_EN = 0).
    #[default]
    Pulse50us,
    /// Held active until the interrupt is cleared (LATCH_INT_EN = 1).
    Latched,
}

/// How a latched interrupt is cleared (INT_PIN_CFG INT_ANYRD_2CLEAR).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IntClear {
    /// Only reading INT_STATUS clears it (INT_ANYRD_2CLEAR = 0).
    #[default]
    OnStatusRead,
    /// Any register read clears it (INT_ANYRD_2CLEAR = 1).
    OnAnyRead,
}

/// Interrupt pin and data-ready configuration (INT_PIN_CFG without BYPASS_EN, INT_ENABLE).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InterruptConfig {
    /// Active level.
    pub level: IntLevel,
    /// Output driver.
    pub drive: IntDrive,
    /// Pulse or latched.
    pub latch: IntLatch,
    /// How a latched interrupt is cleared.
    pub clear: IntClear,
    /// Raise INT when new raw data is ready (INT_ENABLE RAW_RDY_EN).
    pub data_ready: bool,
}

impl Default for InterruptConfig {
    fn default() -> Self {
        Self::new()
    }
}

impl InterruptConfig {
    /// Active high, push-pull, 50 µs pulse, cleared by reading INT_STATUS, data-ready enabled.
    pub const fn new() -> Self {
        Self {
            level: IntLevel::ActiveHigh,
            drive: IntDrive::PushPull,
            latch: IntLatch::Pulse50us,
            clear: IntClear::OnStatusRead,
            data_ready: true,
        }
    }

    /// All interrupts disabled (pin settings as [`new`](Self::new)).
    pub const fn disabled() -> Self {
        Self::new().data_ready(false)
    }

    /// Set the active level.
    #[must_use]
    pub const fn level(mut self, level: IntLevel) -> Self {
        self.level = level;
        self
    }

    /// Set the output driver.
    #[must_use]
    pub const fn drive(mut self, drive: IntDrive) -> Self {
        self.drive = drive;
        self
    }

    /// Set pulse or latched.
    #[must_use]
    pub const fn latch(mut self, latch: IntLatch) -> Self {
        self.latch = latch;
        self
    }

    /// Set how a latched interrupt is cleared.
    #[must_use]
    pub const fn clear(mut self, clear: IntClear) -> Self {
        self.clear = clear;
        self
    }

    /// Enable or disable the data-ready interrupt.
    #[must_use]
    pub const fn data_ready(mut self, enabled: bool) -> Self {
        self.data_ready = enabled;
        self
    }

    /// INT_PIN_CFG bits owned by this setting (BYPASS_EN excluded; see
    /// [`int_pin_cfg`](Self::int_pin_cfg)).
    pub const fn int_pin_cfg_bits(&self) -> u8 {
        let mut v = 0;
        if matches!(self.level, IntLevel::ActiveLow) {
            v |= reg::INT_PIN_CFG_ACTL;
        }
        if matches!(self.drive, IntDrive::OpenDrain) {
            v |= reg::INT_PIN_CFG_OPEN;
        }
        if matches!(self.latch, IntLatch::Latched) {
            v |= reg::INT_PIN_CFG_LATCH_INT_EN;
        }
        if matches!(self.clear, IntClear::OnAnyRead) {
            v |= reg::INT_PIN_CFG_INT_ANYRD_2CLEAR;
        }
        v
    }

    /// Full INT_PIN_CFG value: the interrupt bits plus BYPASS_EN when `bypass`.
    pub const fn int_pin_cfg(&self, bypass: bool) -> u8 {
        if bypass {
            self.int_pin_cfg_bits() | reg::INT_PIN_CFG_BYPASS_EN
        } else {
            self.int_pin_cfg_bits()
        }
    }

    /// INT_ENABLE register value.
    pub const fn int_enable_bits(&self) -> u8 {
        if self.data_ready {
            reg::INT_ENABLE_RAW_RDY_EN
        } else {
            0
        }
    }
}

/// A configuration the chip cannot honour as asked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// A non-zero sample-rate divider with gyro bandwidth 250 Hz or 3600 Hz: the
    /// chip runs at 8 kHz there and ignores SMPLRT_DIV.
    DividerIgnored,
    /// A zero sample count (or other zero-sized request) for gyro-bias calibration.
    NoSamples,
    /// A slave-0 read of 0 or more than 15 bytes, or more than the 24 bytes
    /// of EXT_SENS_DATA requested.
    SlaveReadLength,
}

/// Driver configuration, built with the `const` builder methods.
///
/// Defaults: ±4 g, ±1000 °/s, divider 0, gyro DLPF 41 Hz and accel DLPF 44.8 Hz
/// (both register value 3), 1 kHz output data rate, data-ready interrupt as
/// [`InterruptConfig::new`].
///
/// ```
/// use mpu9250::{AccelRange, Config, GyroBandwidth, GyroRange};
/// let config = Config::new()
///     .accel_range(AccelRange::G8)
///     .gyro_range(GyroRange::Dps2000)
///     .gyro_bandwidth(GyroBandwidth::Hz92)
///     .sample_rate_divider(1);
/// assert_eq!(config.output_data_rate_hz(), 500.0);
/// assert_eq!(config.sample_period_us(), 2000);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Accelerometer full scale.
    pub accel_range: AccelRange,
    /// Gyroscope full scale.
    pub gyro_range: GyroRange,
    /// Gyroscope/temperature DLPF.
    pub gyro_bandwidth: GyroBandwidth,
    /// Accelerometer DLPF.
    pub accel_bandwidth: AccelBandwidth,
    /// SMPLRT_DIV: output rate = 1 kHz / (1 + divider) when the gyro DLPF is 5..184 Hz.
    pub sample_rate_divider: u8,
    /// INT pin and data-ready interrupt.
    pub interrupt: InterruptConfig,
}

impl Default for Config {
    fn default() -> Self {
        Self::new()
    }
}

impl Config {
    /// The default configuration (see the type docs).
    pub const fn new() -> Self {
        Self {
            accel_range: AccelRange::G4,
            gyro_range: GyroRange::Dps1000,
            gyro_bandwidth: GyroBandwidth::Hz41,
            accel_bandwidth: AccelBandwidth::Hz44_8,
            sample_rate_divider: 0,
            interrupt: InterruptConfig::new(),
        }
    }

    /// Set the accelerometer range.
    #[must_use]
    pub const fn accel_range(mut self, range: AccelRange) -> Self {
        self.accel_range = range;
        self
    }

    /// Set the gyroscope range.
    #[must_use]
    pub const fn gyro_range(mut self, range: GyroRange) -> Self {
        self.gyro_range = range;
        self
    }

    /// Set the gyroscope DLPF.
    #[must_use]
    pub const fn gyro_bandwidth(mut self, bw: GyroBandwidth) -> Self {
        self.gyro_bandwidth = bw;
        self
    }

    /// Set the accelerometer DLPF.
    #[must_use]
    pub const fn accel_bandwidth(mut self, bw: AccelBandwidth) -> Self {
        self.accel_bandwidth = bw;
        self
    }

    /// Set SMPLRT_DIV.
    #[must_use]
    pub const fn sample_rate_divider(mut self, divider: u8) -> Self {
        self.sample_rate_divider = divider;
        self
    }

    /// Set the interrupt configuration.
    #[must_use]
    pub const fn interrupt(mut self, interrupt: InterruptConfig) -> Self {
        self.interrupt = interrupt;
        self
    }

    /// Check that the chip will do what this configuration asks.
    pub const fn validate(&self) -> Result<(), ConfigError> {
        if self.sample_rate_divider != 0 && !self.gyro_bandwidth.divider_applies() {
            return Err(ConfigError::DividerIgnored);
        }
        Ok(())
    }

    /// Output data rate in Hz: the rate at which the data registers and the
    /// data-ready interrupt update (1 kHz / (1 + divider), or 8 kHz at gyro
    /// bandwidth 250 Hz / 3600 Hz).
    pub fn output_data_rate_hz(&self) -> f32 {
        1.0e6 / self.sample_period_us() as f32
    }

    /// Sample period in µs (exact): 1000 × (1 + divider), or 125 at 8 kHz.
    pub const fn sample_period_us(&self) -> u32 {
        if self.gyro_bandwidth.divider_applies() {
            1000 * (1 + self.sample_rate_divider as u32)
        } else {
            125
        }
    }

    /// The configuration registers as `(register, value)` in the order
    /// [`Mpu9250::init`](crate::Mpu9250::init) writes them after the reset,
    /// with BYPASS_EN set in INT_PIN_CFG when `bypass`. Every one of them is
    /// read back by `init` and [`verify_config`](crate::Mpu9250::verify_config).
    pub const fn register_values(&self, bypass: bool) -> [(u8, u8); 10] {
        [
            (reg::PWR_MGMT_1, reg::PWR_MGMT_1_CLKSEL_PLL),
            (reg::PWR_MGMT_2, 0x00),
            (reg::USER_CTRL, 0x00),
            (reg::SMPLRT_DIV, self.sample_rate_divider),
            (reg::CONFIG, self.gyro_bandwidth.dlpf_cfg()),
            (reg::GYRO_CONFIG, self.gyro_range.gyro_config_bits()),
            (reg::ACCEL_CONFIG, self.accel_range.accel_config_bits()),
            (
                reg::ACCEL_CONFIG2,
                self.accel_bandwidth.accel_config2_bits(),
            ),
            (reg::INT_PIN_CFG, self.interrupt.int_pin_cfg(bypass)),
            (reg::INT_ENABLE, self.interrupt.int_enable_bits()),
        ]
    }
}
