//! Shared by the benchmark binaries (on the emulated Cortex-M3) and by
//! `cargo xtask bench` (on the host): a deterministic sensor-sample generator
//! and the correctness sequences whose results must agree between the two.
//!
//! Nothing here depends on the target: the integer PRNG and the integer →
//! f32 conversions (single, correctly rounded IEEE operations) give the same
//! bits on every platform, so the same inputs reach the filters on both sides.
//!
//! Frames and units: samples are in the body frame FRD (x forward, y right,
//! z down), like the AHRS inputs. Raw counts use the MPU-9250 scales the
//! firmware configures: accelerometer ±8 g (4096 LSB/g), gyroscope
//! ±1000 °/s (32.8 LSB/(°/s)), and the AK8963 in 16-bit mode (0.15 µT/LSB).
#![no_std]

pub mod check;

use fc_ahrs::{Config, Quaternion};

/// Accelerometer counts per g (MPU-9250 at ±8 g full scale).
pub const ACCEL_LSB_PER_G: i32 = 4096;
/// Gyroscope counts per °/s (MPU-9250 at ±1000 °/s), as a ratio 328/10.
pub const GYRO_LSB_PER_DPS_X10: i32 = 328;
/// Magnetometer µT per count (AK8963, 16-bit output).
pub const MAG_UT_PER_LSB: f32 = 0.15;
/// Standard gravity, m/s² per g.
pub const G_MPS2: f32 = 9.806_65;
/// Sample period of the firmware's fast loop (1 kHz), s.
pub const DT_S: f32 = 0.001;

/// xorshift32 (Marsaglia): tiny, integer-only, identical on every target.
#[derive(Debug, Clone)]
pub struct Rng(u32);

impl Rng {
    /// A generator from a seed (0 is replaced by a fixed non-zero value).
    pub const fn new(seed: u32) -> Self {
        Self(if seed == 0 { 0x9E37_79B9 } else { seed })
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }

    /// Uniform-ish integer in `-amp ..= amp` (`amp` ≥ 0, small).
    pub fn symmetric(&mut self, amp: i32) -> i32 {
        let span = (2 * amp.max(0) + 1) as u64;
        ((u64::from(self.next_u32()) * span) >> 32) as i32 - amp.max(0)
    }
}

/// One raw IMU + magnetometer sample, counts, body frame FRD.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawSample {
    /// Accelerometer (specific force), counts at 4096 LSB/g.
    pub accel: [i16; 3],
    /// Gyroscope, counts at 32.8 LSB/(°/s).
    pub gyro: [i16; 3],
    /// Magnetometer, counts at 0.15 µT/LSB.
    pub mag: [i16; 3],
}

/// A sample in SI units, body frame FRD (the f32 filters' inputs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SiSample {
    /// Specific force, m/s².
    pub accel_mps2: [f32; 3],
    /// Angular rate, rad/s.
    pub gyro_rps: [f32; 3],
    /// Magnetic field, µT.
    pub mag_ut: [f32; 3],
}

/// A sample in the fixed-point filter's formats, body frame FRD.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FixedSample {
    /// Angular rate, rad/s in Q20.
    pub gyro_rps_q20: [i32; 3],
    /// Specific force, raw counts (4096 per g: see [`counts_config`]).
    pub accel: [i32; 3],
    /// Magnetic field, raw counts.
    pub mag: [i32; 3],
}

/// The defaults with every optional feature on: gyro-bias estimation at
/// rest, accelerometer rejection and magnetic-disturbance rejection.
pub fn features_on() -> Config {
    let mut c = Config::DEFAULT;
    c.bias.enabled = true;
    c.accel_rejection.enabled = true;
    c.mag_rejection.enabled = true;
    c
}

/// [`features_on`] in the multirotor mode, with the firmware's drag
/// coefficients (`sensor_stack::pipeline::ROTOR_DRAG_PER_S`,
/// `FORM_DRAG_PER_M`).
pub fn multirotor() -> Config {
    Config {
        rotor_drag_per_s: sensor_stack::pipeline::ROTOR_DRAG_PER_S,
        form_drag_per_m: sensor_stack::pipeline::FORM_DRAG_PER_M,
        ..features_on()
    }
}

