//! The figures that judge a closed-loop flight, all measured on the
//! truth (the model's motion), against what the controller aimed at.

use super::closed_loop::{
    FlightLog, Sample, Scenario, CLIMB2_HOLD_S, CLIMB2_S, CLIMB_FROM_S, CLIMB_TO_S, FORWARD_HOLD_S,
    FORWARD_S, LINK_LOSS_S, MOTOR_FAILURE_S, PITCH_STEP_S, ROLL_STEP_S, STEP_HOLD_S, YAW_STEP_S,
};

/// A step response.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepFigures {
    /// Value before the step.
    pub from: f64,
    /// The setpoint after the step.
    pub to: f64,
    /// 10 % → 90 % of the step (s).
    pub rise_s: f64,
    /// Largest excursion beyond the setpoint, % of the step.
    pub overshoot_pct: f64,
    /// Mean of (value − setpoint) over the last 0.5 s of the step.
    pub final_error: f64,
}

/// Measures a step of `value` starting at `t0` and lasting `len`; the
/// setpoint is `setpoint` inside the step (its mean there).
pub fn step_response(
    samples: &[Sample],
    t0: f64,
    len: f64,
    value: impl Fn(&Sample) -> f64,
    setpoint: impl Fn(&Sample) -> Option<f64>,
) -> Option<StepFigures> {
    let before: Vec<f64> = samples
        .iter()
        .filter(|s| s.t_s >= t0 - 0.5 && s.t_s < t0)
        .map(&value)
        .collect();
    let inside: Vec<&Sample> = samples
        .iter()
        .filter(|s| s.t_s >= t0 && s.t_s < t0 + len)
        .collect();
    if before.is_empty() || inside.is_empty() {
        return None;
    }
    let from = mean(&before);
    let sps: Vec<f64> = inside.iter().filter_map(|s| setpoint(s)).collect();
    if sps.is_empty() {
        return None;
    }
    let to = mean(&sps);
    let delta = to - from;
    if delta.abs() < 1e-9 {
        return None;
    }
    let frac = |s: &Sample| (value(s) - from) / delta;
    let t10 = inside.iter().find(|s| frac(s) >= 0.1)?.t_s;
    let t90 = inside.iter().find(|s| frac(s) >= 0.9)?.t_s;
    let peak = inside.iter().map(|s| frac(s)).fold(f64::MIN, f64::max);
    let tail: Vec<f64> = inside
        .iter()
        .filter(|s| s.t_s >= t0 + len - 0.5)
        .map(|s| value(s) - to)
        .collect();
    Some(StepFigures {
        from,
        to,
        rise_s: t90 - t10,
        overshoot_pct: ((peak - 1.0) * 100.0).max(0.0),
        final_error: mean(&tail),
    })
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.iter().sum::<f64>() / v.len() as f64
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        (sum / n as f64).sqrt()
    }
}

fn euler_deg(s: &Sample) -> [f64; 3] {
    s.truth.q_ned_from_body.to_euler().map(f64::to_degrees)
}

/// The AHRS estimate's Euler angles (°): what the angle loop controls.
fn est_euler_deg(s: &Sample) -> [f64; 3] {
    s.est_q.to_euler().map(f64::to_degrees)
}

fn tilt_deg(s: &Sample) -> f64 {
    let e = euler_deg(s);
    // Angle between body down and earth down.
    let (r, p) = (e[0].to_radians(), e[1].to_radians());
    (r.cos() * p.cos()).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Degrees within which the estimator's tilt error counts as recovered
/// after a stick is released.
pub const TILT_RECOVERED_DEG: f64 = 0.5;
/// How long after the release the recovery is watched (s).
pub const TILT_WATCH_S: f64 = 2.0;

/// The estimator's tilt error through a stick step on one axis (roll or
/// pitch): truth − estimate (°), relative to its mean over the 0.5 s of
/// hover before the step, so the static calibration residue does not
/// count; the craft's attitude as the controller sees it against the
/// model's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiltErrorFigures {
    /// RMS over the hold (°).
    pub hold_rms_deg: f64,
    /// Largest |error| over the hold (°).
    pub hold_max_deg: f64,
    /// Largest |error| over the [`TILT_WATCH_S`] after the release (°).
    pub after_max_deg: f64,
    /// Time after the release from which the error stays within
    /// [`TILT_RECOVERED_DEG`] until the end of the watch (s).
    pub recovered_s: f64,
}

