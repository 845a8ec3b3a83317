//! The sensor stack wiring: drivers → calibration → AHRS → altitude.
//!
//! This module is the only place that knows how the crates are put
//! together; when the `flight` crate's pipeline is ready, [`Stack`] and the
//! two ground-calibration functions are what to replace.

use super::mag::Mag;
use calibration::{
    EllipsoidFit, EllipsoidFitConfig, GyroBias, GyroBiasConfig, GyroBiasEstimator, MagCalibration,
    MagMinMax, MagMinMaxConfig,
};
use control::baro::CheapBaro;
use control::vertical::{Config as VerticalConfig, VerticalEstimator};
use embedded_hal::delay::DelayNs;
use fc_ahrs::fixed::{self, FixedConfig, MadgwickFixed};
use fc_ahrs::Madgwick;
use mpu9250::{Address, Config as MpuConfig, Mpu9250};
use ms5611::{Ms5611, Sampler, SamplerConfig};
use sim::{SimBus, SimConfig, SimDelay, Trajectory};

/// Standard gravity used to turn g into m/s².
pub const G_MPS2: f32 = 9.806_65;

/// Which AHRS implementation to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    /// `fc_ahrs::Madgwick` (f32).
    F32,
    /// The fixed-point Madgwick.
    Fixed,
}

/// The three drivers on one simulated bus.
pub struct Sensors {
    /// MPU-9250 driver.
    pub imu: Mpu9250<SimBus>,
    /// AK8963 access.
    pub mag: Mag,
    /// MS5611 driver.
    pub baro: Ms5611<SimBus>,
}

/// Initialises the three chips (MPU with I2C bypass so the AK8963 is on the bus).
pub fn init_sensors(bus: &SimBus, delay: &mut SimDelay) -> Result<Sensors, String> {
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.set_bypass(true)
        .map_err(|e| format!("MPU-9250 bypass: {e}"))?;
    imu.init(delay, &MpuConfig::default())
        .map_err(|e| format!("MPU-9250 init: {e}"))?;
    let mag = Mag::init(bus.clone(), delay)?;
    let mut baro = Ms5611::new(bus.clone(), ms5611::Address::CsbLow);
    baro.init(delay)
        .map_err(|e| format!("MS5611 init: {e:?}"))?;
    Ok(Sensors { imu, mag, baro })
}

/// MPU sensor frame → body FRD (default mounting: face up, x forward).
pub fn mpu_to_body(v: [f32; 3]) -> [f32; 3] {
    [v[0], -v[1], -v[2]]
}

/// Gyro bias at rest with `calibration::GyroBiasEstimator` (rad/s, MPU frame):
/// one sample per MPU data-ready.
pub fn calibrate_gyro(sensors: &mut Sensors, bus: &SimBus) -> Result<GyroBias, String> {
    let mut est =
        GyroBiasEstimator::new(GyroBiasConfig::RPS_AND_G).map_err(|e| format!("{e:?}"))?;
    loop {
        bus.advance_to_next_mpu_sample();
        let s = sensors
            .imu
            .read()
            .map_err(|e| format!("MPU-9250 read: {e}"))?;
        if est
            .push_with_accel(s.gyro_rps(), s.accel_g)
            .map_err(|e| format!("{e:?}"))?
        {
            return est.finish().map_err(|e| format!("gyro calibration: {e:?}"));
        }
    }
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
    let mut fit =
        EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).map_err(|e| format!("{e:?}"))?;
    let mut minmax = MagMinMax::new(MagMinMaxConfig::MICROTESLA).map_err(|e| format!("{e:?}"))?;
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
            eprintln!("ellipsoid fit failed ({e:?}), falling back to min/max");
            let calibration = minmax.finish().map_err(|e| format!("min/max: {e:?}"))?;
            Ok(MagCalRun {
                raw_mpu_ut: raw,
                calibration,
                method: "min/max",
                rms_error: None,
            })
        }
    }
}

/// What the stack estimates at one IMU sample.
#[derive(Clone, Copy, Debug)]
pub struct Estimate {
    /// AHRS orientation `q_ned_from_body` (w, x, y, z).
    pub q_ned_from_body: [f32; 4],
    /// Height above take-off (m), once the baro has given a first sample.
    pub height_m: Option<f32>,
    /// Bias-corrected angular rate, MPU frame (rad/s).
    pub gyro_mpu_rps: [f32; 3],
    /// Specific force, MPU frame (m/s²).
    pub accel_mpu_mps2: [f32; 3],
    /// Latest calibrated magnetic field, MPU frame (µT).
    pub mag_mpu_ut: Option<[f32; 3]>,
}

/// The per-sample pipeline.
pub struct Stack {
    filter: Filter,
    sensors: Sensors,
    gyro_bias: GyroBias,
    mag_cal: MagCalibration,
    ahrs: Option<Ahrs>,
    sampler: Sampler,
    baro_height: Option<CheapBaro>,
    vertical: VerticalEstimator,
    last_us: Option<u64>,
    last_mag: Option<[f32; 3]>,
    samples: u64,
}

impl Stack {
    /// A stack on initialised sensors with the ground calibrations.
    pub fn new(
        sensors: Sensors,
        gyro_bias: GyroBias,
        mag_cal: MagCalibration,
        filter: Filter,
    ) -> Result<Self, String> {
        Ok(Self {
            filter,
            sensors,
            gyro_bias,
            mag_cal,
            ahrs: None,
            sampler: Sampler::new(SamplerConfig::new()),
            baro_height: None,
            vertical: VerticalEstimator::new(VerticalConfig::default())
                .map_err(|e| format!("{e:?}"))?,
            last_us: None,
            last_mag: None,
            samples: 0,
        })
    }

