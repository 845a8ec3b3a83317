//! The plot of a closed-loop flight: roll and pitch (truth, AHRS estimate,
//! setpoint), yaw rate (truth, setpoint), height (truth, estimate, target),
//! the four motor commands, and the battery. PNG or SVG by extension;
//! drawn by `sim::plot::write_panels`, as `cargo fil --scenario … --plot`
//! draws the emulated board's flight.

use super::closed_loop::{FlightLog, Sample};
use sim::plot::{write_panels, Look, Panel, Series, BLACK, COLORS};
use std::path::Path;

fn line(log: &FlightLog, f: impl Fn(&Sample) -> Option<f64>) -> Vec<(f64, f64)> {
    log.samples
        .iter()
        .filter_map(|s| f(s).map(|v| (s.t_s, v)))
        .collect()
}

/// The panels of `log`.
pub fn panels(log: &FlightLog) -> Vec<Panel> {
    let mut panels = attitude(log);
    let height = vec![
        Series::new("truth", line(log, |s| Some(s.truth.height_m))),
        Series::new("estimate", line(log, |s| s.est_height_m)),
        Series::new(
            "target",
            line(log, |s| s.out.height_target_m.map(f64::from)),
        ),
    ];
    panels.push(Panel::new(
        "height: truth, estimate, altitude-hold target [m]",
        "m",
        Look::Tracking(BLACK),
        height,
    ));
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
            Series::new("truth", line(log, |s| Some(euler(s)[axis]))),
            Series::new("estimate", line(log, |s| Some(est(s)[axis]))),
            Series::new(
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
        Series::new(
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
    write_panels(path, title, &panels(log))
}
