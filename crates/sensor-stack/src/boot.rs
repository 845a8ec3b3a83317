//! Boot-time decisions: bounded probing of each chip with a typed verdict,
//! the degraded capabilities that follow from what was found, and the
//! start-up gyro bias (board must be still; motion restarts the window).

use calibration::{Error as CalError, GyroBiasConfig, GyroBiasEstimator};
use embedded_hal::delay::DelayNs;

/// The three chips on the bus (the log names them as their datasheets do:
/// MPU-9250, AK8963, MS5611).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Chip {
    /// MPU-9250 accelerometer + gyroscope.
    Mpu9250,
    /// AK8963 magnetometer (behind the MPU-9250's bypass).
    Ak8963,
    /// MS5611 barometer.
    Ms5611,
}

/// Why a chip did not come up (the log says it in words).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeFailure {
    /// No answer on the bus (NACK / bus error on every attempt): not fitted
    /// or not wired.
    NoResponse,
    /// It answered with an identity register that is not the expected chip.
    WrongId {
        /// The value read.
        found: u8,
    },
    /// The MPU answered as an MPU-6500 (no magnetometer inside).
    Mpu6500,
    /// The MS5611 PROM failed its CRC-4 or read blank (a damaged or wrong
    /// chip).
    BadProm,
    /// It answered but configuration failed (reset timeout, read-back
    /// mismatch, fuse ROM, ...).
    InitFailed,
    /// Not probed because a chip it depends on is missing (the AK8963 needs
    /// the MPU-9250's bypass).
    DependencyMissing,
}

#[cfg(feature = "defmt")]
impl defmt::Format for Chip {
    fn format(&self, f: defmt::Formatter) {
        // One interned format string per name: no name text in flash.
        match self {
            Self::Mpu9250 => defmt::write!(f, "MPU-9250"),
            Self::Ak8963 => defmt::write!(f, "AK8963"),
            Self::Ms5611 => defmt::write!(f, "MS5611"),
        }
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for ProbeFailure {
    fn format(&self, f: defmt::Formatter) {
        match *self {
            Self::NoResponse => defmt::write!(f, "no answer on the bus (not fitted, or not wired)"),
            Self::WrongId { found } => defmt::write!(
                f,
                "its identity register reads {=u8:#04x}: another chip",
                found
            ),
            Self::Mpu6500 => defmt::write!(f, "it is an MPU-6500 (no magnetometer inside)"),
            Self::BadProm => defmt::write!(f, "its calibration PROM failed its CRC or reads blank"),
            Self::InitFailed => defmt::write!(f, "it answered but its configuration failed"),
            Self::DependencyMissing => {
                defmt::write!(
                    f,
                    "not probed: reached through the MPU-9250, which is missing"
                )
            }
        }
    }
}

/// Verdict of one chip's probe: `Ok` or why not, plus attempts used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProbeResult {
    /// Which chip.
    pub chip: Chip,
    /// `Ok(())` if it is present and configured.
    pub status: Result<(), ProbeFailure>,
    /// Attempts made (1 = first try succeeded).
    pub attempts: u8,
}

impl ProbeResult {
    /// `true` when the chip is usable.
    pub fn present(&self) -> bool {
        self.status.is_ok()
    }
}

/// Runs `op` up to `attempts` times (at least once), waiting `retry_delay_ms`
/// between attempts, and classifies the last error with `classify`.
/// Returns the value and the attempt count, or the failure and the attempt
/// count.
///
/// ```
/// use sensor_stack::boot::{probe_with_retries, ProbeFailure};
/// # struct D; impl embedded_hal::delay::DelayNs for D { fn delay_ns(&mut self, _: u32) {} }
/// let mut n = 0;
/// let r = probe_with_retries(3, 1, &mut D, |_| { n += 1; if n < 2 { Err(()) } else { Ok(5) } },
///                            |_| ProbeFailure::NoResponse);
/// assert_eq!(r, Ok((5, 2)));
/// ```
pub fn probe_with_retries<T, E, D: DelayNs>(
    attempts: u8,
    retry_delay_ms: u32,
    delay: &mut D,
    mut op: impl FnMut(&mut D) -> Result<T, E>,
    classify: impl Fn(&E) -> ProbeFailure,
) -> Result<(T, u8), (ProbeFailure, u8)> {
    let attempts = attempts.max(1);
    let mut n = 0u8;
    loop {
        n = n.saturating_add(1);
        match op(delay) {
            Ok(v) => return Ok((v, n)),
            Err(e) => {
                if n >= attempts {
                    return Err((classify(&e), n));
                }
                delay.delay_ms(retry_delay_ms);
            }
        }
    }
}

/// How the AHRS runs given the sensors found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AhrsMode {
    /// Gyro + accelerometer + magnetometer: absolute heading.
    Marg,
    /// Gyro + accelerometer only: roll and pitch absolute, yaw drifts.
    ImuOnly,
    /// No IMU: no attitude at all.
    None,
}

