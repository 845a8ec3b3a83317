//! Calibration modes as state machines with progress reporting, the PA0
//! button decoder that selects them, and the raw-log row format.
//!
//! * Magnetometer figure-eight: wraps [`calibration::EllipsoidFitF32`] (the
//!   ellipsoid fit with integer moments and an `f32` solve, small enough
//!   for the board); progress is the direction coverage (bins hit of
//!   [`calibration::COVERAGE_BINS`]). [`MagMinMaxMode`] is the per-axis
//!   alternative; both have `standard()` so the firmware picks one by type.
//! * Accelerometer six-position: wraps [`calibration::AccelSixPosition`];
//!   progress is the set of captured positions.
//! * Raw log: stream calibrated sensor values in the BROAD CSV column order
//!   ([`RAW_LOG_HEADER`]) so the replay tool can read a recording.
//!
//! Button (PA0 to GND, pull-up), decoded by [`Button`]:
//! held at boot → accelerometer six-position; long press (≥ 1.5 s) →
//! magnetometer figure-eight; short press → raw log on/off, or abort a
//! calibration in progress.
//!
//! [`CalSession`] ties these together as the firmware runs them: the
//! button and the mode, the samples the 1 kHz task hands in, and a
//! periodic [`CalSession::poll`] that reports progress and, once a
//! calibration is complete, writes it into the calibration record for the
//! caller to save. Its type parameters pick the calibrations a build runs:
//! the calibration build `CalSession<MagCalMode, AccelCalMode>`, the flight
//! build `CalSession<NotBuilt, NotBuilt>` (the modes are refused with
//! [`CalEvent::Unavailable`]; the raw log stays).

use crate::storage::{CalibrationRecord, ValidParts};
use calibration::{
    AccelCalibration, AccelSixPosition, AccelSixPositionConfig, EllipsoidFitConfig,
    EllipsoidFitF32, Error as CalError, MagCalibration, MagMinMax, MagMinMaxConfig, Position,
    Progress, SixPositionEvent, COVERAGE_BINS,
};

/// Figure-eight magnetometer calibration (samples in µT, MPU frame).
#[derive(Clone, Debug)]
pub struct MagCalMode {
    fit: EllipsoidFitF32,
    bins_needed: u8,
    min_samples: u32,
}

/// Progress of [`MagCalMode`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagProgress {
    /// Accepted samples.
    pub samples: u32,
    /// Direction bins hit so far.
    pub bins_hit: u8,
    /// Bins required.
    pub bins_needed: u8,
    /// Overall progress 0..=100 (the lesser of coverage and sample count).
    pub percent: u8,
}

/// Moment quantum of the board's ellipsoid fit, µT: below the AK8963's
/// 0.15 µT step, and samples may lie up to 4096 quanta (512 µT) from the
/// first one.
pub const MAG_FIT_QUANTUM_UT: f32 = 0.125;

impl MagCalMode {
    /// The session the firmware uses: [`EllipsoidFitConfig::MICROTESLA`].
    pub fn standard() -> Result<Self, CalError> {
        Self::new(EllipsoidFitConfig::MICROTESLA)
    }

    /// A fresh session with [`EllipsoidFitConfig::MICROTESLA`]-style
    /// thresholds (`config` is validated by the fit).
    pub fn new(config: EllipsoidFitConfig) -> Result<Self, CalError> {
        Ok(Self {
            fit: EllipsoidFitF32::new(config, MAG_FIT_QUANTUM_UT)?,
            bins_needed: config.bins_needed.min(COVERAGE_BINS),
            min_samples: config.min_samples.max(10),
        })
    }

    /// Adds a sample; bad samples are skipped (counted by the fit).
    pub fn push(&mut self, mag_ut: [f32; 3]) -> MagProgress {
        let _ = self.fit.push(mag_ut);
        self.progress()
    }

    /// Current progress.
    pub fn progress(&self) -> MagProgress {
        let samples = self.fit.count();
        let bins_hit = self.fit.bins_hit();
        let cov = percent(u32::from(bins_hit), u32::from(self.bins_needed));
        let cnt = percent(samples, self.min_samples);
        MagProgress {
            samples,
            bins_hit,
            bins_needed: self.bins_needed,
            percent: cov.min(cnt),
        }
    }

