//! Vertical estimator on simulated flights with MS5611 and MPU-9250 noise.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::{accel_sigma_mps2, baro_reading_pa, rms, Rng};
use control::baro::CheapBaro;
use control::vertical::{BaroOutcome, Config, VerticalEstimator};
use control::Error;

const P0_PA: f64 = 100_500.0;
const IMU_HZ: usize = 1000;
const BARO_DIV: usize = 10; // 100 Hz

/// Truth: height, speed, acceleration (up, m, m/s, m/s²) at time `t`.
type Profile = fn(f64) -> (f64, f64, f64);

/// Extra baro error (m, added to the true height) at time `t` — for glitch tests.
type BaroFault<'a> = &'a mut dyn FnMut(f64, &mut Rng) -> f64;

struct Run {
    h_err: Vec<f64>,
    v_err: Vec<f64>,
    est: VerticalEstimator,
    max_abs_h_err_after: f64,
}

fn simulate(
    cfg: Config,
    seconds: f64,
    settle_s: f64,
    bias_mps2: f64,
    seed: u64,
    profile: Profile,
    fault: BaroFault<'_>,
) -> Run {
    let mut rng = Rng::new(seed);
    let baro = CheapBaro::new(P0_PA as f32).unwrap();
    let mut est = VerticalEstimator::new(cfg).unwrap();
    let dt = 1.0 / IMU_HZ as f64;
    let sigma_a = accel_sigma_mps2(IMU_HZ as f64);
    let steps = (seconds * IMU_HZ as f64) as usize;
    let (mut h_err, mut v_err) = (Vec::new(), Vec::new());
    let mut max_abs = 0.0_f64;
    for k in 0..steps {
        let t = k as f64 * dt;
        let (h, v, a) = profile(t);
        if k.is_multiple_of(BARO_DIV) {
            let extra = fault(t, &mut rng);
            // Fault as a pressure offset of the equivalent height.
            let p = baro_reading_pa(&mut rng, h + extra, P0_PA);
            est.update_baro(baro.height_m(p)).unwrap();
        }
        let a_meas = a + bias_mps2 + sigma_a * rng.gauss();
        est.predict(a_meas as f32, dt as f32).unwrap();
        // `h`, `v` are the truth at t; the estimate now refers to t + dt.
        let _ = (h, v);
        if t >= settle_s {
            let (h1, v1, _) = profile(t + dt);
            let he = f64::from(est.height_m()) - h1;
            max_abs = max_abs.max(he.abs());
            h_err.push(he);
            v_err.push(f64::from(est.velocity_mps()) - v1);
        }
    }
    Run {
        h_err,
        v_err,
        est,
        max_abs_h_err_after: max_abs,
    }
}

fn hover(_t: f64) -> (f64, f64, f64) {
    (12.0, 0.0, 0.0)
}

/// Climbs 10 m and back twice (raised cosine), max 1.57 m/s, 0.49 m/s².
fn climb_descend(t: f64) -> (f64, f64, f64) {
    use std::f64::consts::PI;
    if (10.0..50.0).contains(&t) {
        let w = 2.0 * PI / 20.0;
        let x = w * (t - 10.0);
        (
            2.0 + 5.0 * (1.0 - x.cos()),
            5.0 * w * x.sin(),
            5.0 * w * w * x.cos(),
        )
    } else {
        (2.0, 0.0, 0.0)
    }
}

fn no_fault(_t: f64, _r: &mut Rng) -> f64 {
    0.0
}

#[test]
fn hover_meets_noise_targets_and_bias_converges() {
    let bias = 0.15;
    let r = simulate(Config::default(), 60.0, 20.0, bias, 1, hover, &mut no_fault);
    let (h_rms, v_rms) = (rms(&r.h_err), rms(&r.v_err));
    println!(
        "hover: h rms {h_rms:.4} m, v rms {v_rms:.4} m/s, bias {}",
        r.est.accel_bias_mps2()
    );
    assert!(h_rms < 0.10, "height rms {h_rms}");
    assert!(v_rms < 0.10, "speed rms {v_rms}");
    assert!((f64::from(r.est.accel_bias_mps2()) - bias).abs() < 0.03);
    let s = r.est.stats();
    assert_eq!(s.resyncs, 0);
    // Normal noise (~0.1 m) is essentially never outside a 0.5 m gate.
    assert!(s.rejected <= 2, "{s:?}");
    assert_eq!(s.accepted as usize, 6000 - s.rejected as usize);
}