impl core::fmt::Display for AhrsMode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Marg => "gyro, accelerometer and magnetometer",
            Self::ImuOnly => "gyro and accelerometer (no heading reference)",
            Self::None => "none (no IMU)",
        })
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for AhrsMode {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Self::Marg => defmt::write!(f, "gyro, accelerometer and magnetometer"),
            Self::ImuOnly => defmt::write!(f, "gyro and accelerometer (no heading reference)"),
            Self::None => defmt::write!(f, "none (no IMU)"),
        }
    }
}

/// What the stack can do with the chips that are present.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Capabilities {
    /// Attitude estimation mode.
    pub ahrs: AhrsMode,
    /// Barometric altitude and vertical speed (needs the MS5611).
    pub altitude: bool,
}

/// Results of probing all three chips.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BootReport {
    /// MPU-9250.
    pub mpu: ProbeResult,
    /// AK8963.
    pub mag: ProbeResult,
    /// MS5611.
    pub baro: ProbeResult,
}

impl BootReport {
    /// Graceful degradation: no MPU → nothing; no magnetometer → IMU-only
    /// AHRS; no barometer → no altitude.
    pub fn capabilities(&self) -> Capabilities {
        let ahrs = match (self.mpu.present(), self.mag.present()) {
            (false, _) => AhrsMode::None,
            (true, false) => AhrsMode::ImuOnly,
            (true, true) => AhrsMode::Marg,
        };
        Capabilities {
            ahrs,
            altitude: self.baro.present(),
        }
    }

    /// The chips that failed, in bus order.
    pub fn failures(&self) -> impl Iterator<Item = (Chip, ProbeFailure)> {
        [self.mpu, self.mag, self.baro]
            .into_iter()
            .filter_map(|r| r.status.err().map(|f| (r.chip, f)))
    }
}

/// Progress of the start-up gyro bias measurement. The log writes it in
/// words (`measuring, hold still: 969 of 1000 samples`, `done: [-46, 54,
/// -71] counts`, ...).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BiasStatus {
    /// Collecting: samples accepted so far of the window.
    Collecting {
        /// Accepted samples.
        have: u32,
        /// Window length.
        need: u32,
    },
    /// The board moved; the window restarted (attempt number starting at 1).
    Moved {
        /// Attempts used so far.
        attempt: u8,
    },
    /// Done: bias in gyro counts (MPU frame).
    Done([i16; 3]),
    /// The board did not hold still for a whole window within
    /// `max_attempts` windows' worth of samples: keep the fallback bias
    /// (stored calibration or zero).
    GaveUp,
}

#[cfg(feature = "defmt")]
impl defmt::Format for BiasStatus {
    fn format(&self, f: defmt::Formatter) {
        match *self {
            Self::Collecting { have, need } => defmt::write!(
                f,
                "measuring, hold still: {=u32} of {=u32} samples",
                have,
                need
            ),
            Self::Moved { attempt } => defmt::write!(
                f,
                "the board moved; measuring again (attempt {=u8})",
                attempt
            ),
            Self::Done([x, y, z]) => defmt::write!(
                f,
                "done: [{=i16}, {=i16}, {=i16}] counts (x, y, z; 32.8 counts per °/s at ±1000 °/s)",
                x,
                y,
                z
            ),
            Self::GaveUp => defmt::write!(
                f,
                "gave up: the board never held still for a whole window; using the stored bias, or zero"
            ),
        }
    }
}

/// Start-up gyro bias from raw counts: wraps
/// [`calibration::GyroBiasEstimator`], checking stillness of both gyro and
/// accelerometer, and restarting the window when the board moves.
///
/// The retry budget is time, not restarts: it gives up once a restarted
/// window could no longer end within `max_attempts` windows' worth of
/// samples. Motion restarts the window at nearly every sample while it
/// lasts (each sample past the peak-to-peak limit is a restart), so a
/// budget of restarts would be spent by a 10 ms knock.
#[derive(Clone, Copy, Debug)]
pub struct StartupGyroBias {
    est: GyroBiasEstimator,
    attempt: u8,
    /// Samples pushed so far, in all windows.
    pushed: u32,
    /// Samples the measurement may take in all.
    budget: u32,
    finished: Option<BiasStatus>,
}

