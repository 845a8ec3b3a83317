//! A discrete transfer function's frequency response, evaluated exactly
//! (in f64, construction-time and host use; nothing on the per-sample path).

/// Gain, phase and delay of a filter at one frequency.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Response {
    /// |H(e^jω)| (1 = unity).
    pub gain: f32,
    /// arg H(e^jω) (rad, negative: lag), within (−π, π].
    pub phase_rad: f32,
    /// Group delay −dφ/dω (s): how late a narrow-band signal around this
    /// frequency comes out.
    pub group_delay_s: f32,
}

impl Response {
    /// Gain in dB.
    #[must_use]
    pub fn gain_db(&self) -> f32 {
        20.0 * libm::log10f(self.gain)
    }

    /// H(z) = (b₀ + b₁z⁻¹ + b₂z⁻²)/(a₀ + a₁z⁻¹ + a₂z⁻²) at `f_hz` for
    /// `sample_hz`; the group delay from the phase 0.1 % of the frequency
    /// either side (the phase unwrapped across them).
    #[must_use]
    pub fn of_ratio(b: [f64; 3], a: [f64; 3], f_hz: f32, sample_hz: f32) -> Self {
        let w = 2.0 * core::f64::consts::PI * f64::from(f_hz) / f64::from(sample_hz);
        let (g, p) = eval(b, a, w);
        let dw = (w * 1e-3).max(1e-9);
        let (_, p_lo) = eval(b, a, w - dw);
        let (_, p_hi) = eval(b, a, w + dw);
        let mut dp = p_hi - p_lo;
        if dp > core::f64::consts::PI {
            dp -= 2.0 * core::f64::consts::PI;
        } else if dp < -core::f64::consts::PI {
            dp += 2.0 * core::f64::consts::PI;
        }
        Self {
            gain: g as f32,
            phase_rad: p as f32,
            group_delay_s: (-dp / (2.0 * dw) / f64::from(sample_hz)) as f32,
        }
    }
}

/// (|H|, arg H) of the ratio at normalised angular frequency `w` (rad/sample).
fn eval(b: [f64; 3], a: [f64; 3], w: f64) -> (f64, f64) {
    let poly = |c: [f64; 3]| {
        let re = c[0] + c[1] * libm::cos(w) + c[2] * libm::cos(2.0 * w);
        let im = -c[1] * libm::sin(w) - c[2] * libm::sin(2.0 * w);
        (re, im)
    };
    let (nr, ni) = poly(b);
    let (dr, di) = poly(a);
    let den = dr * dr + di * di;
    if den == 0.0 {
        return (f64::INFINITY, 0.0);
    }
    // N/D = N·conj(D)/|D|².
    let re = (nr * dr + ni * di) / den;
    let im = (ni * dr - nr * di) / den;
    (libm::sqrt(re * re + im * im), libm::atan2(im, re))
}