#[test]
fn hover_with_negative_bias_and_other_seeds() {
    for (seed, bias) in [(7, -0.3), (99, 0.05), (12345, 0.4)] {
        let r = simulate(
            Config::default(),
            60.0,
            25.0,
            bias,
            seed,
            hover,
            &mut no_fault,
        );
        let (h_rms, v_rms) = (rms(&r.h_err), rms(&r.v_err));
        assert!(h_rms < 0.10 && v_rms < 0.10, "seed {seed}: {h_rms} {v_rms}");
        assert!(
            (f64::from(r.est.accel_bias_mps2()) - bias).abs() < 0.05,
            "seed {seed}"
        );
    }
}

#[test]
fn climb_and_descend_profile_tracks() {
    let r = simulate(
        Config::default(),
        60.0,
        8.0,
        0.1,
        3,
        climb_descend,
        &mut no_fault,
    );
    let (h_rms, v_rms) = (rms(&r.h_err), rms(&r.v_err));
    println!("climb: h rms {h_rms:.4} m, v rms {v_rms:.4} m/s");
    assert!(h_rms < 0.10, "height rms {h_rms}");
    assert!(v_rms < 0.10, "speed rms {v_rms}");
    assert_eq!(r.est.stats().resyncs, 0);
}

#[test]
fn baro_glitch_is_rejected() {
    // +5 m for 50 ms (5 samples at 100 Hz) every 10 s, starting at 20 s.
    let mut glitch = |t: f64, _r: &mut Rng| {
        if t >= 20.0 && (t % 10.0) < 0.05 {
            5.0
        } else {
            0.0
        }
    };
    let clean = simulate(Config::default(), 60.0, 20.0, 0.1, 5, hover, &mut no_fault);
    let r = simulate(Config::default(), 60.0, 20.0, 0.1, 5, hover, &mut glitch);
    let s = r.est.stats();
    assert!(s.rejected >= 4 * 5, "{s:?}");
    assert_eq!(s.resyncs, 0);
    // The glitches leave no trace: same worst-case error as the clean run.
    assert!(r.max_abs_h_err_after < clean.max_abs_h_err_after + 0.02);
    assert!(r.max_abs_h_err_after < 0.3, "{}", r.max_abs_h_err_after);
}

#[test]
fn persistent_step_resyncs_instead_of_locking_out() {
    // At 20 s the baro jumps +3 m for good (e.g. a reference change).
    let mut step = |t: f64, _r: &mut Rng| if t >= 20.0 { 3.0 } else { 0.0 };
    let r = simulate(Config::default(), 30.0, 29.0, 0.0, 11, hover, &mut step);
    let s = r.est.stats();
    assert_eq!(s.resyncs, 1, "{s:?}");
    // After the re-sync the estimate follows the (shifted) baro.
    let last = *r.h_err.last().unwrap();
    assert!((last - 3.0).abs() < 0.2, "{last}");
}

/// Hover 0.15 m above the ground with prop-wash: frequent bursts of
/// baro readings 0.3–2 m too low, 20–100 ms long.
fn prop_wash_run(cfg: Config, seed: u64) -> Run {
    fn low_hover(_t: f64) -> (f64, f64, f64) {
        (0.15, 0.0, 0.0)
    }
    let mut burst_left = 0usize;
    let mut depth = 0.0;
    let mut wash = move |_t: f64, r: &mut Rng| {
        if burst_left == 0 && r.uniform() < 0.05 {
            burst_left = 2 + (r.uniform() * 9.0) as usize;
            depth = 0.3 + 1.7 * r.uniform();
        }
        if burst_left > 0 {
            burst_left -= 1;
            -depth
        } else {
            0.0
        }
    };
    simulate(cfg, 60.0, 20.0, 0.1, seed, low_hover, &mut wash)
}

#[test]
fn prop_wash_near_ground_is_ignored() {
    let r = prop_wash_run(Config::default(), 21);
    let h_rms = rms(&r.h_err);
    let mean = r.h_err.iter().sum::<f64>() / r.h_err.len() as f64;
    let s = r.est.stats();
    println!("prop-wash with ground effect: h rms {h_rms:.4} mean {mean:.4} {s:?}");
    assert!(h_rms < 0.10, "{h_rms}");
    assert!(mean.abs() < 0.05, "{mean}");
    assert!(s.ground_effect > 200, "{s:?}");

    // Same flight with the ground-effect handling switched off: the spikes
    // inside the gate pull the estimate down.
    let off = Config {
        ground_effect_band_m: 0.0,
        ..Config::default()
    };
    let r_off = prop_wash_run(off, 21);
    let mean_off = r_off.h_err.iter().sum::<f64>() / r_off.h_err.len() as f64;
    println!(
        "prop-wash without: h rms {:.4} mean {mean_off:.4}",
        rms(&r_off.h_err)
    );
    assert!(rms(&r_off.h_err) > 1.5 * h_rms);
    assert_eq!(r_off.est.stats().ground_effect, 0);
}

