//! The physical world seen by the chips: truth + sensor errors + physical
//! disturbances (vibration, a passing magnet).

use crate::errors::SensorErrors;
use crate::math::{self, mat_vec, Vec3};
use crate::physics::{Environment, Trajectory, TruthSample, G0_MPS2};
use crate::rng::Rng;
use std::f64::consts::PI;

/// Vibration added to the accelerometer and gyroscope (e.g. unbalanced props).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vibration {
    /// Peak acceleration per axis (m/s²).
    pub accel_amplitude_mps2: f64,
    /// Peak angular rate per axis (°/s).
    pub gyro_amplitude_dps: f64,
    /// Frequency (Hz).
    pub frequency_hz: f64,
}

/// A magnet passing by: a field disturbance with a bell-shaped time profile.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagnetPass {
    /// Disturbance at its peak, body frame (µT).
    pub peak_body_ut: Vec3,
    /// Time of the peak (s).
    pub peak_time_s: f64,
    /// Width (s): the disturbance is above 1/e of its peak for ±width/2.
    pub width_s: f64,
    /// The magnet stays after its peak (attached to the body, riding along): a
    /// body-fixed hard-iron offset from then on, which the calibration does not know.
    pub stays: bool,
}

impl MagnetPass {
    /// Disturbance (µT, body) at `t_s`.
    pub fn field_body_ut(&self, t_s: f64) -> Vec3 {
        if self.stays && t_s >= self.peak_time_s {
            return self.peak_body_ut;
        }
        let x = (t_s - self.peak_time_s) / (0.5 * self.width_s.max(1e-9));
        math::scale(self.peak_body_ut, (-x * x).exp())
    }
}

/// An IMU reading in the MPU sensor frame, before conversion to counts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuPhysical {
    /// Angular rate (°/s), with errors.
    pub gyro_mpu_dps: Vec3,
    /// Specific force (m/s²), with errors.
    pub accel_mpu_mps2: Vec3,
    /// Die temperature (°C), with noise.
    pub temp_c: f64,
}

/// Truth, environment, errors and disturbances.
#[derive(Clone, Debug)]
pub struct World {
    /// The motion.
    pub trajectory: Trajectory,
    /// Field and atmosphere.
    pub env: Environment,
    /// Sensor errors.
    pub errors: SensorErrors,
    /// Active vibration, if any.
    pub vibration: Option<Vibration>,
    /// Magnets passing by.
    pub magnets: Vec<MagnetPass>,
    gyro_bias_dps: Vec3,
    accel_bias_mps2: Vec3,
    last_imu_t_s: Option<f64>,
    rng: Rng,
    /// The IMU's own stream (noise, bias walks): how often the MPU-9250
    /// model samples does not change the other chips' noise.
    imu_rng: Rng,
    vib_phase: [f64; 6],
}

impl World {
    /// A world; all randomness derives from `seed`.
    pub fn new(trajectory: Trajectory, env: Environment, errors: SensorErrors, seed: u64) -> Self {
        let mut rng = Rng::new(seed);
        let mut vib_phase = [0.0; 6];
        for p in &mut vib_phase {
            *p = rng.range(0.0, 2.0 * PI);
        }
        let imu_rng = rng.fork(0x0049_4D55);
        Self {
            trajectory,
            env,
            gyro_bias_dps: errors.gyro_dps.bias,
            accel_bias_mps2: errors.accel_mps2.bias,
            errors,
            vibration: None,
            magnets: Vec::new(),
            last_imu_t_s: None,
            rng,
            imu_rng,
            vib_phase,
        }
    }

    /// Truth at `t_s`.
    pub fn truth(&self, t_s: f64) -> TruthSample {
        self.trajectory.sample(t_s)
    }

    /// Current gyro bias (°/s, MPU frame), including its random walk so far.
    pub fn gyro_bias_dps(&self) -> Vec3 {
        self.gyro_bias_dps
    }
    /// Current accelerometer bias (m/s², MPU frame).
    pub fn accel_bias_mps2(&self) -> Vec3 {
        self.accel_bias_mps2
    }

    /// Expected field at `t_s` in the AK8963 frame without iron errors or noise (µT).
    pub fn true_field_ak_ut(&self, t_s: f64) -> Vec3 {
        let truth = self.truth(t_s);
        let b_body = truth.q_ned_from_body.conj().rotate(self.env.field.ned_ut());
        math::mpu_to_ak(math::body_to_mpu(b_body))
    }

