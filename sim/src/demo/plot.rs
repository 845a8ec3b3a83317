//! The plot of a run (plotters): roll, pitch and yaw against the truth, each
//! on its own autoscaled axis (roll kept within ±180°, its line broken
//! where it wraps, so a looping trajectory stays readable; yaw unwrapped,
//! so a heading through ±180° is a continuous line and the estimate is
//! drawn on the truth's side of the wrap), the attitude error, the height, and the magnetometer samples
//! before/after calibration as XY / YZ / XZ scatter plots. Legends sit in
//! a strip right of the data.
//!
//! The building blocks (format by extension, the embedded font, the
//! time-series chart with its legend strip) are `sim::plot`'s.

use super::run::{attitude_errors, Record, RecordSink};
use super::stack::MagCalRun;
use plotters::coord::Shift;
use plotters::prelude::*;
use sim::plot::{
    autoscale, load_font, segments, time_chart, wrap_series_deg, PlotFormat, Res, COLORS, FONT,
};
use std::path::Path;

/// One plotted instant.
#[derive(Clone, Copy, Debug)]
struct Point {
    t_s: f64,
    /// Estimated roll, pitch, yaw (°).
    est_deg: [f64; 3],
    /// True roll, pitch, yaw (°).
    truth_deg: [f64; 3],
    /// Total, heading and inclination error (°).
    err_deg: [f64; 3],
    est_height_m: Option<f64>,
    true_height_m: f64,
}

/// Most points kept per series; past it every other point is dropped and
/// the stride doubles, so memory stays bounded for any run length.
const MAX_POINTS: usize = 4000;

/// Collects a bounded, evenly decimated copy of the records for plotting.
#[derive(Debug)]
pub struct PlotSeries {
    points: Vec<Point>,
    stride: usize,
    seen: usize,
}

impl Default for PlotSeries {
    fn default() -> Self {
        Self {
            points: Vec::with_capacity(MAX_POINTS),
            stride: 1,
            seen: 0,
        }
    }
}

impl PlotSeries {
    /// No point kept.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

impl RecordSink for PlotSeries {
    fn push(&mut self, r: &Record) -> Result<(), String> {
        self.seen += 1;
        if !(self.seen - 1).is_multiple_of(self.stride) {
            return Ok(());
        }
        if self.points.len() == MAX_POINTS {
            let mut i = 0;
            self.points.retain(|_| {
                i += 1;
                i % 2 == 1
            });
            self.stride *= 2;
            if !(self.seen - 1).is_multiple_of(self.stride) {
                return Ok(());
            }
        }
        let (total, heading, incl) = attitude_errors(&r.est, &r.truth);
        self.points.push(Point {
            t_s: r.t_s,
            est_deg: r.est.to_euler().map(f64::to_degrees),
            truth_deg: r.truth.to_euler().map(f64::to_degrees),
            err_deg: [total, heading, incl].map(f64::to_degrees),
            est_height_m: r.est_height_m,
            true_height_m: r.true_height_m,
        });
        Ok(())
    }
}

const WIDTH: u32 = 1500;
const HEIGHT: u32 = 1560;
/// Draws the run into `path` (format from the extension).
pub fn write_plot(
    path: &Path,
    title: &str,
    series: &PlotSeries,
    mag: &MagCalRun,
) -> Result<(), String> {
    let format = PlotFormat::from_path(path)?;
    if series.is_empty() {
        return Err("nothing to plot: the run produced no samples".into());
    }
    load_font()?;
    let res = match format {
        PlotFormat::Png => draw(
            BitMapBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area(),
            title,
            series,
            mag,
        ),
        PlotFormat::Svg => draw(
            SVGBackend::new(path, (WIDTH, HEIGHT)).into_drawing_area(),
            title,
            series,
            mag,
        ),
    };
    res.map_err(|e| e.to_string())
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    series: &PlotSeries,
    mag: &MagCalRun,
) -> Res
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 26))?;
    let rows = root.split_by_breakpoints([] as [u32; 0], [210, 420, 630, 870, 1090]);
    let p = &series.points;
    let t_max = p.last().map_or(1.0, |r| r.t_s).max(1.0);
    let names = ["roll", "pitch", "yaw"];
    for (axis, area) in rows.iter().take(3).enumerate() {
        draw_angle(area, p, t_max, axis, names[axis])?;
    }
    draw_errors(&rows[3], p, t_max)?;
    draw_height(&rows[4], p, t_max)?;
    draw_mag(&rows[5], mag)?;
    root.present()?;
    Ok(())
}