#[test]
fn forced_ground_effect_flag() {
    let mut est = VerticalEstimator::new(Config {
        ground_effect_band_m: 0.0,
        ..Config::default()
    })
    .unwrap();
    est.update_baro(50.0).unwrap();
    assert!(!est.ground_effect_active());
    for _ in 0..10 {
        est.predict(0.0, 0.001).unwrap();
    }
    assert_eq!(est.update_baro(49.6).unwrap(), BaroOutcome::Accepted);
    est.set_ground_effect(true);
    assert!(est.ground_effect_active());
    let h = est.height_m();
    assert_eq!(est.update_baro(h - 0.4).unwrap(), BaroOutcome::GroundEffect);
    assert_eq!(est.height_m(), h);
    // Positive innovations still count in ground effect.
    assert_eq!(est.update_baro(h + 0.3).unwrap(), BaroOutcome::Accepted);
    assert!(est.height_m() > h);
    est.set_ground_effect(false);
    assert_eq!(est.update_baro(h - 0.4).unwrap(), BaroOutcome::Accepted);
}

#[test]
fn non_finite_inputs_leave_state_untouched() {
    let mut est = VerticalEstimator::new(Config::default()).unwrap();
    assert_eq!(est.update_baro(f32::NAN), Err(Error::NonFinite));
    assert!(!est.is_initialized());
    est.update_baro(3.0).unwrap();
    for _ in 0..100 {
        est.predict(0.5, 0.001).unwrap();
        if est.height_m() > 100.0 {
            break;
        }
    }
    let before = est;
    assert_eq!(est.predict(f32::NAN, 0.001), Err(Error::NonFinite));
    assert_eq!(est.predict(f32::INFINITY, 0.001), Err(Error::NonFinite));
    assert_eq!(est.predict(0.0, f32::NAN), Err(Error::InvalidDt));
    assert_eq!(est.predict(0.0, 0.0), Err(Error::InvalidDt));
    assert_eq!(est.predict(0.0, -0.001), Err(Error::InvalidDt));
    assert_eq!(est.predict(0.0, 1.0), Err(Error::InvalidDt)); // > max_dt_s
    assert_eq!(est.update_baro(f32::NEG_INFINITY), Err(Error::NonFinite));
    assert_eq!(est, before);
    // Absurd but finite acceleration is limited, state stays finite.
    for _ in 0..1000 {
        est.predict(f32::MAX, 0.05).unwrap();
    }
    assert!(est.height_m().is_finite() && est.velocity_mps().is_finite());
}

#[test]
fn config_validation() {
    assert!(Config::default().validate().is_ok());
    let bad = [
        Config {
            crossover_rad_s: 0.0,
            ..Config::default()
        },
        Config {
            crossover_rad_s: 20.0,
            ..Config::default()
        },
        Config {
            baro_sigma_m: -0.1,
            ..Config::default()
        },
        Config {
            gate_sigma: f32::NAN,
            ..Config::default()
        },
        Config {
            resync_after: 0,
            ..Config::default()
        },
        Config {
            max_dt_s: 0.0,
            ..Config::default()
        },
        Config {
            ground_effect_band_m: -1.0,
            ..Config::default()
        },
        Config {
            ground_height_m: f32::INFINITY,
            ..Config::default()
        },
    ];
    for c in bad {
        assert!(VerticalEstimator::new(c).is_err(), "{c:?}");
    }
}

#[test]
fn bias_estimate_is_bounded_and_diverging_speed_recovers() {
    // A 5 m/s² accelerometer offset (far beyond max_bias_mps2 = 1): the bias
    // state saturates at the limit instead of winding up, and the re-sync
    // logic keeps height and speed near the truth although the remaining
    // 4 m/s² cannot be modelled.
    let r = simulate(Config::default(), 20.0, 10.0, 5.0, 8, hover, &mut no_fault);
    let b = r.est.accel_bias_mps2();
    assert!((0.99..=1.0).contains(&b), "{b}");
    assert!(r.est.stats().resyncs > 0);
    let v_max = r.v_err.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    // Without the speed re-sync this reaches ~90 m/s; with it, it stays bounded.
    assert!(v_max < 8.0, "speed error {v_max}");
    assert!(r.max_abs_h_err_after < 3.0, "{}", r.max_abs_h_err_after);
}
