//! Test helpers: a seeded deterministic RNG and sensor models.
#![allow(dead_code)]

/// xorshift64* with Box-Muller Gaussian samples; deterministic per seed.
pub struct Rng {
    state: u64,
    spare: Option<f64>,
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self {
            state: seed.max(1),
            spare: None,
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.state;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.state = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in (0, 1].
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn gauss(&mut self) -> f64 {
        if let Some(s) = self.spare.take() {
            return s;
        }
        let u1 = self.uniform();
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (2.0 * std::f64::consts::PI * u2).sin_cos();
        self.spare = Some(r * s);
        r * c
    }
}

pub const G_MPS2: f64 = 9.806_65;

/// MS5611 pressure noise at OSR 4096: 0.012 mbar RMS = 1.2 Pa.
pub const BARO_NOISE_PA: f64 = 1.2;

/// Accelerometer noise density 300 µg/√Hz sampled at 1 kHz (bandwidth
/// 500 Hz): per-sample σ = 300e-6 · g · √500 ≈ 0.066 m/s².
pub fn accel_sigma_mps2(rate_hz: f64) -> f64 {
    300e-6 * G_MPS2 * (rate_hz / 2.0).sqrt()
}

/// Exact pressure at height `h` above `p0` (f64).
pub fn pressure_at(h_m: f64, p0_pa: f64) -> f64 {
    p0_pa * (1.0 - h_m / 44_330.0).powf(5.255)
}

/// MS5611-like reading: true pressure + noise, rounded to integer Pa.
pub fn baro_reading_pa(rng: &mut Rng, h_m: f64, p0_pa: f64) -> i32 {
    (pressure_at(h_m, p0_pa) + BARO_NOISE_PA * rng.gauss()).round() as i32
}

/// Root mean square.
pub fn rms(xs: &[f64]) -> f64 {
    (xs.iter().map(|x| x * x).sum::<f64>() / xs.len().max(1) as f64).sqrt()
}