    /// `true` once coverage and sample count are sufficient to try a fit.
    pub fn ready(&self) -> bool {
        self.progress().percent >= 100
    }

    /// Fits the ellipsoid (one-off `f32` work: call from a low-priority
    /// context).
    pub fn finish(&self) -> Result<MagCalibration, CalError> {
        self.fit.finish().map(|s| s.calibration)
    }
}

/// Light-weight magnetometer calibration (samples in µT, MPU frame): per-axis
/// min/max ([`calibration::MagMinMax`]: hard iron + diagonal soft iron), all
/// `f32`; less flash than [`MagCalMode`] but no cross-axis soft iron.
/// Progress = the smallest per-axis sweep relative to the required range.
#[derive(Clone, Debug)]
pub struct MagMinMaxMode {
    mm: MagMinMax,
    min_range_ut: f32,
    min_samples: u32,
}

impl MagMinMaxMode {
    /// The session for µT: every axis sweeps 40 µT, 300 samples.
    pub fn standard() -> Result<Self, CalError> {
        Self::new(40.0, 300)
    }

    /// Every axis must sweep `min_range_ut` (a full figure-eight sweeps about
    /// twice the local field, 50–130 µT) over at least `min_samples` samples.
    pub fn new(min_range_ut: f32, min_samples: u32) -> Result<Self, CalError> {
        let mm = MagMinMax::new(MagMinMaxConfig {
            min_range: min_range_ut,
            min_samples,
        })?;
        Ok(Self {
            mm,
            min_range_ut,
            min_samples: min_samples.max(1),
        })
    }

    /// Adds a sample; bad samples are skipped (counted).
    pub fn push(&mut self, mag_ut: [f32; 3]) -> MagProgress {
        let _ = self.mm.push(mag_ut);
        self.progress()
    }

    /// Current progress; `bins_hit`/`bins_needed` count axes swept enough (of 3).
    pub fn progress(&self) -> MagProgress {
        let r = self.mm.ranges();
        let mut worst = 100u8;
        let mut axes = 0u8;
        for v in r {
            let p = if self.min_range_ut > 0.0 {
                (v / self.min_range_ut * 100.0).clamp(0.0, 100.0) as u8
            } else {
                100
            };
            if p >= 100 {
                axes += 1;
            }
            worst = worst.min(p);
        }
        let samples = self.mm.count();
        MagProgress {
            samples,
            bins_hit: axes,
            bins_needed: 3,
            percent: worst.min(percent(samples, self.min_samples)),
        }
    }

    /// `true` once every axis is swept and enough samples were taken.
    pub fn ready(&self) -> bool {
        self.progress().percent >= 100
    }

    /// The hard-iron offset and diagonal soft-iron correction.
    pub fn finish(&self) -> Result<MagCalibration, CalError> {
        self.mm.finish()
    }
}

fn percent(have: u32, need: u32) -> u8 {
    if have >= need {
        return 100;
    }
    // have < need here, so have · 100 / need < 100; avoid overflow of have · 100.
    let p = if have <= u32::MAX / 100 {
        have * 100 / need
    } else {
        have / (need / 100).max(1)
    };
    p.min(100) as u8
}

/// Six-position accelerometer calibration (samples in g, MPU frame).
#[derive(Clone, Debug)]
pub struct AccelCalMode {
    six: AccelSixPosition,
}

/// Progress of [`AccelCalMode`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelProgress {
    /// Positions captured (0..=6).
    pub captured: u8,
    /// The next position to present, if any remain (the first missing
    /// in sensor-axis order; [`crate::Mounting::next_face`] names the next
    /// face for the builder).
    pub next: Option<Position>,
    /// The positions captured so far.
    pub done: Progress,
    /// A position captured by this sample.
    pub just_captured: Option<Position>,
    /// The board is moving (window restarted).
    pub moving: bool,
}

impl AccelCalMode {
    /// A fresh session.
    pub fn new(config: AccelSixPositionConfig) -> Result<Self, CalError> {
        Ok(Self {
            six: AccelSixPosition::new(config)?,
        })
    }

    /// Adds a sample.
    pub fn push(&mut self, accel_g: [f32; 3]) -> AccelProgress {
        let r = self.six.push(accel_g);
        let p = self.six.progress();
        AccelProgress {
            captured: p.count(),
            next: p.next_missing(),
            done: p,
            just_captured: match r {
                Ok(SixPositionEvent::Captured(pos)) => Some(pos),
                _ => None,
            },
            moving: matches!(r, Err(CalError::Moved { .. })),
        }
    }

