//! Frequency response of a loop from its signals: Welch cross-spectra,
//! the H1 estimate `H = S_xy / S_xx` with its coherence, banded on a
//! logarithmic grid, and the loop's margins from it.
//!
//! The rate loop is measured from the rate setpoint `r` (the input, which
//! in acro is the pilot's shaped stick: no feedback reaches it) to the
//! gyro `y` the controller sees: the closed loop `T = y / r`. The error the
//! controller acts on is `e = r − y`, so the open loop (controller, motors,
//! airframe and the sensor's delay, everything between `e` and `y`) is
//! `L = y / e = T / (1 − T)` and the sensitivity `S = 1 / (1 + L) = 1 − T`.
//! Assumptions: the loop is linear about the operating point over the
//! band (the sweep's amplitude keeps the motors out of saturation), and
//! whatever else moves `y` (sensor noise, turbulence) is uncorrelated with
//! `r`; bands whose coherence is below a threshold are not used.

use std::f64::consts::PI;
use std::ops::{Add, Div, Mul, Sub};

/// A complex number (the spectra's bins).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct C {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl C {
    /// `re + i·im`.
    pub const fn new(re: f64, im: f64) -> Self {
        Self { re, im }
    }
    /// `e^{iφ}`.
    pub fn from_phase(phi: f64) -> Self {
        Self::new(phi.cos(), phi.sin())
    }
    /// `|z|`.
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    /// `|z|²`.
    pub fn norm2(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
    /// The argument, rad, in (−π, π].
    pub fn arg(self) -> f64 {
        self.im.atan2(self.re)
    }
    /// The conjugate.
    pub fn conj(self) -> Self {
        Self::new(self.re, -self.im)
    }
    /// `self · k`.
    pub fn scale(self, k: f64) -> Self {
        Self::new(self.re * k, self.im * k)
    }
}

impl Mul for C {
    type Output = Self;
    /// `self · o`.
    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
}

impl Div for C {
    type Output = Self;
    /// `self / o` (infinite or NaN for `o = 0`).
    fn div(self, o: Self) -> Self {
        let d = o.norm2();
        let n = self.mul(o.conj());
        Self::new(n.re / d, n.im / d)
    }
}

impl Add for C {
    type Output = Self;
    /// `self + o`.
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
}

impl Sub for C {
    type Output = Self;
    /// `self − o`.
    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }
}

/// In-place radix-2 FFT (`inverse`: the unscaled inverse). `buf.len()`
/// must be a power of two.
pub fn fft(buf: &mut [C], inverse: bool) {
    let n = buf.len();
    if n < 2 || !n.is_power_of_two() {
        return;
    }
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            buf.swap(i, j);
        }
    }
    let sign = if inverse { 1.0 } else { -1.0 };
    let mut len = 2;
    while len <= n {
        let w = C::from_phase(sign * 2.0 * PI / len as f64);
        for start in (0..n).step_by(len) {
            let mut wk = C::new(1.0, 0.0);
            for k in 0..len / 2 {
                let a = buf[start + k];
                let b = buf[start + k + len / 2].mul(wk);
                buf[start + k] = a.add(b);
                buf[start + k + len / 2] = a.sub(b);
                wk = wk.mul(w);
            }
        }
        len <<= 1;
    }
}

/// Hann window of `n` points (periodic form, as for Welch's segments).
pub fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos())
        .collect()
}

/// Welch's averaged auto- and cross-spectra of `x` and `y` (unnormalised:
/// only their ratios are used).
#[derive(Clone, Debug, PartialEq)]
pub struct Spectra {
    /// Bin spacing (Hz); bin `k` is at `k · df_hz`, `k < seg / 2`.
    pub df_hz: f64,
    /// `Σ |X|²` per bin.
    pub sxx: Vec<f64>,
    /// `Σ |Y|²` per bin.
    pub syy: Vec<f64>,
    /// `Σ conj(X)·Y` per bin.
    pub sxy: Vec<C>,
}

