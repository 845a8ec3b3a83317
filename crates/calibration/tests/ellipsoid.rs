//! Full ellipsoid fit.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::needless_range_loop
)]
mod common;

use calibration::{EllipsoidFit, EllipsoidFitConfig, EllipsoidSolution, Error};
use common::*;

/// Feed `n` samples `offset + D·(R·h) + noise` with `h` from `dir`.
fn feed(
    fit: &mut EllipsoidFit,
    rng: &mut Rng,
    n: usize,
    offset: [f64; 3],
    d: &M3,
    noise: f64,
    mut dir: impl FnMut(&mut Rng) -> [f64; 3],
) {
    for _ in 0..n {
        let h = dir(rng);
        let mut m = add(offset, mul_v(d, scale(h, R_UT)));
        for c in &mut m {
            *c += noise * rng.gauss();
        }
        fit.push(to32(m)).unwrap();
    }
}

/// A general distortion: rotation · scale · rotation (not symmetric).
fn general_distortion() -> M3 {
    let r1 = rotation([1.0, 2.0, -0.5], 0.6);
    let r2 = rotation([-0.3, 0.4, 1.0], -0.9);
    mul(&r1, &mul(&diag([1.18, 0.86, 1.05]), &r2))
}

fn check_recovery(sol: &EllipsoidSolution, offset: [f64; 3], d: &M3, noise: f64, rng: &mut Rng) {
    let cal = &sol.calibration;
    cal.validate().unwrap();
    for (got, want) in cal.offset.iter().zip(offset) {
        assert!(
            (f64::from(*got) - want).abs() < 0.15,
            "offset {:?} vs {offset:?}",
            cal.offset
        );
    }
    // W·D must be a scaled rotation: (WD)ᵀ(WD) = ρ² I.
    let wd = mul(&m3_from32(&cal.soft_iron), d);
    let g = mul(&transpose(&wd), &wd);
    let rho2 = (g[0][0] + g[1][1] + g[2][2]) / 3.0;
    for (i, row) in g.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            let want = if i == j { rho2 } else { 0.0 };
            assert!((v - want).abs() < 0.005 * rho2, "WD not orthogonal: {g:?}");
        }
    }
    // The corrected field is a sphere of the reported radius (noise-free check points).
    for _ in 0..500 {
        let m = add(offset, mul_v(d, scale(rng.unit(), R_UT)));
        let c = cal.apply(to32(m));
        let rel = norm32(c) / f64::from(sol.radius) - 1.0;
        assert!(rel.abs() < 0.01, "corrected magnitude off by {rel}");
    }
    // The radius is the mean semi-axis of the raw ellipsoid (R × singular values of D).
    let mean_axis = R_UT * (1.18 + 0.86 + 1.05) / 3.0;
    if noise > 0.0 {
        assert!((f64::from(sol.radius) / mean_axis - 1.0).abs() < 0.01);
        // The quality figure tracks the injected noise: ≈ σ/R.
        let expect = noise / mean_axis;
        let got = f64::from(sol.rms_error);
        assert!(
            got > 0.5 * expect && got < 2.0 * expect,
            "rms {got}, noise/R {expect}"
        );
    }
}

#[test]
fn recovers_hard_iron_and_full_soft_iron_from_noisy_sphere() {
    let mut rng = Rng::new(21);
    let offset = [25.0, -40.0, 15.0];
    let d = general_distortion();
    let noise = 0.25;
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    feed(&mut fit, &mut rng, 1500, offset, &d, noise, Rng::unit);
    let sol = fit.finish().unwrap();
    assert_eq!(sol.bins_hit, 14);
    assert_eq!(sol.samples, 1500);
    let mut sorted = [1.18 * R_UT, 0.86 * R_UT, 1.05 * R_UT];
    sorted.sort_by(f64::total_cmp);
    for (got, want) in sol.semi_axes.iter().zip(sorted) {
        assert!(
            (f64::from(*got) / want - 1.0).abs() < 0.01,
            "{:?}",
            sol.semi_axes
        );
    }
    check_recovery(&sol, offset, &d, noise, &mut rng);
}

