//! Attitude controller against a simple rigid-body axis model, plus API checks.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use control::controllers::{
    AltitudeHold, AltitudeHoldConfig, Attitude, AttitudeConfig, AttitudeController, AttitudeTarget,
    BodyRates, YawTarget,
};
use control::Error;

const DT: f32 = 0.001;

/// One rotational axis: angular acceleration = `alpha_per_unit` × torque
/// command through a 20 ms motor lag, with light aerodynamic damping.
#[derive(Default, Clone, Copy)]
struct Axis {
    angle_rad: f32,
    rate_rps: f32,
    torque: f32,
    /// Constant disturbance torque (e.g. off-centre battery), command units.
    disturbance: f32,
}

impl Axis {
    fn step(&mut self, cmd: f32, alpha_per_unit: f32) {
        self.torque += (cmd - self.torque) * DT / 0.02;
        let acc = alpha_per_unit * (self.torque + self.disturbance) - 0.5 * self.rate_rps;
        self.rate_rps += acc * DT;
        self.angle_rad += self.rate_rps * DT;
    }
}

fn run(
    target: AttitudeTarget,
    seconds: f32,
    roll_disturbance: f32,
) -> (Vec<[f32; 3]>, AttitudeController) {
    let mut ctl = AttitudeController::new(AttitudeConfig::default()).unwrap();
    let (mut r, mut p, mut y) = (Axis::default(), Axis::default(), Axis::default());
    r.disturbance = roll_disturbance;
    let mut trace = Vec::new();
    for _ in 0..(seconds / DT) as usize {
        let att = Attitude {
            roll_rad: r.angle_rad,
            pitch_rad: p.angle_rad,
            yaw_rad: y.angle_rad,
        };
        let rates = BodyRates {
            roll_rps: r.rate_rps,
            pitch_rps: p.rate_rps,
            yaw_rps: y.rate_rps,
        };
        let tq = ctl.update(&target, &att, &rates, DT).unwrap();
        assert!(tq.roll.abs() <= 1.0 && tq.pitch.abs() <= 1.0 && tq.yaw.abs() <= 1.0);
        r.step(tq.roll, 100.0);
        p.step(tq.pitch, 100.0);
        y.step(tq.yaw, 30.0);
        trace.push([r.angle_rad, p.angle_rad, y.rate_rps]);
    }
    (trace, ctl)
}

#[test]
fn roll_step_settles_and_rejects_disturbance() {
    let target = AttitudeTarget {
        roll_rad: 0.3,
        pitch_rad: -0.2,
        yaw: YawTarget::Rate(0.0),
    };
    let (trace, ctl) = run(target, 3.0, 0.05);
    let peak = trace.iter().map(|s| s[0]).fold(f32::MIN, f32::max);
    let last_out = trace
        .iter()
        .rposition(|s| (s[0] - 0.3).abs() > 0.015)
        .unwrap_or(0);
    println!(
        "roll: overshoot {:.1} %, settle {:.3} s",
        (peak / 0.3 - 1.0) * 100.0,
        last_out as f32 * DT
    );
    assert!(peak < 0.3 * 1.15, "overshoot {peak}");
    assert!(
        (last_out as f32) * DT < 1.5,
        "settle {}",
        last_out as f32 * DT
    );
    let end = trace.last().unwrap();
    // The integral cancels the constant disturbance: no steady-state error.
    assert!((end[0] - 0.3).abs() < 0.005, "{}", end[0]);
    assert!((end[1] + 0.2).abs() < 0.005, "{}", end[1]);
    assert!(
        (ctl.integrals().roll + 0.05).abs() < 0.01,
        "{:?}",
        ctl.integrals()
    );
}

#[test]
fn yaw_rate_and_heading_hold() {
    let target = AttitudeTarget {
        roll_rad: 0.0,
        pitch_rad: 0.0,
        yaw: YawTarget::Rate(1.0),
    };
    let (trace, _) = run(target, 3.0, 0.0);
    let r = trace.last().unwrap()[2];
    assert!((r - 1.0).abs() < 0.02, "yaw rate {r}");

    // Heading hold: from 0 to 0.5 rad.
    let mut ctl = AttitudeController::new(AttitudeConfig::default()).unwrap();
    let mut y = Axis::default();
    let target = AttitudeTarget {
        roll_rad: 0.0,
        pitch_rad: 0.0,
        yaw: YawTarget::Angle(0.5),
    };
    for _ in 0..5000 {
        let att = Attitude {
            yaw_rad: y.angle_rad,
            ..Attitude::default()
        };
        let rates = BodyRates {
            yaw_rps: y.rate_rps,
            ..BodyRates::default()
        };
        let tq = ctl.update(&target, &att, &rates, DT).unwrap();
        y.step(tq.yaw, 30.0);
    }
    assert!((y.angle_rad - 0.5).abs() < 0.01, "{}", y.angle_rad);
}

#[test]
fn rate_setpoint_limited_by_max_rate() {
    let cfg = AttitudeConfig::default();
    let mut ctl = AttitudeController::new(cfg).unwrap();
    let target = AttitudeTarget {
        roll_rad: 3.0,
        pitch_rad: -3.0,
        yaw: YawTarget::Angle(3.0),
    };
    ctl.update(&target, &Attitude::default(), &BodyRates::default(), DT)
        .unwrap();
    let sp = ctl.rate_setpoint();
    assert_eq!(sp.roll_rps, cfg.roll.max_rate_rps);
    assert_eq!(sp.pitch_rps, -cfg.pitch.max_rate_rps);
    assert_eq!(sp.yaw_rps, cfg.yaw.max_rate_rps);
}

