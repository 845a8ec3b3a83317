//! Accelerometer six-position calibration.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::needless_range_loop
)]
mod common;

use calibration::{
    AccelSixPosition, AccelSixPositionConfig, Error, MotionCheck, Position, SixPositionEvent,
};
use common::*;

const OFFSET_G: [f64; 3] = [0.031, -0.022, 0.054];
const GAIN: [f64; 3] = [1.02, 0.97, 1.04];
const NOISE_G: f64 = 0.003;

/// Raw reading for true specific force `f` (g): gain ⊙ f + offset + noise.
fn raw(f: [f64; 3], rng: &mut Rng) -> [f32; 3] {
    to32([
        GAIN[0] * f[0] + OFFSET_G[0] + NOISE_G * rng.gauss(),
        GAIN[1] * f[1] + OFFSET_G[1] + NOISE_G * rng.gauss(),
        GAIN[2] * f[2] + OFFSET_G[2] + NOISE_G * rng.gauss(),
    ])
}

/// True specific force (g) with `p` up, tilted by `tilt_deg` about a skew axis.
fn up_vector(p: Position, tilt_deg: f64) -> [f64; 3] {
    let mut f = [0.0; 3];
    f[p.axis() as usize] = if p.is_up() { 1.0 } else { -1.0 };
    mul_v(&rotation([0.3, -0.8, 0.5], tilt_deg.to_radians()), f)
}

fn hold(six: &mut AccelSixPosition, p: Position, tilt_deg: f64, rng: &mut Rng) -> SixPositionEvent {
    let f = up_vector(p, tilt_deg);
    let mut last = None;
    for _ in 0..six_window() {
        last = Some(six.push(raw(f, rng)).unwrap());
    }
    last.unwrap()
}

fn six_window() -> u32 {
    AccelSixPositionConfig::G.window
}

#[test]
fn recovers_injected_offset_and_scale_with_progress() {
    let mut rng = Rng::new(41);
    let mut six = AccelSixPosition::new(AccelSixPositionConfig::G).unwrap();
    assert_eq!(six.progress().count(), 0);
    assert_eq!(six.progress().next_missing(), Some(Position::XUp));
    // Arbitrary order, slightly imperfect placement (1.5° tilt).
    let order = [
        Position::ZUp,
        Position::XDown,
        Position::YUp,
        Position::ZDown,
        Position::XUp,
        Position::YDown,
    ];
    for (k, p) in order.into_iter().enumerate() {
        assert_eq!(
            six.finish(),
            Err(Error::Incomplete {
                positions_done: six.progress().mask
            })
        );
        assert_eq!(
            hold(&mut six, p, 1.5, &mut rng),
            SixPositionEvent::Captured(p)
        );
        assert!(six.progress().is_done(p));
        assert_eq!(usize::from(six.progress().count()), k + 1);
        assert!(six.captured(p).is_some());
    }
    assert!(six.progress().is_complete());
    assert_eq!(six.progress().next_missing(), None);
    // A repeated position is ignored.
    assert_eq!(
        hold(&mut six, Position::ZUp, 0.0, &mut rng),
        SixPositionEvent::AlreadyCaptured(Position::ZUp)
    );

    let cal = six.finish().unwrap();
    cal.validate().unwrap();
    for i in 0..3 {
        // Tilt 1.5° costs cos(1.5°) ≈ 3.4e-4 of scale; noise averages to 2e-4.
        assert!(
            (f64::from(cal.offset[i]) - OFFSET_G[i]).abs() < 1e-3,
            "offset {:?}",
            cal.offset
        );
        assert!(
            (f64::from(cal.scale[i]) * GAIN[i] - 1.0).abs() < 1.5e-3,
            "scale {:?}",
            cal.scale
        );
    }
    // Corrected readings at rest have magnitude 1 g in any orientation.
    for _ in 0..100 {
        let f = rng.unit();
        let c = cal.apply(to32([
            GAIN[0] * f[0] + OFFSET_G[0],
            GAIN[1] * f[1] + OFFSET_G[1],
            GAIN[2] * f[2] + OFFSET_G[2],
        ]));
        assert!((norm32(c) - 1.0).abs() < 2e-3);
    }
}

#[test]
fn works_in_mps2() {
    let mut rng = Rng::new(42);
    let config = AccelSixPositionConfig::MPS2;
    let mut six = AccelSixPosition::new(config).unwrap();
    for p in Position::ALL {
        let f = scale(up_vector(p, 0.0), 9.806_65);
        for _ in 0..config.window {
            let r = to64(raw(f, &mut rng));
            six.push(to32(r)).unwrap();
        }
    }
    let cal = six.finish().unwrap();
    for i in 0..3 {
        assert!((f64::from(cal.scale[i]) * GAIN[i] - 1.0).abs() < 1e-3);
    }
    let c = cal.apply(to32([
        OFFSET_G[0],
        OFFSET_G[1],
        GAIN[2] * 9.806_65 + OFFSET_G[2],
    ]));
    assert!((f64::from(c[2]) - 9.806_65).abs() < 0.01);
}