/// Wraps an angle difference into (-180, 180] degrees.
fn wrap_deg(d: f64) -> f64 {
    let w = (d + 180.0).rem_euclid(360.0) - 180.0;
    if w == -180.0 {
        180.0
    } else {
        w
    }
}

/// A polyline in chart coordinates.
type Line = Vec<(f64, f64)>;

/// Truth unwrapped into a continuous line; the estimate placed at the
/// truth plus their wrapped difference, so both stay on one side of ±180°.
fn unwrapped(p: &[Point], axis: usize) -> (Line, Line) {
    let mut truth = Vec::with_capacity(p.len());
    let mut est = Vec::with_capacity(p.len());
    let mut prev: Option<(f64, f64)> = None;
    for r in p {
        let raw = r.truth_deg[axis];
        let t = match prev {
            Some((prev_raw, prev_t)) => prev_t + wrap_deg(raw - prev_raw),
            None => raw,
        };
        prev = Some((raw, t));
        truth.push((r.t_s, t));
        est.push((r.t_s, t + wrap_deg(r.est_deg[axis] - raw)));
    }
    (truth, est)
}

fn draw_angle<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &[Point],
    t_max: f64,
    axis: usize,
    name: &str,
) -> Res
where
    DB::ErrorType: 'static,
{
    let (truth, est) = if axis == 0 {
        let wrapped = |f: &dyn Fn(&Point) -> f64| {
            let line: Line = p.iter().map(|r| (r.t_s, f(r))).collect();
            wrap_series_deg(&line)
        };
        (wrapped(&|r| r.truth_deg[0]), wrapped(&|r| r.est_deg[0]))
    } else {
        unwrapped(p, axis)
    };
    let (truth, est) = (segments(&truth), segments(&est));
    let y = autoscale(truth.iter().chain(&est).flatten().map(|(_, v)| v), 2.0);
    let color = COLORS[axis];
    let truth_style = color.mix(0.35).stroke_width(5);
    let est_style = color.stroke_width(1);
    let caption = format!("{name}: estimate vs truth [deg]");
    let legend = [("truth", truth_style), ("estimate", est_style)];
    let mut c = time_chart(area, &caption, t_max, y, "deg", &legend)?;
    for line in truth {
        c.draw_series(LineSeries::new(line, truth_style))?;
    }
    for line in est {
        c.draw_series(LineSeries::new(line, est_style))?;
    }
    Ok(())
}

fn draw_errors<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &[Point], t_max: f64) -> Res
where
    DB::ErrorType: 'static,
{
    let hi = p
        .iter()
        .flat_map(|r| r.err_deg)
        .filter(|v| v.is_finite())
        .fold(1.0, f64::max)
        * 1.1;
    let styles = [
        BLACK.stroke_width(2),
        COLORS[2].stroke_width(1),
        COLORS[0].stroke_width(1),
    ];
    let legend = [
        ("total", styles[0]),
        ("heading", styles[1]),
        ("inclination", styles[2]),
    ];
    let mut c = time_chart(
        area,
        "attitude error, estimate vs truth [deg]",
        t_max,
        0.0..hi,
        "deg",
        &legend,
    )?;
    for (k, style) in styles.iter().enumerate() {
        c.draw_series(LineSeries::new(
            p.iter().map(|r| (r.t_s, r.err_deg[k])),
            *style,
        ))?;
    }
    Ok(())
}

fn draw_height<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &[Point], t_max: f64) -> Res
where
    DB::ErrorType: 'static,
{
    let values: Vec<f64> = p
        .iter()
        .flat_map(|r| [Some(r.true_height_m), r.est_height_m])
        .flatten()
        .collect();
    let y = autoscale(values.iter(), 1.0);
    let truth_style = BLACK.mix(0.3).stroke_width(5);
    let est_style = COLORS[2].stroke_width(1);
    let legend = [("truth", truth_style), ("estimate", est_style)];
    let mut c = time_chart(area, "height above take-off [m]", t_max, y, "m", &legend)?;
    c.draw_series(LineSeries::new(
        p.iter().map(|r| (r.t_s, r.true_height_m)),
        truth_style,
    ))?;
    c.draw_series(LineSeries::new(
        p.iter().filter_map(|r| r.est_height_m.map(|h| (r.t_s, h))),
        est_style,
    ))?;
    Ok(())
}

