//! `cargo sim --scenario chirp --sweep SPEC`: one setting over a range,
//! the chirp flown with each value, and the figures against it (the
//! effect of that parameter). A rate-loop gain is swept as multiples of
//! the board's value (`rate.roll.p=0.5:2:5`); a filter in Hz
//! (`gyro.lpf=60:200:5`, `gyro.notch=150:300:4`, `dterm.lpf=20:100:5`);
//! the chip's gyro DLPF by its DLPF_CFG (`gyro.dlpf=1:3:3`: 184, 92 and
//! 41 Hz). Filters and the DLPF act on every axis; their table reports roll.

use super::closed_loop::{fly, ClosedLoopOptions, FlightLog};
use super::flight_fc::FirmwareFc;
use super::stack::BootConfig;
use super::tuning::{self, AxisReport, XyPanel, AXES};
use flight::flightctl::FlightConfig;
use mpu9250::GyroBandwidth;
use sensor_stack::gyro_filter::{GyroLowPass, GyroNotch};

/// What is swept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Param {
    /// A rate-PID gain (0 roll, 1 pitch, 2 yaw; `p`, `i` or `d`), as a
    /// multiple of the board's.
    Rate {
        /// 0 roll, 1 pitch, 2 yaw.
        axis: usize,
        /// `p`, `i` or `d`.
        term: char,
    },
    /// The gyro low-pass cut-off (Hz; the board's kind, PT1 if it has none).
    GyroLowPass,
    /// The gyro notch's centre (Hz; the board's Q, 2 if it has none).
    GyroNotch,
    /// The roll and pitch D-term low-pass cut-off (Hz).
    DtermLowPass,
    /// The MPU-9250's gyro DLPF_CFG (1..=6).
    GyroDlpf,
}

/// What to sweep and the values.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSpec {
    /// The setting.
    pub param: Param,
    /// Lowest value (a multiplier, Hz or a DLPF_CFG).
    pub lo: f64,
    /// Highest value.
    pub hi: f64,
    /// How many, evenly spaced, ≥ 2.
    pub steps: usize,
}

/// Most steps of a sweep (each is a whole chirp flight).
const MAX_STEPS: usize = 20;

/// The DLPF_CFG settings 1..=6 (the 1 kHz ones).
const DLPF: [GyroBandwidth; 6] = [
    GyroBandwidth::Hz184,
    GyroBandwidth::Hz92,
    GyroBandwidth::Hz41,
    GyroBandwidth::Hz20,
    GyroBandwidth::Hz10,
    GyroBandwidth::Hz5,
];

/// The parameter of `name` and its valid range of values.
fn param(name: &str) -> Result<(Param, f64, f64), String> {
    let parts: Vec<&str> = name.split('.').collect();
    Ok(match parts.as_slice() {
        ["rate", axis, term] => {
            let axis = AXES
                .iter()
                .position(|a| a == axis)
                .ok_or_else(|| format!("axis `{axis}`: roll, pitch or yaw"))?;
            let term = match *term {
                "p" => 'p',
                "i" => 'i',
                "d" => 'd',
                t => return Err(format!("term `{t}`: p, i or d")),
            };
            (Param::Rate { axis, term }, 0.0, 10.0)
        }
        ["gyro", "lpf"] => (Param::GyroLowPass, 10.0, 400.0),
        ["gyro", "notch"] => (Param::GyroNotch, 10.0, 400.0),
        ["dterm", "lpf"] => (Param::DtermLowPass, 5.0, 400.0),
        ["gyro", "dlpf"] => (Param::GyroDlpf, 1.0, 6.0),
        _ => {
            return Err(format!(
                "`{name}`: rate.AXIS.TERM, gyro.lpf, gyro.notch, dterm.lpf or gyro.dlpf"
            ))
        }
    })
}

impl core::str::FromStr for SweepSpec {
    type Err = String;

