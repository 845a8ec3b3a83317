//! The filters against their analytic responses and the fixed-point forms
//! against the f32 ones.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use core::f32::consts::{FRAC_1_SQRT_2, PI};
use filters::{Biquad, BiquadCoeffs, BiquadQ, FilterError, Pt1, Pt1Q};
use proptest::prelude::*;

const FS: f32 = 1000.0;
/// 1.0 in the flight stack's Q16 gyro.
const ONE_Q16: f32 = 65536.0;

/// Amplitude and phase (rad) of `run`'s steady response to a unit sine at
/// `f_hz`: 3 s of it, the last 2 s correlated with sine and cosine.
fn measure(f_hz: f32, mut run: impl FnMut(f32) -> f32) -> (f32, f32) {
    let n = (3.0 * FS) as usize;
    let (mut s, mut c) = (0.0f64, 0.0f64);
    let mut count = 0;
    for i in 0..n {
        let ph = 2.0 * PI * f_hz * i as f32 / FS;
        let y = run(libm::sinf(ph));
        if i >= n / 3 {
            s += f64::from(y) * f64::from(libm::sinf(ph));
            c += f64::from(y) * f64::from(libm::cosf(ph));
            count += 1;
        }
    }
    let (s, c) = (2.0 * s / count as f64, 2.0 * c / count as f64);
    (libm::sqrt(s * s + c * c) as f32, libm::atan2(c, s) as f32)
}

fn designs() -> Vec<(&'static str, BiquadCoeffs)> {
    vec![
        (
            "low-pass 100 Hz",
            BiquadCoeffs::low_pass(100.0, FRAC_1_SQRT_2, FS).unwrap(),
        ),
        (
            "low-pass 250 Hz",
            BiquadCoeffs::low_pass(250.0, FRAC_1_SQRT_2, FS).unwrap(),
        ),
        (
            "notch 150 Hz Q 3",
            BiquadCoeffs::notch(150.0, 3.0, FS).unwrap(),
        ),
        (
            "notch 300 Hz Q 5",
            BiquadCoeffs::notch(300.0, 5.0, FS).unwrap(),
        ),
    ]
}

#[test]
fn the_pt1_step_response_is_the_geometric_series() {
    let mut f = Pt1::new(50.0, FS).unwrap();
    let k = f.gain();
    // k = dt/(RC + dt) with RC = 1/(2π·50 Hz).
    let rc = 1.0 / (2.0 * PI * 50.0);
    assert!((k - 0.001 / (rc + 0.001)).abs() < 1e-7);
    for n in 1..=50 {
        let y = f.apply(1.0);
        let want = 1.0 - libm::powf(1.0 - k, n as f32);
        assert!((y - want).abs() < 1e-5, "step {n}: {y} vs {want}");
    }
}

#[test]
fn the_low_pass_is_minus_3_db_at_its_cut_off_and_passes_dc() {
    for fc in [50.0, 100.0, 200.0, 400.0] {
        let c = BiquadCoeffs::low_pass(fc, FRAC_1_SQRT_2, FS).unwrap();
        let at = |f: f32| c.response(f, FS);
        assert!((at(1e-3).gain - 1.0).abs() < 1e-5, "{fc}: DC");
        // The bilinear transform with pre-warping puts −3 dB exactly at fc.
        assert!(
            (at(fc).gain_db() + 3.0103).abs() < 0.01,
            "{fc}: {}",
            at(fc).gain_db()
        );
        // A zero pair at Nyquist.
        assert!(at(0.4999 * FS).gain < 1e-3, "{fc}: Nyquist");
    }
}

/// The bilinear transform prewarped at `f0_hz`: the analog prototype's
/// angular frequency (normalised to 1 at f0) for a digital `f_hz`, and its
/// derivative by the digital angular frequency (s).
fn warp(f0_hz: f32, f_hz: f32) -> (f32, f32) {
    let t = 1.0 / FS;
    let k = 1.0 / libm::tanf(PI * f0_hz * t);
    let half = PI * f_hz * t;
    let cos = libm::cosf(half);
    (k * libm::tanf(half), k * 0.5 * t / (cos * cos))
}

#[test]
fn the_low_pass_delay_is_the_butterworths_through_the_bilinear_transform() {
    // The analog second-order Butterworth, normalised to ω_c = 1, delays by
    // √2·(1 + Ω²)/(1 + Ω⁴); the digital filter is it at the warped Ω, so its
    // delay is that times dΩ/dω.
    for fc in [80.0f32, 100.0, 150.0, 250.0] {
        for f in [10.0f32, 50.0, 120.0] {
            let (w, dw) = warp(fc, f);
            let analog = 2f32.sqrt() * (1.0 + w * w) / (1.0 + w.powi(4)) * dw;
            let d = BiquadCoeffs::low_pass(fc, FRAC_1_SQRT_2, FS)
                .unwrap()
                .response(f, FS)
                .group_delay_s;
            assert!(
                (d - analog).abs() < 0.01 * analog,
                "{fc} Hz at {f} Hz: {d} s vs {analog} s"
            );
        }
    }
}

