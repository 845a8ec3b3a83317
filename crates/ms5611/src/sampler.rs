//! Non-blocking conversion schedule.
//!
//! [`Sampler`] is a pure state machine over a caller-supplied, wrapping u32
//! microsecond clock. [`Sampler::poll`] drives it over the bus: call it as
//! often as you like (from a timer at [`Sampler::next_deadline_us`], from
//! the main loop, ...); it never blocks and never reads a conversion before
//! its maximum conversion time (plus a guard) has passed.
//!
//! The sequence is D2, then N × D1, then D2, N × D1, ... Every D1 yields a
//! [`Measurement`] compensated with the latest D2. A new conversion is
//! started in the same `poll` that reads the previous one, so at OSR 4096
//! the chip delivers a pressure every ~9.3 ms (N/(N+1) of the conversions).
//!
//! # Time
//!
//! `now_us` is any free-running microsecond counter that wraps at 2^32
//! (≈ 71.6 min). Deadlines are compared with wrapping arithmetic
//! ("`now − deadline` as i32 ≥ 0"), so wrap-around is handled, and a clock
//! that steps *backwards* only delays a read (never makes it early). The one
//! limit: `poll` must be called at least once every 2^31 µs (≈ 35 min)
//! while a conversion is in flight, otherwise the deadline looks like it is
//! in the future again and the read is delayed by up to another 35 min.
//!
//! # Errors
//!
//! After any error (bus error, ADC read of 0, out-of-range value) the
//! sampler forgets the conversion in flight and waits
//! [`SamplerConfig::recovery_us`] (the longest conversion time plus the
//! guard) before starting again, so a conversion the chip may still be
//! running is never disturbed. There is no stuck state: the next `poll`
//! after that delay starts a fresh conversion.

use core::fmt;
use core::num::NonZeroU16;

use crate::{compensate, Channel, Error, Interface, Measurement, Ms5611, Osr, Prom, RawOutOfRange};
#[cfg(feature = "async")]
use crate::{InterfaceAsync, Ms5611Async};

/// Default extra wait added to every conversion deadline, µs. Covers the
/// I²C time between the caller's timestamp and the chip actually receiving
/// the conversion command at 400 kHz (see [`guard_for_bus_hz`]).
pub const DEFAULT_GUARD_US: u32 = 210;

/// Upper bound of [`SamplerConfig::guard_us`], µs (keeps every deadline far
/// inside the 2^31 µs wrapping window).
pub const MAX_GUARD_US: u32 = 100_000;

/// A guard time for an I²C clock of `bus_hz`: 64 bit times (the ADC read's
/// three data bytes plus the next conversion command, which [`Sampler::poll`]
/// sends after taking `now_us`) plus 50 µs of CPU time.
/// 400 kHz → 210 µs, 100 kHz → 690 µs. `0` → [`MAX_GUARD_US`].
///
/// ```
/// assert_eq!(ms5611::guard_for_bus_hz(400_000), 210);
/// assert_eq!(ms5611::guard_for_bus_hz(100_000), 690);
/// ```
pub const fn guard_for_bus_hz(bus_hz: u32) -> u32 {
    if bus_hz == 0 {
        return MAX_GUARD_US;
    }
    let bits_us = 64_000_000 / bus_hz;
    let guard = bits_us + 50;
    if guard > MAX_GUARD_US {
        MAX_GUARD_US
    } else {
        guard
    }
}

/// Schedule configuration. Build with [`SamplerConfig::new`] and the
/// `with_*` methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SamplerConfig {
    pressure_osr: Osr,
    temperature_osr: Osr,
    pressures_per_temperature: NonZeroU16,
    guard_us: u32,
}

impl Default for SamplerConfig {
    fn default() -> Self {
        Self::new()
    }
}

impl SamplerConfig {
    /// Default number of D1 conversions per D2 conversion.
    pub const DEFAULT_PRESSURES_PER_TEMPERATURE: NonZeroU16 = match NonZeroU16::new(10) {
        Some(n) => n,
        None => NonZeroU16::MIN,
    };