fn draw_mag<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, mag: &MagCalRun) -> Res
where
    DB::ErrorType: 'static,
{
    let raw = &mag.raw_mpu_ut;
    let cal: Vec<[f32; 3]> = raw.iter().map(|m| mag.calibration.apply(*m)).collect();
    let lim = raw
        .iter()
        .chain(cal.iter())
        .flat_map(|m| m.iter().map(|v| f64::from(v.abs())))
        .filter(|v| v.is_finite())
        .fold(10.0, f64::max)
        * 1.05;
    let every = (raw.len() / 1500).max(1);
    let names = ["x", "y", "z"];
    for (area, (a, b)) in area
        .split_evenly((1, 3))
        .iter()
        .zip([(0usize, 1usize), (1, 2), (0, 2)])
    {
        let mut c = ChartBuilder::on(area)
            .margin(10)
            .caption(
                format!(
                    "mag {}{} [µT]: raw (red) / calibrated (blue)",
                    names[a], names[b]
                ),
                (FONT, 16),
            )
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(-lim..lim, -lim..lim)?;
        c.configure_mesh()
            .x_desc(format!("{} [µT]", names[a]))
            .y_desc(format!("{} [µT]", names[b]))
            .label_style((FONT, 12))
            .draw()?;
        for (points, color) in [(raw, COLORS[0]), (&cal, COLORS[2])] {
            c.draw_series(points.iter().step_by(every).map(|m| {
                Circle::new(
                    (f64::from(m[a]), f64::from(m[b])),
                    2,
                    color.mix(0.5).filled(),
                )
            }))?;
        }
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn wrap_is_half_open_and_unwrap_is_continuous() {
        assert_eq!(wrap_deg(190.0), -170.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
        assert_eq!(wrap_deg(540.0), 180.0);
        // Truth yaw through +180 -> -180; estimate 2° behind, already wrapped.
        let pts: Vec<Point> = [(178.0, 176.0), (-179.0, 179.0), (-176.0, -178.0)]
            .iter()
            .enumerate()
            .map(|(i, &(t, e))| Point {
                t_s: i as f64,
                est_deg: [0.0, 0.0, e],
                truth_deg: [0.0, 0.0, t],
                err_deg: [0.0; 3],
                est_height_m: None,
                true_height_m: 0.0,
            })
            .collect();
        let (truth, est) = unwrapped(&pts, 2);
        assert_eq!(
            truth.iter().map(|p| p.1).collect::<Vec<_>>(),
            [178.0, 181.0, 184.0]
        );
        assert_eq!(
            est.iter().map(|p| p.1).collect::<Vec<_>>(),
            [176.0, 179.0, 182.0]
        );
        let r = autoscale(truth.iter().chain(&est).map(|p| &p.1), 2.0);
        assert!(
            r.start < 176.0 && r.end > 184.0 && r.end - r.start < 10.0,
            "{r:?}"
        );
    }

    #[test]
    fn series_stays_bounded_and_spans_the_run() {
        let mut s = PlotSeries::default();
        let rec = |t_s: f64| Record {
            t_s,
            est: sim::Quat::IDENTITY,
            truth: sim::Quat::IDENTITY,
            est_height_m: None,
            true_height_m: 0.0,
            est_vspeed_mps: None,
            true_vspeed_mps: 0.0,
            gyro_mpu_rps: [0.0; 3],
            accel_mpu_mps2: [0.0; 3],
            mag_mpu_ut: None,
            moving: false,
        };
        for i in 0..100_000 {
            s.push(&rec(i as f64 * 1e-3)).unwrap();
        }
        let n = s.points.len();
        assert!(n <= MAX_POINTS && n > MAX_POINTS / 4, "{n}");
        let last = s.points.last().unwrap().t_s;
        assert!(last > 99.0, "{last}");
        let d: Vec<f64> = s.points.windows(2).map(|w| w[1].t_s - w[0].t_s).collect();
        assert!(
            d.iter().all(|x| (x - d[0]).abs() < 1e-9),
            "uneven decimation"
        );
    }
}
