//! Plots of simulated flights (plotters), shared by `cargo sim` and
//! `cargo fil`: the output-path checks, the building blocks (a time-series
//! chart with its legend strip, autoscaling, the embedded font) and a
//! figure of stacked time-series [`Panel`]s, which is what both tools'
//! `--scenario … --plot` draw, optionally with notes under the title (the
//! run's figures) and an event timeline ([`Marker`]s: a labelled strip
//! under the notes and a vertical line on every panel).
//!
//! A series breaks its line at a non-finite value ([`BREAK`]);
//! [`wrap_series_deg`] uses that to keep an angle within ±180° without a
//! vertical line across the panel where it wraps.
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
    let solid: Vec<(&str, LineStyle)> = legend
        .iter()
        .map(|(name, style)| (*name, LineStyle::solid(*style)))
        .collect();
    styled_time_chart(area, caption, t_max, y, y_desc, &solid)
}

/// A line's look: its stroke, and whether it is dashed.
#[derive(Clone, Copy, Debug)]
pub struct LineStyle {
    /// Colour and width.
    pub stroke: ShapeStyle,
    /// Drawn in dashes (6 px on, 4 px off), in the legend too.
    pub dashed: bool,
}

impl LineStyle {
    /// A solid line.
    pub fn solid(stroke: ShapeStyle) -> Self {
        Self {
            stroke,
            dashed: false,
        }
    }
}

/// [`time_chart`] with legend samples that may be dashed, as drawn.
pub fn styled_time_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    t_max: f64,
    y: Range<f64>,
    y_desc: &str,
    legend: &[(&str, LineStyle)],
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

/// Legend entries (a line sample drawn as the line is, and a name)
/// stacked in their own strip.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(&str, LineStyle)],
) -> Res
where
    DB::ErrorType: 'static,
{
    for (i, (name, style)) in entries.iter().enumerate() {
        let y = 50 + 24 * i as i32;
        if style.dashed {
            for x in [8, 18, 28, 38] {
                area.draw(&PathElement::new(vec![(x, y), (x + 6, y)], style.stroke))?;
            }
        } else {
            area.draw(&PathElement::new(vec![(10, y), (40, y)], style.stroke))?;
        }
        area.draw(&Text::new(name.to_string(), (48, y - 8), (FONT, 15)))?;
    }
    Ok(())
}

/// The value that breaks a series' line: the points on either side are
/// not joined.
pub const BREAK: f64 = f64::NAN;

/// Wraps an angle into [−180°, 180°).
pub fn wrap_deg(a: f64) -> f64 {
    let w = (a + 180.0).rem_euclid(360.0) - 180.0;
    // rem_euclid may round up to the modulus itself (for a tiny negative).
    if w >= 180.0 {
        w - 360.0
    } else {
        w
    }
}

/// An angle series wrapped into [−180°, 180°), with a [`BREAK`] where
/// the wrapped angle jumps by more than 180° between two points (where it
/// went through ±180°), so the line is not drawn across the panel.
pub fn wrap_series_deg(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(points.len() + 8);
    let mut prev: Option<f64> = None;
    for &(t, a) in points {
        let w = wrap_deg(a);
        if prev.is_some_and(|p| (w - p).abs() > 180.0) {
            out.push((t, BREAK));
        }
        prev = w.is_finite().then_some(w);
        out.push((t, w));
    }
    out
}

/// The runs of finite points of `points` (the pieces of a line broken at
/// each [`BREAK`]), each evenly decimated to at most 4,000 points (its
/// last point kept).
pub fn segments(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    let stride = points.len().div_ceil(MAX_POINTS).max(1);
    points
        .split(|p| !p.1.is_finite() || !p.0.is_finite())
        .filter(|run| !run.is_empty())
        .map(|run| {
            let mut v: Vec<(f64, f64)> = run.iter().step_by(stride).copied().collect();
            if let (Some(last), Some(kept)) = (run.last(), v.last()) {
                if last != kept {
                    v.push(*last);
                }
            }
            v
        })
        .collect()
}

/// One named line of a panel: `(t in s, value)` points in time order; a
/// non-finite value ([`BREAK`]) breaks the line.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// The legend's name.
    pub name: String,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// A reference the others are judged against (a setpoint, a target):
    /// drawn dashed black whatever its place in the panel.
    pub reference: bool,
}

