//! PID behaviour: derivative kick, anti-windup, bumpless reset, filtering,
//! limits, non-finite rejection, and property tests.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use control::pid::{Pid, PidConfig};
use control::Error;
use proptest::prelude::*;

const DT: f32 = 0.001;

#[test]
fn proportional_integral_and_derivative_values() {
    let mut pid =
        Pid::new(PidConfig::new(2.0, 10.0, 0.5).with_output_limits(-100.0, 100.0)).unwrap();
    // First call: no derivative history, P + I only.
    let u = pid.update(1.0, 0.0, 0.01).unwrap();
    assert!((u - (2.0 + 10.0 * 0.01)).abs() < 1e-6, "{u}");
    // Measurement rises 0.1 in 0.01 s: D = −0.5 · 10 = −5 (unfiltered).
    let u = pid.update(1.0, 0.1, 0.01).unwrap();
    let want = 2.0 * 0.9 + (0.1 + 10.0 * 0.9 * 0.01) - 5.0;
    assert!((u - want).abs() < 1e-5, "{u} vs {want}");
}

#[test]
fn no_derivative_kick_on_setpoint_step() {
    let cfg = PidConfig::new(1.0, 0.0, 5.0).with_output_limits(-1000.0, 1000.0);
    let mut pid = Pid::new(cfg).unwrap();
    for _ in 0..10 {
        pid.update(0.0, 0.0, DT).unwrap();
    }
    // Setpoint jumps by 1: the output jumps by exactly kp·1, no kd/dt spike.
    let u = pid.update(1.0, 0.0, DT).unwrap();
    assert!((u - 1.0).abs() < 1e-6, "{u}");
    // A measurement step does produce D (derivative on measurement).
    let u = pid.update(1.0, 0.01, DT).unwrap();
    assert!(u < 0.99 - 5.0 * 0.01 / DT * 0.9, "{u}");
}

#[test]
fn derivative_low_pass_attenuates_noise() {
    let raw = PidConfig::new(0.0, 0.0, 1.0).with_output_limits(-1e6, 1e6);
    let filt = raw.with_d_cutoff_hz(5.0);
    let (mut a, mut b) = (Pid::new(raw).unwrap(), Pid::new(filt).unwrap());
    let (mut pa, mut pb) = (0.0f32, 0.0f32);
    for k in 0..2000 {
        // ±1 mm alternating measurement noise: derivative ±2 m/s per sample.
        let m = if k % 2 == 0 { 0.001 } else { -0.001 };
        let ua = a.update(0.0, m, DT).unwrap();
        let ub = b.update(0.0, m, DT).unwrap();
        if k > 1000 {
            pa = pa.max(ua.abs());
            pb = pb.max(ub.abs());
        }
    }
    assert!((pa - 2.0).abs() < 1e-3, "{pa}");
    // 500 Hz noise through a 5 Hz first-order filter: ~100× smaller.
    assert!(pb < 0.05, "{pb}");
    // And the filter has unit DC gain: a ramp gives the ramp rate.
    let mut c = Pid::new(filt).unwrap();
    let mut u = 0.0;
    for k in 0..3000 {
        u = c.update(0.0, k as f32 * 0.002 * DT, DT).unwrap();
    }
    assert!((u + 0.002).abs() < 1e-5, "{u}");
}

#[test]
fn output_limits_hold() {
    let mut pid = Pid::new(PidConfig::new(100.0, 0.0, 0.0).with_output_limits(-0.5, 0.8)).unwrap();
    assert_eq!(pid.update(1.0, 0.0, DT).unwrap(), 0.8);
    assert_eq!(pid.update(-1.0, 0.0, DT).unwrap(), -0.5);
    assert_eq!(pid.update(0.001, 0.0, DT).unwrap(), 0.1);
}

#[test]
fn integral_clamped_to_its_limits() {
    let cfg = PidConfig::new(0.0, 1.0, 0.0)
        .with_output_limits(-10.0, 10.0)
        .with_integral_limits(-0.2, 0.3);
    let mut pid = Pid::new(cfg).unwrap();
    for _ in 0..10_000 {
        pid.update(1.0, 0.0, DT).unwrap();
    }
    assert!((pid.integral() - 0.3).abs() < 1e-6);
    for _ in 0..10_000 {
        pid.update(-1.0, 0.0, DT).unwrap();
    }
    assert!((pid.integral() + 0.2).abs() < 1e-6);
}

