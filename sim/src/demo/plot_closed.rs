//! The plot of a closed-loop flight, for a pilot to read: the scenario's
//! figures under the title, the event timeline (the flight controller's
//! events, the link, a failed motor, lift-off and touch-down) as a
//! labelled strip and a line on every panel, then roll and pitch (truth,
//! AHRS estimate, setpoint; roll wrapped into ±180°), yaw rate (truth,
//! setpoint), height (truth, estimate, altitude-hold target), the
//! horizontal position (north, east), the four motor commands and the
//! battery. PNG or SVG by extension; drawn by `sim::plot::write_figure`,
//! the plotter `cargo fil --scenario … --plot` uses for the emulated
//! board's flight.

use super::closed_loop::{FlightLog, Sample};
use super::figures::figures;
use super::timeline::{label, timeline};
use sim::plot::{
    wrap_series_deg, write_figure, Figure, Look, Marker, Panel, RGBColor, Series, COLORS,
};
use std::path::Path;

/// The height panel's colour (purple: the other colours are the axes').
const HEIGHT_COLOR: RGBColor = RGBColor(148, 103, 189);

fn line(log: &FlightLog, f: impl Fn(&Sample) -> Option<f64>) -> Vec<(f64, f64)> {
    log.samples
        .iter()
        .filter_map(|s| f(s).map(|v| (s.t_s, v)))
        .collect()
}

/// The figure of `log`: its figures as notes, its events as markers, its
/// panels.
pub fn figure(log: &FlightLog) -> Figure {
    let mut notes = figures(log).lines();
    if target_below_ground(log) {
        notes.push(TARGET_NOTE.to_string());
    }
    let markers = timeline(log)
        .iter()
        .map(|e| Marker {
            t_s: e.t_s,
            label: label(e),
        })
        .collect();
    Figure {
        notes,
        markers,
        panels: panels(log),
    }
}

/// Why the height panel's target may lie below the ground.
const TARGET_NOTE: &str = "height target below 0 m: that is the controller's state. Armed in altitude hold with the throttle stick low (before the take-off), or in the failsafe descent after touch-down (until the landing disarm), the hold target moves down at the commanded descent rate while the craft rests on the ground.";

/// Whether the altitude-hold target is ever below the ground.
fn target_below_ground(log: &FlightLog) -> bool {
    log.samples
        .iter()
        .any(|s| s.out.height_target_m.is_some_and(|h| h < 0.0))
}

/// The panels of `log`.
pub fn panels(log: &FlightLog) -> Vec<Panel> {
    let mut panels = attitude(log);
    let height = vec![
        Series::new("truth", line(log, |s| Some(s.truth.height_m))),
        Series::new("estimate", line(log, |s| s.est_height_m)),
        Series::reference(
            "target",
            line(log, |s| s.out.height_target_m.map(f64::from)),
        ),
    ];
    panels.push(Panel::new(
        "height: truth, estimate, altitude-hold target [m]",
        "m",
        Look::Tracking(HEIGHT_COLOR),
        height,
    ));
    panels.push(horizontal(log));
    panels.push(motors(log));
    let battery = vec![Series::new(
        "voltage",
        line(log, |s| Some(s.quad.battery_voltage_v)),
    )];
    panels.push(Panel::new(
        "battery terminal voltage [V]",
        "V",
        Look::Tracking(COLORS[1]),
        battery,
    ));
    panels
}

