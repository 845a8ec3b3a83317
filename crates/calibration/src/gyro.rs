//! Gyroscope bias at rest.

use crate::stats::Stats3;
use crate::{check_input, Error, GyroBias, MotionCheck};

/// Settings for [`GyroBiasEstimator`].
///
/// Thresholds are in the unit of the samples fed in. A threshold of
/// `f32::INFINITY` disables that check; NaN or negative thresholds are
/// rejected as [`Error::InvalidConfig`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroBiasConfig {
    /// Samples to average (the window). Must be at least 1.
    pub samples: u32,
    /// Largest allowed per-axis standard deviation of the rate samples.
    pub max_std: f32,
    /// Largest allowed per-axis peak-to-peak (max − min) of the rate samples.
    pub max_spread: f32,
    /// Largest allowed per-axis standard deviation of the accelerometer
    /// samples (only checked when accelerometer samples were supplied).
    pub max_accel_std: f32,
    /// Largest allowed per-axis peak-to-peak of the accelerometer samples.
    pub max_accel_spread: f32,
}

impl GyroBiasConfig {
    /// Defaults for rates in rad/s and accelerations in g, sized for an
    /// MPU-9250 on a bench (rate noise ≈ 0.0015 rad/s RMS at 41 Hz bandwidth,
    /// ≈ 0.003 rad/s at the 184 Hz the board reads it with: the std limit
    /// keeps 1.7× of margin):
    /// 500 samples, rate std ≤ 0.005 rad/s (0.29 °/s), rate peak-to-peak
    /// ≤ 0.05 rad/s (2.9 °/s), accel std ≤ 0.02 g, accel peak-to-peak ≤ 0.1 g.
    pub const RPS_AND_G: Self = Self {
        samples: 500,
        max_std: 0.005,
        max_spread: 0.05,
        max_accel_std: 0.02,
        max_accel_spread: 0.1,
    };

    /// `Ok` when the sample count is non-zero and no threshold is NaN or
    /// negative.
    pub fn validate(&self) -> Result<(), Error> {
        let thresholds = [
            self.max_std,
            self.max_spread,
            self.max_accel_std,
            self.max_accel_spread,
        ];
        if self.samples == 0 || thresholds.iter().any(|t| t.is_nan() || *t < 0.0) {
            Err(Error::InvalidConfig)
        } else {
            Ok(())
        }
    }
}

impl Default for GyroBiasConfig {
    /// [`GyroBiasConfig::RPS_AND_G`].
    fn default() -> Self {
        Self::RPS_AND_G
    }
}

/// Estimates the gyroscope bias as the mean of a window of samples taken at
/// rest, refusing the result when the samples (or optional accelerometer
/// samples) show motion.
///
/// State is 2 × per-axis running sums/min/max (no samples stored). Samples are
/// in any consistent unit; the bias comes back in the same unit.
///
/// ```
/// use calibration::{GyroBiasConfig, GyroBiasEstimator};
///
/// let mut est = GyroBiasEstimator::new(GyroBiasConfig { samples: 4, ..GyroBiasConfig::RPS_AND_G })?;
/// for w in [[0.011, -0.02, 0.003], [0.009, -0.021, 0.002], [0.010, -0.019, 0.004], [0.010, -0.020, 0.003]] {
///     est.push_with_accel(w, [0.0, 0.0, 1.0])?;
/// }
/// let bias = est.finish()?;
/// assert!((bias.bias[0] - 0.010).abs() < 1e-6);
/// assert_eq!(bias.apply([0.010, -0.020, 0.003]), [0.0, 0.0, 0.0]);
/// # Ok::<(), calibration::Error>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct GyroBiasEstimator {
    config: GyroBiasConfig,
    gyro: Stats3,
    accel: Stats3,
    rejected: u32,
}

