//! The plot of a flight in the loop (`cargo fil --scenario NAME --plot
//! FILE`), drawn by the simulator's plotter (`sim::plot::write_panels`,
//! the one `cargo sim --scenario … --plot` uses), panel for panel:
//!
//! * roll and pitch: the model's truth, the firmware's estimate, the
//!   setpoint the sticks ask for;
//! * yaw rate: truth and the sticks' setpoint;
//! * height: truth and the firmware's estimate;
//! * the four ESC pulse widths as the TIM3 pins carry them;
//! * the pilot's sticks and arm switch from the scenario.
//!
//! The firmware's estimate is what it reports, nothing read from its
//! memory: the live log's `att r= p= y= deg | alt= m vz= m/s` line, which
//! the log task prints at 20 Hz, decoded from RTT like every log line and
//! timed when the host read it ([`LogLine::host_time_ns`]). So the estimate
//! is a 20 Hz line up to one RTT poll late, and missing where the log is
//! (the RTT reader stopped, a reset).
//!
//! The setpoints are computed here from the scenario's sticks with the
//! stick shaping of the firmware's flight configuration (`flight`'s
//! default `SticksConfig`, which `firmware/src/config.rs` keeps): tilt in
//! angle and altitude hold, the yaw rate in every mode, none while the arm
//! switch is off or the link is down. The firmware's own setpoint is not
//! logged; the receiver's channel rounding and deadband make the two
//! differ by less than 0.1°.

use crate::rig::{FlightRig, RigSample};
use crate::rtt::LogLine;
use control::shaping::{StickShaping, Sticks};
use flight::flightctl::FlightConfig;
use sim::plot::{write_panels, Look, Panel, Series, BLACK, COLORS};
use sim::scenario::{Mode, Pilot};
use std::path::Path;

/// The firmware's estimate from one `att` log line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Simulated time the host read the line (s).
    pub t_s: f64,
    /// Roll, pitch, yaw (°).
    pub euler_deg: [f64; 3],
    /// Height above the take-off pressure (m).
    pub altitude_m: f64,
    /// Vertical speed, up (m/s).
    pub vertical_speed_mps: f64,
}

/// The value after `key` up to the next space.
fn field(text: &str, key: &str) -> Option<f64> {
    let start = text.find(key)? + key.len();
    text[start..].split(' ').next()?.parse().ok()
}

/// Reads `att r=R p=P y=Y deg | alt=A m vz=V m/s` (the live log's
/// attitude line); `None` for any other line.
pub fn parse_estimate(line: &LogLine) -> Option<Estimate> {
    let text = line.text.strip_prefix("att r=")?;
    let text = format!("r={text}");
    Some(Estimate {
        t_s: line.host_time_ns as f64 * 1e-9,
        euler_deg: [
            field(&text, "r=")?,
            field(&text, " p=")?,
            field(&text, " y=")?,
        ],
        altitude_m: field(&text, "alt=")?,
        vertical_speed_mps: field(&text, "vz=")?,
    })
}

/// Every estimate in `lines`, in order.
pub fn estimates(lines: &[LogLine]) -> Vec<Estimate> {
    lines.iter().filter_map(parse_estimate).collect()
}

/// Setpoints the pilot's sticks ask for: (roll, pitch) tilt in degrees in
/// the self-levelling modes, and the yaw rate in °/s; `None` while the arm
/// switch is off.
pub fn stick_setpoints(shaping: &StickShaping, p: &Pilot) -> Option<(Option<[f64; 2]>, f64)> {
    if !p.arm {
        return None;
    }
    let s = Sticks {
        roll: p.sticks.roll,
        pitch: p.sticks.pitch,
        yaw: p.sticks.yaw,
        throttle: p.sticks.throttle,
    };
    let deg = |r: f32| f64::from(r).to_degrees();
    if p.mode == Mode::Acro {
        let r = shaping.rate_setpoint(&s).ok()?;
        return Some((None, deg(r.yaw_rps)));
    }
    let (tilt, yaw_rps) = shaping.level_setpoint(&s).ok()?;
    Some((
        Some([deg(tilt.roll_rad), deg(tilt.pitch_rad)]),
        deg(yaw_rps),
    ))
}

fn line(samples: &[RigSample], f: impl Fn(&RigSample) -> Option<f64>) -> Vec<(f64, f64)> {
    samples
        .iter()
        .filter_map(|s| f(s).map(|v| (s.t_s, v)))
        .collect()
}

/// The panels of a rig's flight so far. Errors: the flight configuration's
/// stick shaping is invalid.
pub fn panels(rig: &FlightRig) -> Result<Vec<Panel>, String> {
    let shaping = StickShaping::new(FlightConfig::default().sticks)
        .map_err(|e| format!("stick shaping: {e:?}"))?;
    let samples = rig.samples();
    let est = estimates(rig.board().log_lines());
    let setpoint = |s: &RigSample| s.pilot.as_ref().and_then(|p| stick_setpoints(&shaping, p));
    let truth_deg = |s: &RigSample| s.truth.q_ned_from_body.to_euler().map(f64::to_degrees);
    let mut panels = Vec::new();
    for (axis, name) in [(0usize, "roll"), (1, "pitch")] {
        let series = vec![
            Series::new("truth", line(samples, |s| Some(truth_deg(s)[axis]))),
            Series::new(
                "firmware estimate",
                est.iter().map(|e| (e.t_s, e.euler_deg[axis])).collect(),
            ),
            Series::new(
                "stick setpoint",
                line(samples, |s| {
                    setpoint(s).and_then(|(t, _)| t).map(|t| t[axis])
                }),
            ),
        ];
        let caption =
            format!("{name}: truth, firmware estimate (log, 20 Hz), stick setpoint [deg]");
        panels.push(Panel::new(
            &caption,
            "deg",
            Look::Tracking(COLORS[axis]),
            series,
        ));
    }
    let yaw = vec![
        Series::new(
            "truth",
            line(samples, |s| Some(s.truth.omega_body_rps[2].to_degrees())),
        ),
        Series::new(
            "stick setpoint",
            line(samples, |s| setpoint(s).map(|(_, y)| y)),
        ),
    ];
    panels.push(Panel::new(
        "yaw rate: truth, stick setpoint [deg/s]",
        "deg/s",
        Look::Tracking(COLORS[2]),
        yaw,
    ));
    panels.push(height(samples, &est));
    panels.push(pulses(samples));
    panels.push(sticks(samples));
    Ok(panels)
}