/// Welch cross-spectra of `x` (input) and `y` (output) sampled at `fs_hz`:
/// Hann-windowed segments of `seg` samples (a power of two), overlapping
/// by half, each with its mean removed. An error when the signals differ
/// in length, are shorter than one segment, or hold a non-finite value.
pub fn cross_spectra(x: &[f64], y: &[f64], fs_hz: f64, seg: usize) -> Result<Spectra, String> {
    if x.len() != y.len() {
        return Err(format!(
            "input and output lengths differ ({} vs {})",
            x.len(),
            y.len()
        ));
    }
    if !seg.is_power_of_two() || seg < 8 || x.len() < seg {
        return Err(format!(
            "{} samples: too short for one {seg}-sample segment",
            x.len()
        ));
    }
    if !(fs_hz.is_finite() && fs_hz > 0.0) || x.iter().chain(y).any(|v| !v.is_finite()) {
        return Err("a sample or the sample rate is not finite".into());
    }
    let w = hann(seg);
    let half = seg / 2;
    let mut s = Spectra {
        df_hz: fs_hz / seg as f64,
        sxx: vec![0.0; half],
        syy: vec![0.0; half],
        sxy: vec![C::default(); half],
    };
    let mut start = 0;
    while start + seg <= x.len() {
        let fx = windowed_fft(&x[start..start + seg], &w);
        let fy = windowed_fft(&y[start..start + seg], &w);
        for k in 0..half {
            s.sxx[k] += fx[k].norm2();
            s.syy[k] += fy[k].norm2();
            s.sxy[k] = s.sxy[k].add(fx[k].conj().mul(fy[k]));
        }
        start += half;
    }
    Ok(s)
}

/// The FFT of `x` less its mean, times `w`.
fn windowed_fft(x: &[f64], w: &[f64]) -> Vec<C> {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    let mut buf: Vec<C> = x
        .iter()
        .zip(w)
        .map(|(v, w)| C::new((v - mean) * w, 0.0))
        .collect();
    fft(&mut buf, false);
    buf
}

/// A frequency response on a grid of frequencies.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FreqResponse {
    /// Frequencies (Hz), increasing.
    pub f_hz: Vec<f64>,
    /// The response at each.
    pub h: Vec<C>,
    /// Magnitude-squared coherence `|S_xy|² / (S_xx S_yy)` (0..1) at each.
    pub coherence: Vec<f64>,
}

impl FreqResponse {
    /// The H1 estimate `S_xy / S_xx` banded on a logarithmic grid from
    /// `f_lo_hz` to `f_hi_hz` with `per_decade` bands a decade: the
    /// spectra summed over each band's bins before the ratio (a band with
    /// no bin, or no input power, is left out).
    pub fn banded(s: &Spectra, f_lo_hz: f64, f_hi_hz: f64, per_decade: usize) -> Self {
        let mut out = Self::default();
        let decades = (f_hi_hz / f_lo_hz).log10();
        let bands = (decades * per_decade as f64).ceil() as usize;
        let edge = |i: usize| f_lo_hz * 10f64.powf(i as f64 / per_decade as f64);
        for b in 0..bands {
            let (lo, hi) = (edge(b), edge(b + 1).min(f_hi_hz));
            let (mut sxx, mut syy, mut sxy, mut n) = (0.0, 0.0, C::default(), 0);
            for k in 1..s.sxx.len() {
                let f = k as f64 * s.df_hz;
                if f >= lo && f < hi {
                    sxx += s.sxx[k];
                    syy += s.syy[k];
                    sxy = sxy.add(s.sxy[k]);
                    n += 1;
                }
            }
            if n == 0 || sxx <= 0.0 || syy <= 0.0 {
                continue;
            }
            out.f_hz.push((lo * hi).sqrt());
            out.h.push(sxy.scale(1.0 / sxx));
            out.coherence.push(sxy.norm2() / (sxx * syy));
        }
        out
    }