impl GyroBiasEstimator {
    /// A fresh estimator; [`Error::InvalidConfig`] if `config` is unusable.
    pub fn new(config: GyroBiasConfig) -> Result<Self, Error> {
        config.validate()?;
        Ok(Self {
            config,
            gyro: Stats3::new(),
            accel: Stats3::new(),
            rejected: 0,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &GyroBiasConfig {
        &self.config
    }

    /// Forget all samples (keeps the configuration).
    pub fn reset(&mut self) {
        self.gyro = Stats3::new();
        self.accel = Stats3::new();
        self.rejected = 0;
    }

    /// Add a rate sample.
    ///
    /// Returns `Ok(true)` once the window is full (further samples are
    /// ignored), `Ok(false)` while collecting. Errors:
    /// [`Error::NonFinite`] / [`Error::InputOutOfRange`] — sample skipped and
    /// counted, state unchanged; [`Error::Moved`] — the sample was taken but
    /// the window's peak-to-peak already exceeds the limit, so
    /// [`finish`](Self::finish) will fail too: [`reset`](Self::reset) and
    /// start over.
    pub fn push(&mut self, rate: [f32; 3]) -> Result<bool, Error> {
        self.push_inner(rate, None)
    }

    /// Add a rate sample together with an accelerometer sample taken at the
    /// same time (any unit), which is checked for stillness too. Same
    /// results as [`push`](Self::push); a bad value in either vector skips
    /// the pair.
    pub fn push_with_accel(&mut self, rate: [f32; 3], accel: [f32; 3]) -> Result<bool, Error> {
        self.push_inner(rate, Some(accel))
    }

    fn push_inner(&mut self, rate: [f32; 3], accel: Option<[f32; 3]>) -> Result<bool, Error> {
        if self.is_complete() {
            return Ok(true);
        }
        let checked = check_input(&rate).and_then(|()| match &accel {
            Some(a) => check_input(a),
            None => Ok(()),
        });
        if let Err(e) = checked {
            self.rejected = self.rejected.saturating_add(1);
            return Err(e);
        }
        self.gyro.push(rate);
        if let Some(a) = accel {
            self.accel.push(a);
        }
        self.check_spread()?;
        Ok(self.is_complete())
    }

    /// `true` once `config.samples` samples have been accepted.
    pub fn is_complete(&self) -> bool {
        self.gyro.count() >= self.config.samples
    }

    /// Accepted rate samples.
    pub fn count(&self) -> u32 {
        self.gyro.count()
    }

    /// Samples skipped as non-finite or out of range.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    fn check_spread(&self) -> Result<(), Error> {
        if let Some((axis, value)) = self.gyro.spread_exceeding(self.config.max_spread) {
            return Err(moved(
                MotionCheck::GyroSpread,
                axis,
                value,
                self.config.max_spread,
            ));
        }
        if let Some((axis, value)) = self.accel.spread_exceeding(self.config.max_accel_spread) {
            return Err(moved(
                MotionCheck::AccelSpread,
                axis,
                value,
                self.config.max_accel_spread,
            ));
        }
        Ok(())
    }

    /// The bias (per-axis mean of the window), once the window is full and
    /// all stillness checks pass.
    ///
    /// Errors: [`Error::TooFewSamples`], [`Error::Moved`],
    /// [`Error::OutOfRange`] (cannot happen with bounded inputs; kept as a
    /// guard against a non-finite result).
    pub fn finish(&self) -> Result<GyroBias, Error> {
        if !self.is_complete() {
            return Err(Error::TooFewSamples {
                have: self.gyro.count(),
                need: self.config.samples,
            });
        }
        self.check_spread()?;
        let c = &self.config;
        if let Some((axis, value)) = self.gyro.std_exceeding(c.max_std) {
            return Err(moved(MotionCheck::GyroStdDev, axis, value, c.max_std));
        }
        if let Some((axis, value)) = self.accel.std_exceeding(c.max_accel_std) {
            return Err(moved(
                MotionCheck::AccelStdDev,
                axis,
                value,
                c.max_accel_std,
            ));
        }
        let bias = GyroBias {
            bias: self.gyro.mean(),
        };
        if bias.is_finite() {
            Ok(bias)
        } else {
            Err(Error::OutOfRange)
        }
    }
}

fn moved(check: MotionCheck, axis: u8, value: f32, limit: f32) -> Error {
    Error::Moved {
        check,
        axis,
        value,
        limit,
    }
}
