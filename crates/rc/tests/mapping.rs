//! Channel order, calibration, deadband, switches and their validation.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use proptest::prelude::*;
use rc_input::{
    Axis, ChannelMap, ChannelOrder, ChannelRange, ConfigError, MissingChannel, RcFrame,
    SwitchPosition,
};

fn frame(pairs: &[(usize, u16)], count: u8) -> RcFrame {
    let mut ch = [1500u16; 16];
    for &(i, us) in pairs {
        ch[i] = us;
    }
    RcFrame::new(ch, count)
}

#[test]
fn orders_put_each_stick_on_its_channel() {
    let aetr = ChannelOrder::AETR;
    assert_eq!(
        [Axis::Roll, Axis::Pitch, Axis::Throttle, Axis::Yaw].map(|a| aetr.channel(a)),
        [0, 1, 2, 3]
    );
    let taer = ChannelOrder::TAER;
    assert_eq!(
        [Axis::Throttle, Axis::Roll, Axis::Pitch, Axis::Yaw].map(|a| taer.channel(a)),
        [0, 1, 2, 3]
    );
    let reta = ChannelOrder::from_letters("RETA").unwrap();
    assert_eq!(reta.channel(Axis::Yaw), 0);
    assert_eq!(reta.channel(Axis::Roll), 3);
}

#[test]
fn bad_orders_are_rejected() {
    for s in ["", "AET", "AETRX", "AETT", "AEXR", "ÄETR"] {
        assert_eq!(
            ChannelOrder::from_letters(s),
            Err(ConfigError::BadChannelOrder),
            "{s}"
        );
    }
    assert_eq!(
        ChannelOrder::new(0, 1, 2, 16),
        Err(ConfigError::ChannelOutOfRange { channel: 16 })
    );
    assert_eq!(
        ChannelOrder::new(0, 1, 1, 3),
        Err(ConfigError::DuplicateChannel { channel: 1 })
    );
    assert!(ChannelOrder::new(7, 6, 5, 4).is_ok());
}

#[test]
fn sticks_follow_the_order() {
    let map = ChannelMap::new(ChannelOrder::TAER);
    let f = frame(&[(0, 1000), (1, 2000), (2, 1000), (3, 1750)], 8);
    let s = map.sticks(&f).unwrap();
    assert_eq!(s.throttle, 0.0);
    assert_eq!(s.roll, 1.0);
    assert_eq!(s.pitch, -1.0);
    // (250 − 5) / (500 − 5) with the default 5 µs deadband.
    assert!((s.yaw - 245.0 / 495.0).abs() < 1e-6);
}

#[test]
fn calibration_maps_the_measured_ends_to_full_deflection() {
    let map = ChannelMap::DEFAULT
        .with_range(Axis::Roll, ChannelRange::new(1020, 1510, 1990).unwrap())
        .unwrap()
        .with_range(Axis::Throttle, ChannelRange::new(1100, 1500, 1900).unwrap())
        .unwrap();
    let at = |roll, thr| map.sticks(&frame(&[(0, roll), (2, thr)], 16)).unwrap();
    assert_eq!(at(1020, 1100).roll, -1.0);
    assert_eq!(at(1990, 1900).roll, 1.0);
    assert_eq!(at(1510, 1500).roll, 0.0);
    assert_eq!(at(1500, 1100).throttle, 0.0);
    assert_eq!(at(1500, 1900).throttle, 1.0);
    assert!((at(1500, 1500).throttle - 0.5).abs() < 1e-6);
    // Beyond the calibrated ends: clamped, never beyond ±1 / 0..1.
    assert_eq!(at(900, 1000).roll, -1.0);
    assert_eq!(at(900, 1000).throttle, 0.0);
    assert_eq!(at(2100, 2100).throttle, 1.0);
}

#[test]
fn deadband_is_zero_inside_and_continuous_at_its_edge() {
    let map = ChannelMap::DEFAULT.with_deadband_us(20).unwrap();
    let roll = |us| map.axis(&frame(&[(0, us)], 16), Axis::Roll).unwrap();
    assert_eq!(roll(1480), 0.0);
    assert_eq!(roll(1520), 0.0);
    assert!(roll(1521) > 0.0 && roll(1521) < 0.003);
    assert!(roll(1479) < 0.0 && roll(1479) > -0.003);
    assert_eq!(roll(2000), 1.0);
    assert_eq!(roll(1000), -1.0);
}

#[test]
fn reversed_axes() {
    let map = ChannelMap::DEFAULT
        .with_reversed(Axis::Pitch, true)
        .with_reversed(Axis::Throttle, true);
    let s = map.sticks(&frame(&[(1, 2000), (2, 1250)], 16)).unwrap();
    assert_eq!(s.pitch, -1.0);
    assert!((s.throttle - 0.75).abs() < 1e-6);
}

