//! `sim`: the whole sensor stack on a simulated board, no hardware needed.
//!
//! `cargo sim --help` lists the options. Status lines go to stdout (to
//! stderr when the CSV goes to stdout with `--csv -`); a progress line goes
//! to stderr on long runs. A closed stdout is not an error: the lines stop,
//! the run finishes and its files are written, exit status 0.
//!
//! Exit status: 0 done, 1 the run or an output failed, 2 bad arguments.

mod demo;

use clap::Parser;
use demo::output::CsvWriter;
use demo::plot::PlotSeries;
use demo::run::{run, RecordSink, RunOptions, RunResult};
use demo::stack::Filter;
use host_console::{note, say, SafeFile};
use sim::faults::{FaultSpec, Rig};
use sim::Trajectory;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The first second of flight is settling time, not scored (see `demo::run::Scorer`).
const SETTLE_S: f64 = 1.0;

const ABOUT: &str = "\
The firmware's sensor stack on a simulated board (no hardware): register-level
MPU-9250 / AK8963 / MS5611 models on a virtual I2C bus with seeded
datasheet-size sensor errors, driven by the real drivers.

What runs, in order (each a separate session of the same simulated board):
  1. accelerometer six-position calibration (the board held still on each face);
  2. magnetometer calibration on a figure-eight dance (--mag-dance seconds);
  both go into the firmware's flash record (sensor_stack::storage);
  3. the flight: boot probe, start-up gyro bias while still, then every MPU
     data-ready through sensor_stack::pipeline::Pipeline (raw counts -> calibration ->
     mounting -> AHRS -> vertical estimator -> controllers), the code the
     firmware runs. Errors are scored against the truth after the first second.

With --scenario the flight is closed-loop instead: a 250-class quadcopter
model is the truth, the same pipeline estimates it, flight::flightctl's
FlightController flies it (scripted pilot), and the scenario's figures
(hover height error, rise time, overshoot, failsafe timing) are printed.";