    /// `NAME=LO:HI:STEPS`: `rate.AXIS.TERM` (AXIS roll, pitch or yaw;
    /// TERM p, i or d; multipliers of the board's in (0, 10]), `gyro.lpf`
    /// and `gyro.notch` (10..=400 Hz), `dterm.lpf` (5..=400 Hz) or
    /// `gyro.dlpf` (DLPF_CFG 1..=6, whole numbers); LO < HI; STEPS in
    /// 2..=20.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("`{s}` is not NAME=LO:HI:STEPS (e.g. rate.roll.p=0.5:2:5)");
        let (name, range) = s.split_once('=').ok_or_else(bad)?;
        let (param, min, max) = param(name)?;
        let r: Vec<&str> = range.split(':').collect();
        let [lo, hi, steps] = r.as_slice() else {
            return Err(bad());
        };
        let num = |x: &str| x.trim().parse::<f64>().map_err(|_| bad());
        let (lo, hi) = (num(lo)?, num(hi)?);
        let steps: usize = steps.trim().parse().map_err(|_| bad())?;
        // A multiplier must be positive; a frequency or a DLPF_CFG may be
        // its range's lowest value.
        let (low_ok, op) = if min == 0.0 {
            (lo > 0.0, "<")
        } else {
            (lo >= min, "<=")
        };
        if !(low_ok && lo < hi && hi <= max) {
            return Err(format!(
                "{name} from {lo} to {hi}: want {min} {op} LO < HI <= {max}"
            ));
        }
        if !(2..=MAX_STEPS).contains(&steps) {
            return Err(format!("{steps} steps: want 2..={MAX_STEPS}"));
        }
        let spec = Self {
            param,
            lo,
            hi,
            steps,
        };
        if param == Param::GyroDlpf && spec.values().iter().any(|v| v.fract() != 0.0) {
            return Err(format!(
                "{name}: DLPF_CFG values {:?} are not whole numbers",
                spec.values()
            ));
        }
        Ok(spec)
    }
}

impl SweepSpec {
    /// The values, evenly spaced from `lo` to `hi`.
    pub fn values(&self) -> Vec<f64> {
        (0..self.steps)
            .map(|i| self.lo + (self.hi - self.lo) * i as f64 / (self.steps - 1) as f64)
            .collect()
    }

    /// The axis whose figures the table reports.
    pub fn axis(&self) -> usize {
        match self.param {
            Param::Rate { axis, .. } => axis,
            _ => 0,
        }
    }

    /// The parameter's name, e.g. `rate.roll.p`.
    pub fn name(&self) -> String {
        match self.param {
            Param::Rate { axis, term } => format!("rate.{}.{term}", AXES[axis]),
            Param::GyroLowPass => "gyro.lpf".into(),
            Param::GyroNotch => "gyro.notch".into(),
            Param::DtermLowPass => "dterm.lpf".into(),
            Param::GyroDlpf => "gyro.dlpf".into(),
        }
    }

    /// What the values are.
    fn unit(&self) -> &'static str {
        match self.param {
            Param::Rate { .. } => "multiplier of the board's",
            Param::GyroDlpf => "DLPF_CFG",
            _ => "Hz",
        }
    }

    /// The board's settings with the swept one at `v`, and the setting as
    /// flown (the gain, the cut-off, the DLPF's bandwidth).
    pub fn apply(
        &self,
        base: &FlightConfig,
        boot: &BootConfig,
        v: f64,
    ) -> Result<(FlightConfig, BootConfig, f32), String> {
        let (mut cfg, mut b) = (*base, *boot);
        let value = match self.param {
            Param::Rate { axis, term } => {
                let pid = [&mut cfg.rate.roll, &mut cfg.rate.pitch, &mut cfg.rate.yaw]
                    .into_iter()
                    .nth(axis)
                    .ok_or("axis")?;
                let gain = match term {
                    'p' => &mut pid.kp,
                    'i' => &mut pid.ki,
                    _ => &mut pid.kd,
                };
                *gain *= v as f32;
                *gain
            }
            Param::DtermLowPass => {
                cfg.rate.roll.d_cutoff_hz = v as f32;
                cfg.rate.pitch.d_cutoff_hz = v as f32;
                v as f32
            }
            Param::GyroDlpf => {
                let bw = DLPF[(v as usize).clamp(1, 6) - 1];
                b.sensors.mpu.gyro_bandwidth = bw;
                bw.bandwidth_hz()
            }
            Param::GyroLowPass | Param::GyroNotch => {
                let mut f = settings::GYRO_FILTER;
                if self.param == Param::GyroLowPass {
                    f.low_pass = match f.low_pass {
                        GyroLowPass::Biquad { .. } => GyroLowPass::Biquad {
                            cutoff_hz: v as f32,
                        },
                        _ => GyroLowPass::Pt1 {
                            cutoff_hz: v as f32,
                        },
                    };
                } else {
                    let q = f.notch.map_or(2.0, |n| n.q);
                    f.notch = Some(GyroNotch {
                        center_hz: v as f32,
                        q,
                    });
                }
                b.pipeline.gyro_filter = f
                    .design(settings::IMU_RATE_HZ)
                    .map_err(|e| format!("{} = {v}: {e}", self.name()))?;
                v as f32
            }
        };
        Ok((cfg, b, value))
    }
}