/// The tilt error of the step on `axis` (0 roll, 1 pitch) held from `t0`
/// for `len`; `None` if the flight does not cover it.
pub fn tilt_error(samples: &[Sample], t0: f64, len: f64, axis: usize) -> Option<TiltErrorFigures> {
    let err = |s: &Sample| euler_deg(s)[axis] - s.est_q.to_euler()[axis].to_degrees();
    let within = |a: f64, b: f64| samples.iter().filter(move |s| s.t_s >= a && s.t_s < b);
    let before: Vec<f64> = within(t0 - 0.5, t0).map(err).collect();
    if before.is_empty() {
        return None;
    }
    let offset = mean(&before);
    let hold: Vec<f64> = within(t0, t0 + len).map(|s| err(s) - offset).collect();
    let release = t0 + len;
    let after: Vec<(f64, f64)> = within(release, release + TILT_WATCH_S)
        .map(|s| (s.t_s, err(s) - offset))
        .collect();
    if hold.is_empty() || after.last()?.0 < release + TILT_WATCH_S - 0.1 {
        return None;
    }
    let recovered_s = after
        .iter()
        .rev()
        .find(|(_, e)| e.abs() > TILT_RECOVERED_DEG)
        .map_or(0.0, |(t, _)| t - release);
    Some(TiltErrorFigures {
        hold_rms_deg: rms(hold.iter().copied()),
        hold_max_deg: hold.iter().map(|e| e.abs()).fold(0.0, f64::max),
        after_max_deg: after.iter().map(|p| p.1.abs()).fold(0.0, f64::max),
        recovered_s,
    })
}

/// Height hold in a window: RMS and largest |true height − target| (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoldFigures {
    /// RMS error (m).
    pub rms_m: f64,
    /// Largest error (m).
    pub max_m: f64,
    /// Horizontal drift over the window (m).
    pub drift_m: f64,
}

/// Height hold between `t0` and `t1`.
pub fn height_hold(samples: &[Sample], t0: f64, t1: f64) -> Option<HoldFigures> {
    let w: Vec<&Sample> = samples
        .iter()
        .filter(|s| s.t_s >= t0 && s.t_s < t1 && s.out.height_target_m.is_some())
        .collect();
    let (first, last) = (w.first()?, w.last()?);
    let err = |s: &&Sample| s.truth.height_m - f64::from(s.out.height_target_m.unwrap_or(0.0));
    let (a, b) = (first.truth.position_ned_m, last.truth.position_ned_m);
    Some(HoldFigures {
        rms_m: rms(w.iter().map(err)),
        max_m: w.iter().map(|s| err(s).abs()).fold(0.0, f64::max),
        drift_m: ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt(),
    })
}

/// What happened after the radio link was lost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkLossFigures {
    /// Height when the link was lost (m).
    pub height_at_loss_m: f64,
    /// Time from the last radio frame until the controller flew its failsafe (s).
    pub detected_s: Option<f64>,
    /// Largest |height change| during the first second after the loss (m).
    pub hold_deviation_m: f64,
    /// Time from the loss until the body was 0.3 m below that height (s).
    pub descent_starts_s: Option<f64>,
    /// Mean descent speed between 80 % and 20 % of the height (m/s).
    pub descent_mps: Option<f64>,
    /// Time from the loss to touch-down (s).
    pub landed_s: Option<f64>,
    /// Time from the loss to disarm (s).
    pub disarmed_s: Option<f64>,
    /// Largest tilt after the loss, in the air (°).
    pub max_tilt_deg: f64,
}