    /// Processes one MPU data-ready at `now_us`.
    pub fn on_data_ready(&mut self, now_us: u64) -> Result<Estimate, String> {
        let s = self
            .sensors
            .imu
            .read()
            .map_err(|e| format!("MPU-9250 read: {e}"))?;
        let gyro_mpu_rps = self.gyro_bias.apply(s.gyro_rps());
        let accel_mpu_mps2 = s.accel_g.map(|a| a * G_MPS2);
        // Magnetometer: 100 Hz data, polled at 200 Hz.
        if self.samples.is_multiple_of(5) {
            if let Some(raw) = self.sensors.mag.read()? {
                self.last_mag = Some(self.mag_cal.apply(raw));
            }
        }
        // Barometer: non-blocking conversion schedule.
        match self.sampler.poll(&mut self.sensors.baro, now_us as u32) {
            Ok(Some(m)) => {
                let cheap = match self.baro_height {
                    Some(c) => c,
                    None => {
                        let c =
                            CheapBaro::new(m.pressure_pa as f32).map_err(|e| format!("{e:?}"))?;
                        self.baro_height = Some(c);
                        c
                    }
                };
                let _ = self.vertical.update_baro(cheap.height_m(m.pressure_pa));
            }
            Ok(None) => {}
            Err(e) => eprintln!("MS5611: {e:?}"),
        }
        let dt_s = self
            .last_us
            .map_or(0.001, |l| (now_us.saturating_sub(l)) as f32 * 1e-6);
        self.last_us = Some(now_us);
        self.samples += 1;
        let gyro_b = mpu_to_body(gyro_mpu_rps);
        let acc_b = mpu_to_body(accel_mpu_mps2);
        let mag_b = self.last_mag.map(mpu_to_body);
        let filter = self.filter;
        let ahrs = match (&mut self.ahrs, mag_b) {
            (Some(a), _) => a,
            (None, Some(m)) => self.ahrs.insert(Ahrs::new(filter, Some((acc_b, m)))),
            (None, None) => self.ahrs.insert(Ahrs::new(filter, None)),
        };
        let (q, up) = ahrs.update(gyro_b, acc_b, mag_b, dt_s);
        let _ = self.vertical.predict(up, dt_s);
        Ok(Estimate {
            q_ned_from_body: q,
            height_m: self.baro_height.map(|_| self.vertical.height_m()),
            gyro_mpu_rps,
            accel_mpu_mps2,
            mag_mpu_ut: self.last_mag,
        })
    }
}

/// The AHRS behind one interface: f32 or fixed point (Q-formats of `fc_ahrs::fixed`).
#[allow(clippy::large_enum_variant)] // one instance, never moved in the loop
enum Ahrs {
    F32(Madgwick),
    Fixed(MadgwickFixed),
}

/// Accelerometer fed to the fixed-point filter in mm/s² (its `gravity_norm` is 1 g in that unit).
const FIXED_ACCEL_PER_MPS2: f32 = 1000.0;
/// Magnetometer fed to the fixed-point filter in 0.01 µT.
const FIXED_MAG_PER_UT: f32 = 100.0;

fn to_i32x3(v: [f32; 3], k: f32) -> [i32; 3] {
    v.map(|x| (x * k).round() as i32)
}

impl Ahrs {
    fn new(filter: Filter, init: Option<([f32; 3], [f32; 3])>) -> Self {
        let cfg = fc_ahrs::Config::default();
        match filter {
            Filter::F32 => Ahrs::F32(match init {
                Some((a, m)) => Madgwick::from_accel_mag(cfg, a, m),
                None => Madgwick::new(cfg),
            }),
            Filter::Fixed => {
                let fcfg = FixedConfig::from_config(&fc_ahrs::Config {
                    gravity_norm: G_MPS2 * FIXED_ACCEL_PER_MPS2,
                    ..cfg
                });
                Ahrs::Fixed(match init {
                    Some((a, m)) => MadgwickFixed::from_accel_mag(
                        fcfg,
                        to_i32x3(a, FIXED_ACCEL_PER_MPS2),
                        to_i32x3(m, FIXED_MAG_PER_UT),
                    ),
                    None => MadgwickFixed::new(fcfg),
                })
            }
        }
    }

    /// One update (body FRD inputs); returns `q_ned_from_body` and the
    /// vertical (up) linear acceleration in m/s².
    fn update(
        &mut self,
        gyro_rps: [f32; 3],
        accel_mps2: [f32; 3],
        mag_ut: Option<[f32; 3]>,
        dt_s: f32,
    ) -> ([f32; 4], f32) {
        match self {
            Ahrs::F32(a) => {
                match mag_ut {
                    Some(m) => a.update_marg(gyro_rps, accel_mps2, m, dt_s),
                    None => a.update_imu(gyro_rps, accel_mps2, dt_s),
                };
                let q = a.quaternion();
                ([q.w, q.x, q.y, q.z], a.vertical_accel_up_mps2(accel_mps2))
            }
            Ahrs::Fixed(a) => {
                let g = gyro_rps.map(fixed::rps_to_q20);
                let acc = to_i32x3(accel_mps2, FIXED_ACCEL_PER_MPS2);
                let dt = fixed::dt_s_to_q31(dt_s);
                match mag_ut {
                    Some(m) => a.update_marg(g, acc, to_i32x3(m, FIXED_MAG_PER_UT), dt),
                    None => a.update_imu(g, acc, dt),
                };
                let q = a.quaternion_f32();
                let up_q16 = a.vertical_accel_up_mps2_q16(to_i32x3(accel_mps2, 65_536.0));
                ([q.w, q.x, q.y, q.z], up_q16 as f32 / 65_536.0)
            }
        }
    }
}