impl Series {
    /// A series named `name`, styled by its place in the panel ([`Look`]).
    pub fn new(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.to_string(),
            points,
            reference: false,
        }
    }

    /// A reference series (setpoint, target): dashed black.
    pub fn reference(name: &str, points: Vec<(f64, f64)>) -> Self {
        Self {
            reference: true,
            ..Self::new(name, points)
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

/// An instant of the run worth seeing on every panel (an event).
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// When (s).
    pub t_s: f64,
    /// What, in a few words.
    pub label: String,
}

/// A whole figure: panels, and what [`write_figure`] draws above them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Figure {
    /// Lines of text under the title (the run's figures), wrapped to the
    /// figure's width.
    pub notes: Vec<String>,
    /// The event timeline: a labelled strip above the panels and a
    /// vertical line on each panel.
    pub markers: Vec<Marker>,
    /// The time-series panels, stacked.
    pub panels: Vec<Panel>,
}

/// Draws `panels` stacked under `title` into `path` (.png or .svg, by the
/// extension). An error if no series has a point.
pub fn write_panels(path: &Path, title: &str, panels: &[Panel]) -> Result<(), String> {
    let figure = Figure {
        panels: panels.to_vec(),
        ..Figure::default()
    };
    write_figure(path, title, &figure)
}

/// Draws `figure` under `title` into `path` (.png or .svg, by the
/// extension): the notes, the event strip (when there are markers), then
/// the panels. An error if no series has a point.
pub fn write_figure(path: &Path, title: &str, figure: &Figure) -> Result<(), String> {
    let format = PlotFormat::from_path(path)?;
    let points = figure.panels.iter().flat_map(|p| &p.series);
    if points.clone().all(|s| s.points.is_empty()) {
        return Err("nothing to plot: the flight produced no samples".into());
    }
    load_font()?;
    let layout = Layout::of(figure);
    let size = (WIDTH, layout.height());
    let res = match format {
        PlotFormat::Png => draw_figure(
            BitMapBackend::new(path, size).into_drawing_area(),
            title,
            figure,
            &layout,
        ),
        PlotFormat::Svg => draw_figure(
            SVGBackend::new(path, size).into_drawing_area(),
            title,
            figure,
            &layout,
        ),
    };
    res.map_err(|e| e.to_string())
}

/// Height of a line of notes (px).
const NOTE_LINE_H: u32 = 20;
/// Characters of a line of notes before it wraps (14 px DejaVu Sans is
/// about 8 px a character on average).
const NOTE_CHARS: usize = (WIDTH as usize - 40) / 8;
/// Rows of the event strip (labels in all but the last, which holds the
/// ticks of markers left unlabelled), and the height of one (px).
const EVENT_ROWS: usize = 4;
const EVENT_ROW_H: u32 = 19;

/// The figure's strips, top to bottom (px).
struct Layout {
    notes: Vec<String>,
    notes_h: u32,
    events_h: u32,
    panels: u32,
}

impl Layout {
    fn of(figure: &Figure) -> Self {
        let notes: Vec<String> = figure
            .notes
            .iter()
            .flat_map(|n| wrap_words(n, NOTE_CHARS))
            .collect();
        let notes_h = if notes.is_empty() {
            0
        } else {
            NOTE_LINE_H * notes.len() as u32 + 10
        };
        let events_h = if figure.markers.is_empty() {
            0
        } else {
            EVENT_ROW_H * EVENT_ROWS as u32 + 60
        };
        Self {
            notes,
            notes_h,
            events_h,
            panels: figure.panels.len() as u32,
        }
    }

    fn height(&self) -> u32 {
        TITLE_H + self.notes_h + self.events_h + PANEL_H * self.panels
    }
}

/// `text` in lines of at most `width` characters, broken between words
/// (a longer word gets a line of its own).
fn wrap_words(text: &str, width: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split_whitespace() {
        let Some(line) = lines.last_mut() else { break };
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(word.to_string());
        } else {
            if !line.is_empty() {
                line.push(' ');
            }
            line.push_str(word);
        }
    }
    lines
}

