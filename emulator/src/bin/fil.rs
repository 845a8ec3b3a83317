//! `cargo fil`: the release firmware on the emulated Blue Pill, its live
//! defmt log printed as `cargo embed` shows it, with faults injected at
//! chosen simulated times (`--fault TIME:KIND[:ARG]`, the syntax of
//! `cargo sim`, parsed by `sim::faults`); with `--scenario` it flies the
//! quad model, and `--plot` draws the flight (`emulator::flightplot`).
//! The short options mean what they mean in `cargo sim` (`-t` trajectory,
//! `-s` seed, `-d` seconds, `-f` fault); simulator faults are echoed in
//! the log at their injection time.
//!
//! Exit status: 0 done, 1 the board stopped or an output failed, 2 bad
//! arguments (every value and path is checked before the board starts).

use clap::Parser;
use emulator::i2c1::PeripheralFault;
use emulator::rig::{FlightRig, RigOptions};
use emulator::{calpage, Board, BoardConfig, BoardError, BoardFault, CycleModel, RttMode};
use host_console::{note, SafeFile};
use sim::faults::{BoardAction, FaultAction, FaultSchedule, FaultSpec, Rig};
use sim::scenario::Scenario;
use sim::Trajectory;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Boot the real firmware ELF on an emulated STM32F103 with simulated
/// sensors and print its log. Time is simulated: 10 s run in a few seconds.
#[derive(Parser, Debug)]
#[command(name = "cargo fil", version, after_help = sim::faults::help(Rig::Board))]
struct Args {
    /// Firmware ELF (default: the release build, `cargo fw`).
    #[arg(long)]
    elf: Option<PathBuf>,
    /// Motion of the board (the trajectories of `cargo sim`).
    #[arg(short, long, value_name = "NAME", default_value = "rest",
          value_parser = clap::builder::PossibleValuesParser::new(Trajectory::NAMES))]
    trajectory: String,
    /// Seed of the simulated sensor noise (as in `cargo sim`).
    #[arg(short, long, value_name = "N", default_value_t = 1, value_parser = seed)]
    seed: u64,
    /// The simulated chips' errors on a trajectory: `noise` (white noise
    /// at the datasheets' densities, nothing else: a start-up gyro bias of
    /// [0, 0, 0] counts is expected) or `datasheet` (also the bias, scale,
    /// cross-axis and temperature errors a real chip has within its
    /// datasheet, drawn from the seed, as `cargo sim` and the scenarios use;
    /// the emulated flash holds no calibration for them).
    #[arg(long, value_name = "PROFILE", default_value = "noise",
          value_parser = ["noise", "datasheet"], conflicts_with = "scenario")]
    sensors: String,
    /// Simulated seconds to run, in (0, 3600] (as in `cargo sim`;
    /// default 5, or the scenario's length). `--seconds` is an alias.
    #[arg(short, long, value_name = "SECONDS", visible_alias = "seconds")]
    duration: Option<f64>,
    /// Fly a closed-loop scenario instead of a trajectory: the firmware
    /// flies the quad model from a scripted pilot's CRSF frames (the
    /// scenarios of `cargo sim --scenario`), datasheet sensor errors,
    /// calibrated board.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(Scenario::NAMES),
          conflicts_with = "trajectory")]
    scenario: Option<String>,
    /// Fault at a simulated time, `TIME:KIND[:ARG]` (repeatable; see below).
    #[arg(short, long = "fault", value_name = "TIME:KIND[:ARG]",
          value_parser = sim::faults::parse_board)]
    faults: Vec<FaultSpec>,
    /// With --scenario: plot the flight into FILE (.png or .svg; parent
    /// folders are created): truth, the firmware's estimate (its 20 Hz
    /// `att` log line), the stick setpoints, the four ESC pulse widths and
    /// the pilot's sticks.
    #[arg(long, value_name = "FILE", requires = "scenario")]
    plot: Option<PathBuf>,
    /// With --scenario: the quad model's vibration as a multiple of its
    /// well-balanced default (0 = none), in [0, 100], as in `cargo sim`.
    #[arg(long, value_name = "SCALE", requires = "scenario",
          value_parser = sim::quad::vibration::parse_scale)]
    vibration: Option<f64>,
    /// LSI frequency of this part in Hz (datasheet range 30000–60000).
    #[arg(long, default_value_t = 40_000)]
    lsi_hz: u32,
    /// RTT channel-0 mode set at attach (default: Embed.toml's).
    #[arg(long, value_parser = ["BlockIfFull", "NoBlockSkip", "NoBlockTrim"])]
    rtt_mode: Option<String>,
    /// Print the board's own events (resets, faults) between log lines.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
    events: bool,
    /// Cycle model: `typical`, or `pessimistic` (every cost at the top of
    /// its range).
    #[arg(long, default_value = "typical", value_parser = ["typical", "pessimistic"])]
    cycle_model: String,
    /// At the end, print instructions, CPU cycles and their ratio (CPI)
    /// on stderr.
    #[arg(long)]
    cpi: bool,
}