/// The link-loss figures (`None` when the link was never lost).
pub fn link_loss(samples: &[Sample]) -> Option<LinkLossFigures> {
    let i0 = samples.iter().position(|s| s.pilot.is_none())?;
    let after = samples.get(i0..)?;
    let s0 = after.first()?;
    let (t0, h0) = (s0.t_s, s0.truth.height_m);
    let since = |s: &Sample| s.t_s - t0;
    let hold_deviation_m = after
        .iter()
        .filter(|s| since(s) < 1.0)
        .map(|s| (s.truth.height_m - h0).abs())
        .fold(0.0, f64::max);
    let descent_starts_s = after
        .iter()
        .find(|s| s.truth.height_m < h0 - 0.3)
        .map(since);
    let t80 = after.iter().find(|s| s.truth.height_m < 0.8 * h0);
    let t20 = after.iter().find(|s| s.truth.height_m < 0.2 * h0);
    let descent_mps = match (t80, t20) {
        (Some(a), Some(b)) if b.t_s > a.t_s => Some(0.6 * h0 / (b.t_s - a.t_s)),
        _ => None,
    };
    let landed = after.iter().find(|s| s.truth.height_m < 0.02);
    Some(LinkLossFigures {
        height_at_loss_m: h0,
        detected_s: after.iter().find(|s| s.out.failsafe).map(since),
        hold_deviation_m,
        descent_starts_s,
        descent_mps,
        landed_s: landed.map(since),
        disarmed_s: after.iter().find(|s| !s.out.armed).map(since),
        max_tilt_deg: after
            .iter()
            .filter(|s| !s.quad.on_ground)
            .map(tilt_deg)
            .fold(0.0, f64::max),
    })
}

/// What happened after a motor stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorFailureFigures {
    /// Time from the failure until the controller disarmed (s).
    pub disarmed_s: Option<f64>,
    /// Tilt when it disarmed (°).
    pub tilt_at_disarm_deg: f64,
    /// Largest |body rate| before the disarm (°/s).
    pub max_rate_dps: f64,
    /// Height lost by the disarm (m).
    pub height_lost_m: f64,
}

/// The motor-failure figures (`None` if the flight ended before the failure).
pub fn motor_failure(samples: &[Sample]) -> Option<MotorFailureFigures> {
    let i0 = samples.iter().position(|s| s.t_s >= MOTOR_FAILURE_S)?;
    let after = samples.get(i0..)?;
    let s0 = after.first()?;
    let disarm = after.iter().position(|s| !s.out.armed);
    let flying = after.get(..disarm.unwrap_or(after.len()))?;
    let at = disarm.and_then(|i| after.get(i));
    Some(MotorFailureFigures {
        disarmed_s: at.map(|s| s.t_s - s0.t_s),
        tilt_at_disarm_deg: at.map_or(f64::NAN, tilt_deg),
        max_rate_dps: flying
            .iter()
            .map(|s| sim::math::norm(s.truth.omega_body_rps).to_degrees())
            .fold(0.0, f64::max),
        height_lost_m: at.map_or(f64::NAN, |s| s0.truth.height_m - s.truth.height_m),
    })
}

/// A take-off (with or without a wiring error), from the take-off
/// throttle ([`CLIMB_FROM_S`]) on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunawayFigures {
    /// Time from the take-off throttle until the controller disarmed (s).
    pub disarmed_s: Option<f64>,
    /// Time from the take-off throttle until the body first left the
    /// ground (s).
    pub lift_off_s: Option<f64>,
    /// Time on the ground, armed, before lift-off with the mean motor
    /// command at or above the runaway check's switch-off collective (0.2,
    /// the [`SafetyConfig`](flight::arming::SafetyConfig) default), s: the
    /// most calm time the check can count before the craft flies.
    pub ground_spin_up_s: f64,
    /// Largest tilt until then, or to the end (°).
    pub max_tilt_deg: f64,
    /// Largest height until then, or to the end (m).
    pub max_height_m: f64,
    /// Largest |yaw rate| until then, or to the end (°/s).
    pub max_yaw_rate_dps: f64,
    /// Largest |body rate| until then, or to the end (°/s).
    pub max_rate_dps: f64,
    /// Every sample from the disarm on has the motors off and disarmed.
    pub off_after: bool,
}

