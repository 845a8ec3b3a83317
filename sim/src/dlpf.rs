//! The MPU-9250's digital low-pass filters (DLPF) as discrete filters with
//! the register map's (rev 1.6) bandwidth and delay per setting.
//!
//! The register map gives, per CONFIG.DLPF_CFG / GYRO_CONFIG.FCHOICE_B and
//! per ACCEL_CONFIG2.A_DLPF_CFG / ACCEL_FCHOICE_B, one 3-dB bandwidth, one
//! delay and the rate the filter runs at, and nothing about the filter's
//! structure. The model's structure, chosen to meet both numbers:
//!
//! * a first-order low-pass `y += a·(x − y)` at the filter's rate whose
//!   3-dB point is exactly the table's bandwidth (`a` in closed form from
//!   `|H(e^{jωT})|² = ½`); its equivalent noise bandwidth is then the
//!   bandwidth · π/2 for bandwidths well below the rate;
//! * in series, a pure delay making up the rest of the table's delay: whole
//!   samples plus a first-order Thiran all-pass for the fraction (unit
//!   magnitude, so the 3-dB point stays the low-pass's, and exactly the
//!   fraction of a sample of group delay at DC).
//!
//! The low-pass accounts for a little less than `1/(2π·bandwidth)` of the
//! delay (its DC group delay `(1 − a)/a` samples); what is left comes out
//! at 2.1–2.6 ms for every 1 kHz gyro setting and 1.2–1.8 ms for the 1 kHz
//! accelerometer settings, as a fixed pipeline delay would. The group
//! delay at DC equals the table's delay exactly, and the 3-dB point the
//! table's bandwidth exactly (the all-pass has unit gain).

/// One DLPF setting as the register map states it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DlpfSpec {
    /// 3-dB bandwidth (Hz).
    pub bandwidth_hz: f64,
    /// Delay (s).
    pub delay_s: f64,
    /// The rate the filter runs at, the chip's internal sample rate (Hz).
    pub rate_hz: f64,
}

const fn spec(bandwidth_hz: f64, delay_ms: f64, rate_hz: f64) -> DlpfSpec {
    DlpfSpec {
        bandwidth_hz,
        delay_s: delay_ms * 1e-3,
        rate_hz,
    }
}

/// Gyro, FCHOICE_B = 00, by DLPF_CFG 0..=7 (register map rev 1.6, CONFIG).
pub const GYRO_DLPF: [DlpfSpec; 8] = [
    spec(250.0, 0.97, 8000.0),
    spec(184.0, 2.9, 1000.0),
    spec(92.0, 3.9, 1000.0),
    spec(41.0, 5.9, 1000.0),
    spec(20.0, 9.9, 1000.0),
    spec(10.0, 17.85, 1000.0),
    spec(5.0, 33.48, 1000.0),
    spec(3600.0, 0.17, 8000.0),
];
/// Gyro with FCHOICE_B = x1: the DLPF bypassed, 8800 Hz, 32 kHz.
pub const GYRO_BYPASS_8800: DlpfSpec = spec(8800.0, 0.064, 32_000.0);
/// Gyro with FCHOICE_B = 10: 3600 Hz, 32 kHz.
pub const GYRO_BYPASS_3600: DlpfSpec = spec(3600.0, 0.11, 32_000.0);
/// Accelerometer, ACCEL_FCHOICE_B = 0, by A_DLPF_CFG 0..=7 (register map
/// rev 1.6, ACCEL_CONFIG2).
pub const ACCEL_DLPF: [DlpfSpec; 8] = [
    spec(218.1, 1.88, 1000.0),
    spec(218.1, 1.88, 1000.0),
    spec(99.0, 2.88, 1000.0),
    spec(44.8, 4.88, 1000.0),
    spec(21.2, 8.87, 1000.0),
    spec(10.2, 16.83, 1000.0),
    spec(5.05, 32.48, 1000.0),
    spec(420.0, 1.38, 1000.0),
];
/// Accelerometer with ACCEL_FCHOICE_B = 1: 1046 Hz, 4 kHz.
pub const ACCEL_BYPASS: DlpfSpec = spec(1046.0, 0.503, 4000.0);

/// The longest whole-sample delay any setting needs (samples).
const MAX_DELAY_SAMPLES: usize = 8;

/// One three-axis DLPF: the low-pass, then the delay line and the
/// fractional all-pass.
#[derive(Clone, Debug, PartialEq)]
pub struct Dlpf {
    spec: DlpfSpec,
    /// Low-pass gain per sample, in (0, 1].
    a: f64,
    /// Whole samples of delay (≤ [`MAX_DELAY_SAMPLES`]).
    whole: usize,
    /// Thiran all-pass coefficient for the fractional delay; 0 = none.
    eta: f64,
    lp: Option<[f64; 3]>,
    line: [[f64; 3]; MAX_DELAY_SAMPLES + 1],
    /// All-pass state: its last input and output.
    ap_in: [f64; 3],
    ap_out: [f64; 3],
}

