//! The flight loops' polynomial half-angle sine and cosine against the
//! f64 functions and libm's f32 ones, over the range the loops use (tilt
//! setpoints and headings, |a| ≤ 2π) and beyond.

use control::loops::half_angle_sin_cos;
use proptest::prelude::*;

/// Largest |error| against the f64 functions on a dense grid over ±`max`.
fn max_error(max: f32, steps: u32) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..=steps {
        let a = -max + 2.0 * max * i as f32 / steps as f32;
        let (s, c) = half_angle_sin_cos(a);
        let h = 0.5 * f64::from(a);
        worst = worst
            .max((f64::from(s) - h.sin()).abs())
            .max((f64::from(c) - h.cos()).abs());
    }
    worst
}

#[test]
fn within_2_5e7_over_plus_minus_two_pi() {
    let e = max_error(2.0 * core::f32::consts::PI, 200_000);
    assert!(e < 2.5e-7, "max error {e:e}");
}

#[test]
fn within_1e6_over_plus_minus_200_rad() {
    let e = max_error(200.0, 400_000);
    assert!(e < 1e-6, "max error {e:e}");
}

#[test]
fn cardinal_angles_within_the_stated_error() {
    use core::f32::consts::PI;
    assert_eq!(half_angle_sin_cos(0.0), (0.0, 1.0));
    let (s, c) = half_angle_sin_cos(PI);
    assert!((s - 1.0).abs() < 2.5e-7 && c.abs() < 2.5e-7, "{s} {c}");
    let (s, c) = half_angle_sin_cos(-PI);
    assert!((s + 1.0).abs() < 2.5e-7 && c.abs() < 2.5e-7, "{s} {c}");
    let (s, c) = half_angle_sin_cos(2.0 * PI);
    assert!(s.abs() < 2.5e-7 && (c + 1.0).abs() < 2.5e-7, "{s} {c}");
}

#[test]
fn nan_in_nan_out() {
    let (s, c) = half_angle_sin_cos(f32::NAN);
    assert!(s.is_nan() && c.is_nan());
}

proptest! {
    #[test]
    fn agrees_with_libm_within_the_loops_range(a in -6.3f32..6.3) {
        let (s, c) = half_angle_sin_cos(a);
        prop_assert!((s - libm::sinf(0.5 * a)).abs() < 3e-7);
        prop_assert!((c - libm::cosf(0.5 * a)).abs() < 3e-7);
        // Unit length: the rotation quaternions built from it stay unit.
        prop_assert!((s * s + c * c - 1.0).abs() < 5e-7);
    }
}