    /// Current progress (without a new sample).
    pub fn progress(&self) -> AccelProgress {
        let p = self.six.progress();
        AccelProgress {
            captured: p.count(),
            next: p.next_missing(),
            done: p,
            just_captured: None,
            moving: false,
        }
    }

    /// `true` once all six positions are captured.
    pub fn ready(&self) -> bool {
        self.six.progress().is_complete()
    }

    /// The fitted offsets and scales.
    pub fn finish(&self) -> Result<AccelCalibration, CalError> {
        self.six.finish()
    }
}

/// What a decoded button press means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Press {
    /// Released after less than [`LONG_PRESS_MS`].
    Short,
    /// Held for [`LONG_PRESS_MS`] (reported once, while still held).
    Long,
}

/// Debounce time, ms.
pub const DEBOUNCE_MS: u32 = 30;
/// Long-press threshold, ms.
pub const LONG_PRESS_MS: u32 = 1_500;

/// Debounced button decoder over a polled level (`pressed` = PA0 low) and
/// a wrapping ms clock.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Button {
    stable: bool,
    candidate: bool,
    since_ms: u32,
    pressed_at_ms: u32,
    long_sent: bool,
}

impl Button {
    /// A released button.
    pub const fn new() -> Self {
        Self {
            stable: false,
            candidate: false,
            since_ms: 0,
            pressed_at_ms: 0,
            long_sent: false,
        }
    }

    /// A button already held when the firmware starts (the boot-time
    /// selection of the accelerometer calibration): letting it go is the end
    /// of that gesture, not a short press, and holding it on is no long press.
    pub const fn held_at_boot() -> Self {
        Self {
            stable: true,
            candidate: true,
            since_ms: 0,
            pressed_at_ms: 0,
            long_sent: true,
        }
    }

    /// Feeds the raw level; returns a press event when one completes.
    pub fn update(&mut self, now_ms: u32, pressed: bool) -> Option<Press> {
        if pressed != self.candidate {
            self.candidate = pressed;
            self.since_ms = now_ms;
        }
        if self.candidate != self.stable && now_ms.wrapping_sub(self.since_ms) >= DEBOUNCE_MS {
            self.stable = self.candidate;
            if self.stable {
                self.pressed_at_ms = self.since_ms;
                self.long_sent = false;
            } else if !self.long_sent {
                return Some(Press::Short);
            }
        }
        if self.stable
            && !self.long_sent
            && now_ms.wrapping_sub(self.pressed_at_ms) >= LONG_PRESS_MS
        {
            self.long_sent = true;
            return Some(Press::Long);
        }
        None
    }
}

/// The operating mode selected by the button.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Normal operation: live log.
    Normal,
    /// Streaming calibrated samples in CSV order.
    RawLog,
    /// Magnetometer figure-eight calibration running.
    MagCal,
    /// Accelerometer six-position calibration running.
    AccelCal,
}

impl Mode {
    /// Mode at boot: button held → accelerometer calibration.
    pub fn at_boot(button_held: bool) -> Self {
        if button_held {
            Self::AccelCal
        } else {
            Self::Normal
        }
    }

    /// Transition on a press.
    pub fn on_press(self, press: Press) -> Self {
        match (self, press) {
            (Self::Normal, Press::Short) => Self::RawLog,
            (Self::RawLog, Press::Short) => Self::Normal,
            (Self::Normal | Self::RawLog, Press::Long) => Self::MagCal,
            // A press aborts a calibration.
            (Self::MagCal | Self::AccelCal, _) => Self::Normal,
        }
    }
}

/// Column header of a raw-log recording: the BROAD CSV column order
/// (see `../shared/data/broad/README.md` beside the project); reference columns are `nan`.
pub const RAW_LOG_HEADER: &str =
    "t_s,gyr_x_rad_s,gyr_y_rad_s,gyr_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2,\
mag_x_ut,mag_y_ut,mag_z_ut,ref_qw,ref_qx,ref_qy,ref_qz,moving";

