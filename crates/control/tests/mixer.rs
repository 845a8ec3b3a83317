//! Quad-X mixer: geometry signs, and properties of the desaturation.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::field_reassign_with_default
)]

use control::controllers::TorqueCommand;
use control::mixer::{unmix, Mixer, MixerConfig, MOTORS, QUAD_X};
use proptest::prelude::*;

const IDLE: f32 = 0.05;

fn mixer() -> Mixer {
    Mixer::new(MixerConfig { idle: IDLE }).unwrap()
}

fn tq(roll: f32, pitch: f32, yaw: f32) -> TorqueCommand {
    TorqueCommand { roll, pitch, yaw }
}

/// Motor positions (x forward, y right, m) and spin (+1 = CW from above)
/// of the documented layout; torques from physics, not from the table.
const POS: [(f32, f32, f32); MOTORS] = [
    (-1.0, 1.0, 1.0),   // rear right, CW
    (1.0, 1.0, -1.0),   // front right, CCW
    (-1.0, -1.0, -1.0), // rear left, CCW
    (1.0, -1.0, 1.0),   // front left, CW
];

/// Body torque (FRD) from thrusts (up, i.e. −z) at POS: τ = r × F, plus
/// the reaction torque of each prop (a CW prop pushes the frame CCW = −z).
fn physical_torque(m: &[f32; MOTORS]) -> [f32; 3] {
    let mut t = [0.0; 3];
    for (f, (x, y, spin)) in m.iter().zip(POS) {
        // F = (0, 0, −f): r × F = (y·(−f) − 0, 0 − x·(−f), 0).
        t[0] += -y * f;
        t[1] += x * f;
        t[2] += -spin * f;
    }
    t
}

#[test]
fn table_matches_the_stated_geometry() {
    let m = mixer();
    for (axis, cmd) in [
        (0, tq(0.3, 0.0, 0.0)),
        (1, tq(0.0, 0.3, 0.0)),
        (2, tq(0.0, 0.0, 0.3)),
    ] {
        let out = m.mix(0.5, &cmd).unwrap();
        let t = physical_torque(&out.motors);
        for (k, v) in t.iter().enumerate() {
            if k == axis {
                assert!(*v > 0.0, "axis {axis}: positive command, torque {t:?}");
            } else {
                assert!(v.abs() < 1e-6, "axis {axis} leaks into {k}: {t:?}");
            }
        }
    }
    // Betaflight motor 1 is rear right and CW: it speeds up for roll left,
    // pitch down (nose down) and yaw left.
    assert_eq!(QUAD_X[0], [-0.5, -0.5, -0.5]);
}

#[test]
fn full_single_axis_at_half_throttle_spans_idle_to_one() {
    let out = mixer().mix(0.5, &tq(1.0, 0.0, 0.0)).unwrap();
    // Wanted 0 and 1; idle is 0.05, so the collective shifts up and the
    // roll is scaled to fit the 0.95 span.
    let lo = out.motors.iter().cloned().fold(f32::MAX, f32::min);
    let hi = out.motors.iter().cloned().fold(f32::MIN, f32::max);
    assert!(
        (lo - IDLE).abs() < 1e-6 && (hi - 1.0).abs() < 1e-6,
        "{out:?}"
    );
    assert!((out.roll_pitch_gain - 0.95).abs() < 1e-5);
}

#[test]
fn high_throttle_is_reduced_to_keep_roll() {
    let out = mixer().mix(0.95, &tq(0.4, 0.0, 0.0)).unwrap();
    assert_eq!(out.roll_pitch_gain, 1.0);
    assert!(out.collective_shift < 0.0);
    let (_, t) = unmix(&out.motors);
    assert!((t.roll - 0.4).abs() < 1e-5);
}

#[test]
fn low_throttle_is_raised_to_keep_pitch() {
    let out = mixer().mix(0.0, &tq(0.0, -0.3, 0.0)).unwrap();
    assert_eq!(out.roll_pitch_gain, 1.0);
    assert!(out.collective_shift > 0.0);
    let (_, t) = unmix(&out.motors);
    assert!((t.pitch + 0.3).abs() < 1e-5);
}