impl Dlpf {
    /// The filter for `spec`, at rest (the first input fills it).
    pub fn new(spec: DlpfSpec) -> Self {
        let omega = 2.0 * std::f64::consts::PI * spec.bandwidth_hz / spec.rate_hz;
        let c = omega.cos();
        // |a / (1 − b z⁻¹)|² = ½ at ω, b = 1 − a: b² + 2(c − 2) b + 1 = 0.
        let b = (2.0 - c) - ((2.0 - c) * (2.0 - c) - 1.0).sqrt();
        let a = 1.0 - b;
        let lp_delay = b / a;
        let rest = (spec.delay_s * spec.rate_hz - lp_delay).max(0.0);
        // Whole samples, leaving a fraction in [0.5, 1.5) for the all-pass
        // (its best-behaved range); a rest under half a sample stays whole.
        let whole = ((rest - 0.5).floor().max(0.0) as usize).min(MAX_DELAY_SAMPLES);
        let frac = rest - whole as f64;
        let eta = if frac > 1e-9 {
            (1.0 - frac) / (1.0 + frac)
        } else {
            0.0
        };
        Self {
            spec,
            a,
            whole,
            eta,
            lp: None,
            line: [[0.0; 3]; MAX_DELAY_SAMPLES + 1],
            ap_in: [0.0; 3],
            ap_out: [0.0; 3],
        }
    }

    /// The setting this filter models.
    pub fn spec(&self) -> DlpfSpec {
        self.spec
    }

    /// The filter's period (ns).
    pub fn period_ns(&self) -> u64 {
        (1e9 / self.spec.rate_hz).round() as u64
    }

    /// Equivalent noise bandwidth of the low-pass (Hz): bandwidth · π/2.
    pub fn enbw_hz(&self) -> f64 {
        self.spec.bandwidth_hz * std::f64::consts::FRAC_PI_2
    }

    /// The frequency response at `f_hz` (gain, phase in rad), from the
    /// coefficients (for plots and checks; the tests run the filter).
    pub fn response(&self, f_hz: f64) -> (f64, f64) {
        let w = 2.0 * std::f64::consts::PI * f_hz / self.spec.rate_hz;
        let b = 1.0 - self.a;
        // Low-pass a / (1 − b e^{−jw}).
        let (re, im) = (1.0 - b * w.cos(), b * w.sin());
        let lp_gain = self.a / (re * re + im * im).sqrt();
        let lp_phase = -im.atan2(re);
        let mut phase = lp_phase - w * self.whole as f64;
        if self.eta != 0.0 {
            // (η + e^{−jw}) / (1 + η e^{−jw}): unit gain.
            let num = (self.eta + w.cos(), -w.sin());
            let den = (1.0 + self.eta * w.cos(), -self.eta * w.sin());
            phase += num.1.atan2(num.0) - den.1.atan2(den.0);
        }
        (lp_gain, phase)
    }

    /// One sample in, one out.
    pub fn step(&mut self, x: [f64; 3]) -> [f64; 3] {
        let lp = match self.lp {
            None => {
                // Starts settled on its first input: no start-up transient.
                self.line = [x; MAX_DELAY_SAMPLES + 1];
                self.ap_in = x;
                self.ap_out = x;
                x
            }
            Some(y) => std::array::from_fn(|i| y[i] + self.a * (x[i] - y[i])),
        };
        self.lp = Some(lp);
        self.line.rotate_right(1);
        self.line[0] = lp;
        let delayed = self.line[self.whole];
        if self.eta == 0.0 {
            return delayed;
        }
        let out = std::array::from_fn(|i| {
            self.eta * delayed[i] + self.ap_in[i] - self.eta * self.ap_out[i]
        });
        self.ap_in = delayed;
        self.ap_out = out;
        out
    }
}

/// The gyro filter CONFIG and GYRO_CONFIG select.
pub fn gyro_spec(config: u8, gyro_config: u8) -> DlpfSpec {
    match gyro_config & 0x03 {
        0 => GYRO_DLPF[usize::from(config & 0x07)],
        2 => GYRO_BYPASS_3600,
        _ => GYRO_BYPASS_8800,
    }
}

