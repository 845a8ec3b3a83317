//! Incremental per-axis statistics without storing samples.

/// Per-axis count, mean, variance and min/max of a stream of 3-vectors.
///
/// Sums are taken of deviations from the first sample ("shifted data"), so
/// the variance does not suffer the catastrophic cancellation of the naive
/// `Σx² − (Σx)²/n` when the mean is large compared with the spread, and no
/// division is needed per sample.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stats3 {
    n: u32,
    reference: [f32; 3],
    sum: [f32; 3],
    sum_sq: [f32; 3],
    min: [f32; 3],
    max: [f32; 3],
}

impl Stats3 {
    pub(crate) const fn new() -> Self {
        Self {
            n: 0,
            reference: [0.0; 3],
            sum: [0.0; 3],
            sum_sq: [0.0; 3],
            min: [0.0; 3],
            max: [0.0; 3],
        }
    }

    /// Add one (already validated, finite, bounded) sample.
    pub(crate) fn push(&mut self, v: [f32; 3]) {
        if self.n == 0 {
            self.reference = v;
            self.min = v;
            self.max = v;
        }
        for ((((&x, &r), s), q), (lo, hi)) in v
            .iter()
            .zip(&self.reference)
            .zip(&mut self.sum)
            .zip(&mut self.sum_sq)
            .zip(self.min.iter_mut().zip(&mut self.max))
        {
            let d = x - r;
            *s += d;
            *q += d * d;
            if x < *lo {
                *lo = x;
            }
            if x > *hi {
                *hi = x;
            }
        }
        self.n = self.n.saturating_add(1);
    }

    pub(crate) fn count(&self) -> u32 {
        self.n
    }

    /// Per-axis mean (zero vector when empty).
    pub(crate) fn mean(&self) -> [f32; 3] {
        if self.n == 0 {
            return [0.0; 3];
        }
        let inv_n = 1.0 / self.n as f32;
        let mut m = self.reference;
        for (mi, s) in m.iter_mut().zip(&self.sum) {
            *mi += s * inv_n;
        }
        m
    }

    /// Per-axis population variance (zero when empty).
    pub(crate) fn variance(&self) -> [f32; 3] {
        if self.n == 0 {
            return [0.0; 3];
        }
        let inv_n = 1.0 / self.n as f32;
        let mut var = [0.0; 3];
        for ((v, s), q) in var.iter_mut().zip(&self.sum).zip(&self.sum_sq) {
            let mean_d = s * inv_n;
            let x = q * inv_n - mean_d * mean_d;
            *v = if x > 0.0 { x } else { 0.0 };
        }
        var
    }

    /// Per-axis max − min.
    pub(crate) fn spread(&self) -> [f32; 3] {
        let mut r = [0.0; 3];
        for ((ri, lo), hi) in r.iter_mut().zip(&self.min).zip(&self.max) {
            *ri = hi - lo;
        }
        r
    }

    /// First axis whose spread exceeds `limit`: `(axis, spread)`.
    pub(crate) fn spread_exceeding(&self, limit: f32) -> Option<(u8, f32)> {
        first_exceeding(self.spread(), limit)
    }

    /// First axis whose standard deviation exceeds `limit`: `(axis, std)`.
    pub(crate) fn std_exceeding(&self, limit: f32) -> Option<(u8, f32)> {
        let var = self.variance();
        let lim2 = limit * limit;
        let mut axis = 0u8;
        for v in var {
            if v > lim2 {
                return Some((axis, crate::sqrt::sqrtf(v)));
            }
            axis = axis.saturating_add(1);
        }
        None
    }
}

/// First index whose value exceeds `limit`.
pub(crate) fn first_exceeding(values: [f32; 3], limit: f32) -> Option<(u8, f32)> {
    let mut axis = 0u8;
    for v in values {
        if v > limit {
            return Some((axis, v));
        }
        axis = axis.saturating_add(1);
    }
    None
}