/// The columns the STM32F103CB build adds to [`RAW_LOG_HEADER`]: the rate
/// loop's setpoint and the filtered gyro it controls, body FRD, °/s,
/// averaged over each raw-log period, as `cargo sim --analyse` reads them
/// (the scenario CSV's names).
pub const RATE_LOG_COLUMNS: &str = "sp_roll_rate_dps,gyro_roll_dps,sp_pitch_rate_dps,\
gyro_pitch_dps,sp_yaw_rate_dps,gyro_yaw_dps";

/// Raw-log rate: every [`RAW_LOG_DIVIDER`]th IMU sample (100 Hz at 1 kHz,
/// on the magnetometer's tick; ~45 bytes a row of defmt-encoded floats,
/// ≈ 4.5 KB/s over RTT).
pub const RAW_LOG_DIVIDER: u16 = crate::schedule::MAG_DIVIDER;

/// Measured columns of a raw-log row (the first ten of [`RAW_LOG_HEADER`];
/// the four reference columns are `nan` and `moving` is 0).
pub const RAW_LOG_MEASURED_COLUMNS: usize = 10;

/// One raw-log row: calibrated values in the MPU sensor frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawLogRow {
    /// Time since boot, s.
    pub t_s: f32,
    /// Angular rate, rad/s (bias removed).
    pub gyr_rps: [f32; 3],
    /// Specific force, m/s² (accelerometer calibration applied).
    pub acc_mps2: [f32; 3],
    /// Magnetic field, µT (hard/soft iron applied; NaN if no magnetometer).
    pub mag_ut: [f32; 3],
}

impl RawLogRow {
    /// The measured values in [`RAW_LOG_HEADER`] order: the one place that
    /// order is written down (the CSV writer and the firmware's log line
    /// both print these positionally).
    pub fn columns(&self) -> [f32; RAW_LOG_MEASURED_COLUMNS] {
        let [gx, gy, gz] = self.gyr_rps;
        let [ax, ay, az] = self.acc_mps2;
        let [mx, my, mz] = self.mag_ut;
        [self.t_s, gx, gy, gz, ax, ay, az, mx, my, mz]
    }

