//! The `f32` square root the calibration code uses: `libm::sqrtf`,
//! correctly rounded (IEEE 754 round-to-nearest).
//!
//! The firmware links `libm::sqrtf` anyway (the flight controller's level
//! loop runs it at 1 kHz, where its table-driven Goldschmidt iterations
//! pay for their 0.5 KiB), so a second, compact digit-by-digit root here
//! would only add its own 224 B of flash beside it.

pub(crate) use libm::sqrtf;

#[cfg(test)]
mod tests {
    use super::sqrtf;
    use proptest::prelude::*;

    fn same(a: f32, b: f32) -> bool {
        (a.is_nan() && b.is_nan()) || a.to_bits() == b.to_bits()
    }

    #[test]
    fn special_values_follow_ieee() {
        for x in [
            0.0f32,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -1.0,
            -f32::MIN_POSITIVE,
        ] {
            let want = if x.is_nan() || x < 0.0 { f32::NAN } else { x };
            assert!(same(sqrtf(x), want), "x = {x:e}");
        }
    }

    #[test]
    fn worked_values_are_exact() {
        assert_eq!(sqrtf(4.0), 2.0);
        assert_eq!(sqrtf(0.25), 0.5);
        assert_eq!(sqrtf(2.0), core::f32::consts::SQRT_2);
        // The smallest subnormal, 2^-149: its root 2^-74.5 = 2^-75 * sqrt(2)
        // is normal, so it rounds like sqrt(2) scaled by a power of two.
        assert_eq!(
            sqrtf(f32::from_bits(1)),
            2f32.powi(-75) * core::f32::consts::SQRT_2
        );
    }

    proptest! {
        #[test]
        fn squares_round_trip(r in 1.0e-18f32..1.0e18) {
            // r² rounded then rooted is within one ulp of r.
            let s = sqrtf(r * r);
            prop_assert!((s - r).abs() <= r * 2.0 * f32::EPSILON, "r = {:e}, s = {:e}", r, s);
        }
    }
}