/// A seed: a whole number. `-s` was the run's length before it meant the
/// seed as in `cargo sim`, so a number of seconds gets a pointer to `-d`.
fn seed(s: &str) -> Result<u64, String> {
    s.parse().map_err(|_| {
        let hint = if s.parse::<f64>().is_ok() {
            "; the run's length is -d/--duration SECONDS (as in `cargo sim`, where -s is the seed too)"
        } else {
            ""
        };
        format!("`{s}` is not a seed (a whole number >= 0){hint}")
    })
}

/// The release ELF `cargo fw` builds: under `CARGO_TARGET_DIR` when that is
/// set (as cargo does), else in the workspace's `target/`.
fn default_elf() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR").filter(|d| !d.is_empty()) {
        Some(dir) => emulator::elf::workspace_root()
            .join(dir)
            .join("thumbv7m-none-eabi/release/firmware"),
        None => emulator::release_elf_path(),
    }
}

/// The board's own fault for a board-only kind.
fn board_fault(a: BoardAction) -> BoardFault {
    match a {
        BoardAction::BusyLockup => BoardFault::I2c(PeripheralFault::BusyLockup),
        BoardAction::SpuriousBerr => BoardFault::I2c(PeripheralFault::SpuriousBerr),
        BoardAction::ImuIntStops => BoardFault::ImuIntStops,
        BoardAction::ImuIntRestored => BoardFault::ImuIntRestored,
        BoardAction::RttStops => BoardFault::RttReaderStops,
        BoardAction::RttResumes => BoardFault::RttReaderResumes,
        BoardAction::Button(down) => BoardFault::Button(down),
    }
}

/// Applies one fault to the board.
fn apply(board: &mut Board, f: &FaultSpec) {
    match f.action() {
        FaultAction::Inject(fault) => board.sim().inject(fault),
        FaultAction::Clear => board.sim().clear_faults(),
        FaultAction::Board(a) => board.apply(board_fault(a)),
    }
}

fn ensure_elf(path: &Path, explicit: bool) -> Result<(), String> {
    if path.exists() {
        return Ok(());
    }
    if explicit {
        return Err(format!("{}: no such file", path.display()));
    }
    note!("firmware ELF absent; building it with `cargo fw` ...");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = std::process::Command::new(cargo)
        .args([
            "build",
            "-p",
            "firmware",
            "--target",
            "thumbv7m-none-eabi",
            "--release",
        ])
        .current_dir(emulator::elf::workspace_root())
        .status();
    match status {
        Ok(s) if s.success() && path.exists() => Ok(()),
        _ => Err(format!(
            "could not build {}: run `cargo fw` in {} and try again",
            path.display(),
            emulator::elf::workspace_root().display()
        )),
    }
}

/// What `cargo fil` runs: the board on a trajectory, or the board in the
/// flight rig.
enum Runner {
    Board(Box<Board>),
    Rig(Box<FlightRig>),
}

impl Runner {
    fn board(&self) -> &Board {
        match self {
            Self::Board(b) => b,
            Self::Rig(r) => r.board(),
        }
    }

    fn board_mut(&mut self) -> &mut Board {
        match self {
            Self::Board(b) => b,
            Self::Rig(r) => r.board_mut(),
        }
    }

    fn run_until_ns(&mut self, t: u64) -> Result<(), BoardError> {
        match self {
            Self::Board(b) => b.run_until_ns(t),
            Self::Rig(r) => r.run_until_s(t as f64 * 1e-9),
        }
    }
}

