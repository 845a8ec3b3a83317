//! The sensor stack on the simulated board.
//!
//! * The ground calibrations a user runs once and stores in flash: the
//!   accelerometer six-position ([`calibrate_accel_six_position`]) and the
//!   magnetometer figure-eight dance ([`calibrate_mag_on_dance`]), each a
//!   separate session of the same simulated board, through the real drivers
//!   and `calibration`'s estimators. [`calibration_record`] packs them into
//!   the firmware's flash record (and through its byte encoding).
//! * The flight: [`Stack`] is the firmware's per-sample path without the
//!   RTIC wiring — `sensor_stack::sensors::Sensors` (boot probe, health, reads),
//!   `sensor_stack::boot::StartupGyroBias`, `sensor_stack::schedule` (magnetometer
//!   divider, cycle-counter dt) and `sensor_stack::pipeline::Pipeline` (raw counts
//!   → calibration → mounting → AHRS → vertical estimator → controllers),
//!   called in the same order as the firmware's `imu` and `baro` tasks.

use super::mag::Mag;
use calibration::{
    AccelCalibration, AccelSixPosition, AccelSixPositionConfig, EllipsoidFit, EllipsoidFitConfig,
    MagCalibration, MagMinMax, MagMinMaxConfig, Position, SixPositionEvent,
};
use embedded_hal::delay::DelayNs;
use host_console::note;
use mpu9250::{Address, Mpu9250};
use sensor_stack::boot::{BiasStatus, BootReport, StartupGyroBias};
use sensor_stack::calmode::CalWants;
use sensor_stack::pipeline::{Pipeline, PipelineConfig, G_MPS2};
use sensor_stack::sample::{SampleIn, SampleStep};
use sensor_stack::schedule::{DtClock, SampleScheduler, IMU_RATE_HZ, MAG_DIVIDER};
use sensor_stack::sensors::{MagRead, Sensors as FlightSensors, SensorsConfig};
use sensor_stack::storage::{CalibrationRecord, ValidParts};
use sim::{SimBus, SimConfig, SimDelay, Trajectory};

/// CPU clock of the simulated Blue Pill (its DWT cycle counter), Hz.
pub const CPU_HZ: u32 = 72_000_000;

/// Which AHRS implementation the `flight` pipeline was built with: chosen
/// at compile time by `flight`'s `f32-ahrs` feature (this crate's
/// `f32-ahrs` feature forwards it), exactly as for the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// `fc_ahrs::Madgwick` (f32): built with `--features f32-ahrs`.
    F32,
    /// The fixed-point Madgwick (Q30): the default build.
    Fixed,
}

impl Filter {
    /// The one this binary was built with.
    pub const BUILT: Filter = if cfg!(feature = "f32-ahrs") {
        Filter::F32
    } else {
        Filter::Fixed
    };
}

/// The inertial drivers on one simulated bus, for the ground calibrations
/// (the barometer is not needed there).
pub struct Sensors {
    /// MPU-9250 driver.
    pub imu: Mpu9250<SimBus>,
    /// AK8963 access.
    pub mag: Mag,
}

/// Initialises the MPU-9250 (with I2C bypass so the AK8963 is on the bus)
/// and the AK8963.
pub fn init_sensors(bus: &SimBus, delay: &mut SimDelay) -> Result<Sensors, String> {
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.set_bypass(true)
        .map_err(|e| format!("MPU-9250 bypass: {e}"))?;
    imu.init(delay, &settings::MPU)
        .map_err(|e| format!("MPU-9250 init: {e}"))?;
    let mag = Mag::init(bus.clone(), delay)?;
    Ok(Sensors { imu, mag })
}

/// Result of the accelerometer six-position calibration.
pub struct AccelCalRun {
    /// The correction (g, MPU frame).
    pub calibration: AccelCalibration,
    /// Order in which the faces were captured, with the simulated time (s).
    pub captured: Vec<(Position, f64)>,
    /// Still windows refused (moved, not square to gravity).
    pub refused_windows: u32,
    /// RMS of `|corrected mean| − 1 g` over the six captured faces (g): what
    /// the per-axis model leaves (cross-axis misalignment, tilt, noise).
    pub rms_residual_g: f32,
}

