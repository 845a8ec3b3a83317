//! Accelerometer six-position calibration.

use crate::stats::Stats3;
use crate::{check_input, AccelCalibration, Error, MotionCheck};

/// One of the six orientations: which sensor axis points up (against
/// gravity). With the axis up, a still accelerometer reads about +g on that
/// axis (specific force); with it down, about −g.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Position {
    /// +x axis up: reads ≈ (+g, 0, 0).
    XUp = 0,
    /// +x axis down: reads ≈ (−g, 0, 0).
    XDown = 1,
    /// +y axis up: reads ≈ (0, +g, 0).
    YUp = 2,
    /// +y axis down: reads ≈ (0, −g, 0).
    YDown = 3,
    /// +z axis up (board flat, face up for the MPU frame): reads ≈ (0, 0, +g).
    ZUp = 4,
    /// +z axis down: reads ≈ (0, 0, −g).
    ZDown = 5,
}

impl Position {
    /// All six positions, in bit order.
    pub const ALL: [Position; 6] = [
        Position::XUp,
        Position::XDown,
        Position::YUp,
        Position::YDown,
        Position::ZUp,
        Position::ZDown,
    ];

    /// This position's bit in [`Progress::mask`].
    pub const fn bit(self) -> u8 {
        1 << (self as u8)
    }

    /// The axis that is vertical (0 = x, 1 = y, 2 = z).
    pub const fn axis(self) -> u8 {
        (self as u8) / 2
    }

    /// `true` when the axis points up (reading ≈ +g).
    pub const fn is_up(self) -> bool {
        (self as u8).is_multiple_of(2)
    }

    /// The position whose averaged reading `mean` matches: the dominant axis
    /// and its sign.
    fn classify(mean: [f32; 3]) -> (Position, f32) {
        let [x, y, z] = mean;
        let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
        if ax >= ay && ax >= az {
            (
                if x >= 0.0 {
                    Position::XUp
                } else {
                    Position::XDown
                },
                ax,
            )
        } else if ay >= az {
            (
                if y >= 0.0 {
                    Position::YUp
                } else {
                    Position::YDown
                },
                ay,
            )
        } else {
            (
                if z >= 0.0 {
                    Position::ZUp
                } else {
                    Position::ZDown
                },
                az,
            )
        }
    }
}

/// Which of the six positions have been captured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Progress {
    /// Bit `p.bit()` set when position `p` is captured.
    pub mask: u8,
}

impl Progress {
    /// `true` when `p` has been captured.
    pub const fn is_done(self, p: Position) -> bool {
        self.mask & p.bit() != 0
    }

    /// Number of positions captured (0..=6).
    pub const fn count(self) -> u8 {
        (self.mask & 0x3F).count_ones() as u8
    }

    /// `true` when all six are captured.
    pub const fn is_complete(self) -> bool {
        self.mask & 0x3F == 0x3F
    }

    /// The first position (in [`Position::ALL`] order) still missing.
    pub fn next_missing(self) -> Option<Position> {
        Position::ALL.into_iter().find(|&p| !self.is_done(p))
    }
}

/// What one accepted sample did (see [`AccelSixPosition::push`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SixPositionEvent {
    /// A still window is being collected; `samples` taken so far.
    Collecting {
        /// Samples in the current window.
        samples: u32,
    },
    /// A window completed and captured a new position.
    Captured(Position),
    /// A window completed in a position that was already captured; ignored.
    AlreadyCaptured(Position),
}

/// Settings for [`AccelSixPosition`]. Thresholds are in the input unit.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelSixPositionConfig {
    /// Gravity magnitude in the input unit (1.0 for g, 9.80665 for m/s²).
    /// Corrected readings at rest have this magnitude.
    pub gravity: f32,
    /// Samples averaged per position. At least 1.
    pub window: u32,
    /// Largest allowed per-axis standard deviation within a window.
    pub max_std: f32,
    /// Largest allowed per-axis peak-to-peak within a window; exceeding it
    /// restarts the window at once.
    pub max_spread: f32,
    /// Smallest `|dominant component| / |mean|` (cosine of the largest tilt
    /// from the axis) accepted for a position. A tilt θ biases that axis'
    /// scale by about θ²/2, so hold the board square to the table.
    pub min_alignment: f32,
    /// Largest allowed `| |mean| − gravity | / gravity` of a window (raw
    /// scale errors are a few %).
    pub magnitude_tolerance: f32,
}