#[test]
fn conditional_integration_stops_windup_at_saturated_output() {
    // Integral limits wide (±10) so only the conditional rule can stop it.
    let cfg = PidConfig::new(0.5, 2.0, 0.0)
        .with_output_limits(0.0, 1.0)
        .with_integral_limits(-10.0, 10.0);
    let mut pid = Pid::new(cfg).unwrap();
    // Error 4 for 5 s: P alone (2.0) saturates the output; no integration.
    for _ in 0..5_000 {
        assert_eq!(pid.update(4.0, 0.0, DT).unwrap(), 1.0);
    }
    assert_eq!(pid.integral(), 0.0);
    // The error reverses: the output leaves saturation at once (no wound-up
    // integral to unwind), and integrating away from saturation is allowed.
    let u = pid.update(-0.1, 0.0, DT).unwrap();
    assert_eq!(u, 0.0); // P = −0.05, I ≈ 0 → clamped at 0, integral not pushed
    assert_eq!(pid.integral(), 0.0);
    let u = pid.update(0.5, 0.0, DT).unwrap();
    assert!((u - 0.251).abs() < 1e-4, "{u}");
    // Integrating away from a saturated output is allowed: start with a
    // large integral and a negative error.
    pid.reset(0.0, 1.0).unwrap(); // integral = 1 → output saturated at 1
    let i0 = pid.integral();
    pid.update(-0.01, 0.0, DT).unwrap();
    assert!(pid.integral() < i0);
}

#[test]
fn bumpless_reset() {
    let cfg = PidConfig::new(0.8, 0.5, 0.05)
        .with_output_limits(0.0, 1.0)
        .with_integral_limits(-1.0, 1.0)
        .with_d_cutoff_hz(20.0);
    let mut pid = Pid::new(cfg).unwrap();
    pid.reset(3.7, 0.62).unwrap();
    let u = pid.update(3.7, 3.7, DT).unwrap();
    assert!((u - 0.62).abs() < 1e-6, "{u}");
    // General form with a setpoint offset and feed-forward.
    pid.reset_for(2.0, 1.5, 0.3, 0.7).unwrap();
    let u = pid.update_with_ff(2.0, 1.5, 0.3, DT).unwrap();
    assert!((u - 0.7).abs() < 1e-3, "{u}");
    // clear() forgets everything.
    pid.clear();
    assert_eq!(pid.integral(), 0.0);
    assert_eq!(pid.last_output(), 0.0);
}

#[test]
fn non_finite_inputs_rejected_without_state_change() {
    let mut pid = Pid::new(PidConfig::new(1.0, 1.0, 0.1).with_d_cutoff_hz(30.0)).unwrap();
    for k in 0..50 {
        pid.update(0.5, k as f32 * 0.001, DT).unwrap();
    }
    let before = pid;
    assert_eq!(pid.update(f32::NAN, 0.0, DT), Err(Error::NonFinite));
    assert_eq!(pid.update(0.0, f32::INFINITY, DT), Err(Error::NonFinite));
    assert_eq!(
        pid.update_with_ff(0.0, 0.0, f32::NEG_INFINITY, DT),
        Err(Error::NonFinite)
    );
    assert_eq!(pid.update(0.0, 0.0, 0.0), Err(Error::InvalidDt));
    assert_eq!(pid.update(0.0, 0.0, -DT), Err(Error::InvalidDt));
    assert_eq!(pid.update(0.0, 0.0, f32::NAN), Err(Error::InvalidDt));
    assert_eq!(pid.update(0.0, 0.0, f32::INFINITY), Err(Error::InvalidDt));
    assert_eq!(pid.reset(f32::NAN, 0.0), Err(Error::NonFinite));
    assert_eq!(pid.reset(0.0, f32::NAN), Err(Error::NonFinite));
    assert_eq!(pid, before);
}

#[test]
fn config_validation() {
    assert_eq!(
        PidConfig::new(-1.0, 0.0, 0.0).validate(),
        Err(Error::NegativeGain)
    );
    assert_eq!(
        PidConfig::new(0.0, f32::NAN, 0.0).validate(),
        Err(Error::NegativeGain)
    );
    assert_eq!(
        PidConfig::new(0.0, 0.0, -0.1).validate(),
        Err(Error::NegativeGain)
    );
    assert_eq!(
        PidConfig::new(1.0, 0.0, 0.0)
            .with_output_limits(1.0, -1.0)
            .validate(),
        Err(Error::InvalidLimits)
    );
    assert_eq!(
        PidConfig::new(1.0, 0.0, 0.0)
            .with_integral_limits(0.0, f32::INFINITY)
            .validate(),
        Err(Error::InvalidLimits)
    );
    assert_eq!(
        PidConfig::new(1.0, 0.0, 0.0)
            .with_d_cutoff_hz(-5.0)
            .validate(),
        Err(Error::InvalidParameter)
    );
    assert!(Pid::new(PidConfig::new(1.0, 0.0, 0.0).with_output_limits(2.0, 1.0)).is_err());
    // set_config keeps the old config on error, clamps the integral on success.
    let mut pid = Pid::new(PidConfig::new(0.0, 1.0, 0.0)).unwrap();
    for _ in 0..2000 {
        pid.update(1.0, 0.0, DT).unwrap();
    }
    assert!(pid.set_config(PidConfig::new(-1.0, 0.0, 0.0)).is_err());
    assert_eq!(pid.config().ki, 1.0);
    pid.set_config(PidConfig::new(0.0, 1.0, 0.0).with_integral_limits(-0.5, 0.5))
        .unwrap();
    assert!((pid.integral() - 0.5).abs() < 1e-6);
}

