//! The simulated gyro's spectrum: the MPU-9250 model read the way the
//! firmware sets it up, on the quadcopter model held at a constant motor
//! command, and Welch's power spectral density of what the chip outputs
//! (after its DLPF and the sample-rate divider).

use crate::quad::{QuadLink, QuadParams, QuadState, Quadcopter};
use crate::{SensorErrors, SimBus, SimClock, SimConfig};
use embedded_hal::i2c::I2c;

/// One-sided power spectral density by Welch's method: Hann-windowed
/// segments of `segment` samples overlapping by half, each with its mean
/// removed, averaged. Returns (frequency in Hz, density in unit²/Hz) from
/// 0 to `rate_hz / 2`; empty if there are fewer samples than a segment or
/// a segment shorter than 2.
pub fn welch_psd(samples: &[f64], rate_hz: f64, segment: usize) -> Vec<(f64, f64)> {
    if segment < 2 || samples.len() < segment || rate_hz <= 0.0 {
        return Vec::new();
    }
    let n = segment;
    let window: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())
        .collect();
    let w2: f64 = window.iter().map(|w| w * w).sum();
    let bins = n / 2 + 1;
    let mut psd = vec![0.0; bins];
    let mut count = 0usize;
    let mut start = 0;
    while start + n <= samples.len() {
        let seg = &samples[start..start + n];
        let mean = seg.iter().sum::<f64>() / n as f64;
        for (k, p) in psd.iter_mut().enumerate() {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, (x, w)) in seg.iter().zip(&window).enumerate() {
                let a = -2.0 * std::f64::consts::PI * (k * i) as f64 / n as f64;
                re += (x - mean) * w * a.cos();
                im += (x - mean) * w * a.sin();
            }
            *p += re * re + im * im;
        }
        count += 1;
        start += n / 2;
    }
    psd.iter()
        .enumerate()
        .map(|(k, p)| {
            // One-sided: every bin but DC and Nyquist carries both halves.
            let one_sided = if k == 0 || 2 * k == n { 1.0 } else { 2.0 };
            let f = k as f64 * rate_hz / n as f64;
            (f, one_sided * p / (count as f64 * rate_hz * w2))
        })
        .collect()
}

/// The chip's register setup for a recording: CONFIG (DLPF_CFG),
/// ACCEL_CONFIG2, SMPLRT_DIV; the gyro at ±1000 °/s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChipSetup {
    /// CONFIG.DLPF_CFG, 0..=7.
    pub dlpf_cfg: u8,
    /// SMPLRT_DIV.
    pub smplrt_div: u8,
}

impl ChipSetup {
    /// The `mpu9250` driver's default configuration: DLPF_CFG 3 (41 Hz),
    /// accelerometer 44.8 Hz, 1 kHz. (The board's own setting is the
    /// `settings` crate's, which `cargo sim --spectrum` uses.)
    pub const DRIVER_DEFAULT: Self = Self {
        dlpf_cfg: 3,
        smplrt_div: 0,
    };
}

/// The gyro (°/s, MPU frame) the chip outputs at every sample for
/// `seconds` after `settle_s`, the quad 10 m up, level, its motors held at
/// `command` (the rotors start at that command's speed); errors of the
/// datasheet's size from `seed`. Returns the samples, their rate (Hz) and
/// the rotors' mean speed over the recording (rad/s).
pub fn record_gyro(
    airframe: QuadParams,
    command: f64,
    setup: ChipSetup,
    settle_s: f64,
    seconds: f64,
    seed: u64,
) -> Result<(Vec<[f64; 3]>, f64, f64), String> {
    let mut quad = Quadcopter::new(airframe).map_err(|e| e.to_string())?;
    let w = quad.steady_rotor_rps(command, quad.state().battery_voltage_v);
    quad.set_state(QuadState {
        position_ned_m: [0.0, 0.0, -10.0],
        rotor_rps: [w; 4],
        on_ground: false,
        ..*quad.state()
    });
    let link = QuadLink::new();
    link.publish(&quad);
    let clock = SimClock::new();
    let mut bus = SimBus::new(
        &clock,
        SimConfig {
            trajectory: link.trajectory(),
            errors: SensorErrors::datasheet(seed),
            seed,
            ..SimConfig::default()
        },
    );
    let regs = [
        (0x6B, 0x00),
        (0x1A, setup.dlpf_cfg & 7),
        (0x1B, 0x10),
        (0x1D, 3),
        (0x19, setup.smplrt_div),
    ];
    for (r, v) in regs {
        bus.write(0x68, &[r, v]).map_err(|e| format!("{e:?}"))?;
    }
    let t0 = clock.now_s();
    let mut out = Vec::new();
    let mut times = Vec::new();
    let mut rotor_sum = 0.0;
    while clock.now_s() < t0 + settle_s + seconds {
        let t_next = bus.next_mpu_sample_ns() as f64 * 1e-9;
        quad.advance_to(t_next, [command; 4]);
        link.publish(&quad);
        let t = bus.advance_to_next_mpu_sample() as f64 * 1e-9;
        if t < t0 + settle_s {
            continue;
        }
        let mut raw = [0u8; 6];
        bus.write_read(0x68, &[0x43], &mut raw)
            .map_err(|e| format!("{e:?}"))?;
        out.push(std::array::from_fn(|i| {
            f64::from(i16::from_be_bytes([raw[2 * i], raw[2 * i + 1]])) / 32.8
        }));
        times.push(t);
        rotor_sum += quad.state().rotor_rps.iter().sum::<f64>() / 4.0;
    }
    let rate = match (times.first(), times.last()) {
        (Some(a), Some(b)) if b > a => (times.len() - 1) as f64 / (b - a),
        _ => return Err("no samples recorded".into()),
    };
    let rotor = rotor_sum / times.len() as f64;
    Ok((out, rate, rotor))
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn a_sine_s_power_lands_in_its_bin_and_sums_to_half_its_square() {
        let (fs, f0, a) = (1000.0, 125.0, 3.0);
        let x: Vec<f64> = (0..4096)
            .map(|i| a * (2.0 * std::f64::consts::PI * f0 * i as f64 / fs).sin())
            .collect();
        let psd = welch_psd(&x, fs, 256);
        let df = fs / 256.0;
        let total: f64 = psd.iter().map(|(_, p)| p * df).sum();
        // Parseval with the window's power normalisation: mean square A²/2.
        assert!((total - a * a / 2.0).abs() < 0.02 * a * a / 2.0, "{total}");
        let peak = psd
            .iter()
            .cloned()
            .fold((0.0, 0.0), |m, v| if v.1 > m.1 { v } else { m });
        assert!((peak.0 - f0).abs() <= df, "{peak:?}");
    }

    #[test]
    fn white_noise_is_flat_at_its_variance_over_half_the_rate() {
        let mut rng = Rng::new(7);
        let x: Vec<f64> = (0..65_536).map(|_| rng.normal(2.0)).collect();
        let psd = welch_psd(&x, 1000.0, 256);
        let level = 4.0 / 500.0;
        let mid = &psd[10..118];
        let mean = mid.iter().map(|(_, p)| p).sum::<f64>() / mid.len() as f64;
        assert!((mean - level).abs() < 0.05 * level, "{mean} vs {level}");
    }

    #[test]
    fn too_few_samples_give_nothing() {
        assert!(welch_psd(&[1.0; 10], 1000.0, 256).is_empty());
    }
}
