//! `cargo fil`: the release firmware on the emulated Blue Pill, its live
//! defmt log printed as `cargo embed` shows it, with faults injected at
//! chosen simulated times.

use clap::Parser;
use emulator::i2c1::PeripheralFault;
use emulator::rig::{FlightRig, RigOptions};
use emulator::{calpage, Board, BoardConfig, BoardError, BoardFault, CycleModel, RttMode};
use sim::scenario::Scenario;
use sim::{Chip, Fault, Trajectory};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

/// Boot the real firmware ELF on an emulated STM32F103 with simulated
/// sensors and print its log. Time is simulated: 10 s run in a few seconds.
#[derive(Parser, Debug)]
#[command(name = "cargo fil", version, after_help = FAULT_HELP)]
struct Args {
    /// Firmware ELF (default: the release build, `cargo fw`).
    #[arg(long)]
    elf: Option<PathBuf>,
    /// Motion of the board: rest, spin, slow, figure8, hover, aggressive, sixpos.
    #[arg(short, long, default_value = "rest")]
    trajectory: String,
    /// Seed of the simulated sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulated seconds to run (default 5, or the scenario's length).
    #[arg(short, long)]
    seconds: Option<f64>,
    /// Fly a closed-loop scenario instead of a trajectory: the firmware
    /// flies the quad model from a scripted pilot's CRSF frames (the
    /// scenarios of `cargo sim --scenario`), datasheet sensor errors,
    /// calibrated board.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(Scenario::NAMES),
          conflicts_with = "trajectory")]
    scenario: Option<String>,
    /// Fault at a simulated time, `TIME:KIND[:ARG]` (repeatable; see below).
    #[arg(short, long = "fault", value_name = "TIME:KIND[:ARG]")]
    faults: Vec<String>,
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

const FAULT_HELP: &str = "Fault kinds (TIME in simulated seconds):
  missing:CHIP          CHIP (mpu|mag|baro) never answers (NACK), from TIME
  nack:CHIP:N           the next N transfers to CHIP are not acknowledged
  chip-reset:CHIP       CHIP resets itself (registers back to defaults)
  stuck-bus             every transfer fails with a bus error until `clear`
  sda-held:CHIP         CHIP is left mid-byte holding SDA low (as after a reset
                        during a read); at TIME 0: SDA held low at power-up
  scl-stuck             SCL held low until `clear`
  busy-lockup           errata ES096: I2C1's analog filter locks BUSY
  spurious-berr         errata ES096: a spurious bus error in master mode
  bus-error:N           one transfer fails after N bytes
  arbitration:N         N transfers lose arbitration
  frozen:CHIP           CHIP's data stops updating
  mag-overflow          the magnetometer reports overflow
  wrong-id:CHIP:ID      CHIP reports WHO_AM_I = ID (hex)
  imu-int-stops         the MPU-9250 INT line (PB5) stops
  imu-int-restored      ... and works again
  rtt-stops             the host stops reading RTT (a closed cargo embed)
  rtt-resumes           ... and reads again
  button-down / button-up   the PA0 button
  clear                 clears every persistent chip/bus fault
Example: cargo fil -t hover -s 10 -f 3:chip-reset:mpu -f 5:nack:baro:200";

#[derive(Debug, Clone)]
enum Action {
    Sim(Fault),
    Board(BoardFault),
    Clear,
}

fn chip(s: &str) -> Result<(Chip, u8), String> {
    Ok(match s {
        "mpu" => (Chip::Mpu9250, 0x68),
        "mag" => (Chip::Ak8963, sim::AK8963_ADDRESS),
        "baro" => (Chip::Ms5611, 0x77),
        _ => return Err(format!("unknown chip `{s}` (mpu, mag, baro)")),
    })
}

fn num(s: Option<&str>, what: &str) -> Result<u32, String> {
    s.ok_or(format!("{what} missing"))?
        .parse()
        .map_err(|_| format!("{what}: not a number"))
}