/// What the checks found: what to fly, for how long, on which ELF, and the
/// plot's file (written beside its target, renamed over it at the end).
struct Plan {
    scenario: Option<Scenario>,
    seconds: f64,
    elf: PathBuf,
    plot: Option<SafeFile>,
}

/// Checks every value and path before the board starts; creates the
/// plot's folders and temporary file so an unwritable path fails now.
fn validate(args: &Args) -> Result<Plan, String> {
    if let Some(s) = args.duration {
        if !(s.is_finite() && s > 0.0 && s <= 3600.0) {
            return Err(format!("--duration {s}: must be in (0, 3600] seconds"));
        }
    }
    if let Some(elf) = &args.elf {
        if !elf.is_file() {
            return Err(format!("--elf {}: no such file", elf.display()));
        }
    }
    if !(30_000..=60_000).contains(&args.lsi_hz) {
        return Err("--lsi-hz must be within the datasheet's 30000–60000 Hz".into());
    }
    let scenario = match &args.scenario {
        Some(n) => Some(Scenario::from_name(n).ok_or(format!("unknown scenario `{n}`"))?),
        None => None,
    };
    let seconds = args
        .duration
        .unwrap_or(scenario.map_or(5.0, |s| s.duration_s()));
    if let Some(f) = args.faults.iter().find(|f| f.at_s >= seconds) {
        return Err(format!(
            "--fault {f}: {} s is after the end of the {seconds} s run",
            f.at_s
        ));
    }
    let elf = args.elf.clone().unwrap_or_else(default_elf);
    if let Some(plot) = &args.plot {
        sim::plot::check_plot_path(plot)?;
        if host_console::canonical_path(plot) == host_console::canonical_path(&elf) {
            return Err(format!(
                "--plot {} is the firmware ELF (an input)",
                plot.display()
            ));
        }
    }
    let plot = match &args.plot {
        Some(p) => Some(
            SafeFile::create(p)
                .map_err(|e| format!("--plot {}: {e}", p.display()))?
                .0,
        ),
        None => None,
    };
    Ok(Plan {
        scenario,
        seconds,
        elf,
        plot,
    })
}

fn board_runner(args: &Args, elf: &Path) -> Result<Runner, String> {
    let trajectory = Trajectory::from_name(&args.trajectory)
        .ok_or(format!("unknown trajectory `{}`", args.trajectory))?;
    let mut config = BoardConfig {
        lsi_hz: args.lsi_hz,
        ..BoardConfig::default()
    };
    if args.cycle_model == "pessimistic" {
        config.cycle_model = CycleModel::Pessimistic;
    }
    config.sim.trajectory = trajectory;
    config.sim.seed = args.seed;
    if args.sensors == "datasheet" {
        config.sim.errors = sim::SensorErrors::datasheet(args.seed);
    }
    if let Some(m) = &args.rtt_mode {
        config.rtt_mode = RttMode::from_name(m);
    }
    let board = Board::from_elf(elf, config).map_err(|e| e.to_string())?;
    Ok(Runner::Board(Box::new(board)))
}

fn rig_runner(scenario: Scenario, args: &Args, elf: &Path) -> Result<Runner, String> {
    let fw = emulator::Firmware::load(elf).map_err(|e| e.to_string())?;
    let mut opts = RigOptions::new(scenario, args.seed);
    opts.lsi_hz = Some(args.lsi_hz);
    if let Some(v) = args.vibration {
        opts.airframe = opts.airframe.with_vibration_scale(v);
    }
    if args.cycle_model == "pessimistic" {
        opts.cycle_model = CycleModel::Pessimistic;
    }
    let errors = sim::SensorErrors::datasheet(opts.board_seed);
    opts.flash = Some(calpage::with_record(
        fw.flash,
        &calpage::record_for(&errors),
    ));
    let rig = FlightRig::new(elf, &opts).map_err(|e| e.to_string())?;
    Ok(Runner::Rig(Box::new(rig)))
}

/// New log lines and (with `--events`) board events since the last call,
/// as `cargo fil` prints them.
struct Printer {
    lines: usize,
    events: usize,
    with_events: bool,
    /// Simulator faults applied since the last call, as printed.
    faults: String,
}