/// The accelerometer six-position calibration as a user does it: the same
/// board (`base`'s errors and seed) held still on each face in turn
/// ([`Trajectory::SixPosition`]), one accelerometer sample (g, MPU frame)
/// every 10 ms into `calibration::AccelSixPosition` with its default
/// settings (200-sample still windows), like the firmware's calibration mode.
pub fn calibrate_accel_six_position(base: &SimConfig) -> Result<AccelCalRun, String> {
    let config = SimConfig {
        trajectory: Trajectory::SixPosition,
        ..base.clone()
    };
    let clock = sim::SimClock::new();
    let bus = SimBus::new(&clock, config);
    let mut delay = clock.delay();
    let mut sensors = init_sensors(&bus, &mut delay)?;
    let mut six = AccelSixPosition::new(AccelSixPositionConfig::G).map_err(|e| format!("{e}"))?;
    let mut captured = Vec::new();
    let mut refused_windows = 0;
    // Generous limit: the sequence itself takes ~40 s.
    let limit_s = Trajectory::six_position_duration_s() + 20.0;
    while !six.progress().is_complete() {
        if clock.now_s() > limit_s {
            return Err(format!(
                "accel six-position: only {} of 6 faces captured in {limit_s:.0} s",
                six.progress().count()
            ));
        }
        delay.delay_ms(10);
        let s = sensors
            .imu
            .read()
            .map_err(|e| format!("MPU-9250 read: {e}"))?;
        match six.push(s.accel_g) {
            Ok(SixPositionEvent::Captured(p)) => captured.push((p, clock.now_s())),
            Ok(_) => {}
            Err(_) => refused_windows += 1,
        }
    }
    let calibration = six
        .finish()
        .map_err(|e| format!("accel six-position: {e}"))?;
    let mut sum2 = 0.0;
    for p in Position::ALL {
        let m = six.captured(p).unwrap_or_default();
        let c = calibration.apply(m);
        let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        sum2 += (n - 1.0) * (n - 1.0);
    }
    Ok(AccelCalRun {
        calibration,
        captured,
        refused_windows,
        rms_residual_g: (sum2 / 6.0).sqrt(),
    })
}

/// Result of the magnetometer calibration dance.
pub struct MagCalRun {
    /// Raw samples (µT, MPU frame).
    pub raw_mpu_ut: Vec<[f32; 3]>,
    /// The correction (µT, MPU frame).
    pub calibration: MagCalibration,
    /// "ellipsoid" or "min/max".
    pub method: &'static str,
    /// RMS residual of the fit, relative to the radius (ellipsoid only).
    pub rms_error: Option<f32>,
}

/// The ground calibration dance: the same board (`base`'s errors and seed)
/// on the figure-eight trajectory for `duration_s`, every magnetometer sample
/// into an ellipsoid fit (min/max as a fallback).
pub fn calibrate_mag_on_dance(base: &SimConfig, duration_s: f64) -> Result<MagCalRun, String> {
    let config = SimConfig {
        trajectory: Trajectory::FigureEight,
        ..base.clone()
    };
    let clock = sim::SimClock::new();
    let bus = SimBus::new(&clock, config);
    let mut delay = clock.delay();
    let mut sensors = init_sensors(&bus, &mut delay)?;
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).map_err(|e| format!("{e}"))?;
    let mut minmax = MagMinMax::new(MagMinMaxConfig::MICROTESLA).map_err(|e| format!("{e}"))?;
    let mut raw = Vec::new();
    while clock.now_s() < duration_s {
        delay.delay_ms(5);
        if let Some(m) = sensors.mag.read()? {
            raw.push(m);
            let _ = fit.push(m);
            let _ = minmax.push(m);
        }
    }
    match fit.finish() {
        Ok(sol) => Ok(MagCalRun {
            raw_mpu_ut: raw,
            calibration: sol.calibration,
            method: "ellipsoid",
            rms_error: Some(sol.rms_error),
        }),
        Err(e) => {
            note!("ellipsoid fit failed ({e}), falling back to min/max");
            let calibration = minmax.finish().map_err(|e| format!("min/max: {e}"))?;
            Ok(MagCalRun {
                raw_mpu_ut: raw,
                calibration,
                method: "min/max",
                rms_error: None,
            })
        }
    }
}

