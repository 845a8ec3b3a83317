//! The event timeline of a closed-loop flight, in time order: what the
//! flight controller reported (arming, failsafe phases, disarm causes, as
//! the status lines print them), what the script did to the craft (link
//! lost and back, a motor failing) and what the model's truth shows
//! (lift-off, touch-down). The plot marks them on its time axis; the
//! scenario CSV lists them in its `events` column.

use super::closed_loop::{FlightLog, Sample};

/// Where an event comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// The flight controller's own report (or an injected fault).
    Controller,
    /// The scripted pilot and airframe: radio link, motor failure.
    Script,
    /// The model's true motion: lift-off, touch-down.
    Truth,
}

/// One event.
#[derive(Clone, Debug, PartialEq)]
pub struct TimedEvent {
    /// Simulated time (s): the sample at or after which it happened.
    pub t_s: f64,
    /// What happened: the controller's events as the status lines and the
    /// board's log word them (`disarmed: failsafe: landed`), the others
    /// too (`link lost`, `touch-down`).
    pub text: String,
    /// Who says so.
    pub source: Source,
}

/// Ground contact shorter than this does not count as a touch-down or a
/// lift-off (a bounce while the craft tumbles), s.
const GROUND_DEBOUNCE_S: f64 = 0.1;

/// Every event of `log`, in time order (ties: controller, script, truth).
pub fn timeline(log: &FlightLog) -> Vec<TimedEvent> {
    let mut events: Vec<TimedEvent> = log
        .events
        .iter()
        .map(|(t, e)| TimedEvent {
            t_s: *t,
            text: e.clone(),
            source: Source::Controller,
        })
        .collect();
    events.extend(script_events(log));
    events.extend(ground_events(&log.samples));
    events.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    events
}

/// Link lost / link back (the frames the script sends) and motors failing.
fn script_events(log: &FlightLog) -> Vec<TimedEvent> {
    let mut out = Vec::new();
    let at = |t_s: f64, text: String| TimedEvent {
        t_s,
        text,
        source: Source::Script,
    };
    for w in log.samples.windows(2) {
        let [a, b] = w else { continue };
        match (a.pilot.is_some(), b.pilot.is_some()) {
            (true, false) => out.push(at(b.t_s, "link lost".into())),
            (false, true) => out.push(at(b.t_s, "link back".into())),
            _ => {}
        }
        for motor in 0..4 {
            let failed = |s: &Sample| log.scenario.motor_failed(motor, s.t_s);
            if !failed(a) && failed(b) {
                out.push(at(b.t_s, format!("motor {} failed", motor + 1)));
            }
        }
    }
    out
}

/// Lift-off and touch-down: changes of the model's ground contact that
/// last at least [`GROUND_DEBOUNCE_S`].
fn ground_events(samples: &[Sample]) -> Vec<TimedEvent> {
    let mut out = Vec::new();
    let Some(first) = samples.first() else {
        return out;
    };
    let mut on_ground = first.quad.on_ground;
    for (i, s) in samples.iter().enumerate() {
        if s.quad.on_ground != on_ground && lasts(samples, i) {
            on_ground = s.quad.on_ground;
            out.push(TimedEvent {
                t_s: s.t_s,
                text: if on_ground { "touch-down" } else { "lift-off" }.into(),
                source: Source::Truth,
            });
        }
    }
    out
}

/// Whether the ground contact of `samples[i]` holds for
/// [`GROUND_DEBOUNCE_S`] (or to the end of the flight).
fn lasts(samples: &[Sample], i: usize) -> bool {
    let Some(s) = samples.get(i) else {
        return false;
    };
    samples
        .iter()
        .skip(i)
        .take_while(|x| x.t_s < s.t_s + GROUND_DEBOUNCE_S)
        .all(|x| x.quad.on_ground == s.quad.on_ground)
}

/// A short label for the plot: the controller's events shortened
/// (`failsafe: hold`, `disarmed: failsafe: landed`), the others as they
/// are.
pub fn label(e: &TimedEvent) -> String {
    let t = e.text.as_str();
    if e.source != Source::Controller {
        return t.to_string();
    }
    if t == "ARMED" {
        return "armed".into();
    }
    if t.starts_with("failsafe: no link: holding") {
        return "failsafe: hold".into();
    }
    if t.starts_with("failsafe cleared") {
        return "failsafe cleared".into();
    }
    if t.starts_with("altitude hold unavailable") {
        return "no altitude: self-level".into();
    }
    // Disarm causes and refusals: up to the first advice after a colon.
    match t.match_indices(": ").nth(1) {
        Some((i, _)) if t.starts_with("disarmed: runaway") => t[..i].to_string(),
        _ => t.to_string(),
    }
}
