//! `cargo sim --scenario chirp --sweep rate.roll.p=0.5:2:5`: one rate-loop
//! gain times each of a range of multipliers of its default, the chirp
//! flown with each, and the swept axis' figures against the multiplier
//! (the effect of that parameter).

use super::closed_loop::{fly, ClosedLoopOptions};
use super::flight_fc::FirmwareFc;
use super::tuning::{self, AxisReport, XyPanel, AXES};
use flight::flightctl::FlightConfig;

/// Which gain and the multipliers.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSpec {
    /// 0 roll, 1 pitch, 2 yaw.
    pub axis: usize,
    /// `p`, `i` or `d`.
    pub term: char,
    /// Lowest multiplier.
    pub lo: f64,
    /// Highest multiplier.
    pub hi: f64,
    /// How many, evenly spaced, ≥ 2.
    pub steps: usize,
}

/// Most steps of a sweep (each is a whole chirp flight).
const MAX_STEPS: usize = 20;

impl core::str::FromStr for SweepSpec {
    type Err = String;

    /// `rate.AXIS.TERM=LO:HI:STEPS`: AXIS roll, pitch or yaw; TERM p, i
    /// or d; LO and HI multipliers of the default in (0, 10], LO < HI;
    /// STEPS in 2..=20.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("`{s}` is not rate.AXIS.TERM=LO:HI:STEPS (e.g. rate.roll.p=0.5:2:5)");
        let (name, range) = s.split_once('=').ok_or_else(bad)?;
        let parts: Vec<&str> = name.split('.').collect();
        let ["rate", axis, term] = parts.as_slice() else {
            return Err(bad());
        };
        let axis = AXES
            .iter()
            .position(|a| a == axis)
            .ok_or_else(|| format!("axis `{axis}`: roll, pitch or yaw"))?;
        let term = match *term {
            "p" | "i" | "d" => term.chars().next().unwrap_or('p'),
            t => return Err(format!("term `{t}`: p, i or d")),
        };
        let r: Vec<&str> = range.split(':').collect();
        let [lo, hi, steps] = r.as_slice() else {
            return Err(bad());
        };
        let num = |x: &str| x.trim().parse::<f64>().map_err(|_| bad());
        let (lo, hi) = (num(lo)?, num(hi)?);
        let steps: usize = steps.trim().parse().map_err(|_| bad())?;
        if !(lo > 0.0 && lo < hi && hi <= 10.0) {
            return Err(format!("multipliers {lo}..{hi}: want 0 < LO < HI <= 10"));
        }
        if !(2..=MAX_STEPS).contains(&steps) {
            return Err(format!("{steps} steps: want 2..={MAX_STEPS}"));
        }
        Ok(Self {
            axis,
            term,
            lo,
            hi,
            steps,
        })
    }
}

impl SweepSpec {
    /// The multipliers, evenly spaced from `lo` to `hi`.
    pub fn multipliers(&self) -> Vec<f64> {
        (0..self.steps)
            .map(|i| self.lo + (self.hi - self.lo) * i as f64 / (self.steps - 1) as f64)
            .collect()
    }

    /// The parameter's name, e.g. `rate.roll.p`.
    pub fn name(&self) -> String {
        format!("rate.{}.{}", AXES[self.axis], self.term)
    }

    /// `base` with the swept gain times `m`.
    pub fn apply(&self, base: &FlightConfig, m: f64) -> (FlightConfig, f32) {
        let mut cfg = *base;
        let pid = match self.axis {
            0 => &mut cfg.rate.roll,
            1 => &mut cfg.rate.pitch,
            _ => &mut cfg.rate.yaw,
        };
        let gain = match self.term {
            'p' => &mut pid.kp,
            'i' => &mut pid.ki,
            _ => &mut pid.kd,
        };
        *gain *= m as f32;
        let value = *gain;
        (cfg, value)
    }
}

/// One step of the sweep: the multiplier, the gain, the swept axis' report.
pub struct SweepRow {
    /// Multiplier of the default.
    pub multiplier: f64,
    /// The gain flown.
    pub gain: f32,
    /// The swept axis measured (an error: why not).
    pub report: Result<AxisReport, String>,
}

/// Flies `opts` (the chirp) once per multiplier of `spec`.
pub fn run(
    spec: &SweepSpec,
    opts: &ClosedLoopOptions,
    base: &FlightConfig,
) -> Result<Vec<SweepRow>, String> {
    let mut rows = Vec::new();
    for m in spec.multipliers() {
        let (cfg, gain) = spec.apply(base, m);
        let mut fc = FirmwareFc::new(cfg)?;
        let log = fly(opts, &mut fc)?;
        let report = tuning::analyse_chirp(&log).map(|mut r| r.swap_remove(spec.axis));
        rows.push(SweepRow {
            multiplier: m,
            gain,
            report,
        });
    }
    Ok(rows)
}

