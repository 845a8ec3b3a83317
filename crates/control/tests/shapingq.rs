//! Stick shaping in fixed point (`shapingq`) against its `f32` reference
//! (`shaping::StickShaping`, `loops::TiltQuat`): property tests over random
//! sticks (beyond their ranges too) and random valid configurations.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use control::fixed::q_to_f32;
use control::loops::TiltQuat;
use control::shaping::{AxisRates, StickShaping, Sticks, SticksConfig, ThrottleCurve};
use control::shapingq::StickShapingQ;
use proptest::prelude::*;

/// Rates: within this, rad/s (0.006 °/s).
const RATE_TOL_RPS: f32 = 1e-4;
/// Tilt quaternion components and the throttle: within this.
const UNIT_TOL: f32 = 1e-6;

fn axis() -> impl Strategy<Value = AxisRates> {
    (1.0f32..2000.0, 0.0f32..=1.0, 0.0f32..=0.2).prop_map(|(max_rate_dps, expo, deadband)| {
        AxisRates {
            max_rate_dps,
            expo,
            deadband,
        }
    })
}

fn config() -> impl Strategy<Value = SticksConfig> {
    (
        axis(),
        axis(),
        axis(),
        1.0f32..=80.0,
        0.0f32..=1.0,
        0.05f32..=0.95,
        0.0f32..=1.0,
    )
        .prop_map(
            |(roll, pitch, yaw, max_angle_deg, angle_expo, mid, expo)| SticksConfig {
                roll,
                pitch,
                yaw,
                max_angle_deg,
                angle_expo,
                throttle: ThrottleCurve { mid, expo },
            },
        )
}

fn sticks() -> impl Strategy<Value = Sticks> {
    (-1.3f32..1.3, -1.3f32..1.3, -1.3f32..1.3, -0.3f32..1.3).prop_map(
        |(roll, pitch, yaw, throttle)| Sticks {
            roll,
            pitch,
            yaw,
            throttle,
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn shaping_matches_the_f32_law(cfg in config(), s in sticks()) {
        let f = StickShaping::new(cfg).unwrap();
        let q = StickShapingQ::new(&cfg).unwrap().shape(&s);
        let rates = f.rate_setpoint(&s).unwrap();
        let acro = q.acro_q16.map(|v| q_to_f32(v, 16));
        prop_assert!((rates.roll_rps - acro[0]).abs() < RATE_TOL_RPS, "{rates:?} vs {acro:?}");
        prop_assert!((rates.pitch_rps - acro[1]).abs() < RATE_TOL_RPS, "{rates:?} vs {acro:?}");
        prop_assert!((rates.yaw_rps - acro[2]).abs() < RATE_TOL_RPS, "{rates:?} vs {acro:?}");
        let (tilt, yaw) = f.level_setpoint(&s).unwrap();
        prop_assert!((yaw - q_to_f32(q.yaw_q16, 16)).abs() < RATE_TOL_RPS);
        let t = TiltQuat::new(&tilt).unwrap().quat();
        let tq = q.tilt.q30().map(|v| q_to_f32(v, 30));
        for (a, b) in [t.w, t.x, t.y, t.z].iter().zip(tq) {
            prop_assert!((a - b).abs() < UNIT_TOL, "{t:?} vs {tq:?} for {tilt:?}");
        }
        let thr = f.throttle(s.throttle).unwrap();
        prop_assert!((thr - q_to_f32(q.throttle_q30, 30)).abs() < UNIT_TOL, "{thr} vs {}", q.throttle_q30);
    }
}

#[test]
fn full_sticks_give_the_configured_extremes() {
    let cfg = SticksConfig::default();
    let q = StickShapingQ::new(&cfg).unwrap();
    let s = q.shape(&Sticks {
        roll: 1.0,
        pitch: 1.0,
        yaw: -1.0,
        throttle: 1.0,
    });
    let rate = |v: i32| q_to_f32(v, 16).to_degrees();
    assert!((rate(s.acro_q16[0]) - 500.0).abs() < 0.01);
    assert!(
        (rate(s.acro_q16[1]) + 500.0).abs() < 0.01,
        "pitch forward is nose down"
    );
    assert!((rate(s.yaw_q16) + 300.0).abs() < 0.01);
    assert_eq!(s.throttle_q30, 1 << 30);
    // 30° right roll and 30° nose down: the tilt quaternion's half angles.
    let t = s.tilt.q30().map(|v| q_to_f32(v, 30));
    let (h_s, h_c) = (15f32.to_radians().sin(), 15f32.to_radians().cos());
    assert!((t[0] - h_c * h_c).abs() < 1e-6 && (t[1] - h_c * h_s).abs() < 1e-6);
    assert!((t[2] + h_s * h_c).abs() < 1e-6 && (t[3] - h_s * h_s).abs() < 1e-6);
}

#[test]
fn a_bad_configuration_is_refused() {
    let cfg = SticksConfig {
        max_angle_deg: 95.0,
        ..SticksConfig::default()
    };
    assert!(StickShapingQ::new(&cfg).is_err());
}