/// The firmware's flash record holding the two ground calibrations
/// (default mounting, no stored gyro bias: it is measured at every boot),
/// passed through its byte encoding as a save and load would.
pub fn calibration_record(
    accel: &AccelCalibration,
    mag: &MagCalibration,
) -> Result<CalibrationRecord, String> {
    let rec = CalibrationRecord {
        valid: ValidParts(ValidParts::ACCEL | ValidParts::MAG),
        accel_offset_g: accel.offset,
        accel_scale: accel.scale,
        mag_offset_ut: mag.offset,
        mag_soft_iron: mag.soft_iron,
        ..CalibrationRecord::default()
    };
    sensor_stack::storage::validate(&rec).map_err(|f| format!("calibration record: bad {f:?}"))?;
    sensor_stack::storage::decode(&sensor_stack::storage::encode(&rec))
        .map_err(|e| format!("calibration record: {e:?}"))
}

/// What the stack estimates at one IMU sample.
#[derive(Clone, Copy, Debug)]
pub struct Estimate {
    /// AHRS orientation `q_ned_from_body` (w, x, y, z).
    pub q_ned_from_body: [f32; 4],
    /// Height above take-off (m), once the baro has given a first sample.
    pub height_m: Option<f32>,
    /// Vertical speed, up positive (m/s), with the height.
    pub vertical_speed_mps: Option<f32>,
    /// Bias-corrected angular rate, MPU frame (rad/s).
    pub gyro_mpu_rps: [f32; 3],
    /// Calibrated specific force, MPU frame (m/s²).
    pub accel_mpu_mps2: [f32; 3],
    /// Latest calibrated magnetic field, MPU frame (µT).
    pub mag_mpu_ut: Option<[f32; 3]>,
}

/// What the stack boots with: the sensors' and the pipeline's settings.
#[derive(Clone, Copy, Debug)]
pub struct BootConfig {
    /// The chips' configuration (the MPU-9250's filter among it).
    pub sensors: SensorsConfig,
    /// The pipeline's (the AHRS tuning and the rate loop's gyro filter
    /// among it; the scales and capabilities come from the boot).
    pub pipeline: PipelineConfig,
}

impl BootConfig {
    /// The board's settings (the `settings` crate), as the firmware boots.
    pub fn board() -> Self {
        Self {
            sensors: settings::sensors_config(),
            pipeline: settings::pipeline_config(),
        }
    }

    /// The board's settings with the AHRS configured as `ahrs` (the
    /// hand-held filter for the scripted trajectories, which no rotor drag
    /// shapes).
    pub fn with_ahrs(ahrs: fc_ahrs::Config) -> Self {
        let mut c = Self::board();
        c.pipeline.ahrs = ahrs;
        c
    }
}

/// The firmware's per-sample path on the simulated bus.
pub struct Stack {
    sensors: FlightSensors<SimBus>,
    pipeline: Pipeline,
    boot: BootReport,
    step: SampleStep,
    bias_done: Option<[i16; 3]>,
    sched: SampleScheduler,
    dt: DtClock,
    last_mag: Option<[f32; 3]>,
}

impl Stack {
    /// Boots the chips (`sensor_stack::sensors::Sensors::boot`: probe with
    /// retries, configure) and builds the pipeline from their scales, the
    /// capabilities found and the stored calibration `record` — as the
    /// firmware's `init` does — with the settings of `cfg`.
    pub fn boot(
        bus: &SimBus,
        delay: &mut SimDelay,
        record: &CalibrationRecord,
        cfg: &BootConfig,
    ) -> Result<Self, String> {
        let (sensors, boot) =
            FlightSensors::boot(bus.clone(), bus.clone(), bus.clone(), delay, cfg.sensors);
        let caps = boot.capabilities();
        let scale = sensors.mpu_scale();
        let cfg = PipelineConfig {
            cpu_hz: CPU_HZ,
            gyro_dps_per_lsb: scale.dps_per_lsb,
            accel_g_per_lsb: scale.g_per_lsb,
            mag_ut_per_lsb: if boot.mag.present() {
                sensors.mag_ut_per_lsb()
            } else {
                [0.15; 3]
            },
            ahrs_mode: caps.ahrs,
            altitude: caps.altitude,
            ..cfg.pipeline
        };
        let pipeline = Pipeline::new(cfg, record).map_err(|e| format!("pipeline: {e:?}"))?;
        // Start-up gyro bias: 1 s still within 5 s of samples (as the firmware).
        let bias = StartupGyroBias::new(
            IMU_RATE_HZ,
            1.0 / scale.dps_per_lsb,
            1.0 / scale.g_per_lsb,
            5,
        )
        .map_err(|e| format!("start-up gyro bias: {e:?}"))?;
        Ok(Self {
            sensors,
            pipeline,
            boot,
            step: SampleStep::new(Some(bias)),
            bias_done: None,
            sched: SampleScheduler::new(MAG_DIVIDER),
            dt: DtClock::new(CPU_HZ, IMU_RATE_HZ),
            last_mag: None,
        })
    }

