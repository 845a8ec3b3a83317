//! The driver's error type.

use core::fmt;

use crate::{Channel, PromError, RawOutOfRange, SampleError};

/// Everything that can go wrong talking to an MS5611.
///
/// `E` is the I²C bus's own error type, kept intact in [`Error::Bus`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The I²C transfer failed (NACK, arbitration loss, bus error, ...).
    Bus(E),
    /// PROM CRC-4 mismatch (see [`crate::crc4`]).
    PromCrc {
        /// CRC stored in the PROM (word 7 bits 3..0).
        expected: u8,
        /// CRC computed over the PROM.
        computed: u8,
    },
    /// The PROM read all 0x0000 or all 0xFFFF.
    PromBlank,
    /// An ADC read returned 0: no conversion was started, it had not
    /// finished, or it was already read. Never a valid reading.
    AdcNotReady,
    /// A raw D1/D2 value was not a 24-bit number.
    RawOutOfRange {
        /// D1 (pressure) or D2 (temperature).
        channel: Channel,
        /// The rejected value.
        raw: u32,
    },
    /// A measurement was requested before the PROM was read
    /// ([`crate::Ms5611::init`] / [`crate::Ms5611::read_prom`]).
    NotInitialised,
    /// [`crate::Sampler::on_adc_read`] was called with no conversion in
    /// flight (a sequencing bug in the caller of the pure state machine).
    NoConversionInFlight,
}

impl<E> From<PromError> for Error<E> {
    fn from(e: PromError) -> Self {
        match e {
            PromError::Blank => Error::PromBlank,
            PromError::Crc { expected, computed } => Error::PromCrc { expected, computed },
        }
    }
}

impl<E> From<RawOutOfRange> for Error<E> {
    fn from(e: RawOutOfRange) -> Self {
        Error::RawOutOfRange {
            channel: e.channel,
            raw: e.raw,
        }
    }
}

impl<E> From<SampleError> for Error<E> {
    fn from(e: SampleError) -> Self {
        match e {
            SampleError::AdcNotReady => Error::AdcNotReady,
            SampleError::RawOutOfRange(r) => r.into(),
            SampleError::NoConversionInFlight => Error::NoConversionInFlight,
        }
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Bus(e) => write!(f, "MS5611 I2C bus error: {e:?}"),
            Error::PromCrc { expected, computed } => fmt::Display::fmt(
                &PromError::Crc {
                    expected: *expected,
                    computed: *computed,
                },
                f,
            ),
            Error::PromBlank => fmt::Display::fmt(&PromError::Blank, f),
            Error::AdcNotReady => {
                f.write_str("MS5611 ADC read returned 0 (conversion not started or not finished)")
            }
            Error::RawOutOfRange { channel, raw } => fmt::Display::fmt(
                &RawOutOfRange {
                    channel: *channel,
                    raw: *raw,
                },
                f,
            ),
            Error::NotInitialised => f.write_str("MS5611 PROM not read yet (call init first)"),
            Error::NoConversionInFlight => {
                f.write_str("MS5611 sampler got an ADC result with no conversion in flight")
            }
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {}