fn parse_fault(spec: &str) -> Result<(f64, Action), String> {
    let mut it = spec.split(':');
    let t: f64 = it
        .next()
        .unwrap_or_default()
        .parse()
        .map_err(|_| format!("`{spec}`: TIME must be seconds"))?;
    if !t.is_finite() || t < 0.0 {
        return Err(format!("`{spec}`: TIME must be ≥ 0 s"));
    }
    let kind = it.next().ok_or(format!("`{spec}`: KIND missing"))?;
    let arg = it.next();
    let chip_arg = || chip(arg.unwrap_or(""));
    let a = match kind {
        "missing" => Action::Sim(Fault::Nack {
            address: chip_arg()?.1,
            transactions: None,
        }),
        "nack" => Action::Sim(Fault::Nack {
            address: chip_arg()?.1,
            transactions: Some(num(it.next(), "N")?),
        }),
        "chip-reset" => Action::Sim(Fault::ChipReset(chip_arg()?.0)),
        "frozen" => Action::Sim(Fault::Frozen(chip_arg()?.0)),
        "stuck-bus" => Action::Sim(Fault::StuckBus),
        "bus-error" => Action::Sim(Fault::BusErrorMidTransfer {
            after_bytes: num(arg, "N")? as usize,
        }),
        "arbitration" => Action::Sim(Fault::ArbitrationLoss {
            transactions: num(arg, "N")?,
        }),
        "mag-overflow" => Action::Sim(Fault::MagOverflow),
        "wrong-id" => Action::Sim(Fault::WrongChipId {
            chip: chip_arg()?.0,
            id: u8::from_str_radix(it.next().unwrap_or("").trim_start_matches("0x"), 16)
                .map_err(|_| format!("`{spec}`: ID must be a hex byte"))?,
        }),
        "imu-int-stops" => Action::Board(BoardFault::ImuIntStops),
        "imu-int-restored" => Action::Board(BoardFault::ImuIntRestored),
        "rtt-stops" => Action::Board(BoardFault::RttReaderStops),
        "rtt-resumes" => Action::Board(BoardFault::RttReaderResumes),
        "button-down" => Action::Board(BoardFault::Button(true)),
        "button-up" => Action::Board(BoardFault::Button(false)),
        "clear" => Action::Clear,
        "sda-held" => Action::Sim(Fault::SlaveHoldsSda(chip_arg()?.0)),
        "scl-stuck" => Action::Sim(Fault::SclStuckLow),
        "busy-lockup" => Action::Board(BoardFault::I2c(PeripheralFault::BusyLockup)),
        "spurious-berr" => Action::Board(BoardFault::I2c(PeripheralFault::SpuriousBerr)),
        _ => {
            return Err(format!(
                "`{spec}`: unknown fault kind `{kind}` (see --help)"
            ))
        }
    };
    Ok((t, a))
}