    /// The pipeline (for the flight controller's inputs).
    pub fn pipeline(&self) -> &Pipeline {
        &self.pipeline
    }

    /// Tells the pipeline whether the craft is flying (the flight
    /// controller's verdict), as the firmware's sample task does.
    pub fn set_in_flight(&mut self, in_flight: bool) {
        self.pipeline.set_in_flight(in_flight);
    }

    /// The boot probe's verdicts.
    pub fn boot_report(&self) -> &BootReport {
        &self.boot
    }

    /// The start-up gyro bias (rad/s, MPU frame) once measured.
    pub fn gyro_bias_rps(&self) -> Option<[f32; 3]> {
        let k = self.pipeline.config().gyro_dps_per_lsb.to_radians();
        self.bias_done.map(|b| b.map(|c| f32::from(c) * k))
    }

    /// One MPU data-ready at `now_us`, in the order of the firmware's `imu`
    /// task (then its `baro` task's poll). `None` if the IMU read failed.
    pub fn on_data_ready(&mut self, now_us: u64) -> Option<Estimate> {
        // The DWT cycle counter at 72 MHz (wraps every ~60 s, like the real one).
        let now_cycles = now_us.wrapping_mul(u64::from(CPU_HZ / 1_000_000)) as u32;
        let tick = self.sched.on_imu_sample();
        let dt_cycles = self.dt.step_cycles(now_cycles);
        let raw = self.sensors.read_imu();
        let mag = if tick.read_mag {
            self.sensors.read_mag()
        } else {
            MagRead::NotReady
        };
        if let Some(m) = self.sensors.poll_baro(now_us as u32) {
            self.pipeline.baro_step(m.pressure_pa);
        }
        let raw = raw?;
        let sample = SampleIn {
            raw,
            mag,
            read_mag: tick.read_mag,
            dt_cycles,
            now_us: now_us as u32,
        };
        let out = self
            .step
            .run(&mut self.pipeline, &sample, CalWants::default());
        if let BiasStatus::Done(b) = out.bias {
            self.bias_done.get_or_insert(b);
        }
        let p = &self.pipeline;
        if let MagRead::Sample(m) = mag {
            self.last_mag = Some(p.mag_counts_to_mpu_ut(m.counts));
        }
        // The calibrated values, MPU frame, as the firmware's raw log.
        let cfg = p.config();
        let bias = p.gyro_bias_counts();
        let k_g = cfg.gyro_dps_per_lsb.to_radians();
        let k_a = cfg.accel_g_per_lsb * G_MPS2;
        let gyro_mpu_rps = [0, 1, 2].map(|i| (i32::from(raw.gyro[i]) - bias[i]) as f32 * k_g);
        let accel_mpu_mps2 = p.calibrate_accel_counts(raw.accel).map(|c| c as f32 * k_a);
        let q = p.quaternion();
        let o = p.outputs();
        let has_height = o.baro_samples > 0;
        Some(Estimate {
            q_ned_from_body: [q.w, q.x, q.y, q.z],
            height_m: has_height.then_some(o.altitude_m),
            vertical_speed_mps: has_height.then_some(o.vertical_speed_mps),
            gyro_mpu_rps,
            accel_mpu_mps2,
            mag_mpu_ut: self.last_mag,
        })
    }
}