/// One step of the sweep: the value, the setting as flown, the swept
/// axis' report and its hover noise.
pub struct SweepRow {
    /// The value (a multiplier, Hz or a DLPF_CFG).
    pub value: f64,
    /// The setting flown (the gain, the cut-off, the DLPF's bandwidth).
    pub setting: f32,
    /// The swept axis measured (an error: why not).
    pub report: Result<AxisReport, String>,
    /// [`hover_noise`] on the swept axis (% of the torque range).
    pub noise_pct: Option<f64>,
}

/// Seconds of the chirp flight's hover before the sweeps whose torque
/// noise is measured: from 5 s (the take-off settled) to the chirp.
const NOISE_WINDOW_S: (f64, f64) = (5.0, sim::scenario::CHIRP_START_S);
/// The moving mean taken off the torque before its RMS (samples): what is
/// left is above ≈ 20 Hz, the noise the gyro path and the D term put on
/// the motors, not the control.
const NOISE_MEAN_SAMPLES: usize = 41;

/// The rate loop's torque command noise per axis in the hover before the
/// chirp: the RMS of the command minus its 41-sample moving mean, in % of
/// the ±1 range (`None` when the craft was not flying then). What the frame's
/// vibration and the sensor noise, through the gyro filters and the D term,
/// make the motors do.
pub fn hover_noise(log: &FlightLog) -> Option<[f64; 3]> {
    let (t0, t1) = NOISE_WINDOW_S;
    let torque: Vec<[f32; 3]> = log
        .samples
        .iter()
        .filter(|s| s.t_s >= t0 && s.t_s < t1)
        .map(|s| s.out.torque)
        .collect::<Option<_>>()?;
    let n = NOISE_MEAN_SAMPLES;
    if torque.len() < 4 * n {
        return None;
    }
    let mut out = [0.0; 3];
    for (axis, o) in out.iter_mut().enumerate() {
        let x: Vec<f64> = torque.iter().map(|t| f64::from(t[axis])).collect();
        let hp: Vec<f64> = x
            .windows(n)
            .map(|w| w[n / 2] - w.iter().sum::<f64>() / n as f64)
            .collect();
        *o = 100.0 * (hp.iter().map(|v| v * v).sum::<f64>() / hp.len() as f64).sqrt();
    }
    Some(out)
}

/// Flies `opts` (the chirp) once per value of `spec`, on `base` and the
/// options' boot settings.
pub fn run(
    spec: &SweepSpec,
    opts: &ClosedLoopOptions,
    base: &FlightConfig,
) -> Result<Vec<SweepRow>, String> {
    let mut rows = Vec::new();
    for v in spec.values() {
        let (cfg, boot, setting) = spec.apply(base, &opts.boot, v)?;
        let mut fc = FirmwareFc::new(cfg)?;
        let o = ClosedLoopOptions {
            boot,
            ..opts.clone()
        };
        let log = fly(&o, &mut fc)?;
        let report = tuning::analyse_chirp(&log).map(|mut r| r.swap_remove(spec.axis()));
        rows.push(SweepRow {
            value: v,
            setting,
            noise_pct: hover_noise(&log).map(|n| n[spec.axis()]),
            report,
        });
    }
    Ok(rows)
}

/// The sweep's table: one line per value.
pub fn table(spec: &SweepSpec, rows: &[SweepRow]) -> Vec<String> {
    let mut out = vec![format!(
        "{} swept ({}), {} axis figures; noise: the torque command's RMS above ≈ 20 Hz in the hover, % of its range:",
        spec.name(),
        spec.unit(),
        AXES[spec.axis()]
    )];
    let t = tuning::table(&[]);
    out.push(format!(
        "{:>6} {:>8} {:>6}  {}",
        "value", "setting", "noise", t[0]
    ));
    for r in rows {
        let line = match &r.report {
            Ok(rep) => tuning::table(std::slice::from_ref(rep))[1].clone(),
            Err(e) => format!("not measured: {e}"),
        };
        let noise = r.noise_pct.map_or("-".into(), |n| format!("{n:.2}"));
        out.push(format!(
            "{:>6.2} {:>8.4} {noise:>6}  {line}",
            r.value, r.setting
        ));
    }
    out
}

