//! The three chips on the shared I2C bus with their health bookkeeping:
//! boot-time probing, per-sample reads with bounded retries, periodic
//! configuration checks (a chip that reset itself is re-initialised), and
//! the hooks around a stuck-bus recovery.
//!
//! Each driver owns its own bus handle of type `I` (the firmware passes
//! `embedded_hal_bus` devices, or one handle per chip over a shared bus;
//! the tests pass handles onto the simulator). Nothing here blocks except
//! [`Sensors::boot`] and [`Sensors::service`] (chip resets need a few ms of
//! delay); call those from boot or a low-priority context.

use ak8963::{Ak8963, RawMag};
use embedded_hal::{delay::DelayNs, i2c::I2c};
use mpu9250::{Address as MpuAddress, Mpu9250, RawSample};
use ms5611::{Address as BaroAddress, Measurement, Ms5611, Sampler, SamplerConfig};

use crate::boot::{probe_with_retries, BootReport, Chip, ProbeFailure, ProbeResult};
use crate::health::{needs_bus_recovery, Action, HealthPolicy, SensorHealth};

/// Settings for [`Sensors`].
#[derive(Clone, Copy, Debug)]
pub struct SensorsConfig {
    /// MPU-9250 configuration (the default: 1 kHz, ±4 g, ±1000 °/s, data-ready INT).
    pub mpu: mpu9250::Config,
    /// MPU-9250 address.
    pub mpu_address: MpuAddress,
    /// AK8963 configuration (the default: continuous 100 Hz, 16 bit).
    pub mag: ak8963::Config,
    /// MS5611 conversion schedule.
    pub baro: SamplerConfig,
    /// MS5611 address.
    pub baro_address: BaroAddress,
    /// Probe attempts per chip at boot.
    pub probe_attempts: u8,
    /// Wait between probe attempts, ms.
    pub probe_retry_ms: u32,
    /// Retry / re-init / failure thresholds.
    pub policy: HealthPolicy,
}

impl Default for SensorsConfig {
    fn default() -> Self {
        Self {
            mpu: mpu9250::Config::default(),
            mpu_address: MpuAddress::Ad0Low,
            mag: ak8963::Config::default(),
            baro: SamplerConfig::new(),
            baro_address: BaroAddress::CsbLow,
            probe_attempts: 3,
            probe_retry_ms: 10,
            policy: HealthPolicy::default(),
        }
    }
}

/// Result of a magnetometer read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MagRead {
    /// A new measurement (counts, AK8963 frame).
    Sample(RawMag),
    /// No new data yet (DRDY clear).
    NotReady,
    /// Magnetic overflow: the measurement was dropped.
    Overflow,
    /// Missing, failed or the bus failed after retries.
    Unavailable,
}

/// What [`Sensors::service`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServiceReport {
    /// Re-initialisations attempted, per chip (MPU, AK8963, MS5611):
    /// `Some(true)` succeeded, `Some(false)` failed.
    pub reinit: [Option<bool>; 3],
}

/// The chips, their health, and the barometer schedule.
pub struct Sensors<I> {
    cfg: SensorsConfig,
    mpu: Mpu9250<I>,
    mag: Ak8963<I>,
    baro: Ms5611<I>,
    sampler: Sampler,
    /// MPU-9250 health.
    pub mpu_health: SensorHealth,
    /// AK8963 health.
    pub mag_health: SensorHealth,
    /// MS5611 health.
    pub baro_health: SensorHealth,
    reinit_pending: [bool; 3],
    bus_recoveries: u32,
}

fn classify_mpu<E>(e: &mpu9250::Error<E>) -> ProbeFailure {
    match e {
        mpu9250::Error::Bus(_) => ProbeFailure::NoResponse,
        mpu9250::Error::WrongChipId(id) => ProbeFailure::WrongId { found: *id },
        mpu9250::Error::Mpu6500Detected => ProbeFailure::Mpu6500,
        _ => ProbeFailure::InitFailed,
    }
}

fn classify_mag<E>(e: &ak8963::Error<E>) -> ProbeFailure {
    match e {
        ak8963::Error::Bus(_) => ProbeFailure::NoResponse,
        ak8963::Error::WrongId(id) => ProbeFailure::WrongId { found: *id },
        _ => ProbeFailure::InitFailed,
    }
}

fn classify_baro<E>(e: &ms5611::Error<E>) -> ProbeFailure {
    match e {
        ms5611::Error::Bus(_) => ProbeFailure::NoResponse,
        ms5611::Error::PromCrc { .. } | ms5611::Error::PromBlank => ProbeFailure::BadProm,
        _ => ProbeFailure::InitFailed,
    }
}

fn to_result<T>(chip: Chip, r: Result<(T, u8), (ProbeFailure, u8)>) -> ProbeResult {
    match r {
        Ok((_, attempts)) => ProbeResult {
            chip,
            status: Ok(()),
            attempts,
        },
        Err((f, attempts)) => ProbeResult {
            chip,
            status: Err(f),
            attempts,
        },
    }
}