#[test]
fn symmetric_distortion_is_inverted_exactly_up_to_scale() {
    // For a symmetric positive-definite distortion the symmetric square root
    // is its inverse (times the radius ratio): W·D = ρI.
    let mut rng = Rng::new(22);
    let r = rotation([0.2, -1.0, 0.7], 0.8);
    let d = mul(&r, &mul(&diag([1.18, 0.86, 1.05]), &transpose(&r)));
    let offset = [-12.0, 33.0, -55.0];
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    feed(&mut fit, &mut rng, 1200, offset, &d, 0.1, Rng::unit);
    let sol = fit.finish().unwrap();
    let wd = mul(&m3_from32(&sol.calibration.soft_iron), &d);
    let rho = (wd[0][0] + wd[1][1] + wd[2][2]) / 3.0;
    for (i, row) in wd.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            let want = if i == j { rho } else { 0.0 };
            assert!((v - want).abs() < 0.005, "W·D = {wd:?}");
        }
    }
    check_recovery(&sol, offset, &d, 0.1, &mut rng);
}

#[test]
fn large_hard_iron_offset_and_raw_count_units_are_fine() {
    // Offset of 6 field radii, in raw-count-like magnitudes: conditioning test.
    let mut rng = Rng::new(23);
    let d = general_distortion();
    let offset = [290.0, -180.0, 310.0];
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    feed(&mut fit, &mut rng, 1000, offset, &d, 0.2, Rng::unit);
    let sol = fit.finish().unwrap();
    check_recovery(&sol, offset, &d, 0.2, &mut rng);
}

#[test]
fn noise_free_data_give_a_near_zero_quality_figure() {
    let mut rng = Rng::new(24);
    let d = general_distortion();
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    feed(
        &mut fit,
        &mut rng,
        800,
        [5.0, 6.0, -7.0],
        &d,
        0.0,
        Rng::unit,
    );
    let sol = fit.finish().unwrap();
    assert!(sol.rms_error < 1e-3, "{}", sol.rms_error);
    check_recovery(&sol, [5.0, 6.0, -7.0], &d, 0.0, &mut rng);
}

#[test]
fn systematic_sweep_order_does_not_matter() {
    // Latitude bands from the south pole up: coverage is judged at the end.
    let d = general_distortion();
    let offset = [10.0, 20.0, 30.0];
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    let mut rng = Rng::new(25);
    let mut band = 0.0f64;
    feed(&mut fit, &mut rng, 1000, offset, &d, 0.1, |_| {
        band += 1.0;
        let z: f64 = -0.98 + 1.96 * band / 1000.0;
        let phi = band * 0.7;
        let r = (1.0 - z * z).sqrt();
        [r * f64::cos(phi), r * f64::sin(phi), z]
    });
    let sol = fit.finish().unwrap();
    check_recovery(&sol, offset, &d, 0.1, &mut rng);
}

