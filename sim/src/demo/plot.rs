//! PNG plot of a run (plotters, bitmap backend): attitude and height against
//! the truth, and the magnetometer samples before/after calibration as
//! XY / YZ / XZ scatter plots.
//!
//! Text needs a TrueType font: the first of [`FONT_PATHS`] (or the file named
//! by `SIM_FONT`) that exists is used; without one the plot is drawn without
//! any text.

use super::run::Record;
use super::stack::MagCalRun;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// Where to look for a font.
pub const FONT_PATHS: [&str; 5] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/Library/Fonts/Arial.ttf",
];

fn load_font() -> bool {
    let env = std::env::var("SIM_FONT").ok();
    for p in env.iter().map(String::as_str).chain(FONT_PATHS) {
        if let Ok(bytes) = std::fs::read(p) {
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                return true;
            }
        }
    }
    false
}

type Res = Result<(), Box<dyn std::error::Error>>;

/// Draws the run into `path` (PNG).
pub fn write_plot(
    path: &str,
    title: &str,
    records: &[Record],
    mag: &MagCalRun,
) -> Result<bool, String> {
    let text = load_font();
    draw(path, title, records, mag, text).map_err(|e| e.to_string())?;
    Ok(text)
}

const COLORS: [RGBColor; 3] = [
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(31, 119, 180),
];

fn draw(path: &str, title: &str, records: &[Record], mag: &MagCalRun, text: bool) -> Res {
    let root = BitMapBackend::new(path, (1500, 1250)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = if text {
        root.titled(title, ("sans-serif", 26))?
    } else {
        root.margin(10, 0, 0, 0)
    };
    let (top, rest) = root.split_vertically(420);
    let (mid, bottom) = rest.split_vertically(330);
    let step = (records.len() / 3000).max(1);
    let recs: Vec<&Record> = records.iter().step_by(step).collect();
    let t_max = recs.last().map_or(1.0, |r| r.t_s).max(1.0);

    // Attitude.
    {
        let mut b = ChartBuilder::on(&top);
        b.margin(10)
            .x_label_area_size(if text { 35 } else { 0 })
            .y_label_area_size(if text { 55 } else { 0 });
        if text {
            b.caption(
                "attitude: estimate (solid) vs truth (thick, light) — roll, pitch, yaw [deg]",
                ("sans-serif", 18),
            );
        }
        let mut c = b.build_cartesian_2d(0.0..t_max, -180.0..180.0)?;
        let mut mesh = c.configure_mesh();
        if text {
            mesh.x_desc("t [s]")
                .y_desc("deg")
                .label_style(("sans-serif", 14));
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw()?;
        for (i, color) in COLORS.iter().enumerate() {
            // Break the line at ±180° wraps.
            let truth: Vec<(f64, f64)> = recs
                .iter()
                .map(|r| (r.t_s, r.truth.to_euler()[i].to_degrees()))
                .collect();
            let est: Vec<(f64, f64)> = recs
                .iter()
                .map(|r| (r.t_s, r.est.to_euler()[i].to_degrees()))
                .collect();
            for seg in segments(&truth) {
                c.draw_series(LineSeries::new(seg, color.mix(0.35).stroke_width(5)))?;
            }
            let mut first = true;
            for seg in segments(&est) {
                let s = c.draw_series(LineSeries::new(seg, color.stroke_width(1)))?;
                if first && text {
                    let name = ["roll", "pitch", "yaw"][i];
                    let col = *color;
                    s.label(name).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2))
                    });
                }
                first = false;
            }
        }
        if text {
            c.configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()?;
        }
    }

    // Height.
    {
        let hs: Vec<f64> = recs
            .iter()
            .flat_map(|r| [Some(r.true_height_m), r.est_height_m])
            .flatten()
            .collect();
        let lo = hs.iter().cloned().fold(f64::INFINITY, f64::min).min(0.0) - 1.0;
        let hi = hs
            .iter()
            .cloned()
            .fold(f64::NEG_INFINITY, f64::max)
            .max(1.0)
            + 1.0;
        let mut b = ChartBuilder::on(&mid);
        b.margin(10)
            .x_label_area_size(if text { 35 } else { 0 })
            .y_label_area_size(if text { 55 } else { 0 });
        if text {
            b.caption(
                "height above take-off: estimate (blue) vs truth (thick, grey) [m]",
                ("sans-serif", 18),
            );
        }
        let mut c = b.build_cartesian_2d(0.0..t_max, lo..hi)?;
        let mut mesh = c.configure_mesh();
        if text {
            mesh.x_desc("t [s]")
                .y_desc("m")
                .label_style(("sans-serif", 14));
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw()?;
        c.draw_series(LineSeries::new(
            recs.iter().map(|r| (r.t_s, r.true_height_m)),
            BLACK.mix(0.3).stroke_width(5),
        ))?;
        c.draw_series(LineSeries::new(
            recs.iter()
                .filter_map(|r| r.est_height_m.map(|h| (r.t_s, h))),
            COLORS[2].stroke_width(1),
        ))?;
    }

    // Magnetometer scatter.
    let panels = bottom.split_evenly((1, 3));
    let raw = &mag.raw_mpu_ut;
    let cal: Vec<[f32; 3]> = raw.iter().map(|m| mag.calibration.apply(*m)).collect();
    let lim = raw
        .iter()
        .chain(cal.iter())
        .flat_map(|m| m.iter().map(|v| f64::from(v.abs())))
        .fold(10.0, f64::max)
        * 1.05;
    for (k, (area, (a, b_axis))) in panels
        .iter()
        .zip([(0usize, 1usize), (1, 2), (0, 2)])
        .enumerate()
    {
        let names = ["x", "y", "z"];
        let mut b = ChartBuilder::on(area);
        b.margin(10)
            .x_label_area_size(if text { 35 } else { 0 })
            .y_label_area_size(if text { 45 } else { 0 });
        if text {
            b.caption(
                format!(
                    "mag {}{} [µT]: raw (red) / calibrated (blue)",
                    names[a], names[b_axis]
                ),
                ("sans-serif", 16),
            );
        }
        let mut c = b.build_cartesian_2d(-lim..lim, -lim..lim)?;
        let mut mesh = c.configure_mesh();
        if text {
            mesh.x_desc(format!("{} [µT]", names[a]))
                .y_desc(format!("{} [µT]", names[b_axis]))
                .label_style(("sans-serif", 12));
        } else {
            mesh.x_labels(0).y_labels(0);
        }
        mesh.draw()?;
        let _ = k;
        let every = (raw.len() / 1500).max(1);
        c.draw_series(raw.iter().step_by(every).map(|m| {
            Circle::new(
                (f64::from(m[a]), f64::from(m[b_axis])),
                2,
                COLORS[0].mix(0.5).filled(),
            )
        }))?;
        c.draw_series(cal.iter().step_by(every).map(|m| {
            Circle::new(
                (f64::from(m[a]), f64::from(m[b_axis])),
                2,
                COLORS[2].mix(0.5).filled(),
            )
        }))?;
    }
    root.present()?;
    Ok(())
}

/// Splits a wrapped angle series where it jumps by more than 180°.
fn segments(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for w in points {
        if let Some(last) = out.last_mut().and_then(|s| s.last().copied()) {
            if (w.1 - last.1).abs() > 180.0 {
                out.push(Vec::new());
            }
        }
        if let Some(s) = out.last_mut() {
            s.push(*w);
        }
    }
    out
}