    /// Writes the row as one CSV line (no newline) in [`RAW_LOG_HEADER`]
    /// order.
    ///
    /// ```
    /// let mut s = String::new();
    /// sensor_stack::calmode::RawLogRow { t_s: 0.5, ..Default::default() }.write_csv(&mut s).unwrap();
    /// assert_eq!(s, "0.5,0,0,0,0,0,0,0,0,0,nan,nan,nan,nan,0");
    /// ```
    pub fn write_csv<W: core::fmt::Write>(&self, w: &mut W) -> core::fmt::Result {
        let [t, rest @ ..] = self.columns();
        write!(w, "{t}")?;
        for v in rest {
            if v.is_nan() {
                w.write_str(",nan")?;
            } else {
                write!(w, ",{v}")?;
            }
        }
        w.write_str(",nan,nan,nan,nan,0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn button_short_long_debounce() {
        let mut b = Button::new();
        assert_eq!(b.update(0, true), None);
        // Bounce shorter than the debounce time is ignored.
        assert_eq!(b.update(10, false), None);
        assert_eq!(b.update(50, false), None);
        assert_eq!(b.update(100, true), None);
        assert_eq!(b.update(135, true), None);
        assert_eq!(b.update(400, false), None);
        assert_eq!(b.update(431, false), Some(Press::Short));
        assert_eq!(b.update(1000, true), None);
        assert_eq!(b.update(2499, true), None);
        assert_eq!(b.update(2500, true), Some(Press::Long));
        assert_eq!(b.update(2600, true), None);
        assert_eq!(b.update(2700, false), None);
        assert_eq!(b.update(2800, false), None, "no short after a long");
    }

    #[test]
    fn mode_transitions() {
        assert_eq!(Mode::at_boot(true), Mode::AccelCal);
        assert_eq!(Mode::at_boot(false), Mode::Normal);
        assert_eq!(Mode::Normal.on_press(Press::Short), Mode::RawLog);
        assert_eq!(Mode::RawLog.on_press(Press::Short), Mode::Normal);
        assert_eq!(Mode::Normal.on_press(Press::Long), Mode::MagCal);
        assert_eq!(Mode::MagCal.on_press(Press::Short), Mode::Normal);
        assert_eq!(Mode::AccelCal.on_press(Press::Long), Mode::Normal);
    }

    #[test]
    fn header_has_broad_columns() {
        assert_eq!(RAW_LOG_HEADER.split(',').count(), 15);
        let mut s = String::new();
        RawLogRow {
            t_s: 1.0,
            gyr_rps: [0.1, 0.2, 0.3],
            acc_mps2: [0.0, 0.0, 9.81],
            mag_ut: [f32::NAN; 3],
        }
        .write_csv(&mut s)
        .unwrap();
        assert_eq!(s.split(',').count(), 15);
        assert!(s.starts_with("1,0.1,0.2,0.3,0,0,9.81,nan,nan,nan,nan"));
    }

    extern crate std;
    use std::string::String;

    /// Field of 50 µT, hard iron (10, −20, 5) µT, axis gains 1.1/0.9/1.0.
    fn distorted(dir: [f32; 3]) -> [f32; 3] {
        [
            dir[0] * 55.0 + 10.0,
            dir[1] * 45.0 - 20.0,
            dir[2] * 50.0 + 5.0,
        ]
    }

    #[test]
    fn mag_figure_eight_progress_and_fit() {
        let mut m = MagCalMode::new(EllipsoidFitConfig::MICROTESLA).unwrap();
        let p0 = m.push(distorted([1.0, 0.0, 0.0]));
        assert_eq!(p0.samples, 1);
        assert!(p0.percent < 10);
        // Only one plane first: coverage stays partial, fit refused.
        for i in 0..200 {
            let a = i as f32 * 0.0314;
            m.push(distorted([libm::cosf(a), libm::sinf(a), 0.0]));
        }
        assert!(!m.ready());
        assert!(m.finish().is_err());
        // Then the full sphere (spiral).
        let n = 600;
        let mut last = m.progress();
        for i in 0..n {
            let z = -1.0 + 2.0 * (i as f32 + 0.5) / n as f32;
            let r = libm::sqrtf(1.0 - z * z);
            let a = i as f32 * 2.4;
            let p = m.push(distorted([r * libm::cosf(a), r * libm::sinf(a), z]));
            assert!(p.bins_hit >= last.bins_hit, "coverage never decreases");
            last = p;
        }
        assert!(m.ready(), "{last:?}");
        let cal = m.finish().unwrap();
        let c = cal.apply(distorted([0.0, 0.0, 1.0]));
        let c2 = cal.apply(distorted([1.0, 0.0, 0.0]));
        let n1 = libm::sqrtf(c.iter().map(|v| v * v).sum());
        let n2 = libm::sqrtf(c2.iter().map(|v| v * v).sum());
        assert!((n1 - n2).abs() / n1 < 0.02, "{n1} {n2}");
    }

    #[test]
    fn mag_min_max_mode() {
        let mut m = MagMinMaxMode::new(40.0, 100).unwrap();
        for i in 0..50 {
            let a = i as f32 * 0.0314;
            m.push(distorted([libm::cosf(a), libm::sinf(a), 0.0]));
        }
        // Only a quarter turn in one plane: not ready, z never swept.
        assert!(!m.ready());
        assert_eq!(m.progress().percent, 0);
        let n = 600;
        for i in 0..n {
            let z = -1.0 + 2.0 * (i as f32 + 0.5) / n as f32;
            let r = libm::sqrtf(1.0 - z * z);
            let a = i as f32 * 2.4;
            m.push(distorted([r * libm::cosf(a), r * libm::sinf(a), z]));
        }
        assert!(m.ready());
        let cal = m.finish().unwrap();
        // Hard iron (10, −20, 5) µT recovered within the sampling of the extremes.
        assert!(
            (cal.offset[0] - 10.0).abs() < 1.0 && (cal.offset[1] + 20.0).abs() < 1.0,
            "{cal:?}"
        );
    }

    #[test]
    fn accel_six_position() {
        let cfg = AccelSixPositionConfig {
            window: 20,
            ..AccelSixPositionConfig::G
        };
        let mut a = AccelCalMode::new(cfg).unwrap();
        let mut captured = 0;
        for p in Position::ALL {
            let mut v = [0.02, -0.01, 0.05];
            v[p.axis() as usize] += if p.is_up() { 1.02 } else { -1.02 };
            for _ in 0..20 {
                let pr = a.push(v);
                if pr.just_captured == Some(p) {
                    captured += 1;
                }
            }
        }
        assert_eq!(captured, 6);
        assert!(a.ready());
        let cal = a.finish().unwrap();
        assert!((cal.offset[2] - 0.05).abs() < 1e-4);
        assert!((cal.scale[0] - 1.0 / 1.02).abs() < 1e-4);
    }
}

/// A magnetometer calibration [`CalSession`] can run: [`MagMinMaxMode`]
/// (small, `f32`) or [`MagCalMode`] (ellipsoid fit, integer moments and an
/// `f32` solve).
pub trait MagCalibrator: Sized {
    /// A fresh session with the firmware's thresholds (`None` if they are
    /// refused).
    fn start() -> Option<Self>;
    /// Adds a sample (µT, MPU frame, no hard/soft-iron correction).
    fn push(&mut self, mag_ut: [f32; 3]) -> MagProgress;
    /// Current progress.
    fn progress(&self) -> MagProgress;
    /// `true` once a fit may be tried.
    fn ready(&self) -> bool;
    /// The fit.
    fn finish(&self) -> Result<MagCalibration, CalError>;
}

/// An accelerometer calibration [`CalSession`] can run: [`AccelCalMode`],
/// or [`NotBuilt`] in a build that leaves it out.
pub trait AccelCalibrator: Sized {
    /// A fresh session (`None` if its thresholds are refused, or if the
    /// build leaves this calibration out).
    fn start() -> Option<Self>;
    /// Adds a sample (g, MPU frame, uncorrected).
    fn push(&mut self, accel_g: [f32; 3]) -> AccelProgress;
    /// Current progress.
    fn progress(&self) -> AccelProgress;
    /// `true` once all six faces are captured.
    fn ready(&self) -> bool;
    /// The fit.
    fn finish(&self) -> Result<AccelCalibration, CalError>;
}

impl AccelCalibrator for AccelCalMode {
    fn start() -> Option<Self> {
        Self::new(AccelSixPositionConfig::default()).ok()
    }
    fn push(&mut self, accel_g: [f32; 3]) -> AccelProgress {
        AccelCalMode::push(self, accel_g)
    }
    fn progress(&self) -> AccelProgress {
        AccelCalMode::progress(self)
    }
    fn ready(&self) -> bool {
        AccelCalMode::ready(self)
    }
    fn finish(&self) -> Result<AccelCalibration, CalError> {
        AccelCalMode::finish(self)
    }
}

/// A calibration this build leaves out: [`CalSession`] refuses to enter
/// its mode ([`CalEvent::Unavailable`]) and none of its code is linked.
/// The flight build runs no calibration session (the calibration build
/// does: the flash plan in ARCHITECTURE.md), only the gyro bias at boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NotBuilt {}

impl MagCalibrator for NotBuilt {
    fn start() -> Option<Self> {
        None
    }
    fn push(&mut self, _: [f32; 3]) -> MagProgress {
        match *self {}
    }
    fn progress(&self) -> MagProgress {
        match *self {}
    }
    fn ready(&self) -> bool {
        match *self {}
    }
    fn finish(&self) -> Result<MagCalibration, CalError> {
        match *self {}
    }
}

impl AccelCalibrator for NotBuilt {
    fn start() -> Option<Self> {
        None
    }
    fn push(&mut self, _: [f32; 3]) -> AccelProgress {
        match *self {}
    }
    fn progress(&self) -> AccelProgress {
        match *self {}
    }
    fn ready(&self) -> bool {
        match *self {}
    }
    fn finish(&self) -> Result<AccelCalibration, CalError> {
        match *self {}
    }
}

impl MagCalibrator for MagMinMaxMode {
    fn start() -> Option<Self> {
        Self::standard().ok()
    }
    fn push(&mut self, mag_ut: [f32; 3]) -> MagProgress {
        MagMinMaxMode::push(self, mag_ut)
    }
    fn progress(&self) -> MagProgress {
        MagMinMaxMode::progress(self)
    }
    fn ready(&self) -> bool {
        MagMinMaxMode::ready(self)
    }
    fn finish(&self) -> Result<MagCalibration, CalError> {
        MagMinMaxMode::finish(self)
    }
}

impl MagCalibrator for MagCalMode {
    fn start() -> Option<Self> {
        Self::standard().ok()
    }
    fn push(&mut self, mag_ut: [f32; 3]) -> MagProgress {
        MagCalMode::push(self, mag_ut)
    }
    fn progress(&self) -> MagProgress {
        MagCalMode::progress(self)
    }
    fn ready(&self) -> bool {
        MagCalMode::ready(self)
    }
    fn finish(&self) -> Result<MagCalibration, CalError> {
        MagCalMode::finish(self)
    }
}

/// Which samples the 1 kHz task should hand to a [`CalSession`] and
/// whether it should build raw-log rows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalWants {
    /// Magnetometer samples, µT, MPU frame, uncorrected ([`CalSession::push_mag`]).
    pub mag_ut: bool,
    /// Accelerometer samples, g, MPU frame, uncorrected ([`CalSession::push_accel`]).
    pub accel_g: bool,
    /// Raw-log rows.
    pub raw_log: bool,
}

