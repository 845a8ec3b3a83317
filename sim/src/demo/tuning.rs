//! The rate loop's measurement ([`sim::rate_loop`]) applied to a
//! flight of `cargo sim` (the chirp scenario's sweeps) or to any log
//! holding the rate setpoint and the gyro the controller saw
//! ([`super::analyse`]), and drawn: the Bode plot and the x–y figures of
//! the parameter sweep.

use super::closed_loop::FlightLog;
use plotters::prelude::*;
use sim::plot::FONT;
use sim::rate_loop::{self, freq, F_HI_HZ, F_LO_HZ};
pub use sim::rate_loop::{analyse_axis, table, AxisReport, AxisSignals, AXES};
use std::ops::Sub;
use std::path::Path;

/// The signals of each axis' sweep in a chirp flight (the samples within
/// the sweep; an error when one has no setpoint or gyro, as when the
/// craft was not flying).
pub fn chirp_signals(log: &FlightLog) -> Result<[AxisSignals; 3], String> {
    let widen = |v: Option<[f32; 3]>| v.map(|a| a.map(f64::from));
    rate_loop::chirp_signals(
        log.samples
            .iter()
            .map(|s| (s.t_s, widen(s.out.rate_setpoint_rps), widen(s.out.gyro_rps))),
    )
}

/// The sample rate of a log (Hz) from its mean spacing.
pub fn sample_rate_hz(log: &FlightLog) -> Result<f64, String> {
    match (log.samples.first(), log.samples.last()) {
        (Some(a), Some(b)) if b.t_s > a.t_s => Ok((log.samples.len() - 1) as f64 / (b.t_s - a.t_s)),
        _ => Err("fewer than two samples".into()),
    }
}

/// Measures the three sweeps of a chirp flight.
pub fn analyse_chirp(log: &FlightLog) -> Result<Vec<AxisReport>, String> {
    if log.missed > 0 {
        return Err(format!(
            "{} IMU samples were missed: the analysis wants a constant sample rate",
            log.missed
        ));
    }
    let fs = sample_rate_hz(log)?;
    rate_loop::analyse_sweeps(&chirp_signals(log)?, fs)
}

/// Colours of the lines of a panel (roll, pitch, yaw in a Bode plot).
const COLOURS: [RGBColor; 4] = [RED, RGBColor(0, 150, 0), BLUE, RGBColor(230, 140, 0)];

/// One panel of an x–y figure ([`write_xy`]).
#[derive(Clone, Debug, PartialEq)]
pub struct XyPanel {
    /// Caption (with the y unit).
    pub caption: String,
    /// Named lines of `(x, y)` points.
    pub series: Vec<(String, Vec<(f64, f64)>)>,
    /// A horizontal guide line (a margin's limit), if any.
    pub guide: Option<f64>,
}

/// Draws `panels` stacked under `title` into `path` (.png or .svg) over
/// `x` (logarithmic when `log_x`), labelled `x_desc`.
pub fn write_xy(
    path: &Path,
    title: &str,
    panels: &[XyPanel],
    x: (f64, f64, bool, &str),
) -> Result<(), String> {
    let format = sim::plot::PlotFormat::from_path(path)?;
    if panels
        .iter()
        .all(|p| p.series.iter().all(|s| s.1.is_empty()))
    {
        return Err("nothing to plot".into());
    }
    sim::plot::load_font()?;
    let size = (1200, 60 + 330 * panels.len() as u32);
    let res = match format {
        sim::plot::PlotFormat::Png => draw_xy(
            BitMapBackend::new(path, size).into_drawing_area(),
            title,
            panels,
            x,
        ),
        sim::plot::PlotFormat::Svg => draw_xy(
            SVGBackend::new(path, size).into_drawing_area(),
            title,
            panels,
            x,
        ),
    };
    res.map_err(|e| e.to_string())
}

type Res = Result<(), Box<dyn std::error::Error>>;

fn draw_xy<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    title: &str,
    panels: &[XyPanel],
    (x_lo, x_hi, log_x, x_desc): (f64, f64, bool, &str),
) -> Res
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let root = root.titled(title, (FONT, 24))?;
    let rows = root.split_evenly((panels.len(), 1));
    for (panel, area) in panels.iter().zip(&rows) {
        let values = panel.series.iter().flat_map(|s| &s.1).map(|p| &p.1);
        let y = sim::plot::autoscale(values.chain(panel.guide.as_ref()), 1.0);
        let mut b = ChartBuilder::on(area);
        b.caption(&panel.caption, (FONT, 16))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(55);
        if log_x {
            let mut chart = b.build_cartesian_2d((x_lo..x_hi).log_scale(), y)?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .label_style((FONT, 13))
                .draw()?;
            draw_lines(&mut chart, panel, (x_lo, x_hi))?;
        } else {
            let mut chart = b.build_cartesian_2d(x_lo..x_hi, y)?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .label_style((FONT, 13))
                .draw()?;
            draw_lines(&mut chart, panel, (x_lo, x_hi))?;
        }
    }
    root.present()?;
    Ok(())
}