#[test]
fn invalid_ranges_and_deadbands_are_rejected() {
    for (min, c, max) in [
        (700, 1500, 2000),
        (1000, 1500, 2300),
        (1450, 1500, 2000),
        (1000, 1500, 1550),
        (1600, 1500, 1400),
    ] {
        assert_eq!(
            ChannelRange::new(min, c, max),
            Err(ConfigError::BadRange {
                min_us: min,
                center_us: c,
                max_us: max
            })
        );
    }
    assert_eq!(
        ChannelMap::DEFAULT.with_deadband_us(451),
        Err(ConfigError::DeadbandTooWide { deadband_us: 451 })
    );
    assert!(ChannelMap::DEFAULT.with_deadband_us(450).is_ok());
    // A narrow range then no longer fits the existing deadband.
    let wide = ChannelMap::DEFAULT.with_deadband_us(100).unwrap();
    assert_eq!(
        wide.with_range(Axis::Yaw, ChannelRange::new(1340, 1480, 1640).unwrap()),
        Err(ConfigError::DeadbandTooWide { deadband_us: 100 })
    );
    // Throttle has no centre deadband.
    assert!(wide
        .with_range(Axis::Throttle, ChannelRange::new(1340, 1480, 1640).unwrap())
        .is_ok());
}

#[test]
fn switch_positions_and_the_arm_switch() {
    assert_eq!(SwitchPosition::from_us(1000), SwitchPosition::Low);
    assert_eq!(SwitchPosition::from_us(1299), SwitchPosition::Low);
    assert_eq!(SwitchPosition::from_us(1300), SwitchPosition::Middle);
    assert_eq!(SwitchPosition::from_us(1700), SwitchPosition::Middle);
    assert_eq!(SwitchPosition::from_us(1701), SwitchPosition::High);
    let map = ChannelMap::DEFAULT;
    assert_eq!(map.arm_channel(), 4);
    assert!(map.arm_switch(&frame(&[(4, 1900)], 16)).unwrap());
    assert!(!map.arm_switch(&frame(&[(4, 1500)], 16)).unwrap());
    assert_eq!(
        ChannelMap::switch(&frame(&[(6, 1000)], 16), 6),
        Ok(SwitchPosition::Low)
    );
    let low_arm = map.with_arm_switch(7, SwitchPosition::Low).unwrap();
    assert!(low_arm.arm_switch(&frame(&[(7, 1000)], 16)).unwrap());
    assert_eq!(
        map.with_arm_switch(2, SwitchPosition::High),
        Err(ConfigError::DuplicateChannel { channel: 2 })
    );
    assert_eq!(
        map.with_arm_switch(16, SwitchPosition::High),
        Err(ConfigError::ChannelOutOfRange { channel: 16 })
    );
}

#[test]
fn aux_switches_use_the_radio_numbering() {
    let f = frame(&[(4, 1000), (5, 1500), (15, 2000)], 16);
    assert_eq!(ChannelMap::aux(&f, 1), Ok(SwitchPosition::Low));
    assert_eq!(ChannelMap::aux(&f, 2), Ok(SwitchPosition::Middle));
    assert_eq!(ChannelMap::aux(&f, 12), Ok(SwitchPosition::High));
    assert_eq!(
        ChannelMap::aux(&f, 0),
        Err(MissingChannel {
            channel: u8::MAX,
            count: 16
        })
    );
    assert!(ChannelMap::aux(&f, 13).is_err());
    assert_eq!(
        ChannelMap::aux(&frame(&[], 6), 3),
        Err(MissingChannel {
            channel: 6,
            count: 6
        })
    );
}

#[test]
fn a_short_ppm_frame_lacks_the_arm_channel() {
    let map = ChannelMap::DEFAULT;
    let four = frame(&[], 4);
    assert!(map.sticks(&four).is_ok());
    assert_eq!(
        map.arm_switch(&four),
        Err(MissingChannel {
            channel: 4,
            count: 4
        })
    );
    let err = map.arm_switch(&four).unwrap_err().to_string();
    assert!(err.contains("4 channels"), "{err}");
}

#[test]
fn errors_say_what_is_wrong() {
    let e = ChannelRange::new(1450, 1500, 2000).unwrap_err().to_string();
    assert!(e.contains("1450/1500/2000"), "{e}");
    assert!(ConfigError::BadChannelOrder.to_string().contains("AETR"));
}

proptest! {
    #[test]
    fn sticks_stay_in_range_for_any_pulse_widths(
        ch in prop::array::uniform16(any::<u16>()),
        db in 0u16..=450,
        rev in any::<[bool; 4]>(),
    ) {
        let mut map = ChannelMap::DEFAULT.with_deadband_us(db).unwrap();
        for (axis, r) in Axis::ALL.into_iter().zip(rev) {
            map = map.with_reversed(axis, r);
        }
        let s = map.sticks(&RcFrame::new(ch, 16)).unwrap();
        for v in [s.roll, s.pitch, s.yaw] {
            prop_assert!((-1.0..=1.0).contains(&v));
        }
        prop_assert!((0.0..=1.0).contains(&s.throttle));
    }

    #[test]
    fn sticks_are_monotonic(a in 800u16..2200, b in 800u16..2200) {
        let map = ChannelMap::DEFAULT;
        let roll = |us| map.axis(&frame(&[(0, us)], 16), Axis::Roll).unwrap();
        let thr = |us| map.axis(&frame(&[(2, us)], 16), Axis::Throttle).unwrap();
        let (lo, hi) = (a.min(b), a.max(b));
        prop_assert!(roll(lo) <= roll(hi));
        prop_assert!(thr(lo) <= thr(hi));
    }
}