fn draw_figure<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    figure: &Figure,
    layout: &Layout,
) -> Res
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 26))?;
    let t_max = figure
        .panels
        .iter()
        .flat_map(|p| &p.series)
        .filter_map(|s| s.points.last().map(|p| p.0))
        .fold(1.0, f64::max);
    let (notes, rest) = root.split_vertically(layout.notes_h);
    for (i, line) in layout.notes.iter().enumerate() {
        let y = 4 + (NOTE_LINE_H * i as u32) as i32;
        notes.draw(&Text::new(line.as_str(), (20, y), (FONT, 14)))?;
    }
    let (events, panels_area) = rest.split_vertically(layout.events_h);
    if layout.events_h > 0 {
        draw_events(&events, &figure.markers, t_max)?;
    }
    let breaks: Vec<u32> = (1..layout.panels).map(|i| i * PANEL_H).collect();
    let rows = panels_area.split_by_breakpoints([] as [u32; 0], breaks);
    for (panel, area) in figure.panels.iter().zip(&rows) {
        draw_panel(area, panel, t_max, &figure.markers)?;
    }
    root.present()?;
    Ok(())
}

/// The colour of the event lines.
const EVENT_COLOR: RGBColor = RGBColor(120, 60, 160);

/// The event strip: a time axis like the panels', a line at each marker,
/// labels in rows so they do not overlap (a label with no room left is
/// counted in the caption instead, its marker a tick in the last row).
fn draw_events<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    markers: &[Marker],
    t_max: f64,
) -> Res
where
    DB::ErrorType: 'static,
{
    let mut placed = Vec::new();
    let mut row_end = [i32::MIN; EVENT_ROWS - 1];
    let (plot_area, _) = area.split_horizontally(area.dim_in_pixel().0 - LEGEND_W);
    let px = |t: f64| {
        // The panels' plot area: 8 px margin and the 60 px y-label area on
        // the left, 8 px on the right.
        let (l, r) = (68.0, f64::from(plot_area.dim_in_pixel().0) - 8.0);
        (l + (r - l) * t / t_max) as i32
    };
    for m in markers {
        let x = px(m.t_s);
        let text = format!("{} ({:.2} s)", m.label, m.t_s);
        let w = 8 * text.chars().count() as i32;
        if let Some(row) = row_end.iter().position(|end| x > *end + 6) {
            row_end[row] = x + w;
            placed.push((m.t_s, row, text));
        }
    }
    let unlabelled = markers.len() - placed.len();
    let caption = if unlabelled == 0 {
        "events".to_string()
    } else {
        format!("events ({unlabelled} not labelled for want of room; all are in the --csv file)")
    };
    draw_event_chart(&plot_area, &caption, markers, &placed, t_max)
}

/// The chart of [`draw_events`]: the lines, and the placed labels.
fn draw_event_chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    markers: &[Marker],
    placed: &[(f64, usize, String)],
    t_max: f64,
) -> Res
where
    DB::ErrorType: 'static,
{
    let rows = EVENT_ROWS as f64;
    let mut c = ChartBuilder::on(area)
        .margin(8)
        .caption(caption, (FONT, 17))
        .x_label_area_size(22)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_max, 0.0..rows)?;
    c.configure_mesh()
        .disable_mesh()
        .disable_y_axis()
        .label_style((FONT, 13))
        .draw()?;
    let line = EVENT_COLOR.stroke_width(1);
    // Each line rises to its own label's row only, so it never crosses
    // the labels above it; an unlabelled marker is a tick in the last row.
    for m in markers {
        c.draw_series(LineSeries::new([(m.t_s, 0.0), (m.t_s, 0.6)], line))?;
    }
    for (t, row, text) in placed {
        let y = rows - *row as f64 - 0.15;
        c.draw_series(LineSeries::new([(*t, 0.0), (*t, y + 0.15)], line))?;
        let font = (FONT, 14).into_font().color(&EVENT_COLOR);
        c.draw_series(std::iter::once(
            EmptyElement::at((*t, y)) + Text::new(text.clone(), (4, 0), font),
        ))?;
    }
    Ok(())
}

