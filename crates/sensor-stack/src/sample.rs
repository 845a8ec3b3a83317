//! What the 1 kHz task does with one MPU-9250 sample, as one call: the
//! start-up gyro bias, the magnetometer and IMU steps of the
//! [`Pipeline`], the control step when due, and the values a calibration
//! session or the raw log asked for. The firmware's `imu` task only reads
//! the bus, calls [`SampleStep::run`] inside the pipeline lock, and hands
//! the [`SampleOutcome`] on.

use mpu9250::RawSample;

use crate::boot::{BiasStatus, StartupGyroBias};
use crate::calmode::{CalWants, RawLogRow};
use crate::pipeline::{ImuInput, Pipeline};
use crate::sensors::MagRead;

/// State the 1 kHz task keeps between samples.
#[derive(Clone, Copy, Debug)]
pub struct SampleStep {
    bias: Option<StartupGyroBias>,
    bias_applied: bool,
    /// The latest magnetometer reading, for raw-log rows.
    last_mag: Option<[i16; 3]>,
}

/// One sample as the 1 kHz task has it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleIn {
    /// The MPU-9250 sample, counts.
    pub raw: RawSample,
    /// The magnetometer read on this sample.
    pub mag: MagRead,
    /// This is the magnetometer's tick (accelerometer calibration samples
    /// are taken on it too).
    pub read_mag: bool,
    /// Cycles since the previous sample (clamped; the AHRS time step).
    pub dt_cycles: u32,
    /// Time since boot, µs (stamps a raw-log row).
    pub now_us: u32,
}

/// What one sample produced for the other tasks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleOutcome {
    /// The start-up gyro bias measurement's state.
    pub bias: BiasStatus,
    /// Magnetometer sample for the calibration, µT, MPU frame, uncorrected.
    pub mag_ut: Option<[f32; 3]>,
    /// Accelerometer sample for the calibration, g, MPU frame, uncorrected
    /// (at the magnetometer rate, 100 Hz).
    pub accel_g: Option<[f32; 3]>,
    /// A raw-log row (in raw-log mode, on the magnetometer's tick: 100 Hz,
    /// with the latest magnetometer reading).
    pub row: Option<RawLogRow>,
}

impl SampleStep {
    /// With a start-up gyro bias measurement (`None`: keep the stored bias).
    pub const fn new(bias: Option<StartupGyroBias>) -> Self {
        Self {
            bias,
            bias_applied: false,
            last_mag: None,
        }
    }

    /// Runs one sample through `p`, producing what `wants` asks for.
    pub fn run(&mut self, p: &mut Pipeline, s: &SampleIn, wants: CalWants) -> SampleOutcome {
        let SampleIn {
            ref raw,
            mag,
            read_mag,
            dt_cycles,
            now_us,
        } = *s;
        let bias = self
            .bias
            .as_mut()
            .map_or(BiasStatus::GaveUp, |e| e.push(raw.gyro, raw.accel));
        if let BiasStatus::Done(b) = bias {
            if !self.bias_applied {
                p.set_gyro_bias_counts(b);
                self.bias_applied = true;
            }
        }
        let mag_counts = match mag {
            MagRead::Sample(m) => Some(m.counts),
            _ => None,
        };
        if let Some(c) = mag_counts {
            p.mag_step(c);
            self.last_mag = Some(c);
        }
        let input = ImuInput {
            accel: raw.accel,
            gyro: raw.gyro,
            dt_cycles,
        };
        if p.imu_step(&input) {
            p.control_step();
        }
        let g_per_lsb = p.config().accel_g_per_lsb;
        SampleOutcome {
            bias,
            mag_ut: mag_counts
                .filter(|_| wants.mag_ut)
                .map(|c| p.mag_counts_to_mpu_raw_ut(c)),
            accel_g: (wants.accel_g && read_mag)
                .then(|| raw.accel.map(|c| f32::from(c) * g_per_lsb)),
            row: (wants.raw_log && read_mag)
                .then(|| p.raw_log_row(now_us as f32 * 1e-6, raw.accel, raw.gyro, self.last_mag)),
        }
    }
}
