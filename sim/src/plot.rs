//! Plots of simulated flights (plotters), shared by `cargo sim` and
//! `cargo fil`: the output-path checks, the building blocks (a time-series
//! chart with its legend strip, autoscaling, the embedded font) and a
//! figure of stacked time-series [`Panel`]s, which is what both tools'
//! `--scenario … --plot` draw.
//!
//! The font (DejaVu Sans) is compiled in, so the text does not depend on
//! what the machine has installed. PNG or SVG by the file's extension.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::ops::Range;
use std::path::Path;

/// The colour type of [`Look::Tracking`], and black, for the tools that
/// build panels without depending on plotters.
pub use plotters::style::{RGBColor, BLACK};

/// Image formats, chosen by the output file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlotFormat {
    /// `.png`: bitmap.
    Png,
    /// `.svg`: vector.
    Svg,
}

impl PlotFormat {
    /// The format for `path`'s extension (case-insensitive), or an error
    /// naming the ones supported.
    pub fn from_path(path: &Path) -> Result<Self, String> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(Self::Png),
            Some("svg") => Ok(Self::Svg),
            Some(other) => Err(format!(
                "unsupported plot format `.{other}` (use .png or .svg)"
            )),
            None => Err("the plot file needs an extension: .png or .svg".into()),
        }
    }
}

/// Checks a `--plot` path before any work: a file name (never `-`, stdout)
/// with a .png or .svg extension. The error starts with `--plot`.
pub fn check_plot_path(path: &Path) -> Result<PlotFormat, String> {
    if path == Path::new("-") {
        return Err("--plot needs a file name (.png or .svg), not stdout".into());
    }
    PlotFormat::from_path(path).map_err(|e| format!("--plot {}: {e}", path.display()))
}

/// What the drawing calls return.
pub type Res = Result<(), Box<dyn std::error::Error>>;

/// The line colours of the three attitude axes (red, green, blue).
pub const COLORS: [RGBColor; 3] = [
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(31, 119, 180),
];
/// A fourth colour (orange), for the fourth motor.
pub const ORANGE: RGBColor = RGBColor(255, 127, 14);
/// The font family every text uses (the embedded DejaVu Sans).
pub const FONT: &str = "sans-serif";
/// Width of the legend strip right of each time-series panel (px).
const LEGEND_W: u32 = 210;
/// Figure width (px).
const WIDTH: u32 = 1500;
/// Height of one panel (px), and of the title strip above them.
const PANEL_H: u32 = 225;
const TITLE_H: u32 = 50;
/// Most points drawn per line (evenly decimated).
const MAX_POINTS: usize = 4000;

/// Registers the embedded DejaVu Sans as plotters' sans-serif face.
pub fn load_font() -> Result<(), String> {
    plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "the embedded font could not be loaded".to_string())
}

/// `lo..hi` around the values with a 10 % margin and at least `min_span`.
pub fn autoscale<'a>(values: impl Iterator<Item = &'a f64>, min_span: f64) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
    if lo > hi {
        return -min_span / 2.0..min_span / 2.0;
    }
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo) * 1.1).max(min_span / 2.0);
    mid - half..mid + half
}

/// A chart with f64 axes.
pub type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A time-series chart with its legend strip; returns the chart.
pub fn time_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    t_max: f64,
    y: Range<f64>,
    y_desc: &str,
    legend: &[(&str, ShapeStyle)],
) -> Result<Chart<'a, DB>, Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let (plot_area, legend_area) = area.split_horizontally(area.dim_in_pixel().0 - LEGEND_W);
    draw_legend(&legend_area, legend)?;
    let mut c = ChartBuilder::on(&plot_area)
        .margin(8)
        .caption(caption, (FONT, 17))
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_max, y)?;
    c.configure_mesh()
        .x_desc("t [s]")
        .y_desc(y_desc)
        .label_style((FONT, 13))
        .draw()?;
    Ok(c)
}

/// Legend entries (a line sample and a name) stacked in their own strip.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(&str, ShapeStyle)],
) -> Res
where
    DB::ErrorType: 'static,
{
    for (i, (name, style)) in entries.iter().enumerate() {
        let y = 50 + 24 * i as i32;
        area.draw(&PathElement::new(vec![(10, y), (40, y)], *style))?;
        area.draw(&Text::new(name.to_string(), (48, y - 8), (FONT, 15)))?;
    }
    Ok(())
}

/// One named line of a panel: `(t in s, value)` points in time order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// The legend's name.
    pub name: String,
    /// The points.
    pub points: Vec<(f64, f64)>,
}

impl Series {
    /// A series named `name`.
    pub fn new(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.to_string(),
            points,
        }
    }
}

/// How a panel draws its series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Look {
    /// Truth, estimate, setpoint in `color`: the first wide and pale, the
    /// second thin, the third dashed black (fourth and later thin black).
    Tracking(RGBColor),
    /// Equal thin lines, one colour each (red, green, blue, orange, ...).
    Channels,
}

/// One time-series panel of a [`write_panels`] figure.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// The caption above the chart.
    pub caption: String,
    /// The y axis' label.
    pub unit: String,
    /// The lines, drawn in order.
    pub series: Vec<Series>,
    /// A fixed y range; `None`: autoscaled with at least `min_span`.
    pub y_range: Option<Range<f64>>,
    /// The smallest autoscaled span.
    pub min_span: f64,
    /// How the lines look.
    pub look: Look,
}

