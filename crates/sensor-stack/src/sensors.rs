//! The three chips on the shared I2C bus with their health bookkeeping:
//! boot-time probing, per-sample reads (one attempt: a failed read is
//! counted and the sample skipped), periodic configuration checks (a chip
//! that reset itself is re-initialised), stuck-bus recovery requests, and
//! the re-probing of missing chips with back-off.
//!
//! Each driver owns its own bus handle of type `I` (the firmware passes
//! one zero-sized handle per chip over a shared bus; the tests pass handles
//! onto the simulator). Nothing here blocks except [`Sensors::boot`],
//! [`Sensors::service`] and, disarmed, one step of [`Sensors::maintain`]
//! (the AK8963's and MS5611's resets and the re-probes need a few ms of
//! delay); call those from boot or a low-priority context.
//!
//! The per-sample read also comes split for an interrupt-driven bus:
//! [`Sensors::plan_sample`] says which register blocks to read (the
//! MPU-9250's 14-byte sample, the AK8963's ST1 and, only if ST1 shows
//! DRDY, HXL..ST2), the caller's transfer engine reads them into a
//! [`SampleBytes`] buffer without blocking, and [`Sensors::finish_sample`]
//! parses them with the drivers' pure functions and keeps the same health
//! books as [`Sensors::read_sample`].
//!
//! Background maintenance ([`Sensors::maintain`]) does one thing per call,
//! so a caller that holds a lock around each call never holds it for more
//! than one step:
//! 1. a bus recovery when one was requested ([`Sensors::request_bus_recovery`],
//!    e.g. the I2C peripheral saw BUSY while idle) or every present chip
//!    keeps failing;
//! 2. one step of the MPU-9250's re-initialisation, which never waits:
//!    WHO_AM_I and H_RESET; one PWR_MGMT_1 poll per call until the reset
//!    is over (at most [`MPU_RESET_TIMEOUT_MS`]), then, in the same call,
//!    the configuration writes; their read-back. Each step is a few
//!    register transfers, at most ~0.8 ms of bus time at 400 kHz (the poll
//!    and the writes): less than one 1 kHz sample period;
//! 3. the MPU-9250's check [`SensorsConfig::mpu_settle_ms`] after its
//!    reset (WHO_AM_I and the configuration read-back, PWR_MGMT_1
//!    included, as PX4 does); its samples are not used before;
//! 4. the re-check of a suspect MPU-9250 (below);
//! 5. a pending re-initialisation of the AK8963, then the MS5611;
//! 6. a re-probe of one missing (or failed) chip when its [`Backoff`]
//!    expires, preceded by a bus recovery when no chip answers at all.
//!
//! # Armed
//!
//! An MPU-9250 reset costs its samples for the reset and the 100 ms
//! settle after it, which the flight controller flies open loop (its
//! sensor-loss bridge, 0.25 s, in `flight::flightctl`); a glitch or a
//! NACK burst costs a few samples at most. So while the caller says the
//! craft is armed ([`Sensors::set_armed`]) the MPU-9250 is reset only once
//! it is proven lost ([`crate::health::ResetPolicy`]): a failed read
//! streak, a configuration read-back mismatch or a bus recovery only make
//! it suspect, and [`Sensors::maintain`] re-checks it (WHO_AM_I and the
//! configuration read-back) at most every 5 ms; a wrong answer on 2
//! re-checks in a row, or no answer on 20 (≥ 100 ms), resets it
//! (stepwise, as above). Its samples keep flowing while it is suspect. A
//! chip that reset itself stops its data-ready interrupt: the caller says
//! how long the samples have been away ([`Sensors::mpu_sample_gap`]), and
//! past [`MPU_STALL_US`] the chip is re-checked at once; while it answers
//! wrong, is reset or settles ([`Sensors::mpu_recovering`]), the caller's
//! output guard bridges the missing samples
//! (`flight::outputguard`).
//! Measured on the simulator's 400 kHz bus (`tests/mpu_reset_in_flight.rs`):
//! the longest step 0.82 ms (the reset poll with the configuration
//! writes), the configuration check 0.55 ms. The AK8963's and MS5611's
//! re-initialisations (whose resets wait 1–3 ms) and every re-probe wait
//! until the craft is disarmed: the AHRS flies on the gyro and
//! accelerometer, and the barometer's schedule restarts a lost conversion
//! by itself.

use ak8963::{parse_status_block, Ak8963, RawMag};
use embedded_hal::{delay::DelayNs, i2c::I2c};
use mpu9250::{parse_sample, Address as MpuAddress, Mpu9250, RawSample};
use ms5611::{Address as BaroAddress, Measurement, Ms5611, Sampler, SamplerConfig};