    /// OSR 4096 for both channels, 10 pressures per temperature,
    /// [`DEFAULT_GUARD_US`].
    pub const fn new() -> Self {
        SamplerConfig {
            pressure_osr: Osr::Osr4096,
            temperature_osr: Osr::Osr4096,
            pressures_per_temperature: Self::DEFAULT_PRESSURES_PER_TEMPERATURE,
            guard_us: DEFAULT_GUARD_US,
        }
    }

    /// Oversampling of the D1 (pressure) conversions.
    pub const fn with_pressure_osr(mut self, osr: Osr) -> Self {
        self.pressure_osr = osr;
        self
    }

    /// Oversampling of the D2 (temperature) conversions.
    pub const fn with_temperature_osr(mut self, osr: Osr) -> Self {
        self.temperature_osr = osr;
        self
    }

    /// Number of D1 conversions between two D2 conversions.
    pub const fn with_pressures_per_temperature(mut self, n: NonZeroU16) -> Self {
        self.pressures_per_temperature = n;
        self
    }

    /// Extra wait after each conversion's maximum time, µs, clamped to
    /// [`MAX_GUARD_US`]. See [`guard_for_bus_hz`].
    pub const fn with_guard_us(mut self, guard_us: u32) -> Self {
        self.guard_us = if guard_us > MAX_GUARD_US {
            MAX_GUARD_US
        } else {
            guard_us
        };
        self
    }

    /// D1 oversampling.
    pub const fn pressure_osr(&self) -> Osr {
        self.pressure_osr
    }

    /// D2 oversampling.
    pub const fn temperature_osr(&self) -> Osr {
        self.temperature_osr
    }

    /// D1 conversions per D2 conversion.
    pub const fn pressures_per_temperature(&self) -> NonZeroU16 {
        self.pressures_per_temperature
    }

    /// Guard time, µs.
    pub const fn guard_us(&self) -> u32 {
        self.guard_us
    }

    /// Oversampling used for `channel`.
    pub const fn osr(&self, channel: Channel) -> Osr {
        match channel {
            Channel::Pressure => self.pressure_osr,
            Channel::Temperature => self.temperature_osr,
        }
    }

    /// Time from starting a `channel` conversion until the sampler reads it:
    /// maximum conversion time + guard, µs (≤ 109 040).
    pub const fn conversion_wait_us(&self, channel: Channel) -> u32 {
        self.osr(channel).conversion_time_us() + self.guard_us
    }

    /// Wait after an error before the next conversion starts: the longer
    /// conversion time of the two channels + guard, µs.
    pub const fn recovery_us(&self) -> u32 {
        let p = self.pressure_osr.conversion_time_us();
        let t = self.temperature_osr.conversion_time_us();
        (if p > t { p } else { t }) + self.guard_us
    }
}

/// What the state machine wants done at a given time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Action {
    /// Nothing to do before `until_us`.
    Wait {
        /// The next deadline (wrapping µs clock).
        until_us: u32,
    },
    /// Send the conversion command for `channel` at `osr`, then call
    /// [`Sampler::on_conversion_started`].
    Start {
        /// D1 or D2.
        channel: Channel,
        /// Its oversampling ratio.
        osr: Osr,
    },
    /// Read the ADC (command 0x00 + 3 bytes), then call
    /// [`Sampler::on_adc_read`].
    Read {
        /// The conversion being read.
        channel: Channel,
    },
}

/// Failure of an ADC result handed to [`Sampler::on_adc_read`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SampleError {
    /// The ADC read returned 0 (conversion lost, e.g. the chip was reset).
    AdcNotReady,
    /// The value was not 24-bit.
    RawOutOfRange(RawOutOfRange),
    /// No conversion was in flight.
    NoConversionInFlight,
}

