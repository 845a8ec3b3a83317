//! Correctness sequences: the same deterministic inputs through our filters,
//! run on the emulated Cortex-M3 (`bench-check` binary) and on the host
//! (`cargo xtask bench`), which compares the results.
//!
//! Expected agreement: fixed-point and integer results bit-identical; f32
//! results within [`F32_TOLERANCE`] per component (in practice they are
//! bit-identical too: both sides use correctly rounded IEEE single operations
//! and the same `libm` code, but the requirement is the tolerance).

use fc_ahrs::fixed::{dt_us_to_q31, FixedConfig, MadgwickFixed};
use fc_ahrs::{Madgwick, Quaternion};

use crate::{counts_config, features_on, plain, Rng, SampleGen, DT_S};

/// Largest accepted difference between target and host f32 results.
pub const F32_TOLERANCE: f32 = 1e-6;

/// Samples per correctness sequence: 6 s at 1 kHz, past the filters'
/// 3 s start-up phase, so the steady-state gains and the rejection and
/// bias features (inactive during start-up) run too.
pub const SAMPLES: usize = 6000;

/// Seed of the correctness sequences.
pub const SEED: u32 = 0x00C0_FFEE;

/// One result of a correctness sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// A fixed-point or integer result: must match bit for bit.
    I32([i32; 4]),
    /// A floating-point result: must match within [`F32_TOLERANCE`].
    F32([f32; 4]),
}

fn quat(q: Quaternion) -> Value {
    Value::F32([q.w, q.x, q.y, q.z])
}

/// Runs every correctness sequence and hands each named result to `emit`.
/// The inputs include accelerometer and magnetometer disturbances so the
/// rejection and recovery paths run too.
pub fn run(mut emit: impl FnMut(&'static str, Value)) {
    for (label, cfg) in [("on", features_on()), ("plain", plain())] {
        // f32 MARG.
        let mut g = SampleGen::new(SEED, true);
        let s0 = g.next_sample().to_si();
        let mut f = Madgwick::from_accel_mag(cfg, s0.accel_mps2, s0.mag_ut);
        for s in g.take(SAMPLES) {
            let s = s.to_si();
            f.update_marg(s.gyro_rps, s.accel_mps2, s.mag_ut, DT_S);
        }
        emit(
            pick(label, "f32_marg_rejection_on", "f32_marg_plain"),
            quat(f.quaternion()),
        );

        // f32 IMU.
        let mut f = Madgwick::new(cfg);
        for s in SampleGen::new(SEED ^ 1, true).take(SAMPLES) {
            let s = s.to_si();
            f.update_imu(s.gyro_rps, s.accel_mps2, DT_S);
        }
        emit(
            pick(label, "f32_imu_rejection_on", "f32_imu_plain"),
            quat(f.quaternion()),
        );

        // Fixed-point MARG and IMU, raw counts in.
        let fcfg = FixedConfig::from_config(&counts_config(cfg));
        let dt = dt_us_to_q31(1000);
        let mut g = SampleGen::new(SEED, true);
        let s0 = g.next_sample().to_fixed();
        let mut f = MadgwickFixed::from_accel_mag(fcfg, s0.accel, s0.mag);
        for s in g.take(SAMPLES) {
            let s = s.to_fixed();
            f.update_marg(s.gyro_rps_q20, s.accel, s.mag, dt);
        }
        emit(
            pick(label, "fixed_marg_rejection_on", "fixed_marg_plain"),
            Value::I32(f.quaternion_q30()),
        );
        let mut f = MadgwickFixed::new(fcfg);
        for s in SampleGen::new(SEED ^ 1, true).take(SAMPLES) {
            let s = s.to_fixed();
            f.update_imu(s.gyro_rps_q20, s.accel, dt);
        }
        emit(
            pick(label, "fixed_imu_rejection_on", "fixed_imu_plain"),
            Value::I32(f.quaternion_q30()),
        );
    }

    // MS5611 integer compensation over random raw values (datasheet PROM),
    // including the second-order low-temperature paths.
    {
        let prom = ms5611::Prom::from_coefficients(MS5611_DATASHEET_C);
        let mut rng = Rng::new(SEED);
        let (mut p_sum, mut t_sum, mut last) = (0i32, 0i32, (0, 0));
        for _ in 0..SAMPLES {
            let d1 = 9_085_466u32.wrapping_add_signed(rng.symmetric(2_000_000));
            let d2 = 8_569_150u32.wrapping_add_signed(rng.symmetric(3_000_000));
            if let Ok(m) = ms5611::compensate(&prom, d1, d2) {
                p_sum = p_sum.wrapping_add(m.pressure_pa);
                t_sum = t_sum.wrapping_add(m.temperature_centi_c);
                last = (m.pressure_pa, m.temperature_centi_c);
            }
        }
        emit(
            "ms5611_compensate",
            Value::I32([p_sum, t_sum, last.0, last.1]),
        );
    }
}

/// PROM coefficients C1..C6 of the MS5611 datasheet's worked example.
pub const MS5611_DATASHEET_C: [u16; 6] = [40127, 36924, 23317, 23282, 33464, 28312];

fn pick(label: &str, on: &'static str, plain: &'static str) -> &'static str {
    if label == "on" {
        on
    } else {
        plain
    }
}
