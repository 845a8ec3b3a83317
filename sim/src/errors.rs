//! Sensor error models of datasheet size, drawn from a seed.

use crate::math::{Mat3, Vec3, IDENTITY3};
use crate::rng::Rng;

/// Errors of one inertial sensor triad (gyro or accelerometer), in its own
/// sensor frame and its own unit (°/s for the gyro, m/s² for the accelerometer).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriadErrors {
    /// White noise density (unit/√Hz). Per-sample σ = density·√(noise bandwidth).
    pub noise_density: f64,
    /// Constant bias at t = 0 (unit).
    pub bias: Vec3,
    /// Bias random walk (unit/√s): the bias drifts by N(0, σ·√dt).
    pub bias_walk: f64,
    /// Scale and cross-axis matrix: measured = M·true (identity when ideal).
    pub misalignment: Mat3,
}

impl TriadErrors {
    /// No error at all.
    pub const IDEAL: TriadErrors = TriadErrors {
        noise_density: 0.0,
        bias: [0.0; 3],
        bias_walk: 0.0,
        misalignment: IDENTITY3,
    };
}

/// Magnetometer errors (AK8963 sensor frame, µT).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagErrors {
    /// Hard iron: constant offset added to the field (µT).
    pub hard_iron_ut: Vec3,
    /// Soft iron (and the sensor's own gain/cross-axis errors): measured = S·B + h.
    pub soft_iron: Mat3,
    /// White noise σ per sample (µT).
    pub noise_ut: f64,
}

/// Barometer errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaroErrors {
    /// Multiplies the datasheet's RMS resolution per OSR (1.0 = datasheet, 0 = noiseless).
    pub noise_scale: f64,
    /// Constant pressure offset (Pa).
    pub offset_pa: f64,
}

/// All sensor errors of the simulated board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorErrors {
    /// Gyroscope, MPU frame, °/s.
    pub gyro_dps: TriadErrors,
    /// Accelerometer, MPU frame, m/s².
    pub accel_mps2: TriadErrors,
    /// Magnetometer, AK8963 frame.
    pub mag: MagErrors,
    /// Barometer.
    pub baro: BaroErrors,
    /// RMS noise of the MPU temperature sensor (°C).
    pub temp_noise_c: f64,
}

/// MPU-9250 gyro noise density, datasheet: 0.01 °/s/√Hz.
pub const GYRO_NOISE_DENSITY_DPS_RT_HZ: f64 = 0.01;
/// MPU-9250 accelerometer noise density, datasheet: 300 µg/√Hz (in m/s²/√Hz).
pub const ACCEL_NOISE_DENSITY_MPS2_RT_HZ: f64 = 300e-6 * crate::physics::G0_MPS2;

impl SensorErrors {
    /// No errors, no noise: the sensors read the truth up to quantisation.
    pub fn ideal() -> Self {
        Self {
            gyro_dps: TriadErrors::IDEAL,
            accel_mps2: TriadErrors::IDEAL,
            mag: MagErrors {
                hard_iron_ut: [0.0; 3],
                soft_iron: IDENTITY3,
                noise_ut: 0.0,
            },
            baro: BaroErrors {
                noise_scale: 0.0,
                offset_pa: 0.0,
            },
            temp_noise_c: 0.0,
        }
    }

    /// Datasheet noise only (gyro 0.01 °/s/√Hz, accel 300 µg/√Hz, mag 0.4 µT,
    /// baro per OSR), no bias, no scale error, no iron.
    pub fn noise_only() -> Self {
        let mut e = Self::ideal();
        e.gyro_dps.noise_density = GYRO_NOISE_DENSITY_DPS_RT_HZ;
        e.accel_mps2.noise_density = ACCEL_NOISE_DENSITY_MPS2_RT_HZ;
        e.mag.noise_ut = 0.4;
        e.baro.noise_scale = 1.0;
        e.temp_noise_c = 0.05;
        e
    }

    /// A board drawn at random with errors of datasheet size:
    /// gyro bias ±3 °/s (datasheet ZRO tolerance ±5 °/s), bias walk
    /// 0.005 °/s/√s, accel bias ±60 mg (datasheet ±80 mg), scale ±2 %,
    /// cross-axis ±1 %, hard iron ±40 µT, soft iron ±8 %.
    pub fn datasheet(seed: u64) -> Self {
        let mut rng = Rng::new(seed ^ 0x5EED_E440);
        let mut e = Self::noise_only();
        let g = crate::physics::G0_MPS2;
        e.gyro_dps.bias = [
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        ];
        e.gyro_dps.bias_walk = 0.005;
        e.gyro_dps.misalignment = random_misalignment(&mut rng, 0.02, 0.01);
        e.accel_mps2.bias = [
            rng.range(-0.06, 0.06) * g,
            rng.range(-0.06, 0.06) * g,
            rng.range(-0.06, 0.06) * g,
        ];
        e.accel_mps2.bias_walk = 20e-6 * g;
        e.accel_mps2.misalignment = random_misalignment(&mut rng, 0.02, 0.01);
        e.mag.hard_iron_ut = [
            rng.range(-40.0, 40.0),
            rng.range(-40.0, 40.0),
            rng.range(-40.0, 40.0),
        ];
        e.mag.soft_iron = random_soft_iron(&mut rng, 0.08);
        e.baro.offset_pa = rng.range(-50.0, 50.0);
        e
    }
}

/// Diagonal scale errors within ±`scale`, off-diagonal within ±`cross`.
pub fn random_misalignment(rng: &mut Rng, scale: f64, cross: f64) -> Mat3 {
    let mut m = IDENTITY3;
    for (i, row) in m.iter_mut().enumerate() {
        for (j, c) in row.iter_mut().enumerate() {
            *c = if i == j {
                1.0 + rng.range(-scale, scale)
            } else {
                rng.range(-cross, cross)
            };
        }
    }
    m
}

/// A symmetric positive-definite soft-iron matrix within ±`amount` of identity.
#[allow(clippy::needless_range_loop)]
pub fn random_soft_iron(rng: &mut Rng, amount: f64) -> Mat3 {
    let mut m = IDENTITY3;
    for i in 0..3 {
        m[i][i] = 1.0 + rng.range(-amount, amount);
        for j in (i + 1)..3 {
            let v = rng.range(-amount, amount) * 0.5;
            m[i][j] = v;
            m[j][i] = v;
        }
    }
    m
}