impl RunawayFigures {
    /// The figures as a report line.
    pub fn line(&self) -> String {
        format!(
            "take-off: lift-off {} ({:.2} s of it on the ground at a mean motor command ≥ 0.2), disarmed {} after the take-off throttle; until then tilt up to {:.0}°, height {:.2} m, yaw rate {:.0} °/s, body rate {:.0} °/s; motors off after: {}",
            opt(self.lift_off_s, "s"),
            self.ground_spin_up_s,
            opt(self.disarmed_s, "s"),
            self.max_tilt_deg,
            self.max_height_m,
            self.max_yaw_rate_dps,
            self.max_rate_dps,
            self.off_after
        )
    }
}

/// The runaway figures (`None` if the flight ended before the take-off
/// throttle).
pub fn runaway(samples: &[Sample]) -> Option<RunawayFigures> {
    let i0 = samples.iter().position(|s| s.t_s >= CLIMB_FROM_S)?;
    let after = samples.get(i0..)?;
    let s0 = after.first()?;
    let disarm = after.iter().position(|s| !s.out.armed);
    let flying = after.get(..disarm.unwrap_or(after.len()))?;
    let max = |f: &dyn Fn(&Sample) -> f64| flying.iter().map(f).fold(0.0, f64::max);
    Some(RunawayFigures {
        disarmed_s: disarm.and_then(|i| after.get(i)).map(|s| s.t_s - s0.t_s),
        lift_off_s: after
            .iter()
            .find(|s| !s.quad.on_ground)
            .map(|s| s.t_s - s0.t_s),
        ground_spin_up_s: ground_spin_up_s(samples),
        max_tilt_deg: max(&tilt_deg),
        max_height_m: max(&|s| s.truth.height_m),
        max_yaw_rate_dps: max(&|s| s.truth.omega_body_rps[2].abs().to_degrees()),
        max_rate_dps: max(&|s| sim::math::norm(s.truth.omega_body_rps).to_degrees()),
        off_after: disarm.is_some_and(|i| {
            after
                .iter()
                .skip(i)
                .all(|s| !s.out.armed && s.out.motors == [0.0; 4])
        }),
    })
}

/// See [`RunawayFigures::ground_spin_up_s`]: the sample periods on the
/// ground, armed, before the first lift-off, with the mean motor command at
/// or above the check's switch-off collective.
fn ground_spin_up_s(samples: &[Sample]) -> f64 {
    let collective = f64::from(flight::arming::SafetyConfig::default().runaway_off_collective_min);
    let spun_up = |s: &Sample| {
        s.out.armed && s.out.motors.iter().map(|m| f64::from(*m)).sum::<f64>() >= 4.0 * collective
    };
    samples
        .windows(2)
        .take_while(|w| w.iter().all(|s| s.quad.on_ground))
        .filter_map(|w| match w {
            [a, b] if spun_up(b) => Some(b.t_s - a.t_s),
            _ => None,
        })
        .sum()
}

/// Every figure of a flight.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Figures {
    /// Height hold in the hover after the take-off.
    pub hover: Option<HoldFigures>,
    /// Largest attitude estimation error (truth vs AHRS) in the air (°).
    pub max_attitude_error_deg: f64,
    /// Roll stick step (true roll, °).
    pub roll: Option<StepFigures>,
    /// Pitch stick step (true pitch, °).
    pub pitch: Option<StepFigures>,
    /// Yaw stick step (true yaw rate, °/s).
    pub yaw_rate: Option<StepFigures>,
    /// The estimator's roll error through the roll step.
    pub roll_tilt_error: Option<TiltErrorFigures>,
    /// The estimator's pitch error through the pitch step, or through
    /// the forward flight of the altitude-hold script.
    pub pitch_tilt_error: Option<TiltErrorFigures>,
    /// Altitude hold: overshoot above the target after the climb stops (m).
    pub climb_overshoot_m: Option<f64>,
    /// Altitude hold during and 3 s after the forward flight.
    pub forward_hold: Option<HoldFigures>,
    /// Link loss.
    pub link_loss: Option<LinkLossFigures>,
    /// Motor failure.
    pub motor_failure: Option<MotorFailureFigures>,
    /// The take-off (with or without a wiring error).
    pub runaway: Option<RunawayFigures>,
    /// Battery voltage at the end (V).
    pub battery_end_v: f64,
}