impl fmt::Display for SampleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SampleError::AdcNotReady => f.write_str("MS5611 ADC read returned 0"),
            SampleError::RawOutOfRange(r) => fmt::Display::fmt(r, f),
            SampleError::NoConversionInFlight => {
                f.write_str("MS5611 ADC result with no conversion in flight")
            }
        }
    }
}

impl core::error::Error for SampleError {}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum State {
    /// No conversion in flight; the next may start at `not_before_us`
    /// (`None`: immediately).
    Ready { not_before_us: Option<u32> },
    /// A conversion of `channel` is running; read it at `ready_at_us`.
    Converting { channel: Channel, ready_at_us: u32 },
}

/// `now` is at or after `deadline` on a wrapping u32 clock.
const fn reached(now_us: u32, deadline_us: u32) -> bool {
    (now_us.wrapping_sub(deadline_us) as i32) >= 0
}

/// Non-blocking D1/D2 conversion schedule.
///
/// ```
/// # use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
/// # let i2c = Mock::new(&[
/// #     T::write(0x77, vec![0x58]),
/// #     T::write(0x77, vec![0x00]), T::read(0x77, vec![0x82, 0xC1, 0x3E]), T::write(0x77, vec![0x48]),
/// #     T::write(0x77, vec![0x00]), T::read(0x77, vec![0x8A, 0xA2, 0x1A]), T::write(0x77, vec![0x48]),
/// # ]);
/// use ms5611::{Address, Ms5611, Prom, Sampler, SamplerConfig};
/// let prom = Prom::from_coefficients([40127, 36924, 23317, 23282, 33464, 28312]);
/// let mut baro = Ms5611::with_prom(i2c, Address::CsbLow, prom);
/// let mut sampler = Sampler::new(SamplerConfig::new());
///
/// let mut now_us: u32 = 0;
/// let measurement = loop {
///     if let Some(m) = sampler.poll(&mut baro, now_us)? {
///         break m;
///     }
///     // A firmware would arm a timer for `next_deadline_us()` instead.
///     now_us = sampler.next_deadline_us().unwrap_or(now_us);
/// };
/// assert_eq!(measurement.pressure_pa, 100_009);
/// # baro.release().done();
/// # Ok::<(), ms5611::Error<embedded_hal::i2c::ErrorKind>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sampler {
    config: SamplerConfig,
    state: State,
    d2: Option<u32>,
    pressures_since_temperature: u16,
    error_count: u32,
}

impl Sampler {
    /// A sampler that starts its first (D2) conversion at the first poll.
    pub const fn new(config: SamplerConfig) -> Self {
        Sampler {
            config,
            state: State::Ready {
                not_before_us: None,
            },
            d2: None,
            pressures_since_temperature: 0,
            error_count: 0,
        }
    }

    /// The configuration.
    pub const fn config(&self) -> &SamplerConfig {
        &self.config
    }

    /// Forget everything (conversion in flight, last temperature), e.g.
    /// after resetting the chip. The error count is kept. The next poll
    /// starts a D2 conversion; if the chip was just reset, poll no earlier
    /// than [`crate::RESET_TIME_US`] after the reset.
    pub fn restart(&mut self) {
        self.state = State::Ready {
            not_before_us: None,
        };
        self.d2 = None;
        self.pressures_since_temperature = 0;
    }

    /// [`Sampler::restart`] after sending the reset command at `now_us`
    /// ([`Ms5611::reset`]): the first conversion starts no earlier than
    /// [`crate::RESET_TIME_US`] later.
    pub fn restart_after_reset(&mut self, now_us: u32) {
        self.restart();
        self.state = State::Ready {
            not_before_us: Some(now_us.wrapping_add(crate::RESET_TIME_US)),
        };
    }

    /// When the sampler next needs a poll (wrapping µs clock), or `None` if
    /// it should be polled as soon as possible (nothing in flight).
    pub const fn next_deadline_us(&self) -> Option<u32> {
        match self.state {
            State::Ready { not_before_us } => not_before_us,
            State::Converting { ready_at_us, .. } => Some(ready_at_us),
        }
    }