/// What a [`CalSession`] reports.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalEvent {
    /// The mode changed (a press, or a calibration finished).
    ModeChanged {
        /// Before.
        from: Mode,
        /// After.
        to: Mode,
    },
    /// Magnetometer calibration progress (every [`CalSession::MAG_PROGRESS_POLLS`] polls).
    MagProgress(MagProgress),
    /// Accelerometer calibration progress (every [`CalSession::ACCEL_PROGRESS_POLLS`] polls).
    AccelProgress(AccelProgress),
    /// Magnetometer calibration done and written into the record (hard
    /// iron, µT): save the record and apply it.
    MagDone {
        /// Hard-iron offset, µT, MPU frame.
        offset_ut: [f32; 3],
    },
    /// Accelerometer calibration done and written into the record: save
    /// the record and apply it.
    AccelDone {
        /// Offset, g.
        offset_g: [f32; 3],
        /// Scale factors.
        scale: [f32; 3],
    },
    /// The magnetometer fit was refused, and why (reported at most every
    /// [`CalSession::MAG_PROGRESS_POLLS`] polls while it keeps being
    /// refused); the session goes on (keep turning).
    MagRefused(CalError),
    /// The accelerometer result was implausible; the session restarted.
    AccelRestarted,
    /// A press (or the button held at boot) asked for a calibration this
    /// build leaves out ([`NotBuilt`]: the flight build; calibrate with the
    /// calibration build); the mode did not change.
    Unavailable {
        /// The calibration mode asked for.
        wanted: Mode,
    },
}