impl Panel {
    /// An autoscaled panel (span at least 1 unit).
    pub fn new(caption: &str, unit: &str, look: Look, series: Vec<Series>) -> Self {
        Self {
            caption: caption.to_string(),
            unit: unit.to_string(),
            series,
            y_range: None,
            min_span: 1.0,
            look,
        }
    }

    /// The same panel with a fixed y range.
    pub fn with_range(mut self, y: Range<f64>) -> Self {
        self.y_range = Some(y);
        self
    }
}

/// Draws `panels` stacked under `title` into `path` (.png or .svg, by the
/// extension). An error if no series has a point.
pub fn write_panels(path: &Path, title: &str, panels: &[Panel]) -> Result<(), String> {
    let format = PlotFormat::from_path(path)?;
    let points = panels.iter().flat_map(|p| &p.series);
    if points.clone().all(|s| s.points.is_empty()) {
        return Err("nothing to plot: the flight produced no samples".into());
    }
    load_font()?;
    let size = (WIDTH, TITLE_H + PANEL_H * panels.len() as u32);
    let res = match format {
        PlotFormat::Png => draw_panels(
            BitMapBackend::new(path, size).into_drawing_area(),
            title,
            panels,
        ),
        PlotFormat::Svg => draw_panels(
            SVGBackend::new(path, size).into_drawing_area(),
            title,
            panels,
        ),
    };
    res.map_err(|e| e.to_string())
}

fn draw_panels<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    panels: &[Panel],
) -> Res
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 26))?;
    let t_max = panels
        .iter()
        .flat_map(|p| &p.series)
        .filter_map(|s| s.points.last().map(|p| p.0))
        .fold(1.0, f64::max);
    let breaks: Vec<u32> = (1..panels.len() as u32).map(|i| i * PANEL_H).collect();
    let rows = root.split_by_breakpoints([] as [u32; 0], breaks);
    for (panel, area) in panels.iter().zip(&rows) {
        draw_panel(area, panel, t_max)?;
    }
    root.present()?;
    Ok(())
}

/// The style of series `i` in a panel of `look`.
fn style(look: Look, i: usize) -> ShapeStyle {
    match look {
        Look::Tracking(color) => match i {
            0 => color.mix(0.35).stroke_width(5),
            1 => color.stroke_width(1),
            _ => BLACK.mix(0.8).stroke_width(1),
        },
        Look::Channels => {
            let colors = [COLORS[0], COLORS[1], COLORS[2], ORANGE, BLACK];
            colors[i % colors.len()].stroke_width(1)
        }
    }
}

fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, panel: &Panel, t_max: f64) -> Res
where
    DB::ErrorType: 'static,
{
    let lines: Vec<Vec<(f64, f64)>> = panel
        .series
        .iter()
        .map(|s| {
            let stride = s.points.len().div_ceil(MAX_POINTS).max(1);
            s.points.iter().step_by(stride).copied().collect()
        })
        .collect();
    let y = panel
        .y_range
        .clone()
        .unwrap_or_else(|| autoscale(lines.iter().flatten().map(|(_, v)| v), panel.min_span));
    let styles: Vec<ShapeStyle> = (0..lines.len()).map(|i| style(panel.look, i)).collect();
    let legend: Vec<(&str, ShapeStyle)> = panel
        .series
        .iter()
        .map(|s| s.name.as_str())
        .zip(styles.iter().copied())
        .collect();
    let mut c = time_chart(area, &panel.caption, t_max, y, &panel.unit, &legend)?;
    for (i, (l, style)) in lines.into_iter().zip(styles).enumerate() {
        if matches!(panel.look, Look::Tracking(_)) && i == 2 {
            c.draw_series(DashedLineSeries::new(l, 6, 4, style))?;
        } else {
            c.draw_series(LineSeries::new(l, style))?;
        }
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn format_by_extension_and_plot_paths() {
        assert_eq!(
            PlotFormat::from_path(Path::new("a/b.png")),
            Ok(PlotFormat::Png)
        );
        assert_eq!(
            PlotFormat::from_path(Path::new("b.SVG")),
            Ok(PlotFormat::Svg)
        );
        assert!(PlotFormat::from_path(Path::new("b.jpg"))
            .unwrap_err()
            .contains(".jpg"));
        assert!(PlotFormat::from_path(Path::new("b")).is_err());
        assert!(check_plot_path(Path::new("-"))
            .unwrap_err()
            .contains("not stdout"));
        assert!(check_plot_path(Path::new("x.txt"))
            .unwrap_err()
            .starts_with("--plot x.txt"));
    }

    #[test]
    fn panels_are_drawn_and_an_empty_figure_is_refused() {
        let dir = std::env::temp_dir();
        let path = dir.join(format!("sim-plot-test-{}.svg", std::process::id()));
        let empty = Panel::new(
            "nothing",
            "m",
            Look::Channels,
            vec![Series::new("a", vec![])],
        );
        assert!(write_panels(&path, "t", &[empty]).is_err());
        let line: Vec<(f64, f64)> = (0..10_000).map(|i| (f64::from(i) * 1e-3, 1.0)).collect();
        let panels = [
            Panel::new(
                "height",
                "m",
                Look::Tracking(BLACK),
                vec![Series::new("truth", line.clone())],
            ),
            Panel::new(
                "pulses",
                "us",
                Look::Channels,
                vec![Series::new("motor 1", line)],
            )
            .with_range(0.0..2.0),
        ];
        write_panels(&path, "a test", &panels).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.contains("a test") && svg.contains("motor 1") && svg.contains("pulses"));
        let _ = std::fs::remove_file(path);
    }
}