/// The figures of `log`'s scenario.
pub fn figures(log: &FlightLog) -> Figures {
    let s = &log.samples;
    let hover_end = match log.scenario {
        Scenario::Takeoff => log.samples.last().map_or(0.0, |x| x.t_s),
        Scenario::Steps => ROLL_STEP_S,
        Scenario::AltHold => CLIMB2_S,
        Scenario::LinkLoss => LINK_LOSS_S,
        Scenario::MotorFailure => MOTOR_FAILURE_S,
        Scenario::Swapped | Scenario::ReversedProp => CLIMB_TO_S,
        Scenario::ClimbLinkLoss => sim::scenario::CLIMB_LOSS_THROTTLE_S,
        Scenario::Flapping => sim::scenario::FLAP_S,
        Scenario::Chirp => sim::scenario::CHIRP_START_S,
        Scenario::LowBattery => CLIMB_TO_S + 10.0,
    };
    let mut f = Figures {
        hover: height_hold(s, CLIMB_TO_S + 3.0, hover_end),
        max_attitude_error_deg: s
            .iter()
            .filter(|x| !x.quad.on_ground)
            .map(|x| x.est_q.angle_to(&x.truth.q_ned_from_body).to_degrees())
            .fold(0.0, f64::max),
        battery_end_v: s.last().map_or(0.0, |x| x.quad.battery_voltage_v),
        ..Figures::default()
    };
    match log.scenario {
        Scenario::Steps => steps(s, &mut f),
        Scenario::AltHold => altitude_hold(s, &mut f),
        Scenario::LinkLoss | Scenario::ClimbLinkLoss | Scenario::Flapping => {
            f.link_loss = link_loss(s)
        }
        Scenario::MotorFailure => f.motor_failure = motor_failure(s),
        Scenario::Swapped | Scenario::ReversedProp | Scenario::Takeoff => f.runaway = runaway(s),
        // The sweep's figures are the loop's frequency response (`tuning`);
        // the pack's, the battery voltage.
        Scenario::Chirp | Scenario::LowBattery => {}
    }
    f
}

/// The steps' figures: the roll and pitch steps of the angle loop on the
/// angle it controls (the estimate: a step's overshoot is the controller's,
/// not the estimator's drift over the hold), the estimator's tilt error
/// (truth − estimate) through the holds apart, and the yaw-rate step on the
/// true rate.
fn steps(s: &[Sample], f: &mut Figures) {
    let tilt_sp = |axis: usize| {
        move |x: &Sample| {
            x.out
                .tilt_setpoint_rad
                .map(|t| f64::from(t[axis]).to_degrees())
        }
    };
    f.roll = step_response(
        s,
        ROLL_STEP_S,
        STEP_HOLD_S,
        |x| est_euler_deg(x)[0],
        tilt_sp(0),
    );
    f.pitch = step_response(
        s,
        PITCH_STEP_S,
        STEP_HOLD_S,
        |x| est_euler_deg(x)[1],
        tilt_sp(1),
    );
    f.roll_tilt_error = tilt_error(s, ROLL_STEP_S, STEP_HOLD_S, 0);
    f.pitch_tilt_error = tilt_error(s, PITCH_STEP_S, STEP_HOLD_S, 1);
    f.yaw_rate = step_response(
        s,
        YAW_STEP_S,
        STEP_HOLD_S,
        |x| x.truth.omega_body_rps[2].to_degrees(),
        |x| {
            x.out
                .rate_setpoint_rps
                .map(|r| f64::from(r[2]).to_degrees())
        },
    );
}