#[test]
fn yaw_gives_way_before_roll() {
    // Roll 0.8 needs a 0.8 span, yaw 0.5 another 0.5: only 0.95 available.
    let out = mixer().mix(0.5, &tq(0.8, 0.0, 0.5)).unwrap();
    assert_eq!(out.roll_pitch_gain, 1.0);
    assert!(out.yaw_gain < 1.0 && out.yaw_gain > 0.0);
    let (_, t) = unmix(&out.motors);
    assert!((t.roll - 0.8).abs() < 1e-5);
    assert!((t.yaw - 0.5 * out.yaw_gain).abs() < 1e-5);
}

#[test]
fn rejects_bad_input_and_config() {
    assert!(mixer().mix(f32::NAN, &tq(0.0, 0.0, 0.0)).is_err());
    assert!(mixer().mix(0.5, &tq(0.0, f32::INFINITY, 0.0)).is_err());
    assert!(Mixer::new(MixerConfig { idle: -0.1 }).is_err());
    assert!(Mixer::new(MixerConfig { idle: 0.5 }).is_err());
    assert!(Mixer::new(MixerConfig { idle: f32::NAN }).is_err());
}

fn span(m: &[f32; MOTORS]) -> f32 {
    let lo = m.iter().cloned().fold(f32::MAX, f32::min);
    let hi = m.iter().cloned().fold(f32::MIN, f32::max);
    hi - lo
}

proptest! {
    #[test]
    fn outputs_always_in_range(t in -0.5f32..1.5, r in -2.0f32..2.0, p in -2.0f32..2.0, y in -2.0f32..2.0) {
        let out = mixer().mix(t, &tq(r, p, y)).unwrap();
        for m in out.motors {
            prop_assert!((IDLE..=1.0).contains(&m), "{out:?}");
        }
        prop_assert!((0.0..=1.0).contains(&out.roll_pitch_gain));
        prop_assert!((0.0..=1.0).contains(&out.yaw_gain));
    }

    #[test]
    fn unsaturated_reproduces_exactly(t in 0.2f32..0.8, r in -0.3f32..0.3, p in -0.3f32..0.3, y in -0.3f32..0.3) {
        let cmd = tq(r, p, y);
        // Only the cases where the plain mix fits [idle, 1].
        let fits = QUAD_X.iter().all(|c| {
            let m = t + c[0] * r + c[1] * p + c[2] * y;
            (IDLE..=1.0).contains(&m)
        });
        prop_assume!(fits);
        let out = mixer().mix(t, &cmd).unwrap();
        prop_assert!(!out.saturated());
        let (thr, back) = unmix(&out.motors);
        prop_assert!((thr - t).abs() < 1e-5);
        prop_assert!((back.roll - r).abs() < 1e-5);
        prop_assert!((back.pitch - p).abs() < 1e-5);
        prop_assert!((back.yaw - y).abs() < 1e-5);
    }

    #[test]
    fn saturation_keeps_roll_pitch_ratio(t in 0.0f32..1.0, r in -1.0f32..1.0, p in -1.0f32..1.0, y in -1.0f32..1.0) {
        prop_assume!(r.abs() > 0.05 && p.abs() > 0.05);
        let out = mixer().mix(t, &tq(r, p, y)).unwrap();
        let (_, back) = unmix(&out.motors);
        // Same direction in the roll/pitch plane: cross product ~ 0, dot > 0.
        let cross = back.roll * p - back.pitch * r;
        prop_assert!(cross.abs() < 1e-4, "{out:?} {back:?}");
        prop_assert!(back.roll * r + back.pitch * p > 0.0);
        prop_assert!((back.roll - out.roll_pitch_gain * r).abs() < 1e-4);
        prop_assert!((back.yaw - out.yaw_gain * y).abs() < 1e-4);
        // Roll/pitch are only scaled when they alone need more than the span.
        if out.roll_pitch_gain < 1.0 {
            let rp_need = (r.abs() + p.abs()).max(1e-9);
            prop_assert!(rp_need > 1.0 - IDLE - 1e-4, "{out:?}");
        }
    }

    #[test]
    fn gains_are_maximal(t in 0.0f32..1.0, r in -1.0f32..1.0, p in -1.0f32..1.0, y in -1.0f32..1.0) {
        // Whenever something was given up, the motors use the full span.
        let out = mixer().mix(t, &tq(r, p, y)).unwrap();
        if out.roll_pitch_gain < 1.0 || out.yaw_gain < 1.0 {
            prop_assert!((span(&out.motors) - (1.0 - IDLE)).abs() < 1e-4, "{out:?}");
        }
    }
}