    /// The same response restricted to coherence ≥ `min_coherence`.
    pub fn coherent(&self, min_coherence: f64) -> Self {
        let keep: Vec<usize> = (0..self.f_hz.len())
            .filter(|&i| self.coherence[i] >= min_coherence)
            .collect();
        Self {
            f_hz: keep.iter().map(|&i| self.f_hz[i]).collect(),
            h: keep.iter().map(|&i| self.h[i]).collect(),
            coherence: keep.iter().map(|&i| self.coherence[i]).collect(),
        }
    }

    /// The open loop `L = T / (1 − T)` of this closed loop `T`.
    pub fn open_loop_of_closed(&self) -> Self {
        Self {
            h: self
                .h
                .iter()
                .map(|&t| t.div(C::new(1.0, 0.0).sub(t)))
                .collect(),
            ..self.clone()
        }
    }

    /// The phase at each frequency (°), unwrapped along the grid from a
    /// first value in (−270°, 90°] (a loop with an integrator starts near
    /// −90° or −180°, never much above 0°).
    pub fn phase_deg(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::with_capacity(self.h.len());
        for z in &self.h {
            let mut p = z.arg().to_degrees();
            match out.last() {
                None if p > 90.0 => p -= 360.0,
                None => {}
                Some(&prev) => p += 360.0 * ((prev - p) / 360.0).round(),
            }
            out.push(p);
        }
        out
    }

    /// The magnitude at each frequency (dB).
    pub fn magnitude_db(&self) -> Vec<f64> {
        self.h.iter().map(|z| 20.0 * z.abs().log10()).collect()
    }
}

/// A loop's stability margins, from its open loop `L`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Margins {
    /// Gain crossover: the first frequency where `|L|` falls through 1 (Hz).
    pub crossover_hz: Option<f64>,
    /// `180° + ∠L` at the crossover (°).
    pub phase_margin_deg: Option<f64>,
    /// Phase crossover: the first frequency above the gain crossover where
    /// `∠L` falls through −180° (Hz).
    pub phase_crossover_hz: Option<f64>,
    /// `−20·log10 |L|` there (dB); `None` when the phase never reaches
    /// −180° within the grid.
    pub gain_margin_db: Option<f64>,
    /// The sensitivity peak `Ms = max |1 / (1 + L)|` over the grid.
    pub ms: f64,
    /// Where it is (Hz).
    pub ms_hz: f64,
}