/// The style of series `i` of `panel`.
fn style(panel: &Panel, i: usize) -> LineStyle {
    let reference = LineStyle {
        stroke: BLACK.mix(0.8).stroke_width(1),
        dashed: true,
    };
    if panel.series.get(i).is_some_and(|s| s.reference) {
        return reference;
    }
    match panel.look {
        Look::Tracking(color) => match i {
            0 => LineStyle::solid(color.mix(0.35).stroke_width(5)),
            1 => LineStyle::solid(color.stroke_width(1)),
            2 => reference,
            _ => LineStyle::solid(BLACK.mix(0.8).stroke_width(1)),
        },
        Look::Channels => {
            let colors = [COLORS[0], COLORS[1], COLORS[2], ORANGE, BLACK];
            LineStyle::solid(colors[i % colors.len()].stroke_width(1))
        }
    }
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    t_max: f64,
    markers: &[Marker],
) -> Res
where
    DB::ErrorType: 'static,
{
    let lines: Vec<Vec<Vec<(f64, f64)>>> =
        panel.series.iter().map(|s| segments(&s.points)).collect();
    let y = panel.y_range.clone().unwrap_or_else(|| {
        autoscale(
            lines.iter().flatten().flatten().map(|(_, v)| v),
            panel.min_span,
        )
    });
    let styles: Vec<LineStyle> = (0..lines.len()).map(|i| style(panel, i)).collect();
    let legend: Vec<(&str, LineStyle)> = panel
        .series
        .iter()
        .map(|s| s.name.as_str())
        .zip(styles.iter().copied())
        .collect();
    let mut c = styled_time_chart(area, &panel.caption, t_max, y.clone(), &panel.unit, &legend)?;
    let event_line = EVENT_COLOR.mix(0.6).stroke_width(1);
    for m in markers {
        let l = [(m.t_s, y.start), (m.t_s, y.end)];
        c.draw_series(DashedLineSeries::new(l, 3, 3, event_line))?;
    }
    for (segs, style) in lines.into_iter().zip(styles) {
        for l in segs {
            if style.dashed {
                c.draw_series(DashedLineSeries::new(l, 6, 4, style.stroke))?;
            } else {
                c.draw_series(LineSeries::new(l, style.stroke))?;
            }
        }
    }
    Ok(())
}

/// A spectrum figure: one panel per entry of `panels` (caption, series of
/// (frequency in Hz, density)), densities drawn in dB of `unit` (10·log10),
/// `notes` as text lines under the title. PNG or SVG by the extension.
pub fn write_spectrum(
    path: &Path,
    title: &str,
    unit: &str,
    notes: &[String],
    panels: &[(String, Vec<Series>)],
) -> Result<(), String> {
    let format = PlotFormat::from_path(path)?;
    if panels
        .iter()
        .all(|(_, s)| s.iter().all(|s| s.points.is_empty()))
    {
        return Err("nothing to plot: no spectrum".into());
    }
    load_font()?;
    let h = TITLE_H + NOTE_LINE_H * notes.len() as u32 + 2 * PANEL_H * panels.len() as u32;
    let res = match format {
        PlotFormat::Png => draw_spectrum(
            BitMapBackend::new(path, (WIDTH, h)).into_drawing_area(),
            (title, unit, notes),
            panels,
        ),
        PlotFormat::Svg => draw_spectrum(
            SVGBackend::new(path, (WIDTH, h)).into_drawing_area(),
            (title, unit, notes),
            panels,
        ),
    };
    res.map_err(|e| e.to_string())
}