#[test]
fn attitude_errors_leave_state_untouched() {
    let mut ctl = AttitudeController::new(AttitudeConfig::default()).unwrap();
    let ok = AttitudeTarget {
        roll_rad: 0.1,
        pitch_rad: 0.1,
        yaw: YawTarget::Rate(0.1),
    };
    for _ in 0..100 {
        ctl.update(&ok, &Attitude::default(), &BodyRates::default(), DT)
            .unwrap();
    }
    let before = ctl;
    let bad_yaw = AttitudeTarget {
        yaw: YawTarget::Angle(f32::NAN),
        ..ok
    };
    assert_eq!(
        ctl.update(&bad_yaw, &Attitude::default(), &BodyRates::default(), DT),
        Err(Error::NonFinite)
    );
    let bad_rates = BodyRates {
        yaw_rps: f32::INFINITY,
        ..BodyRates::default()
    };
    assert_eq!(
        ctl.update(&ok, &Attitude::default(), &bad_rates, DT),
        Err(Error::NonFinite)
    );
    let bad_att = Attitude {
        pitch_rad: f32::NAN,
        ..Attitude::default()
    };
    assert_eq!(
        ctl.update(&ok, &bad_att, &BodyRates::default(), DT),
        Err(Error::NonFinite)
    );
    assert_eq!(
        ctl.update(&ok, &Attitude::default(), &BodyRates::default(), 0.0),
        Err(Error::InvalidDt)
    );
    assert_eq!(ctl.reset(&bad_rates), Err(Error::NonFinite));
    assert_eq!(ctl, before);
    // Reset: integrals zero, no D kick from the rates it was given.
    let rates = BodyRates {
        roll_rps: 0.5,
        pitch_rps: -0.2,
        yaw_rps: 0.1,
    };
    ctl.reset(&rates).unwrap();
    assert_eq!(ctl.integrals().roll, 0.0);
    let tq = ctl.update_rates(&rates, &rates, DT).unwrap();
    assert!(tq.roll.abs() < 1e-6 && tq.pitch.abs() < 1e-6 && tq.yaw.abs() < 1e-6);
}

#[test]
fn config_validation() {
    let mut cfg = AttitudeConfig::default();
    cfg.pitch.angle_kp = -1.0;
    assert_eq!(
        AttitudeController::new(cfg).unwrap_err(),
        Error::NegativeGain
    );
    let mut cfg = AttitudeConfig::default();
    cfg.yaw.max_rate_rps = 0.0;
    assert_eq!(
        AttitudeController::new(cfg).unwrap_err(),
        Error::InvalidParameter
    );

    let a = AltitudeHoldConfig {
        hover_throttle: 1.2,
        ..AltitudeHoldConfig::default()
    };
    assert_eq!(AltitudeHold::new(a).unwrap_err(), Error::InvalidLimits);
    let a = AltitudeHoldConfig {
        height_kp: f32::NAN,
        ..AltitudeHoldConfig::default()
    };
    assert_eq!(AltitudeHold::new(a).unwrap_err(), Error::NegativeGain);
    let a = AltitudeHoldConfig {
        max_descent_mps: -1.0,
        ..AltitudeHoldConfig::default()
    };
    assert_eq!(AltitudeHold::new(a).unwrap_err(), Error::InvalidParameter);
}

#[test]
fn altitude_hold_api() {
    let cfg = AltitudeHoldConfig::default();
    let mut hold = AltitudeHold::new(cfg).unwrap();
    // Far below: speed setpoint limited to max climb.
    hold.update(100.0, 0.0, 0.0, DT).unwrap();
    assert_eq!(hold.speed_setpoint_mps(), cfg.max_climb_mps);
    hold.update(0.0, 100.0, 0.0, DT).unwrap();
    assert_eq!(hold.speed_setpoint_mps(), -cfg.max_descent_mps);
    // Bumpless engage at the pilot's throttle.
    hold.reset(0.3, 0.62).unwrap();
    let t = hold.update(7.0, 7.0, 0.3, DT).unwrap();
    // Exactly bumpless up to one integration step (ki · e · dt = 1.5e-4).
    assert!((t - 0.62).abs() < 2e-4, "{t}");
    let before = hold;
    assert_eq!(hold.update(f32::NAN, 7.0, 0.0, DT), Err(Error::NonFinite));
    assert_eq!(
        hold.update(7.0, 7.0, f32::INFINITY, DT),
        Err(Error::NonFinite)
    );
    assert_eq!(hold.update(7.0, 7.0, 0.0, -1.0), Err(Error::InvalidDt));
    assert_eq!(hold.reset(f32::NAN, 0.5), Err(Error::NonFinite));
    assert_eq!(hold, before);
    // Throttle within 0..1 whatever the error.
    for h in [-1e30f32, -5.0, 0.0, 5.0, 1e30] {
        for v in [-1e30f32, -3.0, 0.0, 3.0, 1e30] {
            let t = hold.update(0.0, h, v, DT).unwrap();
            assert!((0.0..=1.0).contains(&t));
        }
    }
}