/// Command-line options (see `--help`).
#[derive(Parser, Debug)]
#[command(name = "sim", version, about = ABOUT, after_help = after_help(), allow_negative_numbers = true)]
struct Cli {
    /// The flight to simulate.
    #[arg(short, long, value_name = "NAME", default_value = "hover",
          value_parser = clap::builder::PossibleValuesParser::new(Trajectory::NAMES))]
    trajectory: String,
    /// Seed of all noise (sensor noise, random walks, vibration phases).
    #[arg(short, long, value_name = "N", default_value_t = 1)]
    seed: u64,
    /// Seed of the board's fixed errors (biases, scale, misalignment, hard/soft iron); default: --seed.
    #[arg(long, value_name = "N")]
    board_seed: Option<u64>,
    /// Simulated flight time, seconds, in (1, 86400] (the first second is
    /// settling time and not scored).
    #[arg(short, long, value_name = "SECONDS", default_value_t = 90.0,
          value_parser = seconds_in(SETTLE_S, 86_400.0))]
    duration: f64,
    /// The AHRS the pipeline was built with; chosen at compile time like the
    /// firmware's (fixed point by default; f32 with `--features f32-ahrs`).
    #[arg(long, value_enum, value_name = "KIND")]
    filter: Option<FilterArg>,
    /// Per-sample CSV; `-` = stdout. Parent folders are created. A
    /// trajectory's is in the BROAD columns (for `replay`); a scenario's has
    /// the columns listed below (truth, estimate, setpoints, motors, events).
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Plot; .png or .svg. Parent folders are created. A trajectory's:
    /// attitude, error and height against the truth, and the magnetometer
    /// calibration. A scenario's: its figures, its events on the time axis,
    /// attitude, yaw rate, height, horizontal position, motors, battery.
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// A status line every this many simulated seconds, >= 0 (0 = never).
    #[arg(long, value_name = "SECONDS", default_value_t = 5.0,
          value_parser = seconds_in(0.0, f64::MAX))]
    print_every: f64,
    /// Length of the magnetometer calibration dance, seconds, in (0, 600].
    #[arg(long, value_name = "SECONDS", default_value_t = 40.0,
          value_parser = seconds_in(0.0, 600.0))]
    mag_dance: f64,
    /// Trajectory only: the gyro's sensitivity error on all three axes, a
    /// fraction in [-0.1, 0.1], instead of the board's drawn one (within
    /// ±2 %); the MPU-9250's datasheet allows ±3 % at 25 °C and up to ±4 %
    /// more over temperature. The cross-axis terms stay the board's.
    #[arg(long, value_name = "FRAC", conflicts_with = "scenario",
          value_parser = fraction_within(0.1), allow_hyphen_values = true)]
    gyro_scale: Option<f64>,
    /// Inject a fault into the flight at TIME (seconds of flight time);
    /// repeatable. Kinds and their ARG are listed below.
    #[arg(short = 'f', long, value_name = "TIME:KIND[:ARG]", value_parser = sim::faults::parse_sim)]
    fault: Vec<FaultSpec>,
    /// Fly the quadcopter model in a closed loop instead of a trajectory:
    /// the chips read its motion, the firmware's pipeline estimates it, the
    /// flight controller flies it through a scripted pilot. Prints the
    /// scenario's figures and events; --plot draws them, --csv logs every
    /// sample.
    #[arg(long, value_name = "NAME", conflicts_with_all = ["trajectory", "duration"],
          value_parser = clap::builder::PossibleValuesParser::new(demo::closed_loop::Scenario::NAMES))]
    scenario: Option<String>,
    /// Scenario only: the airframe's drag (rotor and form) times this, in
    /// (0, 10]; the AHRS's drag model stays the airframe's nominal one.
    #[arg(long, value_name = "FACTOR", requires = "scenario",
          value_parser = seconds_in(0.0, 10.0))]
    drag_scale: Option<f64>,
    /// Scenario only: the rotor drag grows with the rotors' speed (as
    /// measured by Leishman et al. 2014) instead of a constant coefficient.
    #[arg(long, requires = "scenario")]
    thrust_drag: bool,
    /// Scenario only: a steady wind, NORTH,EAST in m/s (each within ±20).
    #[arg(long, value_name = "NORTH,EAST", requires = "scenario",
          value_parser = parse_wind, allow_hyphen_values = true)]
    wind: Option<[f64; 2]>,
    /// The quad model's vibration as a multiple of its well-balanced
    /// default (rotor imbalance, blade pass, frame mode; 0 = none), >= 0:
    /// for --scenario and --spectrum.
    #[arg(long, value_name = "SCALE", default_value_t = 1.0,
          value_parser = sim::quad::vibration::parse_scale)]
    vibration: f64,
    /// Draw the simulated gyro's spectrum (Welch PSD of the chip's output
    /// after its DLPF, set up as the firmware does) with the quad model at
    /// hover and at full throttle, .png or .svg, and print its summary;
    /// flies nothing else.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["scenario", "csv", "plot", "trajectory", "duration"])]
    spectrum: Option<PathBuf>,
    /// With --scenario chirp or --analyse: the Bode plot of the rate loop
    /// per axis (open loop |L| and phase, sensitivity |1 − T|); .png or .svg.
    #[arg(long, value_name = "FILE")]
    bode: Option<PathBuf>,
    /// Measure the rate loop from a CSV log instead of flying: crossover,
    /// margins, Ms and the deconvolved step per axis. The log needs t_s,
    /// sp_AXIS_rate_dps and gyro_AXIS_dps (AXIS roll, pitch, yaw), as a
    /// scenario CSV has them; the board's raw log has no setpoint and is
    /// refused with that reason.
    #[arg(long, value_name = "FILE.csv",
          conflicts_with_all = ["scenario", "trajectory", "duration", "csv", "plot", "fault"])]
    analyse: Option<PathBuf>,
    /// With --scenario chirp: fly it once per value of one setting and print
    /// (--plot: draw) the figures against it: NAME=LO:HI:STEPS, NAME
    /// rate.AXIS.TERM (AXIS roll, pitch, yaw; TERM p, i, d; multipliers of
    /// the board's gain, e.g. rate.roll.p=0.5:2:5), gyro.lpf, gyro.notch or
    /// dterm.lpf (Hz, e.g. gyro.notch=100:300:5) or gyro.dlpf (the chip's
    /// DLPF_CFG 1..=6, e.g. gyro.dlpf=1:3:3); with a torque-noise column.
    #[arg(long, value_name = "SPEC", requires = "scenario", conflicts_with_all = ["csv", "bode"])]
    sweep: Option<demo::sweep::SweepSpec>,
    /// With --scenario: fly the board's settings changed by FILE, the
    /// lines the board's console prints for `dump` or `diff` (`set NAME
    /// VALUE`, `#` comments): the rate and level gains, rates and expo,
    /// gyro and D-term filters, failsafe timings, ESC idle and the battery
    /// thresholds act on the model; the channel map, link timeout,
    /// mounting and trim are the board's wiring, which the model has not.
    #[arg(
        long,
        value_name = "FILE",
        requires = "scenario",
        conflicts_with = "sweep"
    )]
    settings: Option<PathBuf>,
    /// No progress line on stderr.
    #[arg(short, long)]
    quiet: bool,
}

