//! The plot of a closed-loop flight: roll and pitch (truth, AHRS estimate,
//! setpoint), yaw rate (truth, setpoint), height (truth, estimate, target),
//! the four motor commands, and the battery. PNG or SVG by extension; the
//! panels, fonts and legends are those of the open-loop plot.

use super::closed_loop::{FlightLog, Sample};
use super::plot::{autoscale, load_font, time_chart, PlotFormat, Res, COLORS, FONT};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

const WIDTH: u32 = 1500;
const HEIGHT: u32 = 1400;
/// Most points drawn per line (evenly decimated).
const MAX_POINTS: usize = 4000;

type Line = Vec<(f64, f64)>;

/// Draws `log` into `path` (format from the extension).
pub fn write_plot(path: &Path, title: &str, log: &FlightLog) -> Result<(), String> {
    let format = PlotFormat::from_path(path)?;
    if log.samples.is_empty() {
        return Err("nothing to plot: the flight produced no samples".into());
    }
    load_font()?;
    let res = match format {
        PlotFormat::Png => draw(
            BitMapBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area(),
            title,
            log,
        ),
        PlotFormat::Svg => draw(
            SVGBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area(),
            title,
            log,
        ),
    };
    res.map_err(|e| e.to_string())
}

fn line(p: &[&Sample], f: impl Fn(&Sample) -> Option<f64>) -> Line {
    p.iter().filter_map(|s| f(s).map(|v| (s.t_s, v))).collect()
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, title: &str, log: &FlightLog) -> Res
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 26))?;
    let stride = log.samples.len().div_ceil(MAX_POINTS).max(1);
    let p: Vec<&Sample> = log.samples.iter().step_by(stride).collect();
    let t_max = p.last().map_or(1.0, |s| s.t_s).max(1.0);
    let rows = root.split_by_breakpoints([] as [u32; 0], [225, 450, 675, 900, 1125]);
    let euler = |s: &Sample| s.truth.q_ned_from_body.to_euler().map(f64::to_degrees);
    let est = |s: &Sample| s.est_q.to_euler().map(f64::to_degrees);
    for (axis, name) in [(0usize, "roll"), (1, "pitch")] {
        let lines = [
            line(&p, |s| Some(euler(s)[axis])),
            line(&p, |s| Some(est(s)[axis])),
            line(&p, |s| {
                s.out
                    .tilt_setpoint_rad
                    .map(|t| f64::from(t[axis]).to_degrees())
            }),
        ];
        let caption = format!("{name}: truth, AHRS estimate, setpoint [deg]");
        draw_lines(
            &rows[axis],
            &caption,
            "deg",
            t_max,
            &lines,
            &["truth", "estimate", "setpoint"],
            COLORS[axis],
        )?;
    }
    let yaw = [
        line(&p, |s| Some(s.truth.omega_body_rps[2].to_degrees())),
        line(&p, |s| {
            s.out
                .rate_setpoint_rps
                .map(|r| f64::from(r[2]).to_degrees())
        }),
    ];
    draw_lines(
        &rows[2],
        "yaw rate: truth, setpoint [deg/s]",
        "deg/s",
        t_max,
        &yaw,
        &["truth", "setpoint"],
        COLORS[2],
    )?;
    let height = [
        line(&p, |s| Some(s.truth.height_m)),
        line(&p, |s| s.est_height_m),
        line(&p, |s| s.out.height_target_m.map(f64::from)),
    ];
    draw_lines(
        &rows[3],
        "height: truth, estimate, altitude-hold target [m]",
        "m",
        t_max,
        &height,
        &["truth", "estimate", "target"],
        BLACK,
    )?;
    draw_motors(&rows[4], &p, t_max)?;
    let battery = [line(&p, |s| Some(s.quad.battery_voltage_v))];
    draw_lines(
        &rows[5],
        "battery terminal voltage [V]",
        "V",
        t_max,
        &battery,
        &["voltage"],
        COLORS[1],
    )?;
    root.present()?;
    Ok(())
}

/// Up to three lines: a wide pale one (truth), a thin one, a dashed black one.
fn draw_lines<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    unit: &str,
    t_max: f64,
    lines: &[Line],
    names: &[&str],
    color: RGBColor,
) -> Res
where
    DB::ErrorType: 'static,
{
    let styles = [
        color.mix(0.35).stroke_width(5),
        color.stroke_width(1),
        BLACK.mix(0.8).stroke_width(1),
    ];
    let y = autoscale(lines.iter().flatten().map(|(_, v)| v), 1.0);
    let legend: Vec<(&str, ShapeStyle)> = names.iter().copied().zip(styles).collect();
    let mut c = time_chart(area, caption, t_max, y, unit, &legend)?;
    for (i, l) in lines.iter().enumerate() {
        let style = styles[i.min(2)];
        if i == 2 {
            c.draw_series(DashedLineSeries::new(l.iter().copied(), 6, 4, style))?;
        } else {
            c.draw_series(LineSeries::new(l.iter().copied(), style))?;
        }
    }
    Ok(())
}

fn draw_motors<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &[&Sample], t_max: f64) -> Res
where
    DB::ErrorType: 'static,
{
    let colors = [COLORS[0], COLORS[1], COLORS[2], RGBColor(255, 127, 14)];
    let styles = colors.map(|c| c.stroke_width(1));
    let names = [
        "motor 1 (RR)",
        "motor 2 (FR)",
        "motor 3 (RL)",
        "motor 4 (FL)",
    ];
    let legend: Vec<(&str, ShapeStyle)> = names.into_iter().zip(styles).collect();
    let mut c = time_chart(
        area,
        "motor commands [0..1]",
        t_max,
        -0.02..1.02,
        "command",
        &legend,
    )?;
    for (i, style) in styles.iter().enumerate() {
        let l = line(p, |s| Some(f64::from(s.out.motors[i])));
        c.draw_series(LineSeries::new(l, *style))?;
    }
    Ok(())
}