/// The button, the operating mode and the calibration in progress, as one
/// host-testable state machine. The 1 kHz task asks [`wants`](Self::wants)
/// and hands samples to [`push_mag`](Self::push_mag) /
/// [`push_accel`](Self::push_accel); a slow task feeds the button
/// ([`on_button`](Self::on_button)) and calls [`poll`](Self::poll).
#[derive(Clone, Debug)]
pub struct CalSession<M, A = AccelCalMode> {
    mode: Mode,
    button: Button,
    mag: Option<M>,
    accel: Option<A>,
    polls: u32,
    refused_at_boot: bool,
}

impl<M: MagCalibrator, A: AccelCalibrator> CalSession<M, A> {
    /// Polls between magnetometer progress reports.
    pub const MAG_PROGRESS_POLLS: u32 = 10;
    /// Polls between accelerometer progress reports.
    pub const ACCEL_PROGRESS_POLLS: u32 = 20;

    /// The session at boot: the button held → accelerometer calibration
    /// (if this build has it: [`refused_at_boot`](Self::refused_at_boot)).
    pub fn new(button_held_at_boot: bool) -> Self {
        let mut s = Self {
            mode: Mode::Normal,
            button: if button_held_at_boot {
                Button::held_at_boot()
            } else {
                Button::new()
            },
            mag: None,
            accel: None,
            polls: 0,
            refused_at_boot: false,
        };
        s.refused_at_boot = !s.enter(Mode::at_boot(button_held_at_boot));
        s
    }

