//! A compact, correctly rounded `f32` square root.
//!
//! `libm::sqrtf` brings a 256-byte reciprocal-square-root table and
//! Goldschmidt iterations (about 0.45 KiB of flash) to a Cortex-M3, which
//! has no FPU; the calibration code needs a handful of square roots per
//! fit, not speed. This digit-by-digit integer root is about a quarter of
//! that size and returns the same, correctly rounded, result (IEEE 754
//! round-to-nearest: the tests compare it with `libm::sqrtf` bit for bit).

/// `√x`, correctly rounded; `NaN` for `x < 0` or `NaN`, `x` for `±0` and
/// `+∞`.
#[inline(never)]
pub(crate) fn sqrtf(x: f32) -> f32 {
    if x.is_nan() || x < 0.0 {
        return f32::NAN;
    }
    if x == 0.0 || x == f32::INFINITY {
        return x;
    }
    let bits = x.to_bits();
    let biased = (bits >> 23) as i32;
    // Mantissa with its implicit bit: x = m · 2^(exp − 23), 2^23 ≤ m < 2^24.
    let (mut m, mut exp) = if biased == 0 {
        let frac = bits & 0x7f_ffff;
        let shift = frac.leading_zeros() - 8;
        (frac << shift, -126 - shift as i32)
    } else {
        ((bits & 0x7f_ffff) | 0x80_0000, biased - 127)
    };
    // An even exponent halves exactly; the odd one moves into m.
    if exp & 1 != 0 {
        m <<= 1;
        exp -= 1;
    }
    // √x = √(m · 2^23) · 2^(exp/2 − 23); the root has 24 bits because
    // 2^46 ≤ m · 2^23 < 2^48.
    let mut rem = u64::from(m) << 23;
    let mut root: u64 = 0;
    let mut bit: u64 = 1 << 46;
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    // Round to nearest: the exact root exceeds root + ½ iff rem > root
    // (an integer's root is never a half-integer, so there are no ties).
    let round = u64::from(rem > root);
    // root carries the implicit bit (2^23), which adds one to the exponent
    // field; a carry out of the mantissa moves into the exponent, as wanted.
    let biased_out = (exp / 2 + 127 - 1) as u32;
    f32::from_bits((biased_out << 23) + (root + round) as u32)
}

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
            assert!(same(sqrtf(x), libm::sqrtf(x)), "x = {x:e}");
        }
    }

    #[test]
    fn worked_values_are_exact() {
        assert_eq!(sqrtf(4.0), 2.0);
        assert_eq!(sqrtf(0.25), 0.5);
        assert_eq!(sqrtf(2.0), core::f32::consts::SQRT_2);
        assert_eq!(sqrtf(f32::MAX), libm::sqrtf(f32::MAX));
        assert_eq!(sqrtf(f32::from_bits(1)), libm::sqrtf(f32::from_bits(1)));
    }

    #[test]
    fn matches_libm_across_binades_and_subnormals() {
        // Every 4099th bit pattern of the positive finite floats (both
        // exponent parities, subnormals, mantissa edges).
        let mut b: u32 = 1;
        while b < 0x7f80_0000 {
            let x = f32::from_bits(b);
            assert!(same(sqrtf(x), libm::sqrtf(x)), "x = {x:e} ({b:#x})");
            b += 4099;
        }
    }

    proptest! {
        #[test]
        fn matches_libm_bit_for_bit(bits in any::<u32>()) {
            let x = f32::from_bits(bits);
            prop_assert!(same(sqrtf(x), libm::sqrtf(x)), "x = {:e}", x);
        }

        #[test]
        fn squares_round_trip(r in 1.0e-18f32..1.0e18) {
            // r² rounded then rooted is within one ulp of r.
            let s = sqrtf(r * r);
            prop_assert!((s - r).abs() <= r * 2.0 * f32::EPSILON, "r = {:e}, s = {:e}", r, s);
        }
    }
}