/// Roll and pitch (truth, estimate, setpoint), yaw rate (truth, setpoint).
fn attitude(log: &FlightLog) -> Vec<Panel> {
    let euler = |s: &Sample| s.truth.q_ned_from_body.to_euler().map(f64::to_degrees);
    let est = |s: &Sample| s.est_q.to_euler().map(f64::to_degrees);
    let mut panels = Vec::new();
    for (axis, name) in [(0usize, "roll"), (1, "pitch")] {
        let series = vec![
            Series::new(
                "truth",
                wrap_series_deg(&line(log, |s| Some(euler(s)[axis]))),
            ),
            Series::new(
                "estimate",
                wrap_series_deg(&line(log, |s| Some(est(s)[axis]))),
            ),
            Series::reference(
                "setpoint",
                line(log, |s| {
                    s.out
                        .tilt_setpoint_rad
                        .map(|t| f64::from(t[axis]).to_degrees())
                }),
            ),
        ];
        let caption = format!("{name}: truth, AHRS estimate, setpoint [deg]");
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
            line(log, |s| Some(s.truth.omega_body_rps[2].to_degrees())),
        ),
        Series::reference(
            "setpoint",
            line(log, |s| {
                s.out
                    .rate_setpoint_rps
                    .map(|r| f64::from(r[2]).to_degrees())
            }),
        ),
    ];
    panels.push(Panel::new(
        "yaw rate: truth, setpoint [deg/s]",
        "deg/s",
        Look::Tracking(COLORS[2]),
        yaw,
    ));
    panels
}

/// North and east of the take-off point (truth): the drift nothing holds.
fn horizontal(log: &FlightLog) -> Panel {
    let series = ["north", "east"]
        .iter()
        .enumerate()
        .map(|(i, name)| Series::new(name, line(log, |s| Some(s.truth.position_ned_m[i]))))
        .collect();
    Panel::new(
        "horizontal position from the take-off point, truth [m]",
        "m",
        Look::Channels,
        series,
    )
}

fn motors(log: &FlightLog) -> Panel {
    let names = [
        "motor 1 (RR)",
        "motor 2 (FR)",
        "motor 3 (RL)",
        "motor 4 (FL)",
    ];
    let series = names
        .iter()
        .enumerate()
        .map(|(i, name)| Series::new(name, line(log, |s| Some(f64::from(s.out.motors[i])))))
        .collect();
    Panel::new("motor commands [0..1]", "command", Look::Channels, series).with_range(-0.02..1.02)
}

/// Draws `log` into `path` (format from the extension).
pub fn write_plot(path: &Path, title: &str, log: &FlightLog) -> Result<(), String> {
    if log.samples.is_empty() {
        return Err("nothing to plot: the flight produced no samples".into());
    }
    write_figure(path, title, &figure(log))
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use crate::demo::closed_loop::{fly, ClosedLoopOptions, Scenario};
    use crate::demo::flight_fc::FirmwareFc;

    /// Every scenario's plot is written: a PNG, with its figures as notes,
    /// its events as markers and the horizontal-position panel.
    #[test]
    fn every_scenario_is_plotted() {
        let dir = std::env::temp_dir().join(format!("sim-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for name in Scenario::NAMES {
            let scenario = Scenario::from_name(name).unwrap();
            let mut fc = FirmwareFc::new(settings::flight_config()).unwrap();
            let mut o = ClosedLoopOptions::new(scenario, 1);
            o.mag_dance_s = 20.0;
            let log = fly(&o, &mut fc).unwrap();
            let f = figure(&log);
            assert!(f.notes.len() >= 2, "{name}: {:?}", f.notes);
            // Every scenario arms: at least that event is marked.
            assert!(f.markers.iter().any(|m| m.label == "armed"), "{name}");
            assert!(f.panels.iter().any(|p| p.caption.starts_with("horizontal")));
            let path = dir.join(format!("{name}.png"));
            write_plot(&path, name, &log).unwrap();
            let len = std::fs::metadata(&path).unwrap().len();
            assert!(len > 10_000, "{name}: {len} B");
        }
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn setpoints_and_targets_are_reference_lines() {
        let mut fc = FirmwareFc::new(settings::flight_config()).unwrap();
        let mut o = ClosedLoopOptions::new(Scenario::Takeoff, 1);
        o.mag_dance_s = 10.0;
        o.duration_s = Some(0.3);
        let log = fly(&o, &mut fc).unwrap();
        for p in panels(&log) {
            for s in &p.series {
                let is_ref = ["setpoint", "target"].contains(&s.name.as_str());
                assert_eq!(s.reference, is_ref, "{}: {}", p.caption, s.name);
            }
        }
    }
}