#[test]
fn the_notch_removes_its_centre_and_has_its_prototypes_width() {
    for (f0, q) in [(150.0f32, 3.0f32), (200.0, 2.0), (300.0, 5.0)] {
        let c = BiquadCoeffs::notch(f0, q, FS).unwrap();
        let g = |f: f32| c.response(f, FS).gain;
        assert!(g(f0) < 1e-4, "{f0}: {}", g(f0));
        assert!((g(1e-3) - 1.0).abs() < 1e-5);
        // The −3 dB points either side, by bisection on the monotonic flanks.
        let edge = |mut lo: f32, mut hi: f32, rising: bool| {
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if (g(mid) > FRAC_1_SQRT_2) == rising {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let below = edge(1.0, f0, false);
        let above = edge(f0, 0.499 * FS, true);
        // The prototype (s² + 1)/(s² + s/Q + 1) is −3 dB at Ω with
        // Ω_hi − Ω_lo = 1/Q and Ω_lo·Ω_hi = 1; the digital edges are those
        // through the bilinear transform prewarped at f0.
        let root = libm::sqrtf(1.0 / (q * q) + 4.0);
        let digital =
            |big_w: f32| 2.0 * libm::atanf(big_w * libm::tanf(PI * f0 / FS)) * FS / (2.0 * PI);
        let (want_lo, want_hi) = (
            digital(0.5 * (root - 1.0 / q)),
            digital(0.5 * (root + 1.0 / q)),
        );
        assert!(
            (below - want_lo).abs() < 0.5 && (above - want_hi).abs() < 0.5,
            "{f0}/{q}: {below}–{above} Hz vs {want_lo}–{want_hi} Hz"
        );
    }
}

#[test]
fn the_implementations_follow_their_analytic_response() {
    for (name, c) in designs() {
        for f in [5.0, 30.0, 50.0, 100.0, 150.0, 220.0, 300.0, 400.0] {
            let r = c.response(f, FS);
            let mut fl = Biquad::new(&c);
            let (g, p) = measure(f, |x| fl.apply(x));
            let mut fq = BiquadQ::new(&c);
            let (gq, pq) = measure(f, |x| fq.apply((x * ONE_Q16) as i32) as f32 / ONE_Q16);
            let wrap = |d: f32| libm::atan2f(libm::sinf(d), libm::cosf(d)).abs();
            for (impl_name, gain, phase) in [("f32", g, p), ("fixed", gq, pq)] {
                assert!(
                    (gain - r.gain).abs() < 2e-3,
                    "{name} {impl_name} at {f} Hz: {gain} vs {}",
                    r.gain
                );
                if r.gain > 0.05 {
                    assert!(
                        wrap(phase - r.phase_rad) < 0.01,
                        "{name} {impl_name} at {f} Hz: {phase} vs {}",
                        r.phase_rad
                    );
                }
            }
        }
    }
    let p = Pt1::new(100.0, FS).unwrap();
    for f in [5.0, 50.0, 100.0, 300.0] {
        let r = p.response(f, FS);
        let (mut a, mut b) = (p, Pt1Q::new(&p));
        let (g, _) = measure(f, |x| a.apply(x));
        let (gq, _) = measure(f, |x| b.apply((x * ONE_Q16) as i32) as f32 / ONE_Q16);
        assert!(
            (g - r.gain).abs() < 2e-3 && (gq - r.gain).abs() < 2e-3,
            "PT1 at {f} Hz"
        );
    }
}

/// Σ|h| of 1/A(z), the feedback part's impulse response: how far one unit of
/// rounding in the output can spread.
fn feedback_l1(c: &BiquadCoeffs) -> f32 {
    let (_, [a1, a2]) = c.taps();
    let (mut y1, mut y2, mut sum) = (0.0f32, 0.0f32, 0.0f32);
    for n in 0..10_000 {
        let y = if n == 0 { 1.0 } else { 0.0 } - a1 * y1 - a2 * y2;
        sum += y.abs();
        (y2, y1) = (y1, y);
    }
    sum
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]
    /// Any gyro signal within ±30 rad/s in Q16: the fixed form stays within
    /// its rounding bound of the f32 one (up to 1 LSB a step, truncated,
    /// spread by 1/A; the taps' Q29 rounding adds well under one LSB at these
    /// amplitudes).
    #[test]
    fn fixed_point_stays_within_its_rounding_bound(
        xs in proptest::collection::vec(-30.0f32..30.0, 1..400),
        which in 0usize..4,
    ) {
        let (_, c) = designs()[which];
        let bound = feedback_l1(&c) + 2.0;
        let (mut f, mut q) = (Biquad::new(&c), BiquadQ::new(&c));
        for x in xs {
            let xq = libm::roundf(x * ONE_Q16) as i32;
            let y = f.apply(xq as f32 / ONE_Q16) * ONE_Q16;
            let yq = q.apply(xq) as f32;
            // The f32 reference's own rounding: ~1e-7 of the signal's size.
            prop_assert!((yq - y).abs() <= bound + 1e-6 * y.abs(), "{yq} vs {y} (bound {bound})");
        }
    }
}

#[test]
fn designs_out_of_range_are_refused() {
    assert_eq!(Pt1::new(0.0, FS), Err(FilterError::Frequency));
    assert_eq!(Pt1::new(500.0, FS), Err(FilterError::Frequency));
    assert_eq!(Pt1::new(50.0, f32::NAN), Err(FilterError::SampleRate));
    assert_eq!(
        BiquadCoeffs::low_pass(100.0, 0.0, FS),
        Err(FilterError::Quality)
    );
    assert_eq!(
        BiquadCoeffs::notch(f32::NAN, 3.0, FS),
        Err(FilterError::Frequency)
    );
    assert_eq!(
        BiquadCoeffs::notch(100.0, 60.0, FS),
        Err(FilterError::Quality)
    );
}

/// A design fixed at build time: the whole design runs in const evaluation.
const LOW_20: BiquadCoeffs = match BiquadCoeffs::low_pass(20.0, FRAC_1_SQRT_2, FS) {
    Ok(c) => c,
    Err(_) => panic!("20 Hz at 1 kHz is in range"),
};

#[test]
fn the_const_design_is_the_runtime_design() {
    let runtime = BiquadCoeffs::low_pass(core::hint::black_box(20.0), FRAC_1_SQRT_2, FS).unwrap();
    assert_eq!(LOW_20, runtime);
    // −3 dB at 20 Hz, from the taps the const evaluation made.
    let g = LOW_20.response(20.0, FS).gain;
    assert!((g - FRAC_1_SQRT_2).abs() < 1e-3, "{g}");
}

#[test]
fn a_held_input_comes_through_exactly_even_at_a_low_cut_off() {
    // Without error feedback the 20 Hz section stalls 1/(1 + a₁ + a₂) ≈ 69
    // LSB short of a held input; with it the output reaches the input.
    for x in [1 << 16, -(3 << 16), 12_345, -1] {
        let mut q = BiquadQ::new(&LOW_20);
        let mut y = 0;
        for _ in 0..3000 {
            y = q.apply(x);
        }
        assert_eq!(y, x);
    }
}

#[test]
fn the_pt1_section_is_the_pt1() {
    let c = BiquadCoeffs::pt1(80.0, FS).unwrap();
    let p = Pt1::new(80.0, FS).unwrap();
    let (mut fc, mut fp) = (Biquad::new(&c), p);
    for i in 0..500 {
        let x = libm::sinf(i as f32 * 0.37) + if i > 100 { 1.0 } else { 0.0 };
        assert!((fc.apply(x) - fp.apply(x)).abs() < 1e-6);
    }
    for f in [1.0, 50.0, 200.0] {
        let (a, b) = (c.response(f, FS), p.response(f, FS));
        assert!((a.gain - b.gain).abs() < 1e-6 && (a.group_delay_s - b.group_delay_s).abs() < 1e-9);
    }
    assert_eq!(BiquadCoeffs::pt1(0.0, FS), Err(FilterError::Frequency));
}

#[test]
fn pass_is_the_identity_and_settle_starts_without_a_transient() {
    let mut q = BiquadQ::new(&BiquadCoeffs::PASS);
    for x in [0, 1, -7, i32::MAX, i32::MIN, 65_536] {
        assert_eq!(q.apply(x), x);
    }
    let mut lp = BiquadQ::new(&LOW_20);
    lp.settle(40_000);
    assert_eq!(lp.apply(40_000), 40_000);
    let mut n = BiquadQ::new(&BiquadCoeffs::notch(150.0, 3.0, FS).unwrap());
    n.settle(-40_000);
    assert!((n.apply(-40_000) + 40_000).abs() <= 1);
}

#[test]
fn the_fixed_pt1_reaches_a_held_input_exactly() {
    // Truncation alone would stall 1/k − 1 LSB short (k ≈ 0.06 at 10 Hz:
    // 15 LSB); the carried remainder gets there.
    let mut q = Pt1Q::new(&Pt1::new(10.0, FS).unwrap());
    for x in [1 << 16, 77, -(5 << 16), -3] {
        let mut y = 0;
        for _ in 0..5000 {
            y = q.apply(x);
        }
        assert_eq!(y, x);
    }
}