/// The accelerometer filter ACCEL_CONFIG2 selects.
pub fn accel_spec(accel_config2: u8) -> DlpfSpec {
    if accel_config2 & 0x08 != 0 {
        ACCEL_BYPASS
    } else {
        ACCEL_DLPF[usize::from(accel_config2 & 0x07)]
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn all_specs() -> Vec<(&'static str, DlpfSpec)> {
        let mut v: Vec<_> = GYRO_DLPF.iter().map(|s| ("gyro", *s)).collect();
        v.push(("gyro bypass", GYRO_BYPASS_8800));
        v.push(("gyro bypass", GYRO_BYPASS_3600));
        v.extend(ACCEL_DLPF.iter().map(|s| ("accel", *s)));
        v.push(("accel bypass", ACCEL_BYPASS));
        v
    }

    /// Runs the filter on a sine of `f_hz` and returns (gain, phase in rad)
    /// from a least-squares fit of a sine and a cosine to its output.
    fn measure(spec: DlpfSpec, f_hz: f64) -> (f64, f64) {
        let mut f = Dlpf::new(spec);
        let w = 2.0 * PI * f_hz / spec.rate_hz;
        let settle = (20.0 * spec.rate_hz / spec.bandwidth_hz) as usize + 64;
        let n_fit = ((20.0 * spec.rate_hz / f_hz).ceil() as usize).max(20_000);
        let (mut ss, mut cc, mut sc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for n in 0..settle + n_fit {
            let (sn, cn) = (w * n as f64).sin_cos();
            let y = f.step([sn, 0.0, -sn])[0];
            if n >= settle {
                ss += sn * sn;
                cc += cn * cn;
                sc += sn * cn;
                ys += y * sn;
                yc += y * cn;
            }
        }
        // y ≈ p·sin + q·cos: the normal equations.
        let det = ss * cc - sc * sc;
        let p = (ys * cc - yc * sc) / det;
        let q = (yc * ss - ys * sc) / det;
        ((p * p + q * q).sqrt(), q.atan2(p))
    }

    #[test]
    fn low_frequency_delay_matches_the_register_map_within_0_3_ms() {
        for (name, spec) in all_specs() {
            let f_hz = spec.bandwidth_hz / 50.0;
            let (_, phase) = measure(spec, f_hz);
            let delay_s = -phase / (2.0 * PI * f_hz);
            assert!(
                (delay_s - spec.delay_s).abs() < 0.3e-3,
                "{name} {} Hz: {:.3} ms, table {:.3} ms",
                spec.bandwidth_hz,
                delay_s * 1e3,
                spec.delay_s * 1e3
            );
        }
    }

    #[test]
    fn three_db_point_matches_the_register_map_within_10_percent() {
        for (name, spec) in all_specs() {
            let at = |f: f64| measure(spec, f).0;
            // Gain above −3 dB at 0.9·bandwidth, below it at 1.1·bandwidth
            // (where 1.1·bandwidth is still under the filter's Nyquist).
            let lo = at(0.9 * spec.bandwidth_hz);
            assert!(lo > 0.5f64.sqrt(), "{name} {}: {lo}", spec.bandwidth_hz);
            if 1.1 * spec.bandwidth_hz < 0.5 * spec.rate_hz {
                let hi = at(1.1 * spec.bandwidth_hz);
                assert!(hi < 0.5f64.sqrt(), "{name} {}: {hi}", spec.bandwidth_hz);
            }
        }
    }

    #[test]
    fn passes_a_constant_unchanged_and_keeps_axes_apart() {
        let mut f = Dlpf::new(GYRO_DLPF[3]);
        let mut y = [0.0; 3];
        for _ in 0..10 {
            y = f.step([1.5, -2.0, 0.0]);
        }
        assert_eq!(y, [1.5, -2.0, 0.0]);
        for _ in 0..300 {
            y = f.step([0.0, 4.0, 0.0]);
        }
        assert!(y[0].abs() < 1e-6 && (y[1] - 4.0).abs() < 1e-6 && y[2] == 0.0);
    }

    #[test]
    fn the_coefficient_response_agrees_with_the_running_filter() {
        for (_, spec) in all_specs() {
            let f = Dlpf::new(spec);
            let fr = 0.3 * spec.bandwidth_hz.min(0.4 * spec.rate_hz);
            let (g, p) = measure(spec, fr);
            let (g2, p2) = f.response(fr);
            let dp = (p - p2 + PI).rem_euclid(2.0 * PI) - PI;
            assert!((g - g2).abs() < 0.01 && dp.abs() < 0.01, "{spec:?}");
        }
    }

    #[test]
    fn register_fields_select_the_table_rows() {
        assert_eq!(gyro_spec(3, 0), GYRO_DLPF[3]);
        assert_eq!(gyro_spec(0x0B, 0x18), GYRO_DLPF[3]);
        assert_eq!(gyro_spec(3, 1), GYRO_BYPASS_8800);
        assert_eq!(gyro_spec(3, 3), GYRO_BYPASS_8800);
        assert_eq!(gyro_spec(3, 2), GYRO_BYPASS_3600);
        assert_eq!(accel_spec(3), ACCEL_DLPF[3]);
        assert_eq!(accel_spec(0x0B), ACCEL_BYPASS);
    }
}