impl Printer {
    /// Echoes a simulator fault at its injection time (the board's own
    /// kinds are board events already).
    fn fault(&mut self, board: &Board, f: &FaultSpec) {
        if self.with_events && !matches!(f.action(), FaultAction::Board(_)) {
            self.faults.push_str(&format!(
                "[{:>11.6}] [emulator] fault {f} injected\n",
                board.now_ns() as f64 * 1e-9
            ));
        }
    }

    fn text(&mut self, board: &Board) -> String {
        let mut text = std::mem::take(&mut self.faults);
        for l in &board.log_lines()[self.lines..] {
            text.push_str(&format!("[{:>11.6}] {l}\n", l.host_time_ns as f64 * 1e-9));
        }
        self.lines = board.log_lines().len();
        if self.with_events {
            for e in &board.events()[self.events..] {
                text.push_str(&format!(
                    "[{:>11.6}] [emulator] {}\n",
                    e.time_ns as f64 * 1e-9,
                    e.what
                ));
            }
        }
        self.events = board.events().len();
        text
    }
}

/// Runs the board to `end_ns` in 10 ms steps, applying the faults at their
/// times and printing the log as it comes. A closed stdout (`| head`) stops
/// the printing, not the flight.
fn fly(runner: &mut Runner, faults: &[FaultSpec], end_ns: u64, args: &Args) -> Result<(), String> {
    let out = std::io::stdout();
    let mut out = out.lock();
    let mut printer = Printer {
        lines: 0,
        events: 0,
        with_events: args.events,
        faults: String::new(),
    };
    let mut pending = FaultSchedule::new(faults);
    let (mut t, mut printing) = (0, true);
    loop {
        while let Some(f) = pending.next_due(t as f64 * 1e-9) {
            apply(runner.board_mut(), &f);
            printer.fault(runner.board(), &f);
        }
        let next_fault = pending
            .next_at_s()
            .map_or(end_ns, |s| (s * 1e9).ceil() as u64);
        t = (t + 10_000_000).min(end_ns).min(next_fault.max(t + 1));
        let r = runner.run_until_ns(t);
        let text = printer.text(runner.board());
        if printing {
            if let Err(e) = out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
                if e.kind() != std::io::ErrorKind::BrokenPipe {
                    return Err(format!("writing the log to stdout: {e}"));
                }
                printing = false;
            }
        }
        if let Err(e) = r {
            return Err(format!(
                "emulated board stopped at {:.6} s: {e}",
                runner.board().now_ns() as f64 * 1e-9
            ));
        }
        if t >= end_ns {
            return Ok(());
        }
    }
}

/// Runs what `plan` says; writes the plot (also when the board stopped:
/// the flight up to there, unless that would replace an existing file) and
/// the summaries.
fn run(args: &Args, plan: Plan) -> Result<(), String> {
    ensure_elf(&plan.elf, args.elf.is_some())?;
    let mut runner = match plan.scenario {
        Some(s) => rig_runner(s, args, &plan.elf)?,
        None => board_runner(args, &plan.elf)?,
    };
    let result = fly(&mut runner, &args.faults, (plan.seconds * 1e9) as u64, args);
    if let (Some(out), Runner::Rig(rig)) = (plan.plot, &runner) {
        write_plot(args, rig, out, result.is_ok())?;
    }
    if let (Ok(()), Runner::Rig(rig)) = (&result, &runner) {
        print_flight_summary(&mut std::io::stdout().lock(), rig);
        if rig.scenario() == Scenario::Chirp {
            print_rate_loop(&mut std::io::stdout().lock(), rig, args.seed)?;
        }
    }
    if args.cpi {
        print_cpi(runner.board(), &args.cycle_model);
    }
    result
}

/// Draws the flight into `out` and renames it over its target: after a
/// failed flight only if no file is there (a run that failed never
/// replaces an existing output).
fn write_plot(args: &Args, rig: &FlightRig, out: SafeFile, flown: bool) -> Result<(), String> {
    let title = format!(
        "cargo fil: {} seed {} (the release ELF on the emulated board)",
        args.scenario.as_deref().unwrap_or_default(),
        args.seed
    );
    let target = out.target().display().to_string();
    emulator::flightplot::write_plot(rig, out.temp_path(), &title)
        .map_err(|e| format!("plotting {target}: {e}"))?;
    if !flown && out.target().exists() {
        note!("{target} left as it was (the flight failed; its plot is not written over it)");
        return Ok(());
    }
    out.commit().map_err(|e| format!("writing {target}: {e}"))?;
    note!("wrote {target}");
    Ok(())
}