/// `NORTH,EAST` wind in m/s, each within ±20.
fn parse_wind(s: &str) -> Result<[f64; 2], String> {
    let parts: Vec<&str> = s.split(',').collect();
    let [n, e] = parts.as_slice() else {
        return Err(format!("`{s}` is not NORTH,EAST (two numbers in m/s)"));
    };
    let num = |x: &str| -> Result<f64, String> {
        let v: f64 = x
            .trim()
            .parse()
            .map_err(|_| format!("`{x}` is not a number of m/s"))?;
        if v.is_finite() && v.abs() <= 20.0 {
            Ok(v)
        } else {
            Err(format!("{v} m/s is outside ±20 m/s"))
        }
    };
    Ok([num(n)?, num(e)?])
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum FilterArg {
    /// f32 Madgwick.
    F32,
    /// Fixed-point (Q2.30) Madgwick.
    Fixed,
}

/// The text after the options: the fault kinds, the scenario CSV's columns.
fn after_help() -> String {
    format!(
        "{}\n{}",
        sim::faults::help(Rig::Sim),
        demo::scenario_csv::help()
    )
}

/// A parser for a fraction within ±`limit`.
fn fraction_within(limit: f64) -> impl Fn(&str) -> Result<f64, String> + Clone {
    move |s: &str| {
        let v: f64 = s
            .parse()
            .map_err(|_| format!("`{s}` is not a number (a fraction, e.g. 0.03)"))?;
        if v.is_finite() && v.abs() <= limit {
            Ok(v)
        } else {
            Err(format!("{v} is outside ±{limit}"))
        }
    }
}

/// A parser for seconds in `(lo, hi]` (`lo` itself allowed when 0 means "never").
fn seconds_in(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone {
    move |s: &str| {
        let v: f64 = s
            .parse()
            .map_err(|_| format!("`{s}` is not a number of seconds"))?;
        let lo_ok = if lo == 0.0 && hi == f64::MAX {
            v >= 0.0
        } else {
            v > lo
        };
        if !v.is_finite() || !lo_ok || v > hi {
            let range = if hi == f64::MAX {
                ">= 0 and finite".to_string()
            } else {
                format!("in ({lo}, {hi}]")
            };
            return Err(format!("{s} s is out of range: must be {range}"));
        }
        Ok(v)
    }
}

/// The outputs, opened before any work so a bad path fails at once. Each
/// file is written beside its target and renamed over it only when the run
/// succeeded (`host_console::SafeFile`): a failed or interrupted run leaves
/// an existing file as it was.
struct Outputs {
    csv: Option<CsvOut>,
    plot: Option<SafeFile>,
    spectrum: Option<SafeFile>,
    bode: Option<SafeFile>,
}

/// Where the CSV goes.
enum CsvOut {
    /// Standard output (`--csv -`).
    Stdout,
    /// A file: its temporary file, open.
    File(SafeFile, std::fs::File),
}

impl CsvOut {
    /// The stream to write and its name in errors, and the file to commit.
    fn open(self) -> (Box<dyn std::io::Write>, String, Option<SafeFile>) {
        match self {
            Self::Stdout => (Box::new(std::io::stdout()), "stdout".into(), None),
            Self::File(out, file) => {
                let name = out.target().display().to_string();
                (Box::new(file), name, Some(out))
            }
        }
    }
}

impl Outputs {
    /// Renames every finished output over its target.
    fn commit(csv: Option<SafeFile>, plot: Option<SafeFile>) -> Result<(), String> {
        for f in csv.into_iter().chain(plot) {
            let name = f.target().display().to_string();
            f.commit().map_err(|e| format!("writing {name}: {e}"))?;
            say!("wrote {name}");
        }
        Ok(())
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let (opts, outputs) = match validate(&cli) {
        Ok(v) => v,
        Err(e) => {
            note!("sim: {e}");
            return ExitCode::from(2);
        }
    };
    let done = if outputs.spectrum.is_some() {
        execute_spectrum(&cli, outputs)
    } else {
        match (&cli.scenario, &cli.analyse) {
            (_, Some(input)) => demo::tuning_cli::analyse_file(input, outputs.bode),
            (Some(name), None) => execute_scenario(name, &cli, outputs),
            (None, None) => execute(&opts, outputs),
        }
    };
    match done {
        Ok(()) if host_console::stdout_failed() => {
            note!("sim: writing to stdout failed");
            ExitCode::FAILURE
        }
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            note!("sim: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Checks every value and opens the outputs before anything runs.
fn validate(cli: &Cli) -> Result<(RunOptions, Outputs), String> {
    if let Some(want) = cli.filter {
        check_filter(want)?;
    }
    let trajectory = Trajectory::from_name(&cli.trajectory)
        .ok_or_else(|| format!("unknown trajectory `{}`", cli.trajectory))?;
    check_fault_times(cli)?;
    let is_stdout = |p: &Path| p == Path::new("-");
    if let Some(plot) = &cli.plot {
        sim::plot::check_plot_path(plot)?;
    }
    if let (Some(csv), Some(plot)) = (&cli.csv, &cli.plot) {
        if !is_stdout(csv) && same_file(csv, plot) {
            return Err(format!(
                "--csv and --plot name the same file {}",
                csv.display()
            ));
        }
    }
    let csv = match &cli.csv {
        Some(p) if is_stdout(p) => {
            host_console::use_stderr();
            Some(CsvOut::Stdout)
        }
        Some(p) => {
            let (out, file) = create(p, "--csv")?;
            Some(CsvOut::File(out, file))
        }
        None => None,
    };
    let plot = match &cli.plot {
        Some(p) => Some(create(p, "--plot")?.0),
        None => None,
    };
    let spectrum = open_spectrum(cli)?;
    let bode = demo::tuning_cli::check(
        cli.scenario.as_deref(),
        cli.analyse.as_deref(),
        cli.bode.as_deref(),
        cli.sweep.is_some(),
    )?;
    let opts = RunOptions {
        trajectory,
        seed: cli.seed,
        board_seed: cli.board_seed.unwrap_or(cli.seed),
        duration_s: cli.duration,
        print_every_s: cli.print_every,
        mag_dance_s: cli.mag_dance,
        faults: cli.fault.clone(),
        progress: !cli.quiet,
        gyro_scale: cli.gyro_scale,
    };
    Ok((
        opts,
        Outputs {
            csv,
            plot,
            spectrum,
            bode,
        },
    ))
}

fn check_filter(want: FilterArg) -> Result<(), String> {
    let want = match want {
        FilterArg::F32 => Filter::F32,
        FilterArg::Fixed => Filter::Fixed,
    };
    if want == Filter::BUILT {
        return Ok(());
    }
    Err(format!(
        "--filter: this build runs the {}; the AHRS is chosen at compile time like the firmware's: {}",
        sensor_stack::pipeline::AHRS_KIND,
        if want == Filter::F32 {
            "cargo run --release -p sim --features f32-ahrs -- ..."
        } else {
            "cargo run --release -p sim -- ... (without --features f32-ahrs)"
        }
    ))
}

/// Both paths lead to the same file (compared canonically).
fn same_file(a: &Path, b: &Path) -> bool {
    a == b || host_console::canonical_path(a) == host_console::canonical_path(b)
}

/// Every `--fault` falls within the flight.
fn check_fault_times(cli: &Cli) -> Result<(), String> {
    let duration_s = match &cli.scenario {
        Some(name) => demo::closed_loop::Scenario::from_name(name)
            .ok_or_else(|| format!("unknown scenario `{name}`"))?
            .duration_s(),
        None => cli.duration,
    };
    match cli.fault.iter().find(|f| f.at_s >= duration_s) {
        Some(f) => Err(format!(
            "--fault {f}: {} s is after the end of the {duration_s} s flight",
            f.at_s
        )),
        None => Ok(()),
    }
}

/// The `--spectrum` figure's temporary file, its format checked first.
fn open_spectrum(cli: &Cli) -> Result<Option<SafeFile>, String> {
    let Some(p) = &cli.spectrum else {
        return Ok(None);
    };
    sim::plot::check_plot_path(p)?;
    Ok(Some(create(p, "--spectrum")?.0))
}

/// Creates the temporary file of output `path` (and its parent folders).
fn create(path: &Path, what: &str) -> Result<(SafeFile, std::fs::File), String> {
    SafeFile::create(path).map_err(|e| format!("{what} {}: {e}", path.display()))
}

/// `--spectrum`: the gyro's spectrum at hover and full throttle.
fn execute_spectrum(cli: &Cli, outputs: Outputs) -> Result<(), String> {
    let Some(out) = outputs.spectrum else {
        return Ok(());
    };
    let airframe = sim::QuadParams::class_250().with_vibration_scale(cli.vibration);
    let title = format!("sim: simulated gyro spectrum, seed {}", cli.seed);
    let lines = demo::spectrum::write(out.temp_path(), airframe, cli.seed, &title)
        .map_err(|e| format!("spectrum {}: {e}", out.target().display()))?;
    for l in lines {
        say!("{l}");
    }
    Outputs::commit(None, Some(out))
}

fn execute(opts: &RunOptions, outputs: Outputs) -> Result<(), String> {
    let Outputs { csv, plot, .. } = outputs;
    let (mut csv, csv_file) = match csv.map(CsvOut::open) {
        Some((out, name, file)) => (Some(CsvWriter::new(out, &name)?), file),
        None => (None, None),
    };
    let mut series = PlotSeries::default();
    let result = {
        let mut sinks: Vec<&mut dyn RecordSink> = Vec::new();
        if let Some(c) = csv.as_mut() {
            sinks.push(c);
        }
        if plot.is_some() {
            sinks.push(&mut series);
        }
        run(opts, &mut sinks)?
    };
    if let Some(c) = csv {
        c.finish()?;
    }
    if let Some(out) = &plot {
        let title = format!(
            "sim: {} seed {} ({})",
            opts.trajectory.name(),
            opts.seed,
            sensor_stack::pipeline::AHRS_KIND
        );
        demo::plot::write_plot(out.temp_path(), &title, &series, &result.mag_cal)
            .map_err(|e| format!("plotting {}: {e}", out.target().display()))?;
    }
    Outputs::commit(csv_file, plot)?;
    print_summary(opts, &result);
    if result.summary.samples == 0 {
        return Err(format!(
            "no sample was scored (the first second is settling time; the flight lasted {} s)",
            opts.duration_s
        ));
    }
    Ok(())
}

/// A closed-loop scenario: fly it, write its outputs, print its events and
/// figures.
fn execute_scenario(name: &str, cli: &Cli, outputs: Outputs) -> Result<(), String> {
    use demo::closed_loop::{fly, ClosedLoopOptions, FlightControl, Scenario};
    let scenario = Scenario::from_name(name).ok_or_else(|| format!("unknown scenario `{name}`"))?;
    let mut opts = ClosedLoopOptions::new(scenario, cli.seed);
    opts.board_seed = cli.board_seed.unwrap_or(cli.seed);
    opts.mag_dance_s = cli.mag_dance;
    opts.faults = cli.fault.clone();
    let drag = &mut opts.airframe.drag;
    *drag = drag.scaled(cli.drag_scale.unwrap_or(1.0));
    drag.linear_scales_with_rotor_speed = cli.thrust_drag;
    if let Some([n, e]) = cli.wind {
        drag.wind_ned_mps = [n, e, 0.0];
    }
    opts.airframe = opts.airframe.with_vibration_scale(cli.vibration);
    if let Some(spec) = &cli.sweep {
        return demo::tuning_cli::sweep(spec, &opts, outputs.plot);
    }
    let mut fc = board_settings(cli, &mut opts)?;
    say!(
        "sim: closed loop, scenario {}, seed {} (board {}), {} s; 250-class quad model, flight pipeline with the {}, {}",
        scenario.name(),
        opts.seed,
        opts.board_seed,
        scenario.duration_s(),
        sensor_stack::pipeline::AHRS_KIND,
        fc.name()
    );
    let log = fly(&opts, &mut fc)?;
    if log.samples.is_empty() {
        return Err(format!(
            "the flight produced no samples ({} data-ready interrupts, every IMU read failed)",
            log.missed
        ));
    }
    let title = format!("sim closed loop: {} seed {}", scenario.name(), opts.seed);
    let bode = outputs.bode;
    let outputs = Outputs {
        bode: None,
        ..outputs
    };
    write_scenario_outputs(&log, &title, outputs)?;
    print_scenario(&log, &opts);
    if scenario == Scenario::Chirp {
        demo::tuning_cli::report_chirp(&log, opts.seed, bode)?;
    }
    Ok(())
}

/// The flight controller with the board's settings, changed by
/// `--settings` (its gyro filter into `opts`' boot configuration).
fn board_settings(
    cli: &Cli,
    opts: &mut demo::closed_loop::ClosedLoopOptions,
) -> Result<demo::flight_fc::FirmwareFc, String> {
    let Some(path) = &cli.settings else {
        return demo::flight_fc::FirmwareFc::new(settings::flight_config());
    };
    let set = demo::settings_file::read(path)?;
    let changed = demo::settings_file::changed(&set);
    say!(
        "sim: settings from {}: {}",
        path.display(),
        if changed.is_empty() {
            "the defaults".to_string()
        } else {
            changed.join(", ")
        }
    );
    let rate = settings::IMU_RATE_HZ;
    opts.boot.pipeline.gyro_filter = set
        .gyro_filter()
        .design(rate)
        .map_err(|e| format!("{}: gyro filter: {e:?}", path.display()))?;
    let battery = set
        .battery_config()
        .map_err(|e| format!("{}: battery: {e}", path.display()))?;
    let cfg = set.flight_config(settings::flight_config());
    demo::flight_fc::FirmwareFc::with_battery(cfg, battery)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// Writes the scenario's plot and CSV beside their targets, then renames
/// both over them (neither when either failed).
fn write_scenario_outputs(
    log: &demo::closed_loop::FlightLog,
    title: &str,
    outputs: Outputs,
) -> Result<(), String> {
    if let Some(out) = &outputs.plot {
        demo::plot_closed::write_plot(out.temp_path(), title, log)
            .map_err(|e| format!("plotting {}: {e}", out.target().display()))?;
    }
    let csv_file = match outputs.csv.map(CsvOut::open) {
        Some((stream, name, file)) => {
            write_scenario_csv(stream, &name, log)?;
            file
        }
        None => None,
    };
    Outputs::commit(csv_file, outputs.plot)
}

/// The scenario CSV into `stream`; a reader that went away (a closed
/// stdout) is not an error.
fn write_scenario_csv(
    stream: Box<dyn std::io::Write>,
    name: &str,
    log: &demo::closed_loop::FlightLog,
) -> Result<(), String> {
    use std::io::Write;
    let events = demo::timeline::timeline(log);
    let mut w = std::io::BufWriter::new(stream);
    let res = demo::scenario_csv::write(&mut w, log, &events).and_then(|()| w.flush());
    match res {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(format!("writing {name}: {e}")),
        Ok(()) => Ok(()),
    }
}

/// The scenario's events and figures on the status lines.
fn print_scenario(log: &demo::closed_loop::FlightLog, opts: &demo::closed_loop::ClosedLoopOptions) {
    for (t, e) in &log.events {
        say!("t {t:7.3} s: {e}");
    }
    say!("== figures: {} seed {} ==", opts.scenario.name(), opts.seed);
    for line in demo::figures::figures(log).lines() {
        say!("{line}");
    }
    say!(
        "{} samples, {} CRSF frames through the receiver code, in {:.2} s wall{}",
        log.samples.len(),
        log.radio_frames,
        log.wall_s,
        if log.missed > 0 {
            format!(", {} data-ready interrupts without a sample", log.missed)
        } else {
            String::new()
        }
    );
}

fn print_summary(opts: &RunOptions, r: &RunResult) {
    say!(
        "== summary: {} seed {} (board {}), flight pipeline with the {} ==",
        opts.trajectory.name(),
        opts.seed,
        opts.board_seed,
        sensor_stack::pipeline::AHRS_KIND
    );
    print_calibrations(opts, r);
    let s = &r.summary;
    say!(
        "attitude RMS {:.2}° (heading {:.2}°, inclination {:.2}°), max {:.2}°",
        s.attitude_rms_deg,
        s.heading_rms_deg,
        s.inclination_rms_deg,
        s.attitude_max_deg
    );
    say!(
        "height RMS {:.3} m, vertical speed RMS {:.3} m/s",
        s.height_rms_m,
        s.vspeed_rms_mps
    );
    say!(
        "{} samples scored (after 1 s); {} s simulated in {:.2} s",
        s.samples,
        opts.duration_s,
        s.wall_s
    );
    if s.missed > 0 {
        say!(
            "{} data-ready interrupts without a sample (the IMU read failed)",
            s.missed
        );
    }
}

fn print_calibrations(opts: &RunOptions, r: &RunResult) {
    say!("calibrations:");
    match &r.gyro_bias {
        Some(g) => {
            let err = max_abs_diff(g.measured_rps.map(f64::from), g.truth_rps);
            say!(
                "  gyro bias at start-up  done at {:.2} s, max |error| {:.5} rad/s ({:.3} °/s, in whole counts)",
                g.at_s,
                err,
                err.to_degrees()
            );
        }
        None => say!("  gyro bias at start-up  NOT DONE (the board never held still)"),
    }
    let a = &r.accel_cal;
    let (off_t, scale_t) = demo::run::accel_truth(&sim::SensorErrors::datasheet(opts.board_seed));
    say!(
        "  accel six-position     6/6 faces, max |offset error| {:.2} mg, max |scale error| {:.3} %, residual |a|-1g RMS {:.2} mg",
        max_abs_diff(a.calibration.offset.map(f64::from), off_t) * 1000.0,
        max_abs_diff(a.calibration.scale.map(f64::from), scale_t) * 100.0,
        a.rms_residual_g * 1000.0
    );
    let m = &r.mag_cal;
    say!(
        "  magnetometer           {} on {} samples{}",
        m.method,
        m.raw_mpu_ut.len(),
        m.rms_error
            .map(|e| format!(", fit residual RMS {:.2} % of the radius", e * 100.0))
            .unwrap_or_default()
    );
}

fn max_abs_diff(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::Cli;

    /// clap's checks of the definitions; any command line parses or errs, never panics.
    #[test]
    fn the_command_line_is_well_defined() {
        host_console::testing::check_parser::<Cli>();
    }
}
