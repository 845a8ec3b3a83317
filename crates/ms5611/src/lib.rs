//! MS5611-01BA03 barometric pressure sensor driver (embedded-hal 1.0, I²C or
//! SPI, blocking or async).
//!
//! ```no_run
//! use embedded_hal::{delay::DelayNs, i2c::I2c};
//! use ms5611::{Address, Error, Ms5611, Osr};
//!
//! fn log_pressure<B: I2c, D: DelayNs>(bus: B, delay: &mut D) -> Result<(), Error<B::Error>> {
//!     let mut baro = Ms5611::new(bus, Address::CsbLow); // or Ms5611::new_with_spi(spi)
//!     baro.init(delay)?;
//!     loop {
//!         let m = baro.measure(delay, Osr::Osr4096)?; // Pa and 0.01 °C
//!         let _ = (m.pressure_pa, m.temperature_centi_c);
//!     }
//! }
//! ```
//!
//! What it does:
//!
//! * Talks to the chip at 0x76 or 0x77 ([`Address`]): reset, PROM read with
//!   the AN520 CRC-4 check and a blank-PROM check ([`Prom`], [`crc4`]), D1
//!   (pressure) and D2 (temperature) conversions at every oversampling ratio
//!   ([`Osr`]) and the 24-bit ADC read, where a result of 0 is an error
//!   ([`Error::AdcNotReady`]), never a reading.
//! * Compensates exactly as the datasheet, in integer arithmetic including
//!   the second-order correction below 20 °C and −15 °C ([`compensate`],
//!   [`compensate_detailed`] with every intermediate). Pressure is in Pa
//!   (= 0.01 mbar), temperature in 0.01 °C.
//! * Schedules conversions without blocking ([`Sampler`]): the caller passes
//!   a wrapping microsecond timestamp; one D2 per N D1; a
//!   [`Sampler::next_deadline_us`] for timer-driven firmware.
//! * Blocking helpers ([`Ms5611::init`], [`Ms5611::measure`]) take an
//!   `embedded_hal::delay::DelayNs`.
//!
//! * Talks I²C ([`Ms5611::new`]) or SPI ([`Ms5611::new_with_spi`], see
//!   [`Interface`]); with the `async` feature the same driver exists as
//!   `Ms5611Async` over `embedded-hal-async`, and the [`Sampler`] drives it
//!   with `poll_async`.
//!
//! What it does not do: altitude (that is `control`'s job) or filtering.
//!
//! ```
//! # use embedded_hal_mock::eh1::{i2c::{Mock, Transaction as T}, delay::NoopDelay};
//! # let words = ms5611::Prom::from_coefficients([40127, 36924, 23317, 23282, 33464, 28312]).words();
//! # let mut ex = vec![T::write(0x76, vec![0x1E])];
//! # for (i, w) in words.iter().enumerate() {
//! #     ex.push(T::write(0x76, vec![0xA0 + 2 * i as u8]));
//! #     ex.push(T::read(0x76, w.to_be_bytes().to_vec()));
//! # }
//! # ex.extend([
//! #     T::write(0x76, vec![0x44]), T::write(0x76, vec![0x00]), T::read(0x76, vec![0x8A, 0xA2, 0x1A]),
//! #     T::write(0x76, vec![0x54]), T::write(0x76, vec![0x00]), T::read(0x76, vec![0x82, 0xC1, 0x3E]),
//! # ]);
//! # let i2c = Mock::new(&ex);
//! # let mut delay = NoopDelay::new();
//! use ms5611::{Address, Ms5611, Osr};
//!
//! let mut baro = Ms5611::new(i2c, Address::CsbHigh);
//! baro.init(&mut delay)?; // reset, 2.8 ms, PROM + CRC
//! let m = baro.measure(&mut delay, Osr::Osr1024)?;
//! assert_eq!(m.pressure_pa, 100_009);
//! assert_eq!(m.temperature_centi_c, 2007);
//! # baro.release().done();
//! # Ok::<(), ms5611::Error<embedded_hal::i2c::ErrorKind>>(())
//! ```

// The three drivers (mpu9250, ak8963, ms5611) are independently publishable
// crates with no helper crate in common, so the transport seam (interface.rs),
// the private register helpers, the `maybe_async_cfg` attribute blocks, the
// error and config boilerplate, the examples, and the tests' helpers and
// datasheet tables repeat across them on purpose. Within a crate, each impl block
// carries its own `maybe_async_cfg` attribute: the macro works per item.
#![no_std]
#![deny(unsafe_code)]

pub mod command;
mod compensation;
mod device;
mod error;
mod interface;
mod prom;
mod sampler;
mod types;

pub use command::{MAX_CONVERSION_TIME_US, RESET_TIME_US};
pub use compensation::{
    compensate, compensate_detailed, Compensation, Measurement, RawOutOfRange, ADC_LIMIT,
};
pub use device::Ms5611;
#[cfg(feature = "async")]
pub use device::Ms5611Async;
pub use error::Error;
#[cfg(feature = "async")]
pub use interface::InterfaceAsync;
pub use interface::{Interface, SpiInterface};
pub use prom::{crc4, with_valid_crc, Prom, PromError};
pub use sampler::{
    guard_for_bus_hz, Action, SampleError, Sampler, SamplerConfig, DEFAULT_GUARD_US, MAX_GUARD_US,
};
pub use types::{Address, Channel, Osr};