/// The truth at the end of a rig flight, for people.
fn print_flight_summary(out: &mut impl Write, rig: &FlightRig) {
    let Some(last) = rig.samples().last() else {
        return;
    };
    let max_h = rig
        .samples()
        .iter()
        .map(|s| s.truth.height_m)
        .fold(0.0, f64::max);
    let p = last.truth.position_ned_m;
    let pulses: Vec<String> = last
        .pulse_us
        .iter()
        .map(|u| u.map_or("-".into(), |us| format!("{us:.0}")))
        .collect();
    let _ =
        writeln!(
        out,
        "[emulator] flight: {} CRSF frames sent; end at {:.2} s: height {:.2} m (max {:.2} m), \
         {:.2} m N {:.2} m E of take-off, {} ; pulses [{}] us",
        rig.frames_sent(),
        last.t_s,
        last.truth.height_m,
        max_h,
        p[0],
        p[1],
        if last.quad.on_ground { "on the ground" } else { "in the air" },
        pulses.join(", ")
    );
}

/// The chirp's rate-loop table, as `cargo sim --scenario chirp` prints
/// it, from the controller's view reconstructed on the host
/// (`emulator::rate_view`). Errors: the flight did not cover the sweeps
/// flying.
fn print_rate_loop(out: &mut impl Write, rig: &FlightRig, seed: u64) -> Result<(), String> {
    let reports = emulator::rate_view::analyse_chirp(rig).map_err(|e| format!("rate loop: {e}"))?;
    let mut text = format!(
        "== rate loop: chirp seed {seed} (the release ELF on the emulated board; setpoint and gyro as the controller saw them, rebuilt on the host) ==\n"
    );
    for l in sim::rate_loop::table(&reports) {
        text.push_str(&l);
        text.push('\n');
    }
    // A closed pipe ends the printing, not the run.
    let _ = out.write_all(text.as_bytes());
    Ok(())
}

/// What the CPU executed over the run (sleep excluded) and its CPI.
fn print_cpi(board: &Board, model: &str) {
    let e = board.executed();
    let per = |c: u64| c as f64 / e.instructions.max(1) as f64;
    note!(
        "executed: {} instructions, {} CPU cycles, CPI {:.3} ({model} model; of it \
         refills {:.3}, exceptions {:.3}, APB {:.3})",
        e.instructions,
        e.cycles,
        per(e.cycles),
        per(e.refill_cycles),
        per(e.exception_cycles),
        per(e.bus_cycles),
    );
}

fn main() -> ExitCode {
    let args = Args::parse();
    let plan = match validate(&args) {
        Ok(p) => p,
        Err(e) => {
            note!("error: {e}");
            return ExitCode::from(2);
        }
    };
    match run(&args, plan) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            note!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::Args;
    use clap::Parser;

    /// clap's checks of the definitions; any command line parses or errs, never panics.
    #[test]
    fn the_command_line_is_well_defined() {
        host_console::testing::check_parser::<Args>();
    }

    /// One fault syntax with `cargo sim`, the board's own kinds included;
    /// `--plot` only with a scenario.
    #[test]
    fn faults_and_plot_on_the_command_line() {
        let a = Args::try_parse_from([
            "fil",
            "--scenario",
            "takeoff",
            "-f",
            "8:imu-int-stops",
            "--fault",
            "8:missing:mpu",
            "--plot",
            "x.svg",
        ])
        .unwrap();
        let specs: Vec<String> = a.faults.iter().map(ToString::to_string).collect();
        assert_eq!(specs, ["8:imu-int-stops", "8:missing:mpu"]);
        for (argv, want) in [
            (vec!["fil", "-f", "magnet@3"], "e.g. `3:magnet`"),
            (vec!["fil", "-f", "3:nack:baro"], "nack:CHIP:N"),
            (vec!["fil", "-f", "3:laser"], "unknown fault kind `laser`"),
            (vec!["fil", "--plot", "x.svg"], "--scenario"),
        ] {
            let e = Args::try_parse_from(&argv).unwrap_err().to_string();
            assert!(e.contains(want), "{argv:?}: wanted `{want}` in {e}");
        }
    }
}
