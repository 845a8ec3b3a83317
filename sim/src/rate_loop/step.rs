//! The loop's step response from any flight, by deconvolution (after
//! PIDtoolbox): over overlapping Hann windows where the setpoint moves,
//! the spectra `Y·conj(X)` and `|X|²` of setpoint `x` and gyro `y` are
//! summed, the impulse response is their Wiener deconvolution
//! `H = ΣY·conj(X) / (Σ|X|² + λ)`, and its running sum the step response.
//! (PIDtoolbox averages each window's step instead; summing the spectra
//! first weights each frequency by the windows that excite it, which a
//! sweep, exciting one band per window, needs.) No scripted step is
//! needed: any stick activity excites it.

use super::freq::{fft, hann, C};
use std::ops::{Add, Mul};

/// Wiener regularisation: `λ` as a fraction of the window's mean `|X|²`
/// (bins where the setpoint has less power than this are trusted less).
const WIENER_FRACTION: f64 = 0.01;
/// Settling band: within ±5 % of the final value (2 % is within the
/// gyro noise on a 100 °/s step).
pub const SETTLING_BAND: f64 = 0.05;

/// A step response with its figures.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepResponse {
    /// The averaged step response at `dt_s` spacing, 0 at `t = 0`.
    pub step: Vec<f64>,
    /// Sample spacing (s).
    pub dt_s: f64,
    /// Windows averaged.
    pub windows: usize,
    /// The final value (mean over the last 40 % of the horizon).
    pub final_value: f64,
    /// 10–90 % rise time (s).
    pub rise_s: Option<f64>,
    /// Peak above the final value (% of it).
    pub overshoot_pct: f64,
    /// The last time outside ±[`SETTLING_BAND`] of the final value (s).
    pub settling_s: Option<f64>,
}

/// The step response from setpoint `x` to output `y` sampled at `fs_hz`,
/// over windows of `window` samples (a power of two) overlapping by half,
/// `horizon_s` long; windows whose setpoint spans less than
/// `min_span` (peak to peak, in `x`'s unit) are skipped. `None` when no
/// window qualifies or the signals are unusable.
pub fn step_response(
    x: &[f64],
    y: &[f64],
    fs_hz: f64,
    window: usize,
    horizon_s: f64,
    min_span: f64,
) -> Option<StepResponse> {
    let horizon = (horizon_s * fs_hz).round() as usize;
    if x.len() != y.len() || !window.is_power_of_two() || horizon < 4 || horizon > window / 2 {
        return None;
    }
    let w = hann(window);
    let mut sxy = vec![C::default(); window];
    let mut sxx = vec![0.0; window];
    let mut windows = 0;
    let mut start = 0;
    while start + window <= x.len() {
        let (xs, ys) = (&x[start..start + window], &y[start..start + window]);
        let (lo, hi) = xs
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        if hi - lo >= min_span && xs.iter().chain(ys).all(|v| v.is_finite()) {
            let (fx, fy) = (spectrum(xs, &w), spectrum(ys, &w));
            for k in 0..window {
                sxy[k] = sxy[k].add(fy[k].mul(fx[k].conj()));
                sxx[k] += fx[k].norm2();
            }
            windows += 1;
        }
        start += window / 2;
    }
    if windows == 0 {
        return None;
    }
    Some(figures(
        deconvolved_step(&sxy, &sxx, horizon),
        1.0 / fs_hz,
        windows,
    ))
}

/// The FFT of `v` less its mean, times `w`.
fn spectrum(v: &[f64], w: &[f64]) -> Vec<C> {
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let mut b: Vec<C> = v
        .iter()
        .zip(w)
        .map(|(a, w)| C::new((a - mean) * w, 0.0))
        .collect();
    fft(&mut b, false);
    b
}

/// The Wiener deconvolution `H = S_yx / (S_xx + λ)` back in time: the
/// impulse response, summed over the first `horizon` samples.
fn deconvolved_step(sxy: &[C], sxx: &[f64], horizon: usize) -> Vec<f64> {
    let lambda = WIENER_FRACTION * sxx.iter().sum::<f64>() / sxx.len() as f64;
    let mut h: Vec<C> = sxy
        .iter()
        .zip(sxx)
        .map(|(&c, &p)| c.scale(1.0 / (p + lambda)))
        .collect();
    fft(&mut h, true);
    let n = h.len() as f64;
    let mut acc = 0.0;
    h.iter()
        .take(horizon)
        .map(|z| {
            acc += z.re / n;
            acc
        })
        .collect()
}