    /// The IMU's signal at `t_s`, MPU frame, before the chip's filters: the
    /// truth through misalignment, the biases (their random walk advanced
    /// to `t_s`) and any injected vibration; no white noise (see
    /// [`World::imu_noise`]) and the true die temperature.
    pub fn imu_signal(&mut self, t_s: f64) -> ImuPhysical {
        let dt = self.last_imu_t_s.map_or(0.0, |l| (t_s - l).max(0.0));
        self.last_imu_t_s = Some(t_s);
        let e = self.errors;
        if dt > 0.0 {
            let sg = e.gyro_dps.bias_walk * dt.sqrt();
            let sa = e.accel_mps2.bias_walk * dt.sqrt();
            self.gyro_bias_dps = math::add(self.gyro_bias_dps, self.imu_rng.normal3(sg));
            self.accel_bias_mps2 = math::add(self.accel_bias_mps2, self.imu_rng.normal3(sa));
        }
        let truth = self.truth(t_s);
        let w_mpu_dps = math::scale(math::body_to_mpu(truth.omega_body_rps), 180.0 / PI);
        let f_mpu = math::body_to_mpu(truth.specific_force_body_mps2);
        let mut gyro = math::add(
            mat_vec(&e.gyro_dps.misalignment, w_mpu_dps),
            self.gyro_bias_dps,
        );
        let mut acc = math::add(
            mat_vec(&e.accel_mps2.misalignment, f_mpu),
            self.accel_bias_mps2,
        );
        if let Some(v) = self.vibration {
            for i in 0..3 {
                let w = 2.0 * PI * v.frequency_hz * t_s;
                acc[i] += v.accel_amplitude_mps2 * (w + self.vib_phase[i]).sin();
                gyro[i] += v.gyro_amplitude_dps * (w + self.vib_phase[i + 3]).sin();
            }
        }
        ImuPhysical {
            gyro_mpu_dps: gyro,
            accel_mpu_mps2: acc,
            temp_c: self.env.temperature_c(truth.height_m),
        }
    }

    /// White noise for one output sample: the noise densities over the
    /// given equivalent noise bandwidths (Hz), and the temperature noise.
    pub fn imu_noise(&mut self, gyro_enbw_hz: f64, accel_enbw_hz: f64) -> ImuPhysical {
        let e = self.errors;
        ImuPhysical {
            gyro_mpu_dps: self
                .imu_rng
                .normal3(e.gyro_dps.noise_density * gyro_enbw_hz.sqrt()),
            accel_mpu_mps2: self
                .imu_rng
                .normal3(e.accel_mps2.noise_density * accel_enbw_hz.sqrt()),
            temp_c: self.imu_rng.normal(e.temp_noise_c),
        }
    }

    /// One unfiltered IMU sample at `t_s`: [`World::imu_signal`] plus
    /// [`World::imu_noise`] for the given equivalent noise bandwidths (Hz).
    pub fn imu(&mut self, t_s: f64, gyro_enbw_hz: f64, accel_enbw_hz: f64) -> ImuPhysical {
        let s = self.imu_signal(t_s);
        let n = self.imu_noise(gyro_enbw_hz, accel_enbw_hz);
        ImuPhysical {
            gyro_mpu_dps: math::add(s.gyro_mpu_dps, n.gyro_mpu_dps),
            accel_mpu_mps2: math::add(s.accel_mpu_mps2, n.accel_mpu_mps2),
            temp_c: s.temp_c + n.temp_c,
        }
    }

    /// Magnetometer reading at `t_s`, AK8963 frame (µT), with iron errors,
    /// passing magnets and noise.
    pub fn mag_ak_ut(&mut self, t_s: f64) -> Vec3 {
        let truth = self.truth(t_s);
        let mut b_body = truth.q_ned_from_body.conj().rotate(self.env.field.ned_ut());
        for m in &self.magnets {
            b_body = math::add(b_body, m.field_body_ut(t_s));
        }
        let b_ak = math::mpu_to_ak(math::body_to_mpu(b_body));
        let m = &self.errors.mag;
        let meas = math::add(mat_vec(&m.soft_iron, b_ak), m.hard_iron_ut);
        math::add(meas, self.rng.normal3(m.noise_ut))
    }

    /// True pressure (Pa, with the board's offset error) and chip temperature (°C) at `t_s`.
    pub fn baro(&self, t_s: f64) -> (f64, f64) {
        let truth = self.truth(t_s);
        (
            self.env.pressure_pa(truth.height_m) + self.errors.baro.offset_pa,
            self.env.temperature_c(truth.height_m),
        )
    }

    /// A standard normal sample from the world's generator.
    pub fn gauss(&mut self) -> f64 {
        self.rng.gauss()
    }
}

/// 1 g in m/s² as used for MPU scaling.
pub const G_MPS2: f64 = G0_MPS2;