use crate::boot::{probe_with_retries, BootReport, Chip, ProbeFailure, ProbeResult};
use crate::boot::{AhrsMode, Capabilities};
use crate::health::{
    needs_bus_recovery, Action, HealthPolicy, ResetGate, ResetPolicy, ResetVerdict, SensorHealth,
    SensorState,
};
use crate::schedule::Backoff;

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
    /// When an armed craft may reset the MPU-9250.
    pub reset_policy: ResetPolicy,
    /// Wait after the MPU-9250's power-up and after each of its resets
    /// before its registers are trusted, ms (datasheet: 100 ms start-up;
    /// PX4 waits 100 ms after a reset).
    pub mpu_settle_ms: u32,
    /// First re-probe of a missing chip after boot, ms.
    pub reprobe_first_ms: u32,
    /// Longest interval between re-probes of a missing chip, ms.
    pub reprobe_max_ms: u32,
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
            reset_policy: ResetPolicy::default(),
            mpu_settle_ms: 100,
            reprobe_first_ms: 1_000,
            reprobe_max_ms: 32_000,
        }
    }
}

/// What one call of [`Sensors::maintain`] did or asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Maintenance {
    /// Nothing was due.
    Idle,
    /// The caller must free the bus now (clock SCL, STOP, unlock BUSY,
    /// reset the I2C peripheral; [`crate::health::recover_bus`],
    /// [`crate::health::unlock_busy_flag`]) and then call
    /// [`Sensors::after_bus_recovery`].
    RecoverBus,
    /// A chip was re-initialised (`ok`: it answered and took its
    /// configuration).
    Reinitialised {
        /// Which chip.
        chip: Chip,
        /// Success.
        ok: bool,
    },
    /// One step of the MPU-9250's re-initialisation ran (the reset or its
    /// poll, the configuration writes); the last step reports
    /// [`Maintenance::Reinitialised`].
    MpuResetStep,
    /// The MPU-9250's check ran, [`SensorsConfig::mpu_settle_ms`] after
    /// its reset or as the re-check of a suspect chip: `ok` means WHO_AM_I
    /// and the configuration read back right and its samples are used
    /// (again).
    Settled {
        /// Success.
        ok: bool,
    },
    /// A chip that was missing (or failed) answered a re-probe and is now
    /// in use: update the capabilities ([`Sensors::capabilities`]).
    Appeared(Chip),
    /// A missing chip's re-probe failed; the next one is `retry_in_ms`
    /// away.
    StillMissing {
        /// Which chip.
        chip: Chip,
        /// Back-off until the next attempt, ms.
        retry_in_ms: u32,
    },
}

/// No sample step for this long while the MPU-9250 counts as healthy:
/// it is suspect ([`Sensors::mpu_sample_gap`]). 10 ms: the flight
/// controller's hold of its last commands (`flight::flightctl::BAD_INPUT_HOLD_US`,
/// which asserts the two equal; this crate does not depend on the
/// controller); a healthy board's gaps are shorter but for a flash page
/// erase (≤ 40 ms), which costs one re-check that finds the chip right.
pub const MPU_STALL_US: u32 = 10_000;

/// Longest wait for the MPU-9250's H_RESET to clear, ms (the driver's
/// blocking `init` polls as long).
pub const MPU_RESET_TIMEOUT_MS: u32 =
    mpu9250::RESET_MAX_POLLS as u32 * mpu9250::RESET_POLL_INTERVAL_MS;

/// Where the MPU-9250's stepwise re-initialisation stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MpuReset {
    /// Not running.
    Idle,
    /// H_RESET written at this ms time; polling it, then writing the
    /// configuration in the step that finds the reset over.
    Polling(u32),
    /// Configuration written: read it back next.
    Verify,
}

/// First wait before retrying a bus recovery that failed, ms.
pub const RECOVERY_RETRY_FIRST_MS: u32 = 20;
/// Longest wait between failing bus recoveries, ms.
pub const RECOVERY_RETRY_MAX_MS: u32 = 1_000;

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

/// Buffer offset of the AK8963's ST1 byte in [`SampleBytes`]: the
/// MPU-9250's block comes first, and ST1..ST2 lie contiguous after it as
/// [`ak8963::parse_status_block`] reads them.
const ST1_OFFSET: usize = mpu9250::register::SAMPLE_LEN;
/// Length of one sample's bytes: the MPU-9250's ACCEL..GYRO block, then
/// the AK8963's ST1..ST2 block.
pub const SAMPLE_BYTES: usize = ST1_OFFSET + ak8963::register::STATUS_BLOCK_LEN;
/// One sample's bytes as [`SamplePlan`]'s blocks fill them.
pub type SampleBytes = [u8; SAMPLE_BYTES];