/// Rise, overshoot and settling of `step` at `dt_s` spacing.
pub fn figures(step: Vec<f64>, dt_s: f64, windows: usize) -> StepResponse {
    let n = step.len();
    let tail = &step[n * 3 / 5..];
    let final_value = tail.iter().sum::<f64>() / tail.len().max(1) as f64;
    let first_at = |level: f64| {
        (1..n).find(|&i| step[i] >= level * final_value).map(|i| {
            let a = (level * final_value - step[i - 1]) / (step[i] - step[i - 1]);
            (i as f64 - 1.0 + a) * dt_s
        })
    };
    let rise_s = match (first_at(0.1), first_at(0.9)) {
        (Some(a), Some(b)) if final_value > 0.0 => Some(b - a),
        _ => None,
    };
    let peak = step.iter().copied().fold(f64::MIN, f64::max);
    let outside = |v: f64| (v - final_value).abs() > SETTLING_BAND * final_value.abs();
    let settling_s = (final_value > 0.0).then(|| {
        step.iter()
            .rposition(|&v| outside(v))
            .map_or(0.0, |i| (i + 1) as f64 * dt_s)
    });
    StepResponse {
        overshoot_pct: (100.0 * (peak / final_value - 1.0)).max(0.0),
        step,
        dt_s,
        windows,
        final_value,
        rise_s,
        settling_s,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::super::test_signals::{lag, noise};
    use super::*;

    /// A pilot's stick: held levels changing at random every 0.1–0.5 s.
    fn sticks(n: usize, seed: u64) -> Vec<f64> {
        let r = noise(n, seed);
        let mut out = Vec::with_capacity(n);
        let (mut level, mut next) = (0.0, 0);
        for i in 0..n {
            if i >= next {
                level = 100.0 * r[i];
                next = i + 100 + (400.0 * r[(i + 1) % n].abs()) as usize;
            }
            out.push(level);
        }
        out
    }

    #[test]
    fn a_first_order_lag_rises_in_ln9_tau_without_overshoot() {
        let (fs, tau) = (1000.0, 0.02);
        let x = sticks(40_000, 11);
        let y: Vec<f64> = lag(&x, 1.0 / fs, tau, 0)
            .iter()
            .zip(noise(40_000, 12))
            .map(|(y, v)| y + 2.0 * v)
            .collect();
        let s = step_response(&x, &y, fs, 2048, 0.5, 20.0).unwrap();
        let rise = tau * 9f64.ln();
        assert!(
            (s.rise_s.unwrap() - rise).abs() < 0.1 * rise,
            "{:?} {rise}",
            s.rise_s
        );
        assert!((s.final_value - 1.0).abs() < 0.05, "{}", s.final_value);
        assert!(s.overshoot_pct < 3.0, "{}", s.overshoot_pct);
        // ±5 %: ln 20 τ.
        let settle = tau * 20f64.ln();
        assert!(
            (s.settling_s.unwrap() - settle).abs() < 0.15 * settle,
            "{:?}",
            s.settling_s
        );
        assert!(s.windows > 30);
    }

    #[test]
    fn a_second_order_system_overshoots_as_its_damping_says() {
        // ωn = 2π·8 rad/s, ζ = 0.4: overshoot exp(−πζ/√(1−ζ²)) = 25.4 %.
        let (fs, wn, zeta) = (1000.0, 2.0 * std::f64::consts::PI * 8.0, 0.4);
        let x = sticks(60_000, 5);
        let dt = 1.0 / fs;
        let (mut p, mut v) = (0.0, 0.0);
        let y: Vec<f64> = x
            .iter()
            .map(|&u| {
                // Semi-implicit Euler at 1 ms (ωn·dt = 0.05: within 1 %).
                v += dt * (wn * wn * (u - p) - 2.0 * zeta * wn * v);
                p += dt * v;
                p
            })
            .collect();
        let s = step_response(&x, &y, fs, 2048, 0.5, 20.0).unwrap();
        let want = 100.0 * (-std::f64::consts::PI * zeta / (1.0 - zeta * zeta).sqrt()).exp();
        assert!(
            (s.overshoot_pct - want).abs() < 3.0,
            "{} {want}",
            s.overshoot_pct
        );
        assert!((s.final_value - 1.0).abs() < 0.05, "{}", s.final_value);
        // 10–90 % rise: where the analytic step
        // 1 − e^{−ζωn t} sin(ωd t + acos ζ) / √(1−ζ²) crosses 0.1 and 0.9.
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        let analytic = |t: f64| {
            1.0 - (-zeta * wn * t).exp() * (wd * t + zeta.acos()).sin() / (1.0 - zeta * zeta).sqrt()
        };
        let first = |level: f64| {
            (0..100_000)
                .map(|i| i as f64 * 1e-6)
                .find(|&t| analytic(t) >= level)
        };
        let want = first(0.9).unwrap() - first(0.1).unwrap();
        let r = s.rise_s.unwrap();
        assert!((r - want).abs() < 0.05 * want, "{r} {want}");
    }

    #[test]
    fn a_quiet_setpoint_gives_no_step() {
        let x = vec![0.0; 10_000];
        assert!(step_response(&x, &x, 1000.0, 2048, 0.5, 20.0).is_none());
        assert!(step_response(&x, &x[1..], 1000.0, 2048, 0.5, 20.0).is_none());
    }
}
