//! Stick shaping: signs, full-stick rates, expo, max angle, throttle curve.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::field_reassign_with_default
)]

use control::shaping::{AxisRates, StickShaping, Sticks, SticksConfig, ThrottleCurve};
use proptest::prelude::*;

fn sticks(roll: f32, pitch: f32, yaw: f32, throttle: f32) -> Sticks {
    Sticks {
        roll,
        pitch,
        yaw,
        throttle,
    }
}

#[test]
fn full_stick_gives_max_rate_with_frd_signs() {
    let s = StickShaping::new(SticksConfig::default()).unwrap();
    let r = s.rate_setpoint(&sticks(1.0, 1.0, -1.0, 0.0)).unwrap();
    assert!((r.roll_rps - 500f32.to_radians()).abs() < 1e-4); // right wing down
    assert!((r.pitch_rps + 500f32.to_radians()).abs() < 1e-4); // stick forward: nose down
    assert!((r.yaw_rps + 300f32.to_radians()).abs() < 1e-4); // yaw left
                                                             // Beyond full scale clamps.
    let r2 = s.rate_setpoint(&sticks(3.0, 0.0, 0.0, 0.0)).unwrap();
    assert_eq!(r2.roll_rps, r.roll_rps);
}

#[test]
fn expo_softens_the_centre_only() {
    let mut cfg = SticksConfig::default();
    cfg.roll = AxisRates {
        max_rate_dps: 400.0,
        expo: 0.0,
        deadband: 0.0,
    };
    let lin = StickShaping::new(cfg).unwrap();
    cfg.roll.expo = 0.7;
    let exp = StickShaping::new(cfg).unwrap();
    let at = |s: &StickShaping, x| s.rate_setpoint(&sticks(x, 0.0, 0.0, 0.0)).unwrap().roll_rps;
    assert!(at(&exp, 0.3) < 0.5 * at(&lin, 0.3));
    assert!((at(&exp, 1.0) - at(&lin, 1.0)).abs() < 1e-5);
    // (1 − 0.7)·0.5 + 0.7·0.125 = 0.2375 of 400 °/s.
    assert!((at(&exp, 0.5) - (0.2375f32 * 400.0).to_radians()).abs() < 1e-4);
}

#[test]
fn level_setpoint_is_max_angle_at_full_stick() {
    let s = StickShaping::new(SticksConfig::default()).unwrap();
    let (tilt, yaw) = s.level_setpoint(&sticks(-1.0, -1.0, 0.0, 0.5)).unwrap();
    assert!((tilt.roll_rad + 30f32.to_radians()).abs() < 1e-5);
    assert!((tilt.pitch_rad - 30f32.to_radians()).abs() < 1e-5); // stick back: nose up
    assert_eq!(yaw, 0.0);
}

#[test]
fn deadband_gives_zero() {
    let s = StickShaping::new(SticksConfig::default()).unwrap();
    let r = s.rate_setpoint(&sticks(0.015, -0.019, 0.01, 0.0)).unwrap();
    assert_eq!((r.roll_rps, r.pitch_rps, r.yaw_rps), (0.0, 0.0, 0.0));
}

#[test]
fn rejects_non_finite_and_bad_config() {
    let s = StickShaping::new(SticksConfig::default()).unwrap();
    assert!(s.rate_setpoint(&sticks(f32::NAN, 0.0, 0.0, 0.0)).is_err());
    assert!(s.throttle(f32::INFINITY).is_err());
    let bad = [
        SticksConfig {
            max_angle_deg: 0.0,
            ..SticksConfig::default()
        },
        SticksConfig {
            max_angle_deg: 90.0,
            ..SticksConfig::default()
        },
        SticksConfig {
            angle_expo: 1.5,
            ..SticksConfig::default()
        },
        SticksConfig {
            throttle: ThrottleCurve {
                mid: 1.0,
                expo: 0.0,
            },
            ..SticksConfig::default()
        },
        SticksConfig {
            yaw: AxisRates {
                max_rate_dps: -10.0,
                expo: 0.0,
                deadband: 0.0,
            },
            ..SticksConfig::default()
        },
        SticksConfig {
            pitch: AxisRates {
                max_rate_dps: 100.0,
                expo: f32::NAN,
                deadband: 0.0,
            },
            ..SticksConfig::default()
        },
    ];
    for c in bad {
        assert!(StickShaping::new(c).is_err(), "{c:?}");
    }
}

proptest! {
    #[test]
    fn rate_is_odd_monotonic_and_bounded(a in -1.0f32..1.0, b in -1.0f32..1.0, e in 0.0f32..1.0) {
        let mut cfg = SticksConfig::default();
        cfg.roll.expo = e;
        let s = StickShaping::new(cfg).unwrap();
        let at = |x| s.rate_setpoint(&sticks(x, 0.0, 0.0, 0.0)).unwrap().roll_rps;
        let max = 500f32.to_radians();
        prop_assert!(at(a).abs() <= max * (1.0 + 1e-6));
        prop_assert!((at(a) + at(-a)).abs() < 1e-5);
        if a < b { prop_assert!(at(a) <= at(b) + 1e-6); }
    }

    #[test]
    fn throttle_curve_monotonic(a in 0.0f32..1.0, b in 0.0f32..1.0, mid in 0.1f32..0.9, e in 0.0f32..1.0) {
        let c = ThrottleCurve { mid, expo: e };
        prop_assert!(c.validate().is_ok());
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        prop_assert!(c.apply(lo) <= c.apply(hi) + 1e-6);
        prop_assert!((0.0..=1.0).contains(&c.apply(a)));
    }
}