/// The altitude-hold script's figures: the climb's overshoot, the height
/// and the estimator's pitch error through the forward flight.
fn altitude_hold(s: &[Sample], f: &mut Figures) {
    f.pitch_tilt_error = tilt_error(s, FORWARD_S, FORWARD_HOLD_S, 1);
    let stop = CLIMB2_S + CLIMB2_HOLD_S;
    let target = s
        .iter()
        .find(|x| x.t_s >= stop + 0.1)
        .and_then(|x| x.out.height_target_m);
    f.climb_overshoot_m = target.map(|t| {
        s.iter()
            .filter(|x| x.t_s >= stop && x.t_s < FORWARD_S)
            .map(|x| x.truth.height_m - f64::from(t))
            .fold(0.0, f64::max)
    });
    f.forward_hold = height_hold(s, FORWARD_S, FORWARD_S + FORWARD_HOLD_S + 3.0);
}

fn opt(v: Option<f64>, unit: &str) -> String {
    v.map_or("-".to_string(), |x| format!("{x:.2} {unit}"))
}

impl Figures {
    /// The figures as report lines.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(h) = self.hover {
            out.push(format!(
                "hover height error RMS {:.3} m, max {:.3} m; horizontal drift {:.2} m",
                h.rms_m, h.max_m, h.drift_m
            ));
        }
        self.step_lines(&mut out);
        if let Some(o) = self.climb_overshoot_m {
            out.push(format!(
                "altitude hold: overshoot after a full-stick climb {o:.3} m"
            ));
        }
        if let Some(h) = self.forward_hold {
            out.push(format!(
                "altitude hold in 20° forward flight: height error RMS {:.3} m, max {:.3} m",
                h.rms_m, h.max_m
            ));
        }
        self.failure_lines(&mut out);
        out.extend(self.runaway.map(|r| r.line()));
        out.push(format!(
            "attitude estimate vs truth in the air: max error {:.2}°; battery {:.2} V at the end",
            self.max_attitude_error_deg, self.battery_end_v
        ));
        out
    }

    /// The steps' lines and the estimator's tilt error through them.
    fn step_lines(&self, out: &mut Vec<String>) {
        let step = |name: &str, unit: &str, s: &StepFigures| {
            format!(
                "{name} step {:+.1} -> {:+.1} {unit}: rise (10-90 %) {:.3} s, overshoot {:.1} %, error at the end {:+.2} {unit}",
                s.from, s.to, s.rise_s, s.overshoot_pct, s.final_error
            )
        };
        for (name, unit, s) in [
            ("roll (estimate)", "°", &self.roll),
            ("pitch (estimate)", "°", &self.pitch),
            ("yaw rate (truth)", "°/s", &self.yaw_rate),
        ] {
            out.extend(s.as_ref().map(|s| step(name, unit, s)));
        }
        let tilt = |name: &str, e: &TiltErrorFigures| {
            format!(
                "estimator {name} error (truth - estimate) in the hold RMS {:.2}°, max {:.2}°; after the release max {:.2}°, within {TILT_RECOVERED_DEG}° from +{:.2} s",
                e.hold_rms_deg, e.hold_max_deg, e.after_max_deg, e.recovered_s
            )
        };
        for (name, e) in [
            ("roll", &self.roll_tilt_error),
            ("pitch", &self.pitch_tilt_error),
        ] {
            out.extend(e.as_ref().map(|e| tilt(name, e)));
        }
    }

    /// The link-loss and motor-failure lines.
    fn failure_lines(&self, out: &mut Vec<String>) {
        if let Some(l) = self.link_loss {
            out.push(format!(
                "link lost at {:.2} m: failsafe after {}; height within {:.3} m for 1 s; descent from +{} at {}; landed +{}, disarmed +{}; max tilt {:.1}°",
                l.height_at_loss_m,
                opt(l.detected_s, "s"),
                l.hold_deviation_m,
                opt(l.descent_starts_s, "s"),
                opt(l.descent_mps, "m/s"),
                opt(l.landed_s, "s"),
                opt(l.disarmed_s, "s"),
                l.max_tilt_deg
            ));
        }
        if let Some(m) = self.motor_failure {
            out.push(format!(
                "motor 1 stopped: disarmed after {} at {:.0}° of tilt, {:.2} m lower; body rate up to {:.0} °/s",
                opt(m.disarmed_s, "s"),
                m.tilt_at_disarm_deg,
                m.height_lost_m,
                m.max_rate_dps
            ));
        }
    }
}