fn ensure_elf(path: &std::path::Path, explicit: bool) -> Result<(), String> {
    if path.exists() {
        return Ok(());
    }
    if explicit {
        return Err(format!("{}: no such file", path.display()));
    }
    eprintln!("firmware ELF absent; building it with `cargo fw` ...");
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

fn checked_args(args: &Args) -> Result<(), String> {
    if let Some(s) = args.seconds {
        if !(s.is_finite() && s > 0.0 && s <= 3600.0) {
            return Err("--seconds must be in (0, 3600]".into());
        }
    }
    if !(30_000..=60_000).contains(&args.lsi_hz) {
        return Err("--lsi-hz must be within the datasheet's 30000–60000 Hz".into());
    }
    Ok(())
}

fn board_runner(args: &Args, elf: &std::path::Path) -> Result<Runner, String> {
    let trajectory = Trajectory::from_name(&args.trajectory).ok_or(format!(
        "unknown trajectory `{}` (one of {})",
        args.trajectory,
        Trajectory::NAMES.join(", ")
    ))?;
    let mut config = BoardConfig {
        lsi_hz: args.lsi_hz,
        ..BoardConfig::default()
    };
    if args.cycle_model == "pessimistic" {
        config.cycle_model = CycleModel::Pessimistic;
    }
    config.sim.trajectory = trajectory;
    config.sim.seed = args.seed;
    if let Some(m) = &args.rtt_mode {
        config.rtt_mode = RttMode::from_name(m);
    }
    let board = Board::from_elf(elf, config).map_err(|e| e.to_string())?;
    Ok(Runner::Board(Box::new(board)))
}

fn rig_runner(scenario: Scenario, args: &Args, elf: &std::path::Path) -> Result<Runner, String> {
    let fw = emulator::Firmware::load(elf).map_err(|e| e.to_string())?;
    let mut opts = RigOptions::new(scenario, args.seed);
    opts.lsi_hz = Some(args.lsi_hz);
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

fn run(args: Args) -> Result<(), String> {
    checked_args(&args)?;
    let scenario = match &args.scenario {
        Some(n) => Some(Scenario::from_name(n).ok_or(format!("unknown scenario `{n}`"))?),
        None => None,
    };
    let seconds = args
        .seconds
        .unwrap_or(scenario.map_or(5.0, |s| s.duration_s()));
    let mut faults = args
        .faults
        .iter()
        .map(|f| parse_fault(f))
        .collect::<Result<Vec<_>, _>>()?;
    faults.sort_by(|a, b| a.0.total_cmp(&b.0));
    let elf = args.elf.clone().unwrap_or_else(emulator::release_elf_path);
    ensure_elf(&elf, args.elf.is_some())?;
    let mut runner = match scenario {
        Some(s) => rig_runner(s, &args, &elf)?,
        None => board_runner(&args, &elf)?,
    };
    let out = std::io::stdout();
    let mut out = out.lock();
    let end_ns = (seconds * 1e9) as u64;
    let (mut shown_lines, mut shown_events) = (0, 0);
    let mut pending = faults.into_iter().peekable();
    let mut t = 0;
    let result = loop {
        while let Some((_, a)) = pending.next_if(|(ft, _)| (*ft * 1e9) as u64 <= t) {
            let board = runner.board_mut();
            match a {
                Action::Sim(f) => board.sim().inject(f),
                Action::Board(f) => board.apply(f),
                Action::Clear => board.sim().clear_faults(),
            }
        }
        let next_fault = pending.peek().map_or(end_ns, |(ft, _)| (*ft * 1e9) as u64);
        t = (t + 10_000_000).min(end_ns).min(next_fault.max(t + 1));
        let r = runner.run_until_ns(t);
        let board = runner.board();
        let mut text = String::new();
        for l in &board.log_lines()[shown_lines..] {
            text.push_str(&format!("[{:>11.6}] {l}\n", l.host_time_ns as f64 * 1e-9));
        }
        shown_lines = board.log_lines().len();
        if args.events {
            for e in &board.events()[shown_events..] {
                text.push_str(&format!(
                    "[{:>11.6}] [emulator] {}\n",
                    e.time_ns as f64 * 1e-9,
                    e.what
                ));
            }
        }
        shown_events = board.events().len();
        if let Err(e) = out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                return Ok(());
            }
            return Err(e.to_string());
        }
        if let Err(e) = r {
            break Err(format!(
                "emulated board stopped at {:.6} s: {e}",
                board.now_ns() as f64 * 1e-9
            ));
        }
        if t >= end_ns {
            break Ok(());
        }
    };
    if let (Ok(()), Runner::Rig(rig)) = (&result, &runner) {
        print_flight_summary(&mut out, rig);
    }
    if args.cpi {
        print_cpi(runner.board(), &args.cycle_model);
    }
    result
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

/// What the CPU executed over the run (sleep excluded) and its CPI.
fn print_cpi(board: &Board, model: &str) {
    let e = board.executed();
    let per = |c: u64| c as f64 / e.instructions.max(1) as f64;
    eprintln!(
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
    match run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
