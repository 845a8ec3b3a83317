//! Reproducible signals with a known response, for testing the analysis
//! (here and in the tools built on it).

/// A reproducible white noise (xorshift), uniform in −1..1.
pub fn noise(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed.max(1);
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 52) as f64 * 2.0 - 1.0
        })
        .collect()
}

/// `y` = a discrete first-order lag of `x` (time constant `tau_s`,
/// exact for a held input) delayed by `delay` samples.
pub fn lag(x: &[f64], dt_s: f64, tau_s: f64, delay: usize) -> Vec<f64> {
    let a = (-dt_s / tau_s).exp();
    let mut s = 0.0;
    let mut y = vec![0.0; x.len()];
    for i in 0..x.len() {
        y[i] = s;
        if i >= delay {
            s = a * s + (1.0 - a) * x[i - delay];
        }
    }
    y
}