    /// The conversion in flight, if any.
    pub const fn converting(&self) -> Option<Channel> {
        match self.state {
            State::Ready { .. } => None,
            State::Converting { channel, .. } => Some(channel),
        }
    }

    /// The latest raw D2 (temperature) value, if any.
    pub const fn last_d2(&self) -> Option<u32> {
        self.d2
    }

    /// Errors seen since creation (wrapping counter), including those
    /// absorbed by [`Sampler::poll`] (see there).
    pub const fn error_count(&self) -> u32 {
        self.error_count
    }

    /// The channel the next conversion will measure.
    pub const fn next_channel(&self) -> Channel {
        if self.d2.is_none()
            || self.pressures_since_temperature >= self.config.pressures_per_temperature.get()
        {
            Channel::Temperature
        } else {
            Channel::Pressure
        }
    }

    /// What to do at `now_us` (pure; does not change the state).
    pub const fn next_action(&self, now_us: u32) -> Action {
        match self.state {
            State::Ready { not_before_us } => match not_before_us {
                Some(t) if !reached(now_us, t) => Action::Wait { until_us: t },
                _ => {
                    let channel = self.next_channel();
                    Action::Start {
                        channel,
                        osr: self.config.osr(channel),
                    }
                }
            },
            State::Converting {
                channel,
                ready_at_us,
            } => {
                if reached(now_us, ready_at_us) {
                    Action::Read { channel }
                } else {
                    Action::Wait {
                        until_us: ready_at_us,
                    }
                }
            }
        }
    }

    /// Record that the conversion command for `channel` (at the configured
    /// OSR) was sent at (or after) `now_us`.
    pub fn on_conversion_started(&mut self, channel: Channel, now_us: u32) {
        self.state = State::Converting {
            channel,
            ready_at_us: now_us.wrapping_add(self.config.conversion_wait_us(channel)),
        };
    }

    /// Record a failed bus transfer at `now_us`: the conversion in flight is
    /// dropped and the next one starts after [`SamplerConfig::recovery_us`].
    pub fn on_bus_error(&mut self, now_us: u32) {
        self.error_count = self.error_count.wrapping_add(1);
        self.state = State::Ready {
            not_before_us: Some(now_us.wrapping_add(self.config.recovery_us())),
        };
    }

    /// Hand over the raw value of an ADC read made at `now_us` (0 included:
    /// it is reported as [`SampleError::AdcNotReady`]). Returns the new
    /// measurement after a D1, `None` after a D2 (or a D1 with no
    /// temperature yet). On error the sampler recovers as in
    /// [`Sampler::on_bus_error`]; with no conversion in flight it returns
    /// [`SampleError::NoConversionInFlight`] and changes nothing.
    pub fn on_adc_read(
        &mut self,
        prom: &Prom,
        raw: u32,
        now_us: u32,
    ) -> Result<Option<Measurement>, SampleError> {
        let State::Converting { channel, .. } = self.state else {
            return Err(SampleError::NoConversionInFlight);
        };
        if raw == 0 {
            self.on_bus_error(now_us);
            return Err(SampleError::AdcNotReady);
        }
        if raw >= crate::ADC_LIMIT {
            self.on_bus_error(now_us);
            return Err(SampleError::RawOutOfRange(RawOutOfRange { channel, raw }));
        }
        self.state = State::Ready {
            not_before_us: None,
        };
        match channel {
            Channel::Temperature => {
                self.d2 = Some(raw);
                self.pressures_since_temperature = 0;
                Ok(None)
            }
            Channel::Pressure => {
                let Some(d2) = self.d2 else {
                    return Ok(None);
                };
                self.pressures_since_temperature =
                    self.pressures_since_temperature.saturating_add(1);
                match compensate(prom, raw, d2) {
                    Ok(m) => Ok(Some(m)),
                    Err(e) => {
                        // Unreachable (both values were range-checked), but
                        // recover like any other error rather than assume.
                        self.on_bus_error(now_us);
                        Err(SampleError::RawOutOfRange(e))
                    }
                }
            }
        }
    }
}