/// Madgwick's 2010 filter as published (`Algorithm::Textbook`): one β, the
/// joint gradient, no extensions.
pub fn plain() -> Config {
    Config {
        algorithm: fc_ahrs::Algorithm::Textbook,
        ..Config::DEFAULT
    }
}

/// `cfg` for accelerometer inputs in raw counts (the fixed-point filter's
/// inputs here): `gravity_norm` = 1 g in counts.
pub fn counts_config(cfg: Config) -> Config {
    Config {
        gravity_norm: ACCEL_LSB_PER_G as f32,
        ..cfg
    }
}

/// m/s² per accelerometer count.
pub const ACCEL_MPS2_PER_LSB: f32 = G_MPS2 / ACCEL_LSB_PER_G as f32;
/// rad/s per gyroscope count: (π/180) / 32.8.
pub const GYRO_RPS_PER_LSB: f32 = core::f32::consts::PI / 180.0 / 32.8;

impl RawSample {
    /// Converts counts to SI units with one f32 multiplication per axis.
    pub fn to_si(&self) -> SiSample {
        SiSample {
            accel_mps2: self.accel.map(|c| f32::from(c) * ACCEL_MPS2_PER_LSB),
            gyro_rps: self.gyro.map(|c| f32::from(c) * GYRO_RPS_PER_LSB),
            mag_ut: self.mag.map(|c| f32::from(c) * MAG_UT_PER_LSB),
        }
    }

    /// The fixed-point filter's inputs: gyro through the f32 rate (one
    /// multiply, then `fc_ahrs::fixed::rps_to_q20`), accelerometer and
    /// magnetometer as raw counts.
    pub fn to_fixed(&self) -> FixedSample {
        let si = self.to_si();
        FixedSample {
            gyro_rps_q20: si.gyro_rps.map(fc_ahrs::fixed::rps_to_q20),
            accel: self.accel.map(i32::from),
            mag: self.mag.map(i32::from),
        }
    }
}

/// Deterministic stream of physically consistent samples: a true
/// orientation (`q_ned_from_body`) turns with a smoothly varying rate (random
/// walk within ±60 °/s per axis); the gyroscope reads that rate, the
/// accelerometer the specific force of gravity and the magnetometer the
/// earth field (20, 2, 45) µT NED, both rotated into the body, all with
/// sensor noise and rounded to counts. With `disturbances`, occasional
/// linear-acceleration bursts (≈ 0.6 g sideways) and magnetic disturbances
/// (≈ 25 µT) make the rejection paths run too.
///
/// The f32 steps are single IEEE operations and `libm::sqrtf`, so host and
/// target produce the same counts.
#[derive(Debug, Clone)]
pub struct SampleGen {
    rng: Rng,
    rate: [i32; 3],
    q: [f32; 4],
    disturbances: bool,
    n: u32,
}

/// Earth field, µT, NED.
const MAG_NED_UT: [f32; 3] = [20.0, 2.0, 45.0];

impl SampleGen {
    /// A generator; equal seeds give equal streams on every platform. The
    /// board starts level, facing north.
    pub const fn new(seed: u32, disturbances: bool) -> Self {
        Self {
            rng: Rng::new(seed),
            rate: [0; 3],
            q: [1.0, 0.0, 0.0, 0.0],
            disturbances,
            n: 0,
        }
    }

    /// The true orientation `q_ned_from_body` (w, x, y, z) after the last sample.
    pub fn truth(&self) -> [f32; 4] {
        self.q
    }

