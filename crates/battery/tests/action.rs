//! The low-battery action rule and the pilot's override of the descent.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use battery::*;

const ONE_Q30: i32 = 1 << 30;

/// Armed, in the air, barometer running, link up.
const FLYING: FlightContext = FlightContext {
    armed: true,
    in_air: true,
    altitude_available: true,
    link_ok: true,
};

/// Sticks centred, throttle at `throttle` (0..1).
fn sticks(throttle: f64) -> SticksQ30 {
    SticksQ30 {
        throttle_q30: (throttle * f64::from(ONE_Q30)) as i32,
        ..SticksQ30::default()
    }
}

fn q30(x: f64) -> i32 {
    (x * f64::from(ONE_Q30)) as i32
}

const DESCEND: BatteryAction = BatteryAction::Descend {
    descent_mps_q16: 1 << 15,
};

fn guard() -> LowBatteryDescent {
    LowBatteryDescent::new(DescentConfig::DEFAULT).unwrap()
}

#[test]
fn the_default_descent_is_half_a_metre_per_second() {
    assert_eq!(
        DescentConfig::DEFAULT.descent_mps_q16,
        (0.5 * 65_536.0) as i32
    );
    assert_eq!(DescentConfig::DEFAULT.stick_deadband_q30, q30(0.2));
}

#[test]
fn levels_map_to_actions() {
    let d = DescentConfig::DEFAULT;
    let rule = |level, ctx: &FlightContext| battery_action(level, ctx, false, false, &d);
    assert_eq!(rule(Level::NoBattery, &FLYING), BatteryAction::None);
    assert_eq!(rule(Level::Ok, &FLYING), BatteryAction::None);
    assert_eq!(rule(Level::Warning, &FLYING), BatteryAction::Warn);
    assert_eq!(rule(Level::Critical, &FLYING), DESCEND);
    // Critical without the barometer: a warning only.
    let no_baro = FlightContext {
        altitude_available: false,
        ..FLYING
    };
    assert_eq!(rule(Level::Critical, &no_baro), BatteryAction::Warn);
    // On the ground or disarmed: a warning only.
    let ground = FlightContext {
        in_air: false,
        ..FLYING
    };
    assert_eq!(rule(Level::Critical, &ground), BatteryAction::Warn);
    let disarmed = FlightContext {
        armed: false,
        ..FLYING
    };
    assert_eq!(rule(Level::Critical, &disarmed), BatteryAction::Warn);
    // The link lost: the descent stands (the link-loss failsafe flies).
    let no_link = FlightContext {
        link_ok: false,
        ..FLYING
    };
    assert_eq!(rule(Level::Critical, &no_link), DESCEND);
}

#[test]
fn a_descent_under_way_continues_after_touch_down_until_disarmed() {
    let d = DescentConfig::DEFAULT;
    let landed = FlightContext {
        in_air: false,
        ..FLYING
    };
    assert_eq!(
        battery_action(Level::Critical, &landed, true, false, &d),
        DESCEND
    );
    assert_eq!(
        battery_action(Level::Critical, &landed, true, true, &d),
        BatteryAction::Warn
    );
    let mut g = guard();
    assert_eq!(g.update(Level::Critical, &FLYING, &sticks(0.5)), DESCEND);
    assert_eq!(g.update(Level::Critical, &landed, &sticks(0.5)), DESCEND);
    // The landing detector disarms: the next flight starts afresh.
    let disarmed = FlightContext {
        armed: false,
        ..landed
    };
    assert_eq!(
        g.update(Level::Critical, &disarmed, &sticks(0.0)),
        BatteryAction::Warn
    );
    assert_eq!(g.phase(), DescentPhase::Idle);
}

#[test]
fn centred_sticks_and_a_still_throttle_keep_the_descent() {
    let mut g = guard();
    for i in 0..1000 {
        // Sticks within 0.2, the throttle within 0.2 of where it began.
        let wobble = f64::from(i % 7) * 0.02 - 0.06;
        let s = SticksQ30 {
            roll_q30: q30(0.19),
            pitch_q30: q30(-0.19),
            yaw_q30: q30(wobble),
            throttle_q30: q30(0.5 + wobble),
        };
        assert_eq!(g.update(Level::Critical, &FLYING, &s), DESCEND, "step {i}");
    }
    assert!(matches!(
        g.phase(),
        DescentPhase::Descending {
            throttle_at_start_q30: Some(t)
        } if t == q30(0.5 - 0.06)
    ));
}

