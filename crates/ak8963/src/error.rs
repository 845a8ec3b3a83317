//! The driver's error type.

use core::fmt;

use crate::config::Resolution;
use crate::data::{CalibrationError, Overflow, Rejected};

/// Every way a driver call can fail. `E` is the I2C bus error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The I2C bus reported an error (NACK, arbitration loss, ...). A NACK at
    /// 0x0C usually means the MPU-9250's I2C bypass is not enabled.
    Bus(E),
    /// WIA returned this instead of 0x48.
    WrongId(u8),
    /// CNTL2 SRST did not clear within the polling budget.
    ResetTimeout,
    /// A fuse-ROM sensitivity adjustment value was 0x00 or 0xFF (unread,
    /// unprogrammed or a stuck bus); the values read are X, Y, Z.
    BadFuseRom {
        /// ASAX, ASAY, ASAZ as read.
        asa: [u8; 3],
    },
    /// ST1 DRDY is not set: no new measurement yet. Nothing was consumed
    /// (ST2 was not read), try again later.
    NotReady,
    /// ST2 HOFL was set (|X|+|Y|+|Z| > 4912 µT): the measurement was dropped.
    /// ST2 has been read, so the next measurement proceeds normally.
    Overflow,
    /// ST2 BITM says the chip measured at another resolution than the
    /// configured one (its CNTL1 changed behind the driver's back): the
    /// sample was dropped; re-initialise.
    ResolutionMismatch {
        /// The resolution the driver was configured for.
        configured: Resolution,
    },
    /// CNTL1 read back differently from what was written (bus corruption or a
    /// chip reset): re-initialise.
    ConfigMismatch {
        /// Register address.
        register: u8,
        /// Value written.
        expected: u8,
        /// Value read back.
        found: u8,
    },
    /// The call needs [`init`](crate::Ak8963::init) (the fuse-ROM values) first.
    NotInitialized,
    /// The self-test field measured outside the datasheet's limits.
    SelfTestFailed {
        /// Adjusted self-test readings X, Y, Z in counts.
        adjusted_counts: [i32; 3],
    },
    /// DRDY never came during the self-test.
    SelfTestTimeout,
    /// A hard/soft-iron calibration could not be built.
    Calibration(CalibrationError),
}

impl<E> From<Overflow> for Error<E> {
    fn from(_: Overflow) -> Self {
        Error::Overflow
    }
}

impl<E> From<Rejected> for Error<E> {
    fn from(r: Rejected) -> Self {
        match r {
            Rejected::NotReady => Error::NotReady,
            Rejected::Overflow => Error::Overflow,
            Rejected::ResolutionMismatch { configured } => Error::ResolutionMismatch { configured },
        }
    }
}

impl<E> From<CalibrationError> for Error<E> {
    fn from(e: CalibrationError) -> Self {
        Error::Calibration(e)
    }
}

impl fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CalibrationError::ZeroSpan { axis } => {
                write!(f, "axis {axis}: maximum not above minimum")
            }
        }
    }
}

impl fmt::Display for Overflow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("magnetic sensor overflow (|X|+|Y|+|Z| > 4912 uT)")
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Bus(e) => write!(f, "I2C bus error: {e:?}"),
            Error::WrongId(id) => write!(f, "WIA 0x{id:02X} is not an AK8963 (0x48)"),
            Error::ResetTimeout => f.write_str("soft reset did not complete"),
            Error::BadFuseRom { asa } => write!(
                f,
                "bad fuse ROM sensitivity adjustment 0x{:02X} 0x{:02X} 0x{:02X}",
                asa[0], asa[1], asa[2]
            ),
            Error::NotReady => f.write_str("no new measurement (DRDY clear)"),
            Error::Overflow => Overflow.fmt(f),
            Error::ResolutionMismatch { configured } => write!(
                f,
                "ST2 BITM does not match the configured {}-bit output",
                match configured {
                    Resolution::Bits14 => 14,
                    Resolution::Bits16 => 16,
                }
            ),
            Error::ConfigMismatch {
                register,
                expected,
                found,
            } => write!(
                f,
                "register 0x{register:02X} reads 0x{found:02X}, expected 0x{expected:02X}"
            ),
            Error::NotInitialized => f.write_str("driver not initialised"),
            Error::SelfTestFailed { adjusted_counts } => {
                write!(f, "self-test out of limits: {adjusted_counts:?}")
            }
            Error::SelfTestTimeout => f.write_str("self-test measurement never became ready"),
            Error::Calibration(e) => write!(f, "calibration: {e}"),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
