//! Magnetometer calibration from per-axis extremes (min/max method).

use crate::ellipsoid::check_ranges;
use crate::{check_input, Error, MagCalibration};

/// Settings for [`MagMinMax`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagMinMaxConfig {
    /// Smallest acceptable max − min on every axis, input unit. A full
    /// rotation sweeps each axis over about twice the local field magnitude.
    pub min_range: f32,
    /// Fewest accepted samples before a result is given.
    pub min_samples: u32,
}

impl MagMinMaxConfig {
    /// Defaults for µT: every axis must span at least 30 µT (the Earth's
    /// field is 25–65 µT, so a full rotation spans 50–130 µT), 50 samples.
    pub const MICROTESLA: Self = Self {
        min_range: 30.0,
        min_samples: 50,
    };

    /// `Ok` when `min_range` is finite and non-negative.
    pub fn validate(&self) -> Result<(), Error> {
        if self.min_range.is_finite() && self.min_range >= 0.0 {
            Ok(())
        } else {
            Err(Error::InvalidConfig)
        }
    }
}

impl Default for MagMinMaxConfig {
    /// [`MagMinMaxConfig::MICROTESLA`].
    fn default() -> Self {
        Self::MICROTESLA
    }
}

/// Hard/soft-iron estimate from the per-axis extremes seen while the sensor
/// is rotated through all orientations (the classic min/max method).
///
/// * offset = (max + min) / 2 per axis,
/// * delta = (max − min) / 2 per axis, avg_delta = mean of the three deltas,
/// * soft iron = diag(avg_delta / delta).
///
/// It corrects axis-aligned scale errors only (a diagonal matrix); use
/// [`EllipsoidFit`](crate::EllipsoidFit) for cross-axis soft iron. Single
/// outliers move the extremes, so feed it filtered data. State: 6 floats and
/// two counters.
///
/// ```
/// use calibration::{MagMinMax, MagMinMaxConfig};
///
/// let mut mm = MagMinMax::new(MagMinMaxConfig { min_range: 10.0, min_samples: 6 })?;
/// // ±x, ±y, ±z extremes of a field of 50 µT with offset (10, -5, 2) and a 2× y gain.
/// for m in [[60.0, -5.0, 2.0], [-40.0, -5.0, 2.0], [10.0, 95.0, 2.0],
///           [10.0, -105.0, 2.0], [10.0, -5.0, 52.0], [10.0, -5.0, -48.0]] {
///     mm.push(m)?;
/// }
/// let cal = mm.finish()?;
/// assert_eq!(cal.offset, [10.0, -5.0, 2.0]);
/// let c = cal.apply([10.0, 95.0, 2.0]); // +y extreme
/// assert!((c[1] - 66.666_67).abs() < 1e-3); // avg delta = (50 + 100 + 50) / 3
/// # Ok::<(), calibration::Error>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct MagMinMax {
    config: MagMinMaxConfig,
    min: [f32; 3],
    max: [f32; 3],
    count: u32,
    rejected: u32,
}

impl MagMinMax {
    /// A fresh accumulator; [`Error::InvalidConfig`] if `config` is unusable.
    pub fn new(config: MagMinMaxConfig) -> Result<Self, Error> {
        config.validate()?;
        Ok(Self {
            config,
            min: [0.0; 3],
            max: [0.0; 3],
            count: 0,
            rejected: 0,
        })
    }

    /// Forget all samples (keeps the configuration).
    pub fn reset(&mut self) {
        self.count = 0;
        self.rejected = 0;
        self.min = [0.0; 3];
        self.max = [0.0; 3];
    }

    /// Add a sample (input unit). [`Error::NonFinite`] /
    /// [`Error::InputOutOfRange`]: skipped and counted, state unchanged.
    pub fn push(&mut self, m: [f32; 3]) -> Result<(), Error> {
        if let Err(e) = check_input(&m) {
            self.rejected = self.rejected.saturating_add(1);
            return Err(e);
        }
        if self.count == 0 {
            self.min = m;
            self.max = m;
        } else {
            for ((&x, lo), hi) in m.iter().zip(&mut self.min).zip(&mut self.max) {
                if x < *lo {
                    *lo = x;
                }
                if x > *hi {
                    *hi = x;
                }
            }
        }
        self.count = self.count.saturating_add(1);
        Ok(())
    }

    /// Accepted samples.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Samples skipped as non-finite or out of range.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Per-axis max − min so far (input unit), for progress display.
    pub fn ranges(&self) -> [f32; 3] {
        let mut r = [0.0; 3];
        for ((ri, lo), hi) in r.iter_mut().zip(&self.min).zip(&self.max) {
            *ri = hi - lo;
        }
        r
    }

    /// The calibration, or [`Error::TooFewSamples`],
    /// [`Error::RangeTooSmall`] (an axis was not swept far enough), or
    /// [`Error::OutOfRange`] (axis ranges so different that a gain falls
    /// outside [`MIN_GAIN`](crate::MIN_GAIN)..=[`MAX_GAIN`](crate::MAX_GAIN)).
    pub fn finish(&self) -> Result<MagCalibration, Error> {
        let need = self.config.min_samples.max(2);
        if self.count < need {
            return Err(Error::TooFewSamples {
                have: self.count,
                need,
            });
        }
        let ranges = self.ranges();
        check_ranges(ranges, self.config.min_range)?;
        let [rx, ry, rz] = ranges;
        let avg = (rx + ry + rz) / 3.0;
        let mut offset = [0.0; 3];
        for ((o, lo), hi) in offset.iter_mut().zip(&self.min).zip(&self.max) {
            *o = 0.5 * (hi + lo);
        }
        let cal = MagCalibration {
            offset,
            soft_iron: [
                [avg / rx, 0.0, 0.0],
                [0.0, avg / ry, 0.0],
                [0.0, 0.0, avg / rz],
            ],
        };
        cal.validate()?;
        Ok(cal)
    }
}