fn draw_spectrum<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    (title, unit, notes): (&str, &str, &[String]),
    panels: &[(String, Vec<Series>)],
) -> Res
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 22))?;
    let notes_h = NOTE_LINE_H * notes.len() as u32;
    let (notes_area, rest) = root.split_vertically(notes_h);
    for (i, n) in notes.iter().enumerate() {
        let y = (NOTE_LINE_H as usize * i) as i32;
        notes_area.draw(&Text::new(n.clone(), (20, y), (FONT, 14)))?;
    }
    let db = |p: f64| 10.0 * p.max(1e-30).log10();
    let all = panels
        .iter()
        .flat_map(|(_, s)| s.iter().flat_map(|s| s.points.iter().map(|&(_, p)| db(p))));
    let y_max = all.clone().fold(f64::NEG_INFINITY, f64::max).ceil() + 5.0;
    let y_min = (y_max - 90.0).max(all.fold(f64::INFINITY, f64::min).floor());
    let f_max = panels
        .iter()
        .flat_map(|(_, s)| s.iter().flat_map(|s| s.points.iter().map(|&(f, _)| f)))
        .fold(0.0, f64::max)
        .max(1.0);
    for ((caption, series), area) in panels.iter().zip(rest.split_evenly((panels.len(), 1))) {
        let legend: Vec<(&str, LineStyle)> = series
            .iter()
            .enumerate()
            .map(|(i, s)| {
                (
                    s.name.as_str(),
                    LineStyle::solid(COLORS[i % 3].stroke_width(2)),
                )
            })
            .collect();
        let (plot_area, legend_area) = area.split_horizontally(WIDTH - LEGEND_W);
        draw_legend(&legend_area, &legend)?;
        let mut c = ChartBuilder::on(&plot_area)
            .margin(8)
            .caption(caption, (FONT, 17))
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..f_max, y_min..y_max)?;
        c.configure_mesh()
            .x_desc("frequency [Hz]")
            .y_desc(format!("dB of {unit}"))
            .label_style((FONT, 13))
            .draw()?;
        for (s, (_, style)) in series.iter().zip(&legend) {
            let pts = s.points.iter().map(|&(f, p)| (f, db(p)));
            c.draw_series(LineSeries::new(pts, style.stroke))?;
        }
    }
    root.present()?;
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

    proptest::proptest! {
        /// Wrapped angles stay in [−180°, 180°), equal the input modulo
        /// 360°, and the line breaks exactly where it would jump by more
        /// than half a turn.
        #[test]
        fn wrapped_series_stay_within_half_a_turn(
            angles in proptest::collection::vec(-1e5f64..1e5, 0..200),
            tiny in -1e-12f64..0.0,
        ) {
            let mut pts: Vec<(f64, f64)> = angles
                .iter()
                .enumerate()
                .map(|(i, a)| (i as f64, *a))
                .collect();
            // Just below −180°, where rem_euclid may round to the modulus.
            pts.push((pts.len() as f64, -180.0 + tiny));
            let out = wrap_series_deg(&pts);
            let kept: Vec<&(f64, f64)> = out.iter().filter(|p| p.1.is_finite()).collect();
            proptest::prop_assert_eq!(kept.len(), pts.len());
            for (w, p) in kept.iter().zip(&pts) {
                proptest::prop_assert!((-180.0..180.0).contains(&w.1), "{} -> {}", p.1, w.1);
                let turns = (p.1 - w.1) / 360.0;
                proptest::prop_assert!((turns - turns.round()).abs() < 1e-9, "{} -> {}", p.1, w.1);
            }
            for seg in segments(&out) {
                for pair in seg.windows(2) {
                    proptest::prop_assert!((pair[1].1 - pair[0].1).abs() <= 180.0);
                }
            }
        }
    }

    #[test]
    fn a_steady_roll_through_a_loop_wraps_once_per_turn() {
        let pts: Vec<(f64, f64)> = (0..=720).map(|i| (f64::from(i), f64::from(i))).collect();
        let out = wrap_series_deg(&pts);
        // 0..720° crosses +180° twice (at 180° and 540°).
        assert_eq!(out.iter().filter(|p| p.1.is_nan()).count(), 2);
        assert_eq!(segments(&out).len(), 3);
        assert_eq!(wrap_deg(180.0), -180.0);
        assert_eq!(wrap_deg(-180.0), -180.0);
        // Just below −180°: rem_euclid rounds up to 360°, which must not
        // give +180°.
        let w = wrap_deg(-180.0 - 3e-14);
        assert!((-180.0..180.0).contains(&w), "{w}");
    }

    #[test]
    fn a_reference_series_is_dashed_in_the_legend_as_drawn() {
        let panel = Panel::new(
            "p",
            "deg",
            Look::Tracking(BLACK),
            vec![
                Series::new("truth", vec![]),
                Series::reference("setpoint", vec![]),
                Series::new("other", vec![]),
            ],
        );
        let styles: Vec<bool> = (0..3).map(|i| style(&panel, i).dashed).collect();
        // Position 2 of a tracking panel is dashed by place (the emulator's
        // plots rely on it); the reference at 1 by its role.
        assert_eq!(styles, [false, true, true]);
        let channels = Panel::new("c", "", Look::Channels, panel.series.clone());
        assert!(style(&channels, 1).dashed && !style(&channels, 2).dashed);
    }

    #[test]
    fn notes_wrap_between_words() {
        let lines = wrap_words("aaa bbb ccc dddddddddd e", 7);
        assert_eq!(lines, ["aaa bbb", "ccc", "dddddddddd", "e"]);
        assert!(wrap_words("a b", 7) == ["a b"]);
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