/// The sweep's table: one line per multiplier.
pub fn table(spec: &SweepSpec, rows: &[SweepRow]) -> Vec<String> {
    let mut out = vec![format!(
        "{} swept, {} axis figures:",
        spec.name(),
        AXES[spec.axis]
    )];
    let t = tuning::table(&[]);
    out.push(format!("{:>5} {:>8}  {}", "×", "gain", t[0]));
    for r in rows {
        let line = match &r.report {
            Ok(rep) => tuning::table(std::slice::from_ref(rep))[1].clone(),
            Err(e) => format!("not measured: {e}"),
        };
        out.push(format!("{:>5.2} {:>8.4}  {line}", r.multiplier, r.gain));
    }
    out
}

/// The figures against the multiplier.
pub fn write_plot(
    path: &std::path::Path,
    spec: &SweepSpec,
    rows: &[SweepRow],
) -> Result<(), String> {
    let ok: Vec<(f64, &AxisReport)> = rows
        .iter()
        .filter_map(|r| r.report.as_ref().ok().map(|a| (r.multiplier, a)))
        .collect();
    let line = |name: &str, f: &dyn Fn(&AxisReport) -> Option<f64>| {
        (
            name.to_string(),
            ok.iter()
                .filter_map(|(m, a)| f(a).map(|v| (*m, v)))
                .collect(),
        )
    };
    let step = |a: &AxisReport, g: fn(&super::step::StepResponse) -> Option<f64>| {
        a.step.as_ref().and_then(g)
    };
    let panels = [
        XyPanel {
            caption: "phase margin (°); the line: 45°".into(),
            series: vec![line("PM", &|a| a.margins.phase_margin_deg)],
            guide: Some(45.0),
        },
        XyPanel {
            caption: "sensitivity peak Ms; the line: 2".into(),
            series: vec![line("Ms", &|a| Some(a.margins.ms))],
            guide: Some(2.0),
        },
        XyPanel {
            caption: "gain margin (dB)".into(),
            series: vec![line("GM", &|a| a.margins.gain_margin_db)],
            guide: None,
        },
        XyPanel {
            caption: "crossover (Hz)".into(),
            series: vec![line("crossover", &|a| a.margins.crossover_hz)],
            guide: None,
        },
        XyPanel {
            caption: "step: rise (ms), overshoot (%)".into(),
            series: vec![
                line("rise ms", &|a| step(a, |s| s.rise_s.map(|r| r * 1e3))),
                line("overshoot %", &|a| step(a, |s| Some(s.overshoot_pct))),
            ],
            guide: None,
        },
    ];
    let title = format!("{} × default, chirp, {} axis", spec.name(), AXES[spec.axis]);
    tuning::write_xy(
        path,
        &title,
        &panels,
        (spec.lo, spec.hi, false, "multiplier of the default"),
    )
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;

    #[test]
    fn more_roll_p_crosses_over_higher_with_less_margin() {
        // Loop-shaping's first rule: a higher proportional gain raises
        // |L| everywhere, so the crossover moves up, where the airframe's
        // and the sensor's lags have eaten more phase.
        let spec: SweepSpec = "rate.roll.p=1:2:2".parse().unwrap();
        let mut o = ClosedLoopOptions::new(super::super::closed_loop::Scenario::Chirp, 1);
        o.mag_dance_s = 20.0;
        let rows = run(&spec, &o, &FlightConfig::default()).unwrap();
        for l in table(&spec, &rows) {
            println!("{l}");
        }
        let m: Vec<_> = rows
            .iter()
            .map(|r| r.report.as_ref().unwrap().margins)
            .collect();
        assert!(
            m[1].crossover_hz.unwrap() > 1.2 * m[0].crossover_hz.unwrap(),
            "{m:?}"
        );
        assert!(
            m[1].phase_margin_deg.unwrap() < m[0].phase_margin_deg.unwrap(),
            "{m:?}"
        );
        assert!(m[1].ms > m[0].ms, "{m:?}");
    }

    #[test]
    fn specs_parse_and_bad_ones_are_refused() {
        let s: SweepSpec = "rate.pitch.d=0.5:2:4".parse().unwrap();
        assert_eq!((s.axis, s.term, s.steps), (1, 'd', 4));
        assert_eq!(s.multipliers(), vec![0.5, 1.0, 1.5, 2.0]);
        let (cfg, g) = s.apply(&FlightConfig::default(), 2.0);
        assert_eq!(g, 2.0 * FlightConfig::default().rate.pitch.kd);
        assert_eq!(cfg.rate.roll, FlightConfig::default().rate.roll);
        for bad in [
            "rate.roll.p",
            "rate.up.p=1:2:3",
            "rate.roll.x=1:2:3",
            "rate.roll.p=2:1:3",
            "rate.roll.p=0:1:3",
            "rate.roll.p=1:2:1",
            "rate.roll.p=1:2:99",
            "level.roll.p=1:2:3",
        ] {
            assert!(bad.parse::<SweepSpec>().is_err(), "{bad}");
        }
    }
}