/// A condition on an earlier block of the same plan: run only if that
/// block completed and `bytes[byte] & mask != 0`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OnlyIf {
    /// Index of the block that must have completed.
    pub block: u8,
    /// Offset of the tested byte in [`SampleBytes`].
    pub byte: u8,
    /// Bits of which at least one must be set.
    pub mask: u8,
}

/// One register-block read: write `register` to the 7-bit `address`,
/// repeated START, read `len` bytes into [`SampleBytes`] at `offset`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockRead {
    /// 7-bit I2C address.
    pub address: u8,
    /// First register.
    pub register: u8,
    /// Offset of the first byte in [`SampleBytes`].
    pub offset: u8,
    /// Bytes to read (1 or at least 3: the lengths whose endings need no
    /// timing from the master beyond its highest interrupt priority).
    pub len: u8,
    /// Skip this block unless the condition holds.
    pub only_if: Option<OnlyIf>,
}

/// The blocks one sample reads, in order; `None` entries are not read.
/// Index 0: MPU-9250 sample; 1: AK8963 ST1; 2: AK8963 HXL..ST2.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SamplePlan {
    /// The blocks.
    pub blocks: [Option<BlockRead>; 3],
}

/// What became of each block of a [`SamplePlan`]: `None` not read (absent
/// from the plan, or its condition did not hold), else the transfer's
/// result.
pub type BlockResults<E> = [Option<Result<(), E>>; 3];

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
    recovery_requested: bool,
    /// A recovery ran since the last re-probe round: the next probe may go
    /// ahead even though no chip answers.
    fresh_recovery: bool,
    /// The MPU-9250's samples are held back until this ms time (after its
    /// reset), then it is checked.
    mpu_settle_until_ms: Option<u32>,
    reprobe: [Backoff; 3],
    /// The craft is armed: resets wait for proof, re-probes wait.
    armed: bool,
    /// The MPU-9250 became suspect while armed; the gate is told at the
    /// next [`maintain`](Sensors::maintain) (which knows the time).
    mpu_suspect: bool,
    mpu_gate: ResetGate,
    mpu_reset: MpuReset,
    /// Spaces out recoveries that failed (SDA held by a short, not a slave).
    recovery_backoff: Backoff,
    recovery_failing: bool,
}