    /// `true` if the button was held at boot for a calibration this build
    /// leaves out (the session then starts in [`Mode::Normal`]).
    pub fn refused_at_boot(&self) -> bool {
        self.refused_at_boot
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// What the 1 kHz task should feed in.
    pub fn wants(&self) -> CalWants {
        CalWants {
            mag_ut: self.mode == Mode::MagCal,
            accel_g: self.mode == Mode::AccelCal,
            raw_log: self.mode == Mode::RawLog,
        }
    }

    /// Enters `mode`, starting its calibration; `false` (and no change)
    /// if that calibration cannot start (left out of this build).
    fn enter(&mut self, mode: Mode) -> bool {
        let mag = if mode == Mode::MagCal {
            match M::start() {
                Some(m) => Some(m),
                None => return false,
            }
        } else {
            None
        };
        let accel = if mode == Mode::AccelCal {
            match A::start() {
                Some(a) => Some(a),
                None => return false,
            }
        } else {
            None
        };
        self.mode = mode;
        self.mag = mag;
        self.accel = accel;
        self.polls = 0;
        true
    }

    /// A decoded press: changes the mode (and starts or aborts a
    /// calibration), or says the calibration asked for is unavailable.
    pub fn on_press(&mut self, press: Press) -> CalEvent {
        let from = self.mode;
        let to = from.on_press(press);
        if self.enter(to) {
            CalEvent::ModeChanged { from, to }
        } else {
            CalEvent::Unavailable { wanted: to }
        }
    }

    /// The button level at `now_ms` (debounced here); a press changes the
    /// mode.
    // Out of line: measured smaller in the firmware than inlined into its task.
    #[inline(never)]
    pub fn on_button(&mut self, now_ms: u32, pressed: bool) -> Option<CalEvent> {
        self.button
            .update(now_ms, pressed)
            .map(|p| self.on_press(p))
    }

    /// A magnetometer sample (ignored unless calibrating the magnetometer).
    // Out of line: measured smaller in the firmware than inlined into its task.
    #[inline(never)]
    pub fn push_mag(&mut self, mag_ut: [f32; 3]) {
        if let Some(m) = self.mag.as_mut() {
            m.push(mag_ut);
        }
    }

    /// An accelerometer sample (ignored unless calibrating the accelerometer).
    pub fn push_accel(&mut self, accel_g: [f32; 3]) {
        if let Some(a) = self.accel.as_mut() {
            a.push(accel_g);
        }
    }

    /// The slow-task step: progress every few polls and, once a
    /// calibration is complete, its result written into `record` (the
    /// session then returns to [`Mode::Normal`]). The magnetometer fit
    /// runs here.
    // Out of line: run from the slow log task, and inlined there its
    // calibration record is copied once more (less flash).
    #[inline(never)]
    pub fn poll(&mut self, record: &mut CalibrationRecord) -> Option<CalEvent> {
        self.polls = self.polls.wrapping_add(1);
        match self.mode {
            Mode::MagCal => {
                let m = self.mag.as_ref()?;
                if m.ready() {
                    return Some(match m.finish() {
                        Ok(c) => {
                            record.mag_offset_ut = c.offset;
                            record.mag_soft_iron = c.soft_iron;
                            record.valid.0 |= ValidParts::MAG;
                            self.enter(Mode::Normal);
                            CalEvent::MagDone {
                                offset_ut: c.offset,
                            }
                        }
                        Err(e) => {
                            return self
                                .polls
                                .is_multiple_of(Self::MAG_PROGRESS_POLLS)
                                .then_some(CalEvent::MagRefused(e));
                        }
                    });
                }
                self.polls
                    .is_multiple_of(Self::MAG_PROGRESS_POLLS)
                    .then(|| CalEvent::MagProgress(m.progress()))
            }
            Mode::AccelCal => {
                let a = self.accel.as_ref()?;
                if a.ready() {
                    return Some(match a.finish() {
                        Ok(c) => {
                            record.accel_offset_g = c.offset;
                            record.accel_scale = c.scale;
                            record.valid.0 |= ValidParts::ACCEL;
                            self.enter(Mode::Normal);
                            CalEvent::AccelDone {
                                offset_g: c.offset,
                                scale: c.scale,
                            }
                        }
                        Err(_) => {
                            self.enter(Mode::AccelCal);
                            CalEvent::AccelRestarted
                        }
                    });
                }
                self.polls
                    .is_multiple_of(Self::ACCEL_PROGRESS_POLLS)
                    .then(|| CalEvent::AccelProgress(a.progress()))
            }
            Mode::Normal | Mode::RawLog => None,
        }
    }
}