/// The true height and the firmware's estimate.
fn height(samples: &[RigSample], est: &[Estimate]) -> Panel {
    let series = vec![
        Series::new("truth", line(samples, |s| Some(s.truth.height_m))),
        Series::new(
            "firmware estimate",
            est.iter().map(|e| (e.t_s, e.altitude_m)).collect(),
        ),
    ];
    Panel::new(
        "height: truth, firmware estimate (log, 20 Hz) [m]",
        "m",
        Look::Tracking(BLACK),
        series,
    )
}

/// The four pins' pulse widths.
fn pulses(samples: &[RigSample]) -> Panel {
    let names = [
        "PA6 motor 1 (RR)",
        "PA7 motor 2 (FR)",
        "PB0 motor 3 (RL)",
        "PB1 motor 4 (FL)",
    ];
    let series = names
        .iter()
        .enumerate()
        .map(|(i, name)| Series::new(name, line(samples, |s| s.pulse_us[i])))
        .collect();
    let mut p = Panel::new(
        "ESC pulse widths on the TIM3 pins [us]",
        "us",
        Look::Channels,
        series,
    );
    p.min_span = 100.0;
    p
}

/// The pilot's sticks and arm switch (nothing while the link is down).
fn sticks(samples: &[RigSample]) -> Panel {
    let stick = |f: fn(&Pilot) -> f64| line(samples, move |s| s.pilot.as_ref().map(f));
    let series = vec![
        Series::new("roll", stick(|p| f64::from(p.sticks.roll))),
        Series::new("pitch", stick(|p| f64::from(p.sticks.pitch))),
        Series::new("yaw", stick(|p| f64::from(p.sticks.yaw))),
        Series::new("throttle", stick(|p| f64::from(p.sticks.throttle))),
        Series::new("arm switch", stick(|p| f64::from(u8::from(p.arm)))),
    ];
    Panel::new(
        "pilot (scenario): sticks and arm switch",
        "stick",
        Look::Channels,
        series,
    )
    .with_range(-1.05..1.05)
}

/// Draws the rig's flight into `path` (.png or .svg, by the extension).
pub fn write_plot(rig: &FlightRig, path: &Path, title: &str) -> Result<(), String> {
    if rig.samples().is_empty() {
        return Err("nothing to plot: the flight produced no samples".into());
    }
    write_panels(path, title, &panels(rig)?)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use sim::scenario::Sticks as PilotSticks;

    fn log(text: &str) -> LogLine {
        LogLine {
            host_time_ns: 2_500_000_000,
            level: Some("info".into()),
            timestamp: None,
            text: text.into(),
        }
    }

    #[test]
    fn the_attitude_line_is_read_and_others_are_not() {
        let e = parse_estimate(&log(
            "att r=1.5 p=-0.25 y=179.9 deg | alt=1.76 m vz=-0.02 m/s",
        ));
        assert_eq!(
            e,
            Some(Estimate {
                t_s: 2.5,
                euler_deg: [1.5, -0.25, 179.9],
                altitude_m: 1.76,
                vertical_speed_mps: -0.02,
            })
        );
        assert_eq!(
            parse_estimate(&log("att r=x p=0 y=0 deg | alt=0 m vz=0 m/s")),
            None
        );
        assert_eq!(parse_estimate(&log("loop: 20 runs")), None);
        assert_eq!(parse_estimate(&log("att r=1 p=2")), None);
    }

    #[test]
    fn setpoints_follow_the_sticks_and_the_mode() {
        let shaping = StickShaping::new(FlightConfig::default().sticks).unwrap();
        let mut p = Pilot {
            sticks: PilotSticks {
                roll: 1.0,
                pitch: 1.0,
                yaw: 0.0,
                throttle: 0.5,
            },
            arm: true,
            mode: Mode::Angle,
        };
        let (tilt, yaw) = stick_setpoints(&shaping, &p).unwrap();
        let tilt = tilt.unwrap();
        // Full stick: the configured maximum tilt; forward pitch = nose down.
        let max = f64::from(FlightConfig::default().sticks.max_angle_deg);
        assert!(
            (tilt[0] - max).abs() < 1e-3 && (tilt[1] + max).abs() < 1e-3,
            "{tilt:?}"
        );
        assert_eq!(yaw, 0.0);
        p.mode = Mode::Acro;
        assert_eq!(stick_setpoints(&shaping, &p).unwrap().0, None);
        p.arm = false;
        assert_eq!(stick_setpoints(&shaping, &p), None);
    }
}