impl AccelSixPositionConfig {
    /// Defaults for samples in g: 200-sample windows, std ≤ 0.01 g,
    /// peak-to-peak ≤ 0.08 g, tilt ≤ ~20° (alignment 0.94), magnitude within
    /// 25 % of 1 g.
    pub const G: Self = Self {
        gravity: 1.0,
        window: 200,
        max_std: 0.01,
        max_spread: 0.08,
        min_alignment: 0.94,
        magnitude_tolerance: 0.25,
    };

    /// [`Self::G`] converted to m/s² (gravity 9.80665).
    pub const MPS2: Self = Self {
        gravity: 9.806_65,
        window: 200,
        max_std: 0.01 * 9.806_65,
        max_spread: 0.08 * 9.806_65,
        min_alignment: 0.94,
        magnitude_tolerance: 0.25,
    };

    /// `Ok` when gravity is positive and finite, the window non-zero,
    /// thresholds not NaN or negative, alignment in 0..=1.
    pub fn validate(&self) -> Result<(), Error> {
        let ok = self.gravity.is_finite()
            && self.gravity > 0.0
            && self.window > 0
            && self.max_std >= 0.0
            && self.max_spread >= 0.0
            && (0.0..=1.0).contains(&self.min_alignment)
            && self.magnitude_tolerance >= 0.0;
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidConfig)
        }
    }
}

impl Default for AccelSixPositionConfig {
    /// [`AccelSixPositionConfig::G`].
    fn default() -> Self {
        Self::G
    }
}

/// Six-position accelerometer calibration: hold the board still with each
/// axis up and down in turn (any order); each still window is averaged,
/// classified by which axis is vertical, and stored once. Then per axis
/// `offset = (a₊ + a₋)/2` and `scale = 2g/(a₊ − a₋)`, where a₊/a₋ are that
/// axis' averaged readings with it up/down.
///
/// State: one window of running statistics plus six stored means (≈ 170
/// bytes). Cross-axis misalignment is not estimated.
///
/// ```
/// use calibration::{AccelSixPosition, AccelSixPositionConfig, Position};
///
/// let mut six = AccelSixPosition::new(AccelSixPositionConfig { window: 10, ..AccelSixPositionConfig::G })?;
/// // A sensor with offset (0.02, -0.01, 0.05) g and 2 % gain on every axis.
/// for p in Position::ALL {
///     let mut a = [0.02, -0.01, 0.05];
///     let s = if p.is_up() { 1.02 } else { -1.02 };
///     a[p.axis() as usize] += s;
///     for _ in 0..10 {
///         six.push(a)?;
///     }
/// }
/// assert!(six.progress().is_complete());
/// let cal = six.finish()?;
/// let z_up = cal.apply([0.02, -0.01, 1.07]);
/// assert!((z_up[2] - 1.0).abs() < 1e-5);
/// # Ok::<(), calibration::Error>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct AccelSixPosition {
    config: AccelSixPositionConfig,
    window: Stats3,
    means: [[f32; 3]; 6],
    progress: Progress,
    rejected: u32,
}

impl AccelSixPosition {
    /// A fresh calibration; [`Error::InvalidConfig`] if `config` is unusable.
    pub fn new(config: AccelSixPositionConfig) -> Result<Self, Error> {
        config.validate()?;
        Ok(Self {
            config,
            window: Stats3::new(),
            means: [[0.0; 3]; 6],
            progress: Progress::default(),
            rejected: 0,
        })
    }

    /// Forget everything (keeps the configuration).
    pub fn reset(&mut self) {
        self.window = Stats3::new();
        self.means = [[0.0; 3]; 6];
        self.progress = Progress::default();
        self.rejected = 0;
    }

    /// Forget one captured position so it is collected again.
    pub fn discard(&mut self, p: Position) {
        self.progress.mask &= !p.bit();
    }

    /// Positions captured so far.
    pub fn progress(&self) -> Progress {
        self.progress
    }

    /// Samples skipped as non-finite or out of range.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// The averaged reading stored for `p`, if captured.
    pub fn captured(&self, p: Position) -> Option<[f32; 3]> {
        if self.progress.is_done(p) {
            Some(*self.slot(p))
        } else {
            None
        }
    }