#[test]
fn any_stick_beyond_the_deadband_hands_control_back_for_the_flight() {
    let moves: [fn(&mut SticksQ30); 6] = [
        |s| s.roll_q30 = q30(0.21),
        |s| s.roll_q30 = q30(-0.21),
        |s| s.pitch_q30 = q30(0.3),
        |s| s.yaw_q30 = q30(-0.5),
        |s| s.throttle_q30 = q30(0.71), // 0.5 + 0.21
        |s| s.throttle_q30 = q30(0.29), // 0.5 − 0.21
    ];
    for (k, mv) in moves.iter().enumerate() {
        let mut g = guard();
        assert_eq!(g.update(Level::Critical, &FLYING, &sticks(0.5)), DESCEND);
        let mut s = sticks(0.5);
        mv(&mut s);
        assert_eq!(
            g.update(Level::Critical, &FLYING, &s),
            BatteryAction::Warn,
            "move {k}"
        );
        assert_eq!(g.phase(), DescentPhase::PilotControl);
        // Sticks back to centre: the pilot keeps control, warned.
        for _ in 0..100 {
            assert_eq!(
                g.update(Level::Critical, &FLYING, &sticks(0.5)),
                BatteryAction::Warn
            );
        }
    }
}

#[test]
fn a_pilot_flying_when_the_descent_would_begin_keeps_control() {
    let mut g = guard();
    let s = SticksQ30 {
        pitch_q30: q30(0.6),
        ..sticks(0.7)
    };
    assert_eq!(g.update(Level::Critical, &FLYING, &s), BatteryAction::Warn);
    assert_eq!(g.phase(), DescentPhase::PilotControl);
}

#[test]
fn with_the_link_lost_the_sticks_are_not_read() {
    let no_link = FlightContext {
        link_ok: false,
        ..FLYING
    };
    let mut g = guard();
    // The descent begins while the link is down: garbage sticks ignored.
    let garbage = SticksQ30 {
        roll_q30: ONE_Q30,
        pitch_q30: -ONE_Q30,
        yaw_q30: i32::MIN,
        throttle_q30: ONE_Q30,
    };
    assert_eq!(g.update(Level::Critical, &no_link, &garbage), DESCEND);
    assert!(matches!(
        g.phase(),
        DescentPhase::Descending {
            throttle_at_start_q30: None
        }
    ));
    // The link is back: the throttle then is the reference.
    assert_eq!(g.update(Level::Critical, &FLYING, &sticks(0.3)), DESCEND);
    assert_eq!(g.update(Level::Critical, &FLYING, &sticks(0.45)), DESCEND);
    assert_eq!(
        g.update(Level::Critical, &FLYING, &sticks(0.55)),
        BatteryAction::Warn
    );
}

#[test]
fn losing_the_barometer_in_the_descent_hands_control_back_for_good() {
    let mut g = guard();
    assert_eq!(g.update(Level::Critical, &FLYING, &sticks(0.5)), DESCEND);
    let no_baro = FlightContext {
        altitude_available: false,
        ..FLYING
    };
    assert_eq!(
        g.update(Level::Critical, &no_baro, &sticks(0.5)),
        BatteryAction::Warn
    );
    assert_eq!(g.phase(), DescentPhase::PilotControl);
    // The barometer returns: no descent resumes in this flight.
    assert_eq!(
        g.update(Level::Critical, &FLYING, &sticks(0.5)),
        BatteryAction::Warn
    );
}

#[test]
fn a_warning_never_takes_control() {
    let mut g = guard();
    let s = sticks(0.5);
    for ctx in [
        FLYING,
        FlightContext {
            link_ok: false,
            ..FLYING
        },
    ] {
        assert_eq!(g.update(Level::Warning, &ctx, &s), BatteryAction::Warn);
        assert_eq!(g.phase(), DescentPhase::Idle);
    }
}

#[test]
fn descent_settings_out_of_range_are_refused() {
    type Change = fn(&mut DescentConfig);
    let cases: [(Change, Setting); 7] = [
        (|c| c.descent_mps_q16 = 6_553, Setting::DescentRate), // < 0.1 m/s
        (|c| c.descent_mps_q16 = 196_609, Setting::DescentRate), // > 3 m/s
        (|c| c.descent_mps_q16 = -32_768, Setting::DescentRate),
        (|c| c.stick_deadband_q30 = q30(0.04), Setting::StickDeadband),
        (|c| c.stick_deadband_q30 = q30(0.51), Setting::StickDeadband),
        (|c| c.throttle_move_q30 = 0, Setting::ThrottleMove),
        (|c| c.throttle_move_q30 = q30(0.6), Setting::ThrottleMove),
    ];
    for (change, setting) in cases {
        let mut cfg = DescentConfig::DEFAULT;
        change(&mut cfg);
        assert_eq!(
            LowBatteryDescent::new(cfg).unwrap_err(),
            Error::Setting(setting)
        );
    }
    // The bounds themselves: 0.1 and 3 m/s, 0.05 and 0.5.
    let ok = DescentConfig {
        descent_mps_q16: 6_554,
        stick_deadband_q30: ONE_Q30 / 20,
        throttle_move_q30: ONE_Q30 / 2,
    };
    assert!(LowBatteryDescent::new(ok).is_ok());
    let fast = DescentConfig {
        descent_mps_q16: 3 << 16,
        ..DescentConfig::DEFAULT
    };
    assert!(LowBatteryDescent::new(fast).is_ok());
}
