//! AK8963 magnetometer driver for embedded-hal 1.0 (the magnetometer inside
//! the MPU-9250, reached through the MPU-9250's I2C bypass at 0x0C, or
//! through its internal I2C master with any [`Interface`]); blocking or
//! (feature `async`) async.
//!
//! ```no_run
//! use embedded_hal::{delay::DelayNs, i2c::I2c};
//! use ak8963::{Ak8963, Config, Error};
//!
//! fn log_field<B: I2c, D: DelayNs>(bus: B, delay: &mut D) -> Result<(), Error<B::Error>> {
//!     let mut mag = Ak8963::new(bus); // the MPU-9250's bypass is on
//!     mag.init(delay, &Config::default())?;
//!     loop {
//!         match mag.read() {
//!             Ok(s) => { let _ = s.field_mpu_ut(); } // µT, MPU frame
//!             Err(Error::NotReady) => {}
//!             Err(e) => return Err(e),
//!         }
//!         delay.delay_ms(10);
//!     }
//! }
//! ```
//!
//! What it does:
//! * checks WIA (0x48), soft-resets, reads the fuse-ROM sensitivity
//!   adjustment (ASA; 0x00/0xFF rejected as [`Error::BadFuseRom`]) and sets a
//!   typed [`Config`] (mode, 14/16-bit), always through power-down with the
//!   datasheet's 100 µs wait, reading CNTL1 back ([`Error::ConfigMismatch`]);
//! * reads ST1 (DRDY clear → [`Error::NotReady`], nothing consumed; DOR →
//!   [`RawMag::data_overrun`] / [`Sample::data_overrun`], data still valid),
//!   then HXL..ST2 in one 7-byte little-endian burst (ST2 HOFL →
//!   [`Error::Overflow`], sample dropped, next measurement unblocked; ST2 BITM
//!   not matching the configured resolution → [`Error::ResolutionMismatch`],
//!   sample dropped);
//! * converts counts to µT with the factory adjustment
//!   `(ASA − 128) / 256 + 1`, then applies a hard/soft-iron correction
//!   [`HardSoftIron`] (`M · (field − offset)`);
//! * maps the AK8963 frame to the MPU frame ([`to_mpu_frame`]);
//! * runs the datasheet self-test ([`Ak8963::self_test`]).
//!
//! Pure functions ([`parse_st1`], [`parse_measurement`], [`parse_status_block`]
//! for the ST1..ST2 block the MPU-9250's internal master copies, [`adjustment_factor`],
//! [`adjustment_q8`], [`ut_per_lsb`], [`convert`], [`exceeds_range`]) work
//! without a bus (DMA or IRQ transports, integer pipelines).
//!
//! What it does not do: enable the MPU-9250 bypass (see
//! `mpu9250::Mpu9250::set_bypass`) or its internal master (`mpu9250::AuxBus`
//! implements [`Interface`] over it), fit a calibration (see the
//! `calibration` crate), or talk SPI to a stand-alone AK8963.
//!
//! **Frames.** Everything here is in the AK8963 sensor frame:
//! x_mag = y_mpu, y_mag = x_mpu, z_mag = −z_mpu (MPU-9250 datasheet §9.1).
//! [`to_mpu_frame`] returns `[v[1], v[0], -v[2]]`.
//!
//! **Measurement range.** The datasheet's overflow condition is
//! |X| + |Y| + |Z| > 4912 µT (before the factory adjustment); the chip then
//! sets ST2 HOFL. [`parse_measurement`] treats HOFL, and a reading whose sum
//! exceeds the range ([`exceeds_range`]), as [`Rejected::Overflow`].
//!
//! ```
//! use embedded_hal_mock::eh1::delay::NoopDelay;
//! use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
//! use ak8963::{Ak8963, Config, Error};
//!
//! let a = 0x0C;
//! let mut i2c = Mock::new(&[
//!     T::write_read(a, vec![0x00], vec![0x48]),
//!     T::write(a, vec![0x0B, 0x01]),
//!     T::write_read(a, vec![0x0B], vec![0x00]),
//!     T::write(a, vec![0x0A, 0x00]),
//!     T::write(a, vec![0x0A, 0x0F]),
//!     T::write_read(a, vec![0x10], vec![0x80, 0x80, 0x80]),
//!     T::write(a, vec![0x0A, 0x00]),
//!     T::write(a, vec![0x0A, 0x16]),
//!     T::write_read(a, vec![0x0A], vec![0x16]),
//!     T::write_read(a, vec![0x02], vec![0x00]), // DRDY clear
//! ]);
//! let mut mag = Ak8963::new(i2c.clone());
//! mag.init(&mut NoopDelay::new(), &Config::default()).unwrap();
//! assert_eq!(mag.read(), Err(Error::NotReady));
//! i2c.done();
//! ```

// The three drivers (mpu9250, ak8963, ms5611) are independently publishable
// crates with no helper crate in common, so the transport seam (interface.rs),
// the private register helpers, the `maybe_async_cfg` attribute blocks, the
// error and config boilerplate, the examples, and the tests' helpers and
// datasheet tables repeat across them on purpose. Within a crate, each impl block
// carries its own `maybe_async_cfg` attribute: the macro works per item.
#![no_std]
#![deny(unsafe_code)]

mod config;
mod data;
mod device;
mod error;
mod interface;
pub mod register;

pub use config::{Config, Mode, Resolution};
pub use data::{
    adjustment_factor, adjustment_q8, asa_valid, convert, counts_to_ut, exceeds_range,
    parse_measurement, parse_st1, parse_status_block, to_mpu_frame, to_mpu_frame_counts,
    ut_per_lsb, CalibrationError, HardSoftIron, Overflow, RawMag, Rejected, Sample, St1,
    MEASUREMENT_RANGE_NT, MEASUREMENT_RANGE_UT,
};
#[cfg(feature = "async")]
pub use device::Ak8963Async;
pub use device::{
    Ak8963, MODE_CHANGE_DELAY_US, RESET_MAX_POLLS, RESET_POLL_INTERVAL_US, SELF_TEST_MAX_POLLS,
    SELF_TEST_POLL_INTERVAL_US,
};
pub use error::Error;
pub use interface::Interface;
#[cfg(feature = "async")]
pub use interface::InterfaceAsync;