fn draw_lines<'a, DB: DrawingBackend + 'a, X>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, plotters::coord::types::RangedCoordf64>>,
    panel: &XyPanel,
    (x_lo, x_hi): (f64, f64),
) -> Res
where
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64>,
{
    for (i, (name, pts)) in panel.series.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))?;
    }
    if let Some(g) = panel.guide {
        chart.draw_series(LineSeries::new(
            [(x_lo, g), (x_hi, g)],
            BLACK.stroke_width(1),
        ))?;
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .label_font((FONT, 13))
        .draw()?;
    Ok(())
}

/// Draws the Bode plot of the open loops (magnitude, phase) and the
/// sensitivity `|S| = |1 − T|` into `path` (.png or .svg), the guides at
/// 0 dB, −180° and Ms = 2 (6 dB).
pub fn write_bode(path: &Path, title: &str, reports: &[AxisReport]) -> Result<(), String> {
    let panel = |caption: &str, guide: f64, values: &dyn Fn(&AxisReport) -> Vec<f64>| XyPanel {
        caption: caption.to_string(),
        series: reports
            .iter()
            .map(|r| {
                (
                    r.axis.to_string(),
                    r.open.f_hz.iter().copied().zip(values(r)).collect(),
                )
            })
            .collect(),
        guide: Some(guide),
    };
    let sensitivity = |r: &AxisReport| -> Vec<f64> {
        r.closed
            .h
            .iter()
            .map(|t| 20.0 * freq::C::new(1.0, 0.0).sub(*t).abs().log10())
            .collect()
    };
    let panels = [
        panel("open loop |L| (dB)", 0.0, &|r| r.open.magnitude_db()),
        panel("open loop phase ∠L (°)", -180.0, &|r| r.open.phase_deg()),
        panel(
            "sensitivity |S| = |1 − T| (dB); the line: Ms = 2",
            20.0 * 2f64.log10(),
            &sensitivity,
        ),
    ];
    write_xy(
        path,
        title,
        &panels,
        (F_LO_HZ, F_HI_HZ, true, "frequency (Hz)"),
    )
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use crate::demo::closed_loop::{fly, ClosedLoopOptions, Scenario};
    use crate::demo::flight_fc::FirmwareFc;
    use sim::scenario::CHIRP_START_S;

    /// The chirp flown with the default configuration, and measured.
    pub(crate) fn measured(seed: u64) -> (FlightLog, Vec<AxisReport>) {
        let mut fc = FirmwareFc::new(settings::flight_config()).unwrap();
        let mut o = ClosedLoopOptions::new(Scenario::Chirp, seed);
        o.mag_dance_s = 20.0;
        let log = fly(&o, &mut fc).unwrap();
        let r = analyse_chirp(&log).unwrap();
        for l in table(&r) {
            println!("chirp seed {seed}: {l}");
        }
        (log, r)
    }

    #[test]
    fn the_sweeps_stay_within_30_degrees_and_a_metre_of_height() {
        let (log, _) = measured(1);
        let start = log.samples.iter().find(|s| s.t_s >= CHIRP_START_S).unwrap();
        for s in log.samples.iter().filter(|s| s.t_s >= CHIRP_START_S) {
            let e = s.truth.q_ned_from_body.to_euler();
            assert!(
                e[0].abs().max(e[1].abs()).to_degrees() < 30.0,
                "{:.3} s: {e:?}",
                s.t_s
            );
            let dh = s.truth.height_m - start.truth.height_m;
            assert!(dh.abs() < 1.0, "{:.3} s: {dh} m", s.t_s);
            assert!(s.out.armed && !s.quad.on_ground, "{:.3} s", s.t_s);
        }
    }

    #[test]
    fn the_rate_loop_has_sensible_margins_on_every_axis() {
        for r in measured(1).1 {
            let m = r.margins;
            // A rate loop that flies: it crosses over within the band, at
            // a few Hz to a few tens, with the margins a stable, not
            // fragile, loop has (Ms below 3, PM above 30°); a gain margin
            // when the phase reaches −180° in the band.
            let fc = m.crossover_hz.unwrap();
            assert!((1.0..60.0).contains(&fc), "{}: {m:?}", r.axis);
            assert!(m.phase_margin_deg.unwrap() > 30.0, "{}: {m:?}", r.axis);
            assert!(m.ms > 1.0 && m.ms < 3.0, "{}: {m:?}", r.axis);
            // The board's tuning's aim, with the sensor's delay and the
            // frame's vibration: 45° of phase margin and Ms ≤ 2, the line
            // Betaflight's configurator draws.
            assert!(m.phase_margin_deg.unwrap() >= 45.0, "{}: {m:?}", r.axis);
            assert!(m.ms <= 2.0, "{}: {m:?}", r.axis);
            assert!(
                m.gain_margin_db.is_none_or(|g| g > 3.0),
                "{}: {m:?}",
                r.axis
            );
            // The deconvolved step settles on the setpoint: the loop has
            // an integrator, so no steady-state error beyond the noise.
            let s = r.step.unwrap();
            assert!((s.final_value - 1.0).abs() < 0.1, "{}: {s:?}", r.axis);
            assert!(s.rise_s.unwrap() < 0.2, "{}: {s:?}", r.axis);
        }
    }

    #[test]
    fn the_bode_plot_is_written() {
        let (_, r) = measured(2);
        let path = std::env::temp_dir().join(format!("sim-bode-{}.png", std::process::id()));
        write_bode(&path, "test", &r).unwrap();
        assert!(std::fs::metadata(&path).unwrap().len() > 10_000);
        let _ = std::fs::remove_file(path);
    }
}