#[test]
fn changing_dt_is_handled() {
    // Varying dt: derivative uses the actual dt each call.
    let mut pid = Pid::new(PidConfig::new(0.0, 0.0, 1.0).with_output_limits(-10.0, 10.0)).unwrap();
    pid.update(0.0, 0.0, 0.001).unwrap();
    let u = pid.update(0.0, 0.002, 0.002).unwrap();
    assert!((u + 1.0).abs() < 1e-5, "{u}");
    let u = pid.update(0.0, 0.003, 0.0005).unwrap();
    assert!((u + 2.0).abs() < 1e-4, "{u}");
}

fn finite_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        -1.0e3f32..1.0e3,
        -1.0e30f32..1.0e30,
        Just(f32::MAX),
        Just(f32::MIN),
        Just(f32::MIN_POSITIVE),
        Just(0.0f32),
    ]
}

fn config() -> impl Strategy<Value = PidConfig> {
    (
        0.0f32..100.0,
        0.0f32..100.0,
        0.0f32..10.0,
        prop_oneof![Just(0.0f32), 0.1f32..500.0],
        -10.0f32..10.0,
        0.0f32..10.0,
        -5.0f32..5.0,
        0.0f32..5.0,
        prop_oneof![Just(1.0f32), Just(f32::MAX)],
    )
        .prop_map(|(kp, ki, kd, fc, omin, ow, imin, iw, scale)| {
            let kp = if scale > 1.0 { f32::MAX } else { kp };
            PidConfig::new(kp, ki, kd)
                .with_d_cutoff_hz(fc)
                .with_output_limits(omin, omin + ow)
                .with_integral_limits(imin, imin + iw)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn output_finite_and_within_limits(
        cfg in config(),
        steps in proptest::collection::vec((finite_f32(), finite_f32(), finite_f32(), 1.0e-6f32..1.0), 1..40),
    ) {
        let mut pid = Pid::new(cfg).unwrap();
        for (sp, m, ff, dt) in steps {
            let u = pid.update_with_ff(sp, m, ff, dt).unwrap();
            prop_assert!(u.is_finite());
            prop_assert!(u >= cfg.output_min && u <= cfg.output_max, "{} not in [{}, {}]", u, cfg.output_min, cfg.output_max);
            prop_assert!(pid.integral() >= cfg.integral_min && pid.integral() <= cfg.integral_max);
            prop_assert!(pid.integral().is_finite());
        }
    }

    #[test]
    fn reset_then_update_is_bumpless(cfg in config(), m in -100.0f32..100.0, frac in 0.0f32..1.0) {
        let target = cfg.output_min + frac * (cfg.output_max - cfg.output_min);
        // Integral limits wide enough for the target to be reachable.
        let cfg = cfg.with_integral_limits(cfg.integral_min.min(target), cfg.integral_max.max(target));
        let mut pid = Pid::new(cfg).unwrap();
        pid.reset(m, target).unwrap();
        // At zero error there is no integration: the output is exactly the target.
        let u = pid.update(m, m, 0.001).unwrap();
        prop_assert!((u - target).abs() <= 1e-5 * (1.0 + target.abs()), "{} vs {}", u, target);
    }

    #[test]
    fn non_finite_never_changes_state(cfg in config(), sp in finite_f32(), m in finite_f32(), which in 0usize..4) {
        let mut pid = Pid::new(cfg).unwrap();
        pid.update(sp, m, 0.01).unwrap();
        let before = pid;
        let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][which % 3];
        let r = match which {
            0 => pid.update(bad, m, 0.01),
            1 => pid.update(sp, bad, 0.01),
            2 => pid.update_with_ff(sp, m, bad, 0.01),
            _ => pid.update(sp, m, bad),
        };
        prop_assert!(r.is_err());
        prop_assert_eq!(pid, before);
    }
}