#[test]
fn single_plane_is_refused_as_insufficient_coverage() {
    let mut rng = Rng::new(26);
    // A great circle in a tilted plane: every axis still has a wide range.
    let n = [1.0, 1.0, 1.0];
    let e1 = [1.0 / 2f64.sqrt(), -1.0 / 2f64.sqrt(), 0.0];
    let e2 = [1.0 / 6f64.sqrt(), 1.0 / 6f64.sqrt(), -2.0 / 6f64.sqrt()];
    let _ = n;
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    let id = diag([1.0, 1.0, 1.0]);
    feed(&mut fit, &mut rng, 1000, [3.0, 4.0, 5.0], &id, 0.2, |r| {
        let t = 2.0 * core::f64::consts::PI * r.uniform();
        add(scale(e1, t.cos()), scale(e2, t.sin()))
    });
    assert!(fit.ranges().iter().all(|&r| r > 60.0));
    match fit.finish() {
        Err(Error::InsufficientCoverage {
            bins_hit,
            bins_needed,
        }) => {
            assert!(bins_hit <= 6, "{bins_hit}");
            assert_eq!(bins_needed, 12);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn small_cap_and_hemisphere_are_refused() {
    let id = diag([1.0, 1.0, 1.0]);
    // Directions within 40° of +x (relaxed range so coverage is what fails).
    let config = EllipsoidFitConfig {
        min_range: 5.0,
        ..EllipsoidFitConfig::MICROTESLA
    };
    let mut rng = Rng::new(27);
    let mut fit = EllipsoidFit::new(config).unwrap();
    let cos_cap = 40f64.to_radians().cos();
    feed(&mut fit, &mut rng, 1000, [0.0; 3], &id, 0.1, |r| loop {
        let u = r.unit();
        if u[0] >= cos_cap {
            return u;
        }
    });
    assert!(
        matches!(fit.finish(), Err(Error::InsufficientCoverage { bins_hit, .. }) if bins_hit <= 3),
        "{:?}",
        fit.finish()
    );
    // Upper hemisphere only (the board was never turned over).
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    feed(&mut fit, &mut rng, 1000, [0.0; 3], &id, 0.1, |r| {
        let u = r.unit();
        [u[0], u[1], u[2].abs()]
    });
    assert!(
        matches!(fit.finish(), Err(Error::InsufficientCoverage { bins_hit, .. }) if bins_hit <= 10),
        "{:?}",
        fit.finish()
    );
}

#[test]
fn stationary_noise_is_refused() {
    let mut rng = Rng::new(28);
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    feed(
        &mut fit,
        &mut rng,
        500,
        [20.0, -3.0, 40.0],
        &diag([0.0; 3]),
        0.3,
        Rng::unit,
    );
    assert!(matches!(fit.finish(), Err(Error::RangeTooSmall { .. })));
}

#[test]
fn too_few_samples_refused() {
    let mut rng = Rng::new(29);
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    feed(
        &mut fit,
        &mut rng,
        100,
        [0.0; 3],
        &general_distortion(),
        0.1,
        Rng::unit,
    );
    assert_eq!(
        fit.finish(),
        Err(Error::TooFewSamples {
            have: 100,
            need: 300
        })
    );
}

#[test]
fn bad_samples_are_skipped_and_leave_the_fit_unchanged() {
    let d = general_distortion();
    let mut clean = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    let mut dirty = clean;
    let mut rng = Rng::new(30);
    for i in 0..600 {
        let m = to32(add([1.0, 2.0, 3.0], mul_v(&d, scale(rng.unit(), R_UT))));
        clean.push(m).unwrap();
        if i % 7 == 0 {
            assert_eq!(dirty.push([f32::NAN, m[1], m[2]]), Err(Error::NonFinite));
            assert_eq!(
                dirty.push([m[0], f32::INFINITY, m[2]]),
                Err(Error::NonFinite)
            );
            assert_eq!(
                dirty.push([m[0], m[1], 3.0e30]),
                Err(Error::InputOutOfRange)
            );
        }
        dirty.push(m).unwrap();
    }
    assert_eq!(dirty.count(), 600);
    assert_eq!(dirty.rejected(), 3 * 86);
    assert_eq!(clean.finish().unwrap(), dirty.finish().unwrap());
}

#[test]
fn reset_forgets_everything() {
    let mut rng = Rng::new(31);
    let mut fit = EllipsoidFit::new(EllipsoidFitConfig::MICROTESLA).unwrap();
    feed(
        &mut fit,
        &mut rng,
        400,
        [9.0, 9.0, 9.0],
        &diag([2.0, 0.1, 1.0]),
        0.1,
        Rng::unit,
    );
    fit.reset();
    assert_eq!(fit.count(), 0);
    assert_eq!(fit.bins_hit(), 0);
    let d = general_distortion();
    feed(&mut fit, &mut rng, 800, [1.0, 1.0, 1.0], &d, 0.1, Rng::unit);
    let sol = fit.finish().unwrap();
    check_recovery(&sol, [1.0, 1.0, 1.0], &d, 0.1, &mut rng);
}