/// The margins of open loop `l` (the crossings interpolated linearly in
/// log-frequency between grid points).
pub fn margins(l: &FreqResponse) -> Margins {
    let mag_db = l.magnitude_db();
    let phase = l.phase_deg();
    let lf: Vec<f64> = l.f_hz.iter().map(|f| f.ln()).collect();
    let cross = |v: &[f64], level: f64, from: usize| -> Option<(usize, f64)> {
        (from.max(1)..v.len())
            .find(|&i| v[i - 1] >= level && v[i] < level)
            .map(|i| (i, (v[i - 1] - level) / (v[i - 1] - v[i])))
    };
    let at = |v: &[f64], (i, a): (usize, f64)| v[i - 1] + a * (v[i] - v[i - 1]);
    let mut m = Margins::default();
    if let Some(c) = cross(&mag_db, 0.0, 1) {
        m.crossover_hz = Some(at(&lf, c).exp());
        m.phase_margin_deg = Some(180.0 + at(&phase, c));
        if let Some(p) = cross(&phase, -180.0, c.0) {
            m.phase_crossover_hz = Some(at(&lf, p).exp());
            m.gain_margin_db = Some(-at(&mag_db, p));
        }
    }
    for (i, z) in l.h.iter().enumerate() {
        let s = 1.0 / C::new(1.0, 0.0).add(*z).abs();
        if s > m.ms {
            m.ms = s;
            m.ms_hz = l.f_hz[i];
        }
    }
    m
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::super::test_signals::{lag, noise};
    use super::*;

    /// The grid of analytic `L(j2πf)` over 0.5..200 Hz, 50 points a decade.
    fn analytic(l: impl Fn(f64) -> C) -> FreqResponse {
        let f_hz: Vec<f64> = (0..=120)
            .map(|i| 0.5 * 10f64.powf(i as f64 / 50.0))
            .collect();
        FreqResponse {
            h: f_hz.iter().map(|&f| l(2.0 * PI * f)).collect(),
            coherence: vec![1.0; f_hz.len()],
            f_hz,
        }
    }

    /// `L = K e^{−sθ} / s`: crossover at `ω = K`, phase margin
    /// `90° − Kθ`, phase crossover at `ω = π / 2θ` with gain margin
    /// `20 log10(π / 2Kθ)`.
    fn integrator_with_delay(k: f64, theta_s: f64) -> impl Fn(f64) -> C {
        move |w: f64| C::from_phase(-w * theta_s).div(C::new(0.0, w)).scale(k)
    }

    #[test]
    fn the_fft_of_a_sinusoid_is_one_bin() {
        let n = 64;
        let mut buf: Vec<C> = (0..n)
            .map(|i| C::new((2.0 * PI * 5.0 * i as f64 / n as f64).cos(), 0.0))
            .collect();
        fft(&mut buf, false);
        for (k, z) in buf.iter().enumerate() {
            let want = if k == 5 || k == n - 5 {
                n as f64 / 2.0
            } else {
                0.0
            };
            assert!((z.abs() - want).abs() < 1e-9, "{k} {z:?}");
        }
        fft(&mut buf, true);
        assert!((buf[1].re / n as f64 - (2.0 * PI * 5.0 / n as f64).cos()).abs() < 1e-12);
    }

    #[test]
    fn margins_of_an_integrator_with_delay_are_the_analytic_ones() {
        let (k, theta) = (2.0 * PI * 10.0, 0.01);
        let m = margins(&analytic(integrator_with_delay(k, theta)));
        let pm = 90.0 - (k * theta).to_degrees();
        let gm = 20.0 * (PI / (2.0 * k * theta)).log10();
        assert!((m.crossover_hz.unwrap() - 10.0).abs() < 0.05, "{m:?}");
        assert!((m.phase_margin_deg.unwrap() - pm).abs() < 0.5, "{m:?} {pm}");
        let f180 = 1.0 / (4.0 * theta);
        assert!(
            (m.phase_crossover_hz.unwrap() - f180).abs() < 0.01 * f180,
            "{m:?}"
        );
        assert!((m.gain_margin_db.unwrap() - gm).abs() < 0.1, "{m:?} {gm}");
        // At the phase crossover L = −|L|, so |S| = 1/(1 − |L|) there: a
        // lower bound of the peak (within the grid's spacing).
        assert!(m.ms >= 0.99 / (1.0 - 10f64.powf(-gm / 20.0)), "{m:?}");
    }

    #[test]
    fn margins_of_a_second_order_loop_follow_the_damping() {
        // L = ωn² / (s (s + 2ζωn)): T is the standard second-order system,
        // PM = atan(2ζ / sqrt(sqrt(1 + 4ζ⁴) − 2ζ²)), no phase crossover.
        let (wn, zeta) = (2.0 * PI * 8.0, 0.5);
        let l =
            move |w: f64| C::new(wn * wn, 0.0).div(C::new(0.0, w).mul(C::new(2.0 * zeta * wn, w)));
        let m = margins(&analytic(l));
        let pm = (2.0 * zeta / ((1.0 + 4.0 * zeta.powi(4)).sqrt() - 2.0 * zeta * zeta).sqrt())
            .atan()
            .to_degrees();
        let wc = wn * ((1.0 + 4.0 * zeta.powi(4)).sqrt() - 2.0 * zeta * zeta).sqrt();
        assert!((m.phase_margin_deg.unwrap() - pm).abs() < 0.5, "{m:?} {pm}");
        assert!(
            (m.crossover_hz.unwrap() - wc / (2.0 * PI)).abs() < 0.05,
            "{m:?}"
        );
        assert!(
            m.gain_margin_db.is_none() && m.phase_crossover_hz.is_none(),
            "{m:?}"
        );
    }

    #[test]
    fn the_estimate_of_a_first_order_lag_and_a_delay_is_analytic() {
        let (fs, tau, delay) = (1000.0, 0.01, 5);
        let x = noise(60_000, 7);
        let y = lag(&x, 1.0 / fs, tau, delay);
        let s = cross_spectra(&x, &y, fs, 2048).unwrap();
        let h = FreqResponse::banded(&s, 1.0, 100.0, 20);
        let phase = h.phase_deg();
        for (i, &f) in h.f_hz.iter().enumerate() {
            let w = 2.0 * PI * f;
            // The held-input lag and its output one sample late: the
            // exact discrete response is within 1 % in gain and 1° in phase
            // of the continuous one at these frequencies (below fs/10).
            let want = C::from_phase(-w * (delay as f64 + 1.0) / fs)
                .div(C::new(1.0, w * tau))
                .mul(C::from_phase(w * 0.5 / fs));
            let gain_err = (h.h[i].abs() / want.abs() - 1.0).abs();
            let phase_err = phase[i] - want.arg().to_degrees();
            let phase_err = phase_err - 360.0 * (phase_err / 360.0).round();
            assert!(gain_err < 0.03, "{f} Hz: gain {gain_err}");
            assert!(phase_err.abs() < 2.0, "{f} Hz: phase {phase_err}");
            assert!(h.coherence[i] > 0.97, "{f} Hz: {}", h.coherence[i]);
        }
    }

    #[test]
    fn a_closed_loop_with_known_margins_is_measured_from_its_signals() {
        // The integrator with a delay of 10 ms closed around a white
        // setpoint, with gyro-like noise on the feedback: T from r and y,
        // L = T/(1 − T), margins against the analytic ones.
        let (fs, k, d) = (1000.0, 2.0 * PI * 10.0, 10);
        let r = noise(120_000, 3);
        let v = noise(120_000, 4);
        let (mut y, mut e_hist) = (vec![0.0; r.len()], vec![0.0; r.len()]);
        let mut state = 0.0;
        for i in 0..r.len() {
            y[i] = state + 0.05 * v[i];
            e_hist[i] = r[i] - y[i];
            if i >= d {
                state += k / fs * e_hist[i - d];
            }
        }
        let s = cross_spectra(&r, &y, fs, 2048).unwrap();
        let t = FreqResponse::banded(&s, 1.0, 100.0, 24);
        let m = margins(&t.open_loop_of_closed());
        // The discrete loop: delay d + 1 samples (the integrator's own)
        // less half a sample of the forward-Euler hold.
        let theta = (d as f64 + 0.5) / fs;
        let pm = 90.0 - (k * theta).to_degrees();
        let gm = 20.0 * (PI / (2.0 * k * theta)).log10();
        assert!((m.crossover_hz.unwrap() - 10.0).abs() < 0.5, "{m:?}");
        assert!((m.phase_margin_deg.unwrap() - pm).abs() < 3.0, "{m:?} {pm}");
        assert!((m.gain_margin_db.unwrap() - gm).abs() < 1.0, "{m:?} {gm}");
        let exact = margins(&analytic(integrator_with_delay(k, theta)));
        assert!((m.ms - exact.ms).abs() < 0.1 * exact.ms, "{m:?} {exact:?}");
    }

    #[test]
    fn bad_signals_are_refused() {
        assert!(cross_spectra(&[0.0; 100], &[0.0; 99], 1000.0, 64).is_err());
        assert!(cross_spectra(&[0.0; 10], &[0.0; 10], 1000.0, 64).is_err());
        assert!(cross_spectra(&[f64::NAN; 100], &[0.0; 100], 1000.0, 64).is_err());
    }
}
