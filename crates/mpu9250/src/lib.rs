//! MPU-9250 accelerometer / gyroscope / temperature driver for embedded-hal 1.0:
//! I2C or SPI, blocking or (feature `async`) async.
//!
//! ```no_run
//! use embedded_hal::{delay::DelayNs, i2c::I2c};
//! use mpu9250::{Address, Config, Error, Mpu9250};
//!
//! fn log_samples<B: I2c, D: DelayNs>(bus: B, delay: &mut D) -> Result<(), Error<B::Error>> {
//!     let mut imu = Mpu9250::new(bus, Address::Ad0Low); // or Mpu9250::new_with_spi(spi)
//!     imu.init(delay, &Config::default())?;
//!     loop {
//!         let s = imu.read()?; // g, °/s, °C in the MPU sensor frame
//!         let _ = (s.accel_g, s.gyro_dps, s.temp_c);
//!         delay.delay_ms(1);
//!     }
//! }
//! ```
//!
//! What it does:
//! * checks WHO_AM_I (MPU-9250 0x71, MPU-9255 0x73; the MPU-6500 0x70, which has
//!   no magnetometer, is its own error), resets the chip with a bounded wait and
//!   writes a typed [`Config`] (ranges, DLPFs, sample-rate divider, INT pin),
//!   then reads every written register back ([`Error::ConfigMismatch`]);
//!   [`Mpu9250::verify_config`] repeats that check at run time;
//! * reads the 14-byte ACCEL/TEMP/GYRO block in one burst; [`parse_sample`],
//!   [`convert`], [`Scale`] and the range helpers work without a bus (DMA or IRQ
//!   transports), and the integer factors ([`AccelRange::lsb_per_g`],
//!   [`GyroRange::full_scale_dps`], [`temp_centi_c`]) let a fixed-point
//!   pipeline skip f32 entirely;
//! * keeps a gyro bias in raw counts ([`Mpu9250::calibrate_gyro_bias`] with
//!   motion rejection) that survives re-initialisation;
//! * configures the data-ready interrupt and the I2C bypass that puts the
//!   AK8963 (see the `ak8963` crate) on the host bus;
//! * talks SPI ([`Mpu9250::new_with_spi`], see [`Interface`]) and, with the
//!   `async` feature, the same API as `Mpu9250Async` over `embedded-hal-async`;
//! * changes one setting at a time, written and read back
//!   ([`Mpu9250::set_accel_range`] and its siblings);
//! * queues whole samples in the FIFO (`set_fifo`, `read_fifo`; feature
//!   `fifo`) and reports an overflow or a torn queue as an error after
//!   resetting it;
//! * drives the internal I2C master (`set_i2c_master`, slave 4 single
//!   transfers, slave 0 periodic reads into EXT_SENS_DATA; feature `master`),
//!   the way to the AK8963 when the chip is on SPI (`AuxBus`, feature
//!   `ak8963`);
//! * runs the factory self-test ([`Mpu9250::self_test`]) against the trim
//!   codes.
//!
//! What it does not do: the DMP, wake-on-motion, or writing the chip's
//! offset registers.
//!
//! **Frame**: every vector is in the MPU sensor frame (datasheet §9.1, axes
//! printed on the package): right-handed, z out of the top face; at rest, face
//! up, the accelerometer reads (0, 0, +1 g).
//!
//! ```
//! use embedded_hal_mock::eh1::delay::NoopDelay;
//! use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
//! use mpu9250::{Address, Config, Mpu9250};
//!
//! let a = 0x68;
//! let config = Config::default();
//! let mut expected = vec![
//!     T::write_read(a, vec![0x75], vec![0x71]),
//!     T::write(a, vec![0x6B, 0x80]),
//!     T::write_read(a, vec![0x6B], vec![0x01]),
//! ];
//! for (register, value) in config.register_values(false) {
//!     expected.push(T::write(a, vec![register, value]));
//! }
//! expected.push(T::write_read(a, vec![0x19], vec![0x00, 0x03, 0x10, 0x08, 0x03]));
//! expected.push(T::write_read(a, vec![0x37], vec![0x00, 0x01]));
//! expected.push(T::write_read(a, vec![0x6A], vec![0x00, 0x01, 0x00]));
//! expected.push(T::write_read(a, vec![0x3B], vec![0, 0, 0, 0, 0x20, 0, 0, 0, 0, 0, 0, 0, 0, 0]));
//!
//! let mut i2c = Mock::new(&expected);
//! let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
//! imu.init(&mut NoopDelay::new(), &config).unwrap();
//! let sample = imu.read().unwrap();
//! assert_eq!(sample.accel_g, [0.0, 0.0, 1.0]);
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

pub use config::{
    AccelBandwidth, AccelRange, Address, Config, ConfigError, GyroBandwidth, GyroRange, IntClear,
    IntDrive, IntLatch, IntLevel, InterruptConfig, Variant,
};
pub use data::{
    apply_gyro_bias, convert, dps_to_rps, parse_sample, rescale_gyro_bias, temp_c, temp_centi_c,
    RawSample, Sample, Scale, RAD_PER_DEG, TEMP_LSB_PER_C, TEMP_OFFSET_C,
};
#[cfg(feature = "ak8963")]
pub use device::AuxBus;
#[cfg(all(feature = "ak8963", feature = "async"))]
pub use device::AuxBusAsync;
#[cfg(feature = "async")]
pub use device::Mpu9250Async;
pub use device::{
    factory_trim_lsb, BiasCalibration, IntStatus, Mpu9250, SelfTest, SelfTestCheck,
    FIFO_BURST_SAMPLES, RESET_MAX_POLLS, RESET_POLL_INTERVAL_MS, SELF_TEST_SAMPLES,
    SELF_TEST_SETTLE_MS,
};
#[cfg(feature = "master")]
pub use device::{SlaveRead, AUX_POLL_INTERVAL_US};
pub use error::{Error, Motion};
#[cfg(feature = "async")]
pub use interface::InterfaceAsync;
pub use interface::{Interface, SpiInterface, SPI_READ};