impl<I: I2c> Sensors<I> {
    /// Probes and configures all three chips with bounded retries and
    /// returns the set with the verdicts. A chip that failed is marked
    /// `Missing` and never touched again; the AK8963 is only probed if the
    /// MPU-9250 (its bypass) came up.
    pub fn boot<D: DelayNs>(
        mpu_bus: I,
        mag_bus: I,
        baro_bus: I,
        delay: &mut D,
        cfg: SensorsConfig,
    ) -> (Self, BootReport) {
        let mut mpu = Mpu9250::new(mpu_bus, cfg.mpu_address);
        let mut mag = Ak8963::new(mag_bus);
        let mut baro = Ms5611::new(baro_bus, cfg.baro_address);
        let mpu_cfg = cfg.mpu;
        let mpu_r = to_result(
            Chip::Mpu9250,
            probe_with_retries(
                cfg.probe_attempts,
                cfg.probe_retry_ms,
                delay,
                |d| {
                    mpu.init(d, &mpu_cfg)?;
                    mpu.set_bypass(true)
                },
                classify_mpu,
            ),
        );
        let mag_r = if mpu_r.present() {
            let mag_cfg = cfg.mag;
            to_result(
                Chip::Ak8963,
                probe_with_retries(
                    cfg.probe_attempts,
                    cfg.probe_retry_ms,
                    delay,
                    |d| mag.init(d, &mag_cfg),
                    classify_mag,
                ),
            )
        } else {
            ProbeResult {
                chip: Chip::Ak8963,
                status: Err(ProbeFailure::DependencyMissing),
                attempts: 0,
            }
        };
        let baro_r = to_result(
            Chip::Ms5611,
            probe_with_retries(
                cfg.probe_attempts,
                cfg.probe_retry_ms,
                delay,
                |d| baro.init(d),
                classify_baro,
            ),
        );
        let health = |r: &ProbeResult| {
            if r.present() {
                SensorHealth::new(cfg.policy)
            } else {
                SensorHealth::missing(cfg.policy)
            }
        };
        let report = BootReport {
            mpu: mpu_r,
            mag: mag_r,
            baro: baro_r,
        };
        let s = Self {
            cfg,
            mpu,
            mag,
            baro,
            sampler: Sampler::new(cfg.baro),
            mpu_health: health(&mpu_r),
            mag_health: health(&mag_r),
            baro_health: health(&baro_r),
            reinit_pending: [false; 3],
            bus_recoveries: 0,
        };
        (s, report)
    }

    /// Gyro/accelerometer scale of the configured ranges.
    pub fn mpu_scale(&self) -> mpu9250::Scale {
        self.mpu.scale()
    }

    /// AK8963 µT per count (factory adjustment included), AK8963 frame.
    pub fn mag_ut_per_lsb(&self) -> [f32; 3] {
        self.mag.ut_per_lsb()
    }

    /// Reads one raw IMU sample (counts, MPU frame, no bias removed) with
    /// bounded retries. `None` if the MPU is unusable or the read failed.
    pub fn read_imu(&mut self) -> Option<RawSample> {
        if !self.mpu_health.usable() {
            return None;
        }
        let mpu = &mut self.mpu;
        let r = self.mpu_health.with_retries(|| mpu.read_raw());
        if r.is_err() && self.mpu_health.pending_action() == Action::Reinit {
            self.reinit_pending[0] = true;
        }
        r.ok()
    }

    /// Reads the magnetometer if a measurement is ready.
    pub fn read_mag(&mut self) -> MagRead {
        if !self.mag_health.usable() {
            return MagRead::Unavailable;
        }
        let mag = &mut self.mag;
        let r = self.mag_health.with_retries(|| match mag.read_raw() {
            Ok(raw) => Ok(MagRead::Sample(raw)),
            Err(ak8963::Error::NotReady) => Ok(MagRead::NotReady),
            Err(ak8963::Error::Overflow) => Ok(MagRead::Overflow),
            Err(e) => Err(e),
        });
        match r {
            Ok(MagRead::NotReady) => {
                self.mag_health.not_ready();
                MagRead::NotReady
            }
            Ok(MagRead::Overflow) => {
                self.mag_health.overflow();
                MagRead::Overflow
            }
            Ok(MagRead::Sample(raw)) => {
                if raw.data_overrun {
                    self.mag_health.overflow();
                }
                MagRead::Sample(raw)
            }
            Ok(MagRead::Unavailable) => MagRead::Unavailable,
            Err(_) => {
                if self.mag_health.pending_action() == Action::Reinit {
                    self.reinit_pending[1] = true;
                }
                MagRead::Unavailable
            }
        }
    }

    /// Advances the barometer schedule at `now_us` (never blocks; at most
    /// one ADC read and one command). A new pressure comes back as `Some`.
    pub fn poll_baro(&mut self, now_us: u32) -> Option<Measurement> {
        if !self.baro_health.usable() {
            return None;
        }
        match self.sampler.poll(&mut self.baro, now_us) {
            Ok(Some(m)) => {
                self.baro_health.success();
                Some(m)
            }
            Ok(None) => None,
            Err(ms5611::Error::AdcNotReady) => {
                // Conversion lost (the chip reset itself or was disturbed);
                // the sampler waits and restarts by itself.
                self.baro_health.not_ready();
                if self.baro_health.error() == Action::Reinit {
                    self.reinit_pending[2] = true;
                }
                None
            }
            Err(_) => {
                if self.baro_health.error() == Action::Reinit {
                    self.reinit_pending[2] = true;
                }
                None
            }
        }
    }