/// Why [`StartupGyroBias::new`] refused its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BiasConfigError(pub CalError);

impl StartupGyroBias {
    /// A measurement over `samples` samples for a gyro with `lsb_per_dps`
    /// and an accelerometer with `lsb_per_g`: at most 3 °/s peak-to-peak
    /// and 0.3 °/s standard deviation on the gyro, 0.1 g peak-to-peak and
    /// 0.02 g standard deviation on the accelerometer; within
    /// `max_attempts × samples` samples in all.
    pub fn new(
        samples: u32,
        lsb_per_dps: f32,
        lsb_per_g: f32,
        max_attempts: u8,
    ) -> Result<Self, BiasConfigError> {
        let cfg = GyroBiasConfig {
            samples,
            max_std: 0.3 * lsb_per_dps,
            max_spread: 3.0 * lsb_per_dps,
            max_accel_std: 0.02 * lsb_per_g,
            max_accel_spread: 0.1 * lsb_per_g,
        };
        let est = GyroBiasEstimator::new(cfg).map_err(BiasConfigError)?;
        Ok(Self {
            est,
            attempt: 1,
            pushed: 0,
            budget: samples.saturating_mul(u32::from(max_attempts.max(1))),
            finished: None,
        })
    }

    /// Feeds one raw sample (counts, MPU frame).
    pub fn push(&mut self, gyro: [i16; 3], accel: [i16; 3]) -> BiasStatus {
        if let Some(done) = self.finished {
            return done;
        }
        self.pushed = self.pushed.saturating_add(1);
        let g = gyro.map(f32::from);
        let a = accel.map(f32::from);
        match self.est.push_with_accel(g, a) {
            Ok(true) => match self.est.finish() {
                Ok(b) => {
                    let bias = b.bias.map(round_i16);
                    let s = BiasStatus::Done(bias);
                    self.finished = Some(s);
                    s
                }
                Err(_) => self.restart(),
            },
            Ok(false) => BiasStatus::Collecting {
                have: self.est.count(),
                need: self.est.config().samples,
            },
            Err(CalError::Moved { .. }) => self.restart(),
            // Non-finite/out-of-range cannot come from i16 input; skip.
            Err(_) => BiasStatus::Collecting {
                have: self.est.count(),
                need: self.est.config().samples,
            },
        }
    }

    fn restart(&mut self) -> BiasStatus {
        if self.pushed.saturating_add(self.est.config().samples) > self.budget {
            self.finished = Some(BiasStatus::GaveUp);
            return BiasStatus::GaveUp;
        }
        self.est.reset();
        let moved = BiasStatus::Moved {
            attempt: self.attempt,
        };
        self.attempt = self.attempt.saturating_add(1);
        moved
    }

    /// Windows started so far.
    pub fn attempts(&self) -> u8 {
        self.attempt
    }
}

/// Rounds to the nearest `i16`, saturating (NaN → 0).
fn round_i16(x: f32) -> i16 {
    let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
    // `as` saturates and maps NaN to 0.
    r as i16
}

#[cfg(test)]
mod tests {
    use super::*;

    struct NoDelay(u32);
    impl DelayNs for NoDelay {
        fn delay_ns(&mut self, ns: u32) {
            self.0 = self.0.saturating_add(ns);
        }
    }

    #[test]
    fn probe_is_bounded_and_classified() {
        let mut d = NoDelay(0);
        let mut calls = 0;
        let r: Result<((), u8), _> = probe_with_retries(
            3,
            10,
            &mut d,
            |_| {
                calls += 1;
                Err(0x12u8)
            },
            |e| ProbeFailure::WrongId { found: *e },
        );
        assert_eq!(r, Err((ProbeFailure::WrongId { found: 0x12 }, 3)));
        assert_eq!(calls, 3);
        assert_eq!(d.0, 20_000_000); // two waits of 10 ms between three tries
    }

    fn report(mpu: bool, mag: bool, baro: bool) -> BootReport {
        let r = |chip, ok: bool| ProbeResult {
            chip,
            status: if ok {
                Ok(())
            } else {
                Err(ProbeFailure::NoResponse)
            },
            attempts: 1,
        };
        BootReport {
            mpu: r(Chip::Mpu9250, mpu),
            mag: r(Chip::Ak8963, mag),
            baro: r(Chip::Ms5611, baro),
        }
    }