#[test]
fn motion_restarts_the_window_and_captures_nothing() {
    let mut rng = Rng::new(43);
    let mut six = AccelSixPosition::new(AccelSixPositionConfig::G).unwrap();
    let f = up_vector(Position::ZUp, 0.0);
    for _ in 0..100 {
        six.push(raw(f, &mut rng)).unwrap();
    }
    // A bump of 0.2 g on x.
    let mut r = raw(f, &mut rng);
    r[0] += 0.2;
    assert!(matches!(
        six.push(r),
        Err(Error::Moved {
            check: MotionCheck::AccelSpread,
            axis: 0,
            ..
        })
    ));
    assert_eq!(six.progress().count(), 0);
    // The window restarted with the bump sample; going back to still data
    // also exceeds the spread once, then a fresh window completes.
    let back = six.push(raw(f, &mut rng));
    assert!(matches!(back, Err(Error::Moved { .. })));
    let mut last = None;
    for _ in 0..six_window() - 1 {
        last = Some(six.push(raw(f, &mut rng)).unwrap());
    }
    assert_eq!(last, Some(SixPositionEvent::Captured(Position::ZUp)));
}

#[test]
fn vibration_fails_the_std_dev_test() {
    let mut rng = Rng::new(44);
    let config = AccelSixPositionConfig {
        max_spread: f32::INFINITY,
        ..AccelSixPositionConfig::G
    };
    let mut six = AccelSixPosition::new(config).unwrap();
    let mut result = Ok(SixPositionEvent::Collecting { samples: 0 });
    for _ in 0..config.window {
        let mut r = raw(up_vector(Position::XUp, 0.0), &mut rng);
        r[1] += (0.05 * rng.gauss()) as f32;
        result = six.push(r);
    }
    assert!(matches!(
        result,
        Err(Error::Moved {
            check: MotionCheck::AccelStdDev,
            axis: 1,
            ..
        })
    ));
    assert_eq!(six.progress().count(), 0);
}

#[test]
fn tilted_or_wrong_magnitude_windows_are_refused() {
    let mut rng = Rng::new(45);
    let mut six = AccelSixPosition::new(AccelSixPositionConfig::G).unwrap();
    // 45° between two axes.
    let f = [
        core::f64::consts::FRAC_1_SQRT_2,
        0.0,
        core::f64::consts::FRAC_1_SQRT_2,
    ];
    let mut res = Ok(SixPositionEvent::Collecting { samples: 0 });
    for _ in 0..six_window() {
        res = six.push(raw(f, &mut rng));
    }
    assert_eq!(res, Err(Error::NotAxisAligned));
    // Free fall-ish magnitude (0.5 g).
    for _ in 0..six_window() {
        res = six.push(raw([0.0, 0.0, 0.5], &mut rng));
    }
    assert_eq!(res, Err(Error::NotAxisAligned));
    assert_eq!(six.progress().count(), 0);
}

#[test]
fn bad_samples_skipped_discard_and_reset_work() {
    let mut rng = Rng::new(46);
    let mut six = AccelSixPosition::new(AccelSixPositionConfig::G).unwrap();
    let f = up_vector(Position::YDown, 0.0);
    for i in 0..six_window() {
        if i % 10 == 0 {
            assert_eq!(six.push([f32::NAN, 0.0, 0.0]), Err(Error::NonFinite));
            assert_eq!(six.push([0.0, 1.0e7, 0.0]), Err(Error::InputOutOfRange));
        }
        six.push(raw(f, &mut rng)).unwrap();
    }
    assert_eq!(six.rejected(), 40);
    assert!(six.progress().is_done(Position::YDown));
    six.discard(Position::YDown);
    assert!(!six.progress().is_done(Position::YDown));
    assert_eq!(six.captured(Position::YDown), None);
    hold(&mut six, Position::YDown, 0.0, &mut rng);
    six.reset();
    assert_eq!(six.progress().count(), 0);
    assert_eq!(six.rejected(), 0);
    let bad = AccelSixPositionConfig {
        gravity: 0.0,
        ..AccelSixPositionConfig::G
    };
    assert!(matches!(
        AccelSixPosition::new(bad),
        Err(Error::InvalidConfig)
    ));
}

#[test]
fn position_bits_and_axes_are_consistent() {
    let mut seen = 0u8;
    for p in Position::ALL {
        assert_eq!(seen & p.bit(), 0);
        seen |= p.bit();
        let f = up_vector(p, 0.0);
        assert_eq!(f[p.axis() as usize] > 0.0, p.is_up());
    }
    assert_eq!(seen, 0x3F);
}