    /// The barometer schedule's next deadline (wrapping µs), for a timer.
    pub fn baro_deadline_us(&self) -> Option<u32> {
        self.sampler.next_deadline_us()
    }

    /// Reads back the MPU-9250 and AK8963 configuration registers; a
    /// mismatch means the chip reset itself and schedules a
    /// re-initialisation. Returns `true` if any mismatch was found. Call
    /// every ~100 ms.
    pub fn check_configs(&mut self) -> bool {
        let mut found = false;
        let mut mpu_ok = true;
        if self.mpu_health.usable() {
            match self.mpu.verify_config() {
                Ok(()) => self.mpu_health.success(),
                Err(mpu9250::Error::ConfigMismatch { .. }) => {
                    found = true;
                    mpu_ok = false;
                    self.reinit_pending[0] |= self.mpu_health.config_mismatch() == Action::Reinit;
                }
                Err(_) => {
                    mpu_ok = false;
                    self.reinit_pending[0] |= self.mpu_health.error() == Action::Reinit;
                }
            }
        }
        // The AK8963 is reached through the MPU-9250's bypass: if the MPU
        // reset itself (bypass off) the AK8963 cannot answer; check it on
        // the next round, after the MPU's re-initialisation.
        if mpu_ok && self.mag_health.usable() {
            match self.mag.verify_config() {
                Ok(()) => self.mag_health.success(),
                Err(ak8963::Error::ConfigMismatch { .. }) => {
                    found = true;
                    self.reinit_pending[1] |= self.mag_health.config_mismatch() == Action::Reinit;
                }
                Err(_) => self.reinit_pending[1] |= self.mag_health.error() == Action::Reinit,
            }
        }
        found
    }

    /// `true` if any re-initialisation is pending (call [`service`](Self::service)).
    pub fn service_due(&self) -> bool {
        self.reinit_pending.iter().any(|p| *p)
    }

    /// Runs the pending re-initialisations (blocking: chip resets take a
    /// few ms up to ~200 ms for a slow MPU-9250 reset). The MPU goes first
    /// because the AK8963 is reached through its bypass.
    pub fn service<D: DelayNs>(&mut self, delay: &mut D) -> ServiceReport {
        let mut report = ServiceReport::default();
        let [mpu_p, mag_p, baro_p] = self.reinit_pending;
        self.reinit_pending = [false; 3];
        if mpu_p && !matches!(self.mpu_health.state(), crate::health::SensorState::Missing) {
            let cfg = self.cfg.mpu;
            let ok = self.mpu.init(delay, &cfg).is_ok() && self.mpu.set_bypass(true).is_ok();
            self.mpu_health.reinit_done(ok);
            report.reinit[0] = Some(ok);
        }
        if mag_p && !matches!(self.mag_health.state(), crate::health::SensorState::Missing) {
            let cfg = self.cfg.mag;
            let ok = self.mag.init(delay, &cfg).is_ok();
            self.mag_health.reinit_done(ok);
            report.reinit[1] = Some(ok);
        }
        if baro_p
            && !matches!(
                self.baro_health.state(),
                crate::health::SensorState::Missing
            )
        {
            let ok = self.baro.init(delay).is_ok();
            if ok {
                self.sampler.restart();
            }
            self.baro_health.reinit_done(ok);
            report.reinit[2] = Some(ok);
        }
        report
    }

    /// `true` when every present chip keeps failing: the bus is stuck.
    pub fn needs_bus_recovery(&self) -> bool {
        needs_bus_recovery(&[&self.mpu_health, &self.mag_health, &self.baro_health])
    }

    /// After the caller freed the bus ([`crate::health::recover_bus`]) and
    /// re-created the I2C peripheral: revive failed chips and schedule a
    /// re-initialisation of every present one.
    pub fn after_bus_recovery(&mut self) {
        self.bus_recoveries = self.bus_recoveries.saturating_add(1);
        for (h, p) in [
            &mut self.mpu_health,
            &mut self.mag_health,
            &mut self.baro_health,
        ]
        .into_iter()
        .zip(self.reinit_pending.iter_mut())
        {
            if h.state() != crate::health::SensorState::Missing {
                h.revive();
                *p = true;
            }
        }
    }

    /// Stuck-bus recoveries performed.
    pub fn bus_recoveries(&self) -> u32 {
        self.bus_recoveries
    }

    /// Direct access to the MPU-9250 driver (calibration, tests).
    pub fn mpu(&mut self) -> &mut Mpu9250<I> {
        &mut self.mpu
    }

    /// Direct access to the AK8963 driver.
    pub fn mag(&mut self) -> &mut Ak8963<I> {
        &mut self.mag
    }

    /// Direct access to the MS5611 driver.
    pub fn baro(&mut self) -> &mut Ms5611<I> {
        &mut self.baro
    }
}