    fn slot(&self, p: Position) -> &[f32; 3] {
        match p {
            Position::XUp => &self.means[0],
            Position::XDown => &self.means[1],
            Position::YUp => &self.means[2],
            Position::YDown => &self.means[3],
            Position::ZUp => &self.means[4],
            Position::ZDown => &self.means[5],
        }
    }

    fn slot_mut(&mut self, p: Position) -> &mut [f32; 3] {
        match p {
            Position::XUp => &mut self.means[0],
            Position::XDown => &mut self.means[1],
            Position::YUp => &mut self.means[2],
            Position::YDown => &mut self.means[3],
            Position::ZUp => &mut self.means[4],
            Position::ZDown => &mut self.means[5],
        }
    }

    /// Add a sample.
    ///
    /// Errors (all leave captured positions untouched):
    /// [`Error::NonFinite`] / [`Error::InputOutOfRange`] — sample skipped;
    /// [`Error::Moved`] — the window showed motion and was restarted (with
    /// this sample as its first when the peak-to-peak test fired);
    /// [`Error::NotAxisAligned`] — a still window was too tilted or had an
    /// implausible magnitude and was discarded.
    pub fn push(&mut self, a: [f32; 3]) -> Result<SixPositionEvent, Error> {
        if let Err(e) = check_input(&a) {
            self.rejected = self.rejected.saturating_add(1);
            return Err(e);
        }
        let c = self.config;
        self.window.push(a);
        if let Some((axis, value)) = self.window.spread_exceeding(c.max_spread) {
            self.window = Stats3::new();
            self.window.push(a);
            return Err(Error::Moved {
                check: MotionCheck::AccelSpread,
                axis,
                value,
                limit: c.max_spread,
            });
        }
        if self.window.count() < c.window {
            return Ok(SixPositionEvent::Collecting {
                samples: self.window.count(),
            });
        }
        let window = self.window;
        self.window = Stats3::new();
        if let Some((axis, value)) = window.std_exceeding(c.max_std) {
            return Err(Error::Moved {
                check: MotionCheck::AccelStdDev,
                axis,
                value,
                limit: c.max_std,
            });
        }
        let mean = window.mean();
        let [x, y, z] = mean;
        let norm = crate::sqrt::sqrtf(x * x + y * y + z * z);
        let (position, dominant) = Position::classify(mean);
        let magnitude_ok = (norm - c.gravity).abs() <= c.magnitude_tolerance * c.gravity;
        if !magnitude_ok || dominant < c.min_alignment * norm {
            return Err(Error::NotAxisAligned);
        }
        if self.progress.is_done(position) {
            return Ok(SixPositionEvent::AlreadyCaptured(position));
        }
        *self.slot_mut(position) = mean;
        self.progress.mask |= position.bit();
        Ok(SixPositionEvent::Captured(position))
    }

    /// The calibration once all six positions are captured, else
    /// [`Error::Incomplete`]; [`Error::OutOfRange`] if a scale is implausible.
    pub fn finish(&self) -> Result<AccelCalibration, Error> {
        if !self.progress.is_complete() {
            return Err(Error::Incomplete {
                positions_done: self.progress.mask,
            });
        }
        let two_g = 2.0 * self.config.gravity;
        let solve = |up: Position, down: Position, axis: usize| -> Result<(f32, f32), Error> {
            let a_plus = self.slot(up).get(axis).copied().ok_or(Error::OutOfRange)?;
            let a_minus = self
                .slot(down)
                .get(axis)
                .copied()
                .ok_or(Error::OutOfRange)?;
            let diff = a_plus - a_minus;
            if diff.is_nan() || diff <= 0.0 {
                return Err(Error::OutOfRange);
            }
            Ok((0.5 * (a_plus + a_minus), two_g / diff))
        };
        let (ox, sx) = solve(Position::XUp, Position::XDown, 0)?;
        let (oy, sy) = solve(Position::YUp, Position::YDown, 1)?;
        let (oz, sz) = solve(Position::ZUp, Position::ZDown, 2)?;
        let cal = AccelCalibration {
            offset: [ox, oy, oz],
            scale: [sx, sy, sz],
        };
        cal.validate()?;
        Ok(cal)
    }
}
