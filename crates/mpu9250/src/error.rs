//! The driver's error type.

use core::fmt;

use crate::config::ConfigError;

/// What the gyro-bias calibration saw that shows the device was not at rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Motion {
    /// A gyro axis' peak-to-peak spread over the window exceeded the limit.
    GyroSpread {
        /// Axis index (0 = x, 1 = y, 2 = z, MPU frame).
        axis: u8,
        /// Observed max − min, counts.
        peak_to_peak_counts: u16,
        /// The limit that was exceeded, counts.
        limit_counts: u16,
    },
    /// One sample's accelerometer magnitude was outside 1 g ± the tolerance.
    AccelMagnitude {
        /// Observed |a| in milli-g (saturated at `u16::MAX`).
        magnitude_mg: u16,
    },
}

/// Every way a driver call can fail. `E` is the bus (I2C or SPI) error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The bus reported an error (I2C NACK, arbitration loss, SPI fault, ...).
    Bus(E),
    /// WHO_AM_I returned an id that is not an MPU-9250/9255/6500.
    WrongChipId(u8),
    /// WHO_AM_I returned 0x70: an MPU-6500, which has no AK8963 magnetometer.
    Mpu6500Detected,
    /// PWR_MGMT_1 H_RESET did not clear within the polling budget.
    ResetTimeout,
    /// A configuration register read back differently from what was written
    /// (bus corruption or the chip reset itself): re-initialise.
    ConfigMismatch {
        /// Register address.
        register: u8,
        /// Value written.
        expected: u8,
        /// Value read back.
        found: u8,
    },
    /// Gyro-bias calibration saw motion; nothing was stored.
    Moved(Motion),
    /// The call needs [`init`](crate::Mpu9250::init) to have succeeded first.
    NotInitialized,
    /// The requested configuration is not valid; nothing was written.
    InvalidConfig(ConfigError),
    /// The I2C bypass was asked for while the chip is on SPI.
    BypassOnSpi,
    /// The internal I2C master and the bypass were both asked for; they
    /// exclude each other (USER_CTRL I2C_MST_EN must be 0 for the bypass).
    MasterWithBypass,
    /// An auxiliary-bus call while the internal I2C master is off.
    MasterDisabled,
    /// The chip on the auxiliary bus did not acknowledge (I2C_SLV4_NACK).
    AuxNack,
    /// The internal master lost arbitration on the auxiliary bus.
    AuxLostArbitration,
    /// Slave 4 did not finish within two sample periods plus 1 ms.
    AuxTimeout,
    /// The FIFO was read while it is off ([`set_fifo`](crate::Mpu9250::set_fifo)).
    FifoDisabled,
    /// The FIFO could not take another sample: samples were dropped. The
    /// FIFO has been emptied; reading resumes with the next sample.
    FifoOverflow {
        /// FIFO byte count found.
        count_bytes: u16,
    },
    /// The FIFO byte count was not a whole number of samples (a torn sample,
    /// for example after a failed burst). The FIFO has been emptied.
    FifoMisaligned {
        /// FIFO byte count found.
        count_bytes: u16,
    },
}

impl<E> From<ConfigError> for Error<E> {
    fn from(e: ConfigError) -> Self {
        Error::InvalidConfig(e)
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::DividerIgnored => f.write_str(
                "sample-rate divider is ignored at gyro bandwidth 250 Hz / 3600 Hz (8 kHz)",
            ),
            ConfigError::NoSamples => f.write_str("zero samples requested"),
            ConfigError::SlaveReadLength => {
                f.write_str("slave read length outside 1..=15 (24 for EXT_SENS_DATA)")
            }
        }
    }
}

impl fmt::Display for Motion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Motion::GyroSpread {
                axis,
                peak_to_peak_counts,
                limit_counts,
            } => write!(
                f,
                "gyro axis {axis} peak-to-peak {peak_to_peak_counts} counts > {limit_counts}"
            ),
            Motion::AccelMagnitude { magnitude_mg } => {
                write!(f, "accelerometer magnitude {magnitude_mg} mg is not 1 g")
            }
        }
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Bus(e) => write!(f, "I2C bus error: {e:?}"),
            Error::WrongChipId(id) => write!(f, "WHO_AM_I 0x{id:02X} is not an MPU-9250"),
            Error::Mpu6500Detected => {
                f.write_str("WHO_AM_I 0x70: MPU-6500 (no magnetometer), not an MPU-9250")
            }
            Error::ResetTimeout => f.write_str("device reset did not complete"),
            Error::ConfigMismatch {
                register,
                expected,
                found,
            } => write!(
                f,
                "register 0x{register:02X} reads 0x{found:02X}, expected 0x{expected:02X}"
            ),
            Error::Moved(m) => write!(f, "device moved during gyro calibration: {m}"),
            Error::NotInitialized => f.write_str("driver not initialised"),
            Error::InvalidConfig(e) => write!(f, "invalid configuration: {e}"),
            Error::MasterWithBypass => {
                f.write_str("internal I2C master and bypass exclude each other")
            }
            Error::MasterDisabled => f.write_str("internal I2C master is off"),
            Error::AuxNack => f.write_str("auxiliary-bus chip did not acknowledge"),
            Error::AuxLostArbitration => f.write_str("auxiliary bus arbitration lost"),
            Error::AuxTimeout => f.write_str("auxiliary-bus transfer did not finish"),
            Error::FifoDisabled => f.write_str("FIFO read while the FIFO is off"),
            Error::FifoOverflow { count_bytes } => {
                write!(
                    f,
                    "FIFO overflow at {count_bytes} bytes: samples lost, FIFO reset"
                )
            }
            Error::FifoMisaligned { count_bytes } => write!(
                f,
                "FIFO holds {count_bytes} bytes, not whole samples: FIFO reset"
            ),
            Error::BypassOnSpi => {
                f.write_str("I2C bypass requested on SPI (use the internal I2C master)")
            }
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