    /// The next sample.
    pub fn next_sample(&mut self) -> RawSample {
        self.n = self.n.wrapping_add(1);
        // True rate: random walk in gyro counts, ±60 °/s, pulled towards 0.
        let lim = 60 * GYRO_LSB_PER_DPS_X10 / 10;
        for r in &mut self.rate {
            *r = (*r - *r / 256 + self.rng.symmetric(6)).clamp(-lim, lim);
        }
        let w = self.rate.map(|r| r as f32 * GYRO_RPS_PER_LSB);
        // q ← normalise(q + ½·dt·q ⊗ (0, ω)).
        let [a, b, c, d] = self.q;
        let h = 0.5 * DT_S;
        let q = [
            a + h * (-b * w[0] - c * w[1] - d * w[2]),
            b + h * (a * w[0] + c * w[2] - d * w[1]),
            c + h * (a * w[1] - b * w[2] + d * w[0]),
            d + h * (a * w[2] + b * w[1] - c * w[0]),
        ];
        let inv = 1.0 / libm::sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        self.q = q.map(|x| x * inv);

        // Body-frame vectors: v_body = R(q)ᵀ · v_ned.
        let [w, x, y, z] = self.q;
        let q_ned_from_body = Quaternion::new(w, x, y, z);
        let g_body = q_ned_from_body.rotate_inverse([0.0, 0.0, -G_MPS2]);
        let m_body = q_ned_from_body.rotate_inverse(MAG_NED_UT);
        let mut accel = g_body.map(|x| round(x / ACCEL_MPS2_PER_LSB) + self.rng.symmetric(40));
        let mut mag = m_body.map(|x| round(x / MAG_UT_PER_LSB) + self.rng.symmetric(4));
        let gyro = self.rate.map(|r| r + self.rng.symmetric(8));
        if self.disturbances {
            if self.n % 97 < 6 {
                // ≈ (0.6, −0.3, −0.3) g of linear acceleration.
                accel[0] += 2458;
                accel[1] -= 1229;
                accel[2] -= 1229;
            }
            if self.n % 211 < 10 {
                mag[0] += 120;
                mag[2] -= 90;
            }
        }
        let c16 = |v: i32| v.clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16;
        RawSample {
            accel: accel.map(c16),
            gyro: gyro.map(c16),
            mag: mag.map(c16),
        }
    }
}

fn round(x: f32) -> i32 {
    // `as` saturates; adding ±0.5 then truncating rounds half away from zero.
    (if x >= 0.0 { x + 0.5 } else { x - 0.5 }) as i32
}

impl Iterator for SampleGen {
    type Item = RawSample;
    fn next(&mut self) -> Option<RawSample> {
        Some(self.next_sample())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xorshift32_reference_values() {
        // Marsaglia's xorshift32 (13, 17, 5) from seed 1.
        let mut r = Rng::new(1);
        assert_eq!(r.next_u32(), 270_369);
        assert_eq!(r.next_u32(), 67_634_689);
        assert_eq!(r.next_u32(), 2_647_435_461);
    }

    #[test]
    fn symmetric_stays_in_range_and_covers_it() {
        let mut r = Rng::new(7);
        let mut seen = [false; 9];
        for _ in 0..1000 {
            let v = r.symmetric(4);
            assert!((-4..=4).contains(&v));
            seen[(v + 4) as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
    }

    #[test]
    fn samples_are_plausible() {
        for s in SampleGen::new(3, false).take(2000) {
            let si = s.to_si();
            let a = si.accel_mps2;
            let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            assert!((norm - G_MPS2).abs() < 0.5, "|a| = {norm}");
            let m = si.mag_ut;
            let mnorm = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
            assert!((40.0..60.0).contains(&mnorm), "|m| = {mnorm}");
            assert!(si.gyro_rps.iter().all(|g| g.abs() < 1.1));
        }
    }

    #[test]
    fn truth_is_a_unit_quaternion_that_moves() {
        let mut g = SampleGen::new(5, false);
        let q0 = g.truth();
        for _ in 0..3000 {
            g.next_sample();
        }
        let q = g.truth();
        let n: f32 = q.iter().map(|x| x * x).sum();
        assert!((n - 1.0).abs() < 1e-5);
        let dot: f32 = q.iter().zip(q0).map(|(a, b)| a * b).sum();
        assert!(
            dot.abs() < 0.999,
            "3 s of random rates should turn the board"
        );
    }

    #[test]
    fn level_start_reads_gravity_and_north() {
        let s = SampleGen::new(9, false).next_sample().to_si();
        assert!(
            (s.accel_mps2[2] + G_MPS2).abs() < 0.15,
            "{:?}",
            s.accel_mps2
        );
        assert!((s.mag_ut[0] - 20.0).abs() < 1.0 && (s.mag_ut[2] - 45.0).abs() < 1.0);
    }

    #[test]
    fn disturbances_appear_when_enabled() {
        let big = SampleGen::new(3, true)
            .take(300)
            .filter(|s| {
                let a = s.to_si().accel_mps2;
                (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() > 1.3 * G_MPS2
            })
            .count();
        assert!(big >= 6, "{big} disturbed samples");
    }
}