/// The figures against the swept value.
pub fn write_plot(
    path: &std::path::Path,
    spec: &SweepSpec,
    rows: &[SweepRow],
) -> Result<(), String> {
    let title = format!("{} swept, chirp, {} axis", spec.name(), AXES[spec.axis()]);
    let x = (spec.lo, spec.hi, false, spec.unit());
    tuning::write_xy(path, &title, &panels(rows), x)
}

/// The plot's panels: the margins, the crossover, the step, the noise.
fn panels(rows: &[SweepRow]) -> Vec<XyPanel> {
    let ok: Vec<(f64, &AxisReport)> = rows
        .iter()
        .filter_map(|r| r.report.as_ref().ok().map(|a| (r.value, a)))
        .collect();
    let noise: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| r.noise_pct.map(|n| (r.value, n)))
        .collect();
    let line = |name: &str, f: &dyn Fn(&AxisReport) -> Option<f64>| {
        let points = ok.iter().filter_map(|(m, a)| f(a).map(|v| (*m, v)));
        (name.to_string(), points.collect())
    };
    let step = |a: &AxisReport, g: fn(&sim::rate_loop::step::StepResponse) -> Option<f64>| {
        a.step.as_ref().and_then(g)
    };
    let panel = |caption: &str, series, guide| XyPanel {
        caption: caption.into(),
        series,
        guide,
    };
    vec![
        panel(
            "phase margin (°); the line: 45°",
            vec![line("PM", &|a| a.margins.phase_margin_deg)],
            Some(45.0),
        ),
        panel(
            "sensitivity peak Ms; the line: 2",
            vec![line("Ms", &|a| Some(a.margins.ms))],
            Some(2.0),
        ),
        panel(
            "gain margin (dB)",
            vec![line("GM", &|a| a.margins.gain_margin_db)],
            None,
        ),
        panel(
            "crossover (Hz)",
            vec![line("crossover", &|a| a.margins.crossover_hz)],
            None,
        ),
        panel(
            "step: rise (ms), overshoot (%)",
            vec![
                line("rise ms", &|a| step(a, |s| s.rise_s.map(|r| r * 1e3))),
                line("overshoot %", &|a| step(a, |s| Some(s.overshoot_pct))),
            ],
            None,
        ),
        panel(
            "torque noise in the hover (% of range, above ≈ 20 Hz)",
            vec![("noise".to_string(), noise)],
            None,
        ),
    ]
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
        let rows = run(&spec, &o, &settings::flight_config()).unwrap();
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
        assert_eq!((s.param, s.steps), (Param::Rate { axis: 1, term: 'd' }, 4));
        assert_eq!(s.values(), vec![0.5, 1.0, 1.5, 2.0]);
        let base = settings::flight_config();
        let (cfg, _, g) = s.apply(&base, &BootConfig::board(), 2.0).unwrap();
        assert_eq!(g, 2.0 * base.rate.pitch.kd);
        assert_eq!(cfg.rate.roll, base.rate.roll);
        let f: SweepSpec = "gyro.lpf=50:150:3".parse().unwrap();
        let (_, boot, hz) = f.apply(&base, &BootConfig::board(), 50.0).unwrap();
        assert_eq!(hz, 50.0);
        assert_ne!(
            boot.pipeline.gyro_filter,
            BootConfig::board().pipeline.gyro_filter
        );
        let d: SweepSpec = "gyro.dlpf=1:3:3".parse().unwrap();
        let (_, boot, bw) = d.apply(&base, &BootConfig::board(), 3.0).unwrap();
        assert_eq!(
            (bw, boot.sensors.mpu.gyro_bandwidth),
            (41.0, GyroBandwidth::Hz41)
        );
        let t: SweepSpec = "dterm.lpf=20:80:2".parse().unwrap();
        let (cfg, _, _) = t.apply(&base, &BootConfig::board(), 20.0).unwrap();
        assert_eq!(
            (cfg.rate.roll.d_cutoff_hz, cfg.rate.yaw),
            (20.0, base.rate.yaw)
        );
        for bad in [
            "gyro.dlpf=1:2:3",
            "gyro.dlpf=0:3:4",
            "gyro.lpf=5:100:3",
            "gyro.rate=1:2:3",
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