    #[test]
    fn degradation() {
        assert_eq!(
            report(true, true, true).capabilities(),
            Capabilities {
                ahrs: AhrsMode::Marg,
                altitude: true
            }
        );
        assert_eq!(
            report(true, false, true).capabilities(),
            Capabilities {
                ahrs: AhrsMode::ImuOnly,
                altitude: true
            }
        );
        assert_eq!(
            report(true, true, false).capabilities(),
            Capabilities {
                ahrs: AhrsMode::Marg,
                altitude: false
            }
        );
        assert_eq!(
            report(false, false, true).capabilities().ahrs,
            AhrsMode::None
        );
        let f: [(Chip, ProbeFailure); 1] = [(Chip::Ms5611, ProbeFailure::NoResponse)];
        assert!(report(true, true, false).failures().eq(f));
    }

    #[test]
    fn gyro_bias_still_board() {
        let mut b = StartupGyroBias::new(100, 32.8, 8192.0, 3).unwrap();
        let mut last = BiasStatus::GaveUp;
        for i in 0..100 {
            let n = (i % 5) as i16 - 2; // ±2 counts of noise
            last = b.push([40 + n, -13 - n, 7], [n, 0, 8192 + n]);
        }
        assert_eq!(last, BiasStatus::Done([40, -13, 7]));
        assert_eq!(b.push([0; 3], [0; 3]), BiasStatus::Done([40, -13, 7]));
    }

    #[test]
    fn gyro_bias_moved_then_retry_then_give_up() {
        let mut b = StartupGyroBias::new(50, 32.8, 8192.0, 2).unwrap();
        for _ in 0..10 {
            b.push([0; 3], [0, 0, 8192]);
        }
        // A 20 °/s twitch: restart.
        assert_eq!(
            b.push([656, 0, 0], [0, 0, 8192]),
            BiasStatus::Moved { attempt: 1 }
        );
        for _ in 0..40 {
            b.push([0; 3], [0, 0, 8192]);
        }
        // Picked up at sample 51 (accelerometer spread 0.2 g): a new window
        // would end at 101, past the budget of 2 × 50. Out of time.
        assert_eq!(b.push([0; 3], [0, 1638, 8192]), BiasStatus::GaveUp);
        assert_eq!(b.push([0; 3], [0, 0, 8192]), BiasStatus::GaveUp);
    }

    /// One sample of a 0.2 s knock (peak 31 °/s, as a 2° roll bump) at
    /// `i` ms into it, counts at ±1000 °/s, over ±3 counts of noise and a
    /// 40-count bias.
    fn knock(i: u32) -> [i16; 3] {
        let tau = i as f32 / 200.0;
        let rate = 31.0 * libm::sinf(2.0 * core::f32::consts::PI * tau);
        [40 + (rate * 32.8) as i16 + (i % 7) as i16 - 3, -13, 7]
    }

    #[test]
    fn gyro_bias_a_knock_costs_its_duration_not_the_budget() {
        let mut b = StartupGyroBias::new(1000, 32.8, 8192.0, 5).unwrap();
        for i in 0..500 {
            b.push([40 + (i % 7) as i16 - 3, -13, 7], [0, 0, 8192]);
        }
        let mut restarts = 0;
        for i in 0..200 {
            if let BiasStatus::Moved { .. } = b.push(knock(i), [0, 0, 8192]) {
                restarts += 1;
            }
        }
        // Each sample past the limit restarted the window: far more
        // restarts than the 5 windows the budget holds.
        assert!(restarts > 5, "{restarts}");
        let mut last = BiasStatus::GaveUp;
        for i in 0..1000 {
            last = b.push([40 + (i % 7) as i16 - 3, -13, 7], [0, 0, 8192]);
        }
        assert_eq!(last, BiasStatus::Done([40, -13, 7]));
    }

    #[test]
    fn gyro_bias_motion_for_the_whole_budget_gives_up() {
        let mut b = StartupGyroBias::new(1000, 32.8, 8192.0, 5).unwrap();
        // A slow 2 °/s yaw swing (0.5 Hz) from power-up on.
        let mut n = 0u32;
        let status = loop {
            let t = n as f32 * 1e-3;
            let rate = 2.0 * libm::sinf(core::f32::consts::PI * t);
            let s = b.push([(rate * 32.8) as i16, 0, 0], [0, 0, 8192]);
            n += 1;
            if s == BiasStatus::GaveUp || n > 10_000 {
                break s;
            }
        };
        assert_eq!(status, BiasStatus::GaveUp);
        // Within the budget of 5 windows, at the last restart whose window
        // could not have ended within it.
        assert!((4_000..=5_000).contains(&n), "{n}");
    }
}