/// PX4's post-reset check: the chip answers as an MPU-9250 and every
/// configuration register (PWR_MGMT_1 included) reads back as written.
fn mpu_settled<I: I2c>(mpu: &mut Mpu9250<I>) -> Result<(), mpu9250::Error<I::Error>> {
    mpu.who_am_i()?;
    mpu.verify_config()
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

/// One chip's boot probe: `op` with the configured retries, its errors
/// sorted by `classify`.
fn probe_chip<T, E, D: DelayNs>(
    chip: Chip,
    cfg: &SensorsConfig,
    delay: &mut D,
    op: impl FnMut(&mut D) -> Result<T, E>,
    classify: impl Fn(&E) -> ProbeFailure,
) -> ProbeResult {
    to_result(
        chip,
        probe_with_retries(cfg.probe_attempts, cfg.probe_retry_ms, delay, op, classify),
    )
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
    /// returns the set with the verdicts. Waits
    /// [`SensorsConfig::mpu_settle_ms`] for the MPU-9250's power-up first,
    /// and as long again after its reset before checking WHO_AM_I and the
    /// configuration. A chip that failed is marked `Missing` and re-probed
    /// with back-off by [`maintain`](Self::maintain); the AK8963 is only
    /// probed if the MPU-9250 (its bypass) came up. Free the bus before
    /// calling this (a reset during a transfer can leave a slave holding
    /// SDA low).
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
        // Power-up: the MPU-9250's registers are not reliable before.
        delay.delay_ms(cfg.mpu_settle_ms);
        let mpu_r = probe_chip(
            Chip::Mpu9250,
            &cfg,
            delay,
            |d| {
                mpu.init(d, &mpu_cfg)?;
                mpu.set_bypass(true)?;
                d.delay_ms(cfg.mpu_settle_ms);
                mpu_settled(&mut mpu)
            },
            classify_mpu,
        );
        let mag_r = if mpu_r.present() {
            let mag_cfg = cfg.mag;
            probe_chip(
                Chip::Ak8963,
                &cfg,
                delay,
                |d| mag.init(d, &mag_cfg),
                classify_mag,
            )
        } else {
            ProbeResult {
                chip: Chip::Ak8963,
                status: Err(ProbeFailure::DependencyMissing),
                attempts: 0,
            }
        };
        let baro_r = probe_chip(Chip::Ms5611, &cfg, delay, |d| baro.init(d), classify_baro);
        let report = BootReport {
            mpu: mpu_r,
            mag: mag_r,
            baro: baro_r,
        };
        (Self::after_boot(cfg, mpu, mag, baro, &report), report)
    }

    /// The set as [`boot`](Self::boot) leaves it: each chip's health starts
    /// from its probe verdict, no recovery or re-probe pending.
    fn after_boot(
        cfg: SensorsConfig,
        mpu: Mpu9250<I>,
        mag: Ak8963<I>,
        baro: Ms5611<I>,
        report: &BootReport,
    ) -> Self {
        let health = |r: &ProbeResult| {
            if r.present() {
                SensorHealth::new(cfg.policy)
            } else {
                SensorHealth::missing(cfg.policy)
            }
        };
        Self {
            cfg,
            mpu,
            mag,
            baro,
            sampler: Sampler::new(cfg.baro),
            mpu_health: health(&report.mpu),
            mag_health: health(&report.mag),
            baro_health: health(&report.baro),
            reinit_pending: [false; 3],
            bus_recoveries: 0,
            recovery_requested: false,
            fresh_recovery: false,
            mpu_settle_until_ms: None,
            reprobe: [Backoff::new(cfg.reprobe_first_ms, cfg.reprobe_max_ms); 3],
            armed: false,
            mpu_suspect: false,
            mpu_gate: ResetGate::new(cfg.reset_policy),
            mpu_reset: MpuReset::Idle,
            recovery_backoff: Backoff::new(RECOVERY_RETRY_FIRST_MS, RECOVERY_RETRY_MAX_MS),
            recovery_failing: false,
        }
    }

    /// Gyro/accelerometer scale of the configured ranges.
    pub fn mpu_scale(&self) -> mpu9250::Scale {
        self.mpu.scale()
    }

    /// AK8963 µT per count (factory adjustment included), AK8963 frame.
    pub fn mag_ut_per_lsb(&self) -> [f32; 3] {
        self.mag.ut_per_lsb()
    }

    /// Reads one raw IMU sample (counts, MPU frame, no bias removed): one
    /// attempt, a failure is counted and the sample skipped. `None` if the
    /// MPU is unusable, settling after a reset, or the read failed.
    pub fn read_imu(&mut self) -> Option<RawSample> {
        if !self.mpu_usable() {
            return None;
        }
        let r = self.mpu.read_raw();
        self.record_imu(r)
    }

    fn record_imu(&mut self, r: Result<RawSample, mpu9250::Error<I::Error>>) -> Option<RawSample> {
        let r = self.mpu_health.record(r);
        if r.is_err() && self.mpu_health.pending_action() == Action::Reinit {
            self.mpu_trouble();
        }
        r.ok()
    }

    /// The 1 kHz task's bus work: the IMU sample, and the magnetometer on
    /// its tick (whatever happened to the IMU read).
    pub fn read_sample(&mut self, read_mag: bool) -> (Option<RawSample>, MagRead) {
        let imu = self.read_imu();
        let mag = if read_mag {
            self.read_mag()
        } else {
            MagRead::NotReady
        };
        (imu, mag)
    }

    /// The register blocks [`read_sample`](Self::read_sample) would read,
    /// for a caller that reads them without blocking: the MPU-9250's
    /// sample if it is usable; on a magnetometer tick with both chips
    /// usable, the AK8963's ST1 and, on condition of its DRDY bit, HXL..ST2
    /// (the driver's own order: a block read while DRDY is clear would
    /// start a data read and make the chip skip a measurement that ends
    /// during it). Each block is one attempt, whatever became of the
    /// others.
    pub fn plan_sample(&self, read_mag: bool) -> SamplePlan {
        let mut plan = SamplePlan::default();
        if !self.mpu_usable() {
            return plan;
        }
        plan.blocks[0] = Some(BlockRead {
            address: self.mpu.address(),
            register: mpu9250::register::ACCEL_XOUT_H,
            offset: 0,
            len: mpu9250::register::SAMPLE_LEN as u8,
            only_if: None,
        });
        if read_mag && self.mag_health.usable() {
            let address = self.mag.address();
            plan.blocks[1] = Some(BlockRead {
                address,
                register: ak8963::register::ST1,
                offset: ST1_OFFSET as u8,
                len: 1,
                only_if: None,
            });
            plan.blocks[2] = Some(BlockRead {
                address,
                register: ak8963::register::HXL,
                offset: ST1_OFFSET as u8 + 1,
                len: ak8963::register::MEASUREMENT_LEN as u8,
                only_if: Some(OnlyIf {
                    block: 1,
                    byte: ST1_OFFSET as u8,
                    mask: ak8963::register::ST1_DRDY,
                }),
            });
        }
        plan
    }

    /// Parses and books what a [`plan_sample`](Self::plan_sample) read
    /// brought back, as [`read_sample`](Self::read_sample) does for its own
    /// reads: the same counters, the same re-initialisation triggers, the
    /// same results. A failed HXL..ST2 block is followed by the driver's
    /// blocking ST2 read ([`Ak8963::end_data_read`]), so call this with
    /// the bus idle.
    pub fn finish_sample(
        &mut self,
        read_mag: bool,
        bytes: &SampleBytes,
        results: BlockResults<I::Error>,
    ) -> (Option<RawSample>, MagRead) {
        let [imu_r, st1_r, data_r] = results;
        let imu = match (
            imu_r,
            bytes.first_chunk::<{ mpu9250::register::SAMPLE_LEN }>(),
        ) {
            (Some(r), Some(block)) => {
                self.record_imu(r.map(|()| parse_sample(block)).map_err(mpu9250::Error::Bus))
            }
            _ => None,
        };
        if !read_mag {
            return (imu, MagRead::NotReady);
        }
        let r = match (st1_r, data_r) {
            (Some(Err(e)), _) => Err(ak8963::Error::Bus(e)),
            (Some(Ok(())), Some(Err(e))) => {
                // Best effort, as the driver's own read: its error is the one reported.
                let _ = self.mag.end_data_read();
                Err(ak8963::Error::Bus(e))
            }
            (Some(Ok(())), Some(Ok(()))) => match bytes
                .get(ST1_OFFSET..)
                .and_then(|b| b.first_chunk::<{ ak8963::register::STATUS_BLOCK_LEN }>())
            {
                Some(block) => parse_status_block(block, self.mag.config().resolution)
                    .map_err(ak8963::Error::from),
                None => return (imu, MagRead::Unavailable),
            },
            // The data block is skipped only when ST1 showed DRDY clear.
            (Some(Ok(())), None) => Err(ak8963::Error::NotReady),
            (None, _) => return (imu, MagRead::Unavailable),
        };
        (imu, self.record_mag(r))
    }

    /// Reads the magnetometer if a measurement is ready (one attempt, as
    /// [`read_imu`](Self::read_imu)).
    pub fn read_mag(&mut self) -> MagRead {
        if !self.mag_health.usable() || !self.mpu_usable() {
            return MagRead::Unavailable;
        }
        let r = self.mag.read_raw();
        self.record_mag(r)
    }

    fn record_mag(&mut self, r: Result<RawMag, ak8963::Error<I::Error>>) -> MagRead {
        let r = self.mag_health.record(match r {
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
    /// re-initialisation (armed, the MPU-9250 only becomes suspect: see
    /// the module docs). Returns `true` if a mismatch was acted on. Call
    /// every ~100 ms.
    pub fn check_configs(&mut self) -> bool {
        let mut found = false;
        // Skipped while it is being reset or re-checked: those read it.
        let mut mpu_ok = self.mpu_reset == MpuReset::Idle && !self.mpu_gate.pending();
        if mpu_ok && self.mpu_health.usable() {
            match self.mpu.verify_config() {
                Ok(()) => self.mpu_health.success(),
                Err(mpu9250::Error::ConfigMismatch { .. }) if self.armed => {
                    mpu_ok = false;
                    self.mpu_suspect = true;
                }
                Err(mpu9250::Error::ConfigMismatch { .. }) => {
                    found = true;
                    mpu_ok = false;
                    self.reinit_pending[0] |= self.mpu_health.config_mismatch() == Action::Reinit;
                }
                Err(_) => {
                    mpu_ok = false;
                    if self.mpu_health.error() == Action::Reinit {
                        self.mpu_trouble();
                    }
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
    /// because the AK8963 is reached through its bypass. For boot and the
    /// host tools: it ignores [`set_armed`](Self::set_armed) and blocks, so
    /// a board in flight uses [`maintain`](Self::maintain).
    pub fn service<D: DelayNs>(&mut self, delay: &mut D) -> ServiceReport {
        let mut report = ServiceReport::default();
        let [mpu_p, mag_p, baro_p] = self.reinit_pending;
        self.reinit_pending = [false; 3];
        if mpu_p && !matches!(self.mpu_health.state(), crate::health::SensorState::Missing) {
            let cfg = self.cfg.mpu;
            let ok = self.mpu.init(delay, &cfg).is_ok() && self.mpu.set_bypass(true).is_ok();
            self.mpu_health.reinit_done(ok);
            report.reinit[0] = Some(ok);
            if ok {
                delay.delay_ms(self.cfg.mpu_settle_ms);
            }
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

    /// `true` when a recovery was requested or every present chip keeps
    /// failing: the bus is stuck.
    pub fn needs_bus_recovery(&self) -> bool {
        self.recovery_requested
            || needs_bus_recovery(&[&self.mpu_health, &self.mag_health, &self.baro_health])
    }

    /// Asks for a bus recovery at the next [`maintain`](Self::maintain):
    /// the caller saw the bus held (e.g. the I2C peripheral reported BUSY
    /// with no transfer under way).
    pub fn request_bus_recovery(&mut self) {
        self.recovery_requested = true;
    }

    /// After the caller freed the bus ([`crate::health::recover_bus`]) and
    /// re-created the I2C peripheral: revive failed chips and schedule a
    /// re-initialisation of every present one.
    pub fn after_bus_recovery(&mut self) {
        self.bus_recoveries = self.bus_recoveries.saturating_add(1);
        self.recovery_requested = false;
        self.recovery_failing = false;
        self.recovery_backoff.reset();
        self.fresh_recovery = true;
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
        // A recovery clocks the bus free; it does not reset a chip.
        if self.armed && self.reinit_pending[0] {
            self.reinit_pending[0] = false;
            self.mpu_suspect = true;
        }
    }

    /// Tells the stack whether the craft is armed (see the module docs):
    /// call it every flight-controller step, or at least on every change.
    pub fn set_armed(&mut self, armed: bool) {
        // A reset asked for on the ground, not yet begun: armed, it needs
        // the proof first. Only at the arming: a reset proven while armed
        // stays asked for.
        if armed && !self.armed && self.reinit_pending[0] {
            self.reinit_pending[0] = false;
            self.mpu_suspect = true;
        }
        self.armed = armed;
    }

    /// `gap_us`: the time since the last sample step. Past
    /// [`MPU_STALL_US`] while the MPU-9250 counts as healthy, its
    /// data-ready interrupt is gone (it reset itself, or lost power or its
    /// INT wire): armed, it becomes suspect, re-checked at once rather than
    /// at the next configuration check. Disarmed, nothing: the
    /// configuration check finds a reset, and the watchdog rule handles a
    /// dead INT line.
    pub fn mpu_sample_gap(&mut self, gap_us: u32) {
        let stalled = gap_us > MPU_STALL_US;
        if stalled && self.armed && self.mpu_usable() && !self.mpu_gate.pending() {
            self.mpu_suspect = true;
        }
    }

    /// `true` while the MPU-9250 answered wrong and is being re-checked,
    /// reset or settled after its reset: its samples stop or are not used
    /// for that long, which the caller bridges
    /// (`flight::outputguard::OutputGuard::set_mpu_recovering`). `false`
    /// for a chip that does not answer at all.
    pub fn mpu_recovering(&self) -> bool {
        self.mpu_gate.answered_wrong()
            || self.reinit_pending[0]
            || self.mpu_reset != MpuReset::Idle
            || self.mpu_settle_until_ms.is_some()
    }

    /// The MPU-9250's failed reads or checks call for a re-initialisation:
    /// at once when disarmed; armed, it only becomes suspect.
    fn mpu_trouble(&mut self) {
        if self.armed {
            self.mpu_suspect = true;
        } else {
            self.reinit_pending[0] = true;
        }
    }

    /// The caller's recovery could not free the bus (SDA or SCL held by
    /// something that does not let go): further attempts are spaced out,
    /// 20 ms doubling to 1 s, until one succeeds ([`after_bus_recovery`](Self::after_bus_recovery)).
    // Out of line: measured smaller in the firmware than inlined into its task.
    #[inline(never)]
    pub fn bus_recovery_failed(&mut self, now_ms: u32) {
        self.bus_recoveries = self.bus_recoveries.saturating_add(1);
        if self.recovery_failing {
            self.recovery_backoff.failed(now_ms);
        } else {
            self.recovery_failing = true;
            self.recovery_backoff.reset();
            self.recovery_backoff.due(now_ms);
        }
    }

    /// Stuck-bus recoveries attempted.
    pub fn bus_recoveries(&self) -> u32 {
        self.bus_recoveries
    }

    /// `true` while the MPU-9250 is usable, not being reset and not
    /// settling after a reset.
    fn mpu_usable(&self) -> bool {
        self.mpu_health.usable()
            && self.mpu_reset == MpuReset::Idle
            && self.mpu_settle_until_ms.is_none()
    }

    /// What the stack can do with the chips in use now (changes when a
    /// missing chip appears or one fails for good).
    pub fn capabilities(&self) -> Capabilities {
        let up =
            |h: &SensorHealth| !matches!(h.state(), SensorState::Missing | SensorState::Failed);
        let ahrs = match (up(&self.mpu_health), up(&self.mag_health)) {
            (false, _) => AhrsMode::None,
            (true, false) => AhrsMode::ImuOnly,
            (true, true) => AhrsMode::Marg,
        };
        Capabilities {
            ahrs,
            altitude: up(&self.baro_health),
        }
    }

    /// One step of background maintenance at `now_ms` (a wrapping ms
    /// clock): see the module documentation for the order. The MPU-9250's
    /// steps never wait; disarmed, the AK8963's or MS5611's
    /// re-initialisation or a re-probe blocks for that chip's init (an
    /// MPU-9250 re-probe up to its 200 ms reset poll).
    pub fn maintain<D: DelayNs>(&mut self, now_ms: u32, delay: &mut D) -> Maintenance {
        if self.recovery_failing {
            // The bus could not be freed: nothing else can work either;
            // try again after the back-off.
            if !self.recovery_backoff.due(now_ms) {
                return Maintenance::Idle;
            }
            return Maintenance::RecoverBus;
        }
        if self.needs_bus_recovery() {
            return Maintenance::RecoverBus;
        }
        if core::mem::take(&mut self.mpu_suspect) {
            self.mpu_gate.suspect(now_ms);
        }
        if let Some(step) = self.mpu_step(now_ms) {
            return step;
        }
        let [_, mag_p, baro_p] = self.reinit_pending;
        if self.armed {
            // Re-initialisations that wait, and re-probes, wait for the
            // ground.
            return Maintenance::Idle;
        }
        if mag_p && self.mpu_usable() {
            self.reinit_pending[1] = false;
            let cfg = self.cfg.mag;
            let ok = self.mag.init(delay, &cfg).is_ok();
            self.mag_health.reinit_done(ok);
            return Maintenance::Reinitialised {
                chip: Chip::Ak8963,
                ok,
            };
        }
        if baro_p {
            self.reinit_pending[2] = false;
            let ok = self.init_baro(delay);
            self.baro_health.reinit_done(ok);
            return Maintenance::Reinitialised {
                chip: Chip::Ms5611,
                ok,
            };
        }
        self.reprobe_step(now_ms, delay)
    }

    /// The MPU-9250's part of [`maintain`](Self::maintain): a step of its
    /// re-initialisation, its post-reset check, or its re-check; `None`
    /// when none is due.
    fn mpu_step(&mut self, now_ms: u32) -> Option<Maintenance> {
        if self.mpu_reset != MpuReset::Idle {
            return Some(self.mpu_reset_step(now_ms));
        }
        if self.reinit_pending[0] {
            self.reinit_pending[0] = false;
            if !self.mpu_health.usable() {
                return Some(Maintenance::Idle);
            }
            let cfg = self.cfg.mpu;
            if self.mpu.start_reset(&cfg).is_err() {
                return Some(self.mpu_reset_over(now_ms, false));
            }
            self.mpu_reset = MpuReset::Polling(now_ms);
            return Some(Maintenance::MpuResetStep);
        }
        if let Some(until) = self.mpu_settle_until_ms {
            if (now_ms.wrapping_sub(until) as i32) < 0 {
                return Some(Maintenance::Idle);
            }
            self.mpu_settle_until_ms = None;
            let ok = mpu_settled(&mut self.mpu).is_ok();
            if ok {
                // The AK8963 is reachable again through the bypass: if it
                // is missing, probe it now rather than at its back-off.
                if let Some(b) = self.reprobe.get_mut(1) {
                    b.due_now(now_ms);
                }
            } else {
                self.mpu_health.error();
                self.reinit_pending[0] = true;
            }
            return Some(Maintenance::Settled { ok });
        }
        if self.mpu_gate.due(now_ms) {
            return Some(self.mpu_recheck(now_ms));
        }
        None
    }

    /// One step of the MPU-9250's re-initialisation after its H_RESET.
    fn mpu_reset_step(&mut self, now_ms: u32) -> Maintenance {
        match self.mpu_reset {
            MpuReset::Polling(since) => {
                if now_ms.wrapping_sub(since) >= MPU_RESET_TIMEOUT_MS {
                    return self.mpu_reset_over(now_ms, false);
                }
                // The poll and the writes fit one step: ~0.8 ms of bus.
                if !self.mpu.reset_done() {
                    return Maintenance::MpuResetStep;
                }
                if self.mpu.write_config().is_err() {
                    return self.mpu_reset_over(now_ms, false);
                }
                self.mpu_reset = MpuReset::Verify;
                Maintenance::MpuResetStep
            }
            MpuReset::Verify | MpuReset::Idle => {
                let ok = self.mpu.finish_init().is_ok();
                self.mpu_reset_over(now_ms, ok)
            }
        }
    }

    /// Ends the MPU-9250's re-initialisation: health books, and on success
    /// its samples wait [`SensorsConfig::mpu_settle_ms`].
    fn mpu_reset_over(&mut self, now_ms: u32, ok: bool) -> Maintenance {
        self.mpu_reset = MpuReset::Idle;
        self.mpu_health.reinit_done(ok);
        if ok {
            self.mpu_settle_until_ms = Some(now_ms.wrapping_add(self.cfg.mpu_settle_ms));
        }
        Maintenance::Reinitialised {
            chip: Chip::Mpu9250,
            ok,
        }
    }

    /// Re-checks a suspect MPU-9250 (WHO_AM_I, configuration read-back)
    /// and resets it once the [`ResetGate`] calls it lost.
    fn mpu_recheck(&mut self, now_ms: u32) -> Maintenance {
        let answered = match mpu_settled(&mut self.mpu) {
            Ok(()) => {
                self.mpu_gate.right_answer();
                self.mpu_health.success();
                return Maintenance::Settled { ok: true };
            }
            Err(e) => !matches!(e, mpu9250::Error::Bus(_)),
        };
        let verdict = self.mpu_gate.failed(now_ms, self.armed, answered);
        if verdict == ResetVerdict::Reset && answered {
            self.mpu_health.config_mismatch();
        }
        if verdict == ResetVerdict::Reset {
            self.reinit_pending[0] = true;
        }
        Maintenance::Settled { ok: false }
    }

    fn init_mpu<D: DelayNs>(&mut self, delay: &mut D) -> bool {
        let cfg = self.cfg.mpu;
        self.mpu.init(delay, &cfg).is_ok() && self.mpu.set_bypass(true).is_ok()
    }

    fn init_baro<D: DelayNs>(&mut self, delay: &mut D) -> bool {
        let ok = self.baro.init(delay).is_ok();
        if ok {
            self.sampler.restart();
        }
        ok
    }

    /// Re-probes the first absent chip whose back-off expired.
    fn reprobe_step<D: DelayNs>(&mut self, now_ms: u32, delay: &mut D) -> Maintenance {
        let absent =
            |h: &SensorHealth| matches!(h.state(), SensorState::Missing | SensorState::Failed);
        let chips = [
            (Chip::Mpu9250, absent(&self.mpu_health)),
            // Behind the MPU's bypass: only once the MPU is in use.
            (Chip::Ak8963, absent(&self.mag_health) && self.mpu_usable()),
            (Chip::Ms5611, absent(&self.baro_health)),
        ];
        let mut due = None;
        for (i, (chip, want)) in chips.into_iter().enumerate() {
            if let Some(b) = self.reprobe.get_mut(i) {
                if want && b.due(now_ms) && due.is_none() {
                    due = Some((i, chip));
                }
            }
        }
        let Some((i, chip)) = due else {
            return Maintenance::Idle;
        };
        let nobody_answers = ![&self.mpu_health, &self.mag_health, &self.baro_health]
            .iter()
            .any(|h| h.usable());
        if nobody_answers && !self.fresh_recovery {
            // A slave holding SDA looks exactly like no chip at all.
            return Maintenance::RecoverBus;
        }
        self.fresh_recovery = false;
        let policy = self.cfg.policy;
        let ok = match chip {
            Chip::Mpu9250 => self.init_mpu(delay),
            Chip::Ak8963 => {
                let cfg = self.cfg.mag;
                self.mag.init(delay, &cfg).is_ok()
            }
            Chip::Ms5611 => self.init_baro(delay),
        };
        let (health, backoff) = match (chip, self.reprobe.get_mut(i)) {
            (Chip::Mpu9250, Some(b)) => (&mut self.mpu_health, b),
            (Chip::Ak8963, Some(b)) => (&mut self.mag_health, b),
            (Chip::Ms5611, Some(b)) => (&mut self.baro_health, b),
            (_, None) => return Maintenance::Idle,
        };
        if !ok {
            backoff.failed(now_ms);
            return Maintenance::StillMissing {
                chip,
                retry_in_ms: backoff.interval_ms(),
            };
        }
        backoff.reset();
        let counters = *health.counters();
        *health = SensorHealth::with_counters(policy, counters);
        if chip == Chip::Mpu9250 {
            self.mpu_settle_until_ms = Some(now_ms.wrapping_add(self.cfg.mpu_settle_ms));
        }
        Maintenance::Appeared(chip)
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