#[maybe_async_cfg::maybe(
    idents(
        Ms5611(sync, async = "Ms5611Async"),
        Interface(sync, async = "InterfaceAsync"),
        poll(sync, async = "poll_async"),
        start(sync, async = "start_async")
    ),
    sync(keep_self),
    async(feature = "async", keep_self)
)]
impl Sampler {
    /// Drive the schedule over the bus at `now_us` (wrapping µs clock, taken
    /// just before the call). Never blocks: at most one ADC read plus one
    /// conversion command per call.
    ///
    /// Returns `Ok(Some(_))` when a D1 conversion completed into a new
    /// measurement, `Ok(None)` otherwise. Needs the driver's PROM
    /// ([`Error::NotInitialised`], no bus traffic). Errors are returned and
    /// the schedule recovers by itself (see the module docs). One exception
    /// so that no data is lost: if the ADC read produced a measurement but
    /// starting the next conversion failed, the measurement is returned, the
    /// failure is only counted in [`Sampler::error_count`], and the start is
    /// retried after the recovery wait (where a persisting fault is
    /// returned).
    pub async fn poll<DI: Interface>(
        &mut self,
        dev: &mut Ms5611<DI>,
        now_us: u32,
    ) -> Result<Option<Measurement>, Error<DI::Error>> {
        let Some(prom) = dev.prom().copied() else {
            return Err(Error::NotInitialised);
        };
        match self.next_action(now_us) {
            Action::Wait { .. } => Ok(None),
            Action::Start { channel, osr } => {
                Self::start(self, dev, channel, osr, now_us).await?;
                Ok(None)
            }
            Action::Read { .. } => {
                let raw = match dev.read_adc_raw().await {
                    Ok(raw) => raw,
                    Err(e) => {
                        self.on_bus_error(now_us);
                        return Err(e);
                    }
                };
                let measurement = self.on_adc_read(&prom, raw, now_us)?;
                if let Action::Start { channel, osr } = self.next_action(now_us) {
                    if let Err(e) = Self::start(self, dev, channel, osr, now_us).await {
                        if measurement.is_none() {
                            return Err(e);
                        }
                    }
                }
                Ok(measurement)
            }
        }
    }

    async fn start<DI: Interface>(
        &mut self,
        dev: &mut Ms5611<DI>,
        channel: Channel,
        osr: Osr,
        now_us: u32,
    ) -> Result<(), Error<DI::Error>> {
        match dev.start_conversion(channel, osr).await {
            Ok(()) => {
                self.on_conversion_started(channel, now_us);
                Ok(())
            }
            Err(e) => {
                self.on_bus_error(now_us);
                Err(e)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reached_handles_wrap() {
        assert!(reached(5, 5));
        assert!(reached(6, 5));
        assert!(!reached(4, 5));
        assert!(reached(10, u32::MAX - 10));
        assert!(!reached(u32::MAX - 10, 10));
        // A clock stepping backwards never counts as reached.
        assert!(!reached(1000, 2000));
    }

    #[test]
    fn guard_and_waits() {
        let c = SamplerConfig::new()
            .with_pressure_osr(Osr::Osr256)
            .with_temperature_osr(Osr::Osr1024)
            .with_guard_us(u32::MAX);
        assert_eq!(c.guard_us(), MAX_GUARD_US);
        assert_eq!(c.conversion_wait_us(Channel::Pressure), 600 + MAX_GUARD_US);
        assert_eq!(c.recovery_us(), 2280 + MAX_GUARD_US);
        assert_eq!(guard_for_bus_hz(0), MAX_GUARD_US);
        assert_eq!(guard_for_bus_hz(1), MAX_GUARD_US);
        assert_eq!(SamplerConfig::DEFAULT_PRESSURES_PER_TEMPERATURE.get(), 10);
    }
}
