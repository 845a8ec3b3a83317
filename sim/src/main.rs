//! `sim`: the whole sensor stack on a simulated board, no hardware needed.
//!
//! ```text
//! cargo sim [--trajectory NAME] [--seed N] [--duration S] [--filter f32|fixed]
//!           [--csv FILE] [--plot FILE.png] [--print-every S] [--mag-dance S]
//! ```
//! See [`HELP`] (`cargo sim --help`).

mod demo;

use demo::run::{run, RunOptions, RunResult};
use demo::stack::Filter;
use sim::Trajectory;

const USAGE: &str = "usage: sim [--trajectory rest|spin|slow|figure8|hover|aggressive|whirl|vibration|sixpos] [--seed N] \
[--duration S] [--filter f32|fixed] [--csv FILE] [--plot FILE.png] [--print-every S] [--mag-dance S]";

/// The `--help` text.
const HELP: &str = "\
The firmware's sensor stack on a simulated board (no hardware): register-level
MPU-9250 / AK8963 / MS5611 models on a virtual I2C bus with seeded
datasheet-size sensor errors, driven by the real drivers.

What runs, in order (each a separate session of the same simulated board):
  1. accelerometer six-position calibration: the board held still on each face
     (trajectory `sixpos`), 100 Hz samples into calibration::AccelSixPosition;
  2. magnetometer calibration: the figure-eight dance (--mag-dance seconds),
     every sample into calibration::EllipsoidFit (min/max as a fallback);
  both go into the firmware's flash record (flight::storage, encoded and decoded);
  3. the flight: flight::sensors::Sensors boots the chips, the start-up gyro
     bias is measured while still (flight::boot::StartupGyroBias, first ~1 s),
     and every MPU data-ready runs flight::pipeline::Pipeline (raw counts ->
     bias/calibration -> mounting -> AHRS -> vertical estimator -> controllers),
     the same code the firmware runs. Errors are scored against the truth
     after the first second.

Options:
  -t, --trajectory NAME  rest | spin | slow | figure8 | hover (default) | aggressive | whirl |
                         vibration | sixpos
  -s, --seed N           board errors and noise (default 1)
  -d, --duration S       simulated flight time, (0, 3600] s (default 90)
      --filter f32|fixed the AHRS the pipeline was built with; it is chosen at
                         compile time like the firmware's: fixed point by default,
                         f32 with `cargo run --release -p sim --features f32-ahrs --`.
                         Asking for the other one is an error.
      --csv FILE         per-sample CSV (BROAD columns, for tools/replay)
      --plot FILE.png    attitude and height vs truth, magnetometer samples
                         before/after calibration
      --print-every S    status line every S simulated seconds (0 = never; default 5)
      --mag-dance S      length of the magnetometer dance (default 40)
  -h, --help             this text";

struct Args {
    opts: RunOptions,
    csv: Option<String>,
    plot: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let mut opts = RunOptions {
        trajectory: Trajectory::Hover,
        seed: 1,
        duration_s: 90.0,
        print_every_s: 5.0,
        mag_dance_s: 40.0,
    };
    let (mut csv, mut plot) = (None, None);
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut val = || {
            it.next()
                .ok_or_else(|| format!("{a} needs a value\n{USAGE}"))
        };
        match a.as_str() {
            "--trajectory" | "-t" => {
                let v = val()?;
                opts.trajectory = Trajectory::from_name(&v).ok_or_else(|| {
                    format!("unknown trajectory `{v}` (one of {:?})", Trajectory::NAMES)
                })?;
            }
            "--seed" | "-s" => opts.seed = val()?.parse().map_err(|e| format!("--seed: {e}"))?,
            "--duration" | "-d" => {
                opts.duration_s = val()?.parse().map_err(|e| format!("--duration: {e}"))?;
                if !(opts.duration_s > 0.0 && opts.duration_s <= 3600.0) {
                    return Err("--duration must be in (0, 3600] s".into());
                }
            }
            "--filter" => {
                let want = match val()?.as_str() {
                    "f32" => Filter::F32,
                    "fixed" => Filter::Fixed,
                    v => return Err(format!("--filter: `{v}` is not f32 or fixed")),
                };
                if want != Filter::BUILT {
                    return Err(format!(
                        "--filter: this build runs the {}; the AHRS is chosen at compile time like the firmware's: {}",
                        flight::pipeline::AHRS_KIND,
                        if want == Filter::F32 {
                            "cargo run --release -p sim --features f32-ahrs -- ..."
                        } else {
                            "cargo run --release -p sim -- ... (without --features f32-ahrs)"
                        }
                    ));
                }
            }
            "--print-every" => {
                opts.print_every_s = val()?.parse().map_err(|e| format!("--print-every: {e}"))?
            }
            "--mag-dance" => {
                opts.mag_dance_s = val()?.parse().map_err(|e| format!("--mag-dance: {e}"))?;
                if !(opts.mag_dance_s > 0.0 && opts.mag_dance_s <= 600.0) {
                    return Err("--mag-dance must be in (0, 600] s".into());
                }
            }
            "--csv" => csv = Some(val()?),
            "--plot" => plot = Some(val()?),
            "-h" | "--help" => {
                println!("{USAGE}\n\n{HELP}");
                std::process::exit(0);
            }
            _ => return Err(format!("unknown argument `{a}`\n{USAGE}")),
        }
    }
    Ok(Args { opts, csv, plot })
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let result = match run(&args.opts) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("sim: {e}");
            std::process::exit(1);
        }
    };
    if let Some(path) = &args.csv {
        match demo::output::write_csv(path, &result.records) {
            Ok(()) => println!("wrote {path}"),
            Err(e) => {
                eprintln!("sim: writing {path}: {e}");
                std::process::exit(1);
            }
        }
    }
    if let Some(path) = &args.plot {
        let title = format!(
            "sim: {} seed {} ({})",
            args.opts.trajectory.name(),
            args.opts.seed,
            flight::pipeline::AHRS_KIND
        );
        match demo::plot::write_plot(path, &title, &result.records, &result.mag_cal) {
            Ok(text) => println!(
                "wrote {path}{}",
                if text {
                    ""
                } else {
                    " (no font found: no text)"
                }
            ),
            Err(e) => {
                eprintln!("sim: plotting {path}: {e}");
                std::process::exit(1);
            }
        }
    }
    print_summary(&args.opts, &result);
}

fn print_summary(opts: &RunOptions, r: &RunResult) {
    let s = &r.summary;
    println!(
        "== summary: {} seed {}, flight pipeline with the {} ==",
        opts.trajectory.name(),
        opts.seed,
        flight::pipeline::AHRS_KIND
    );
    println!("calibrations:");
    match &r.gyro_bias {
        Some(g) => {
            let err = max_abs_diff(g.measured_rps.map(f64::from), g.truth_rps);
            println!(
                "  gyro bias at start-up  done at {:.2} s, max |error| {:.5} rad/s ({:.3} °/s, in whole counts)",
                g.at_s,
                err,
                err.to_degrees()
            );
        }
        None => println!("  gyro bias at start-up  NOT DONE (the board never held still)"),
    }
    let a = &r.accel_cal;
    let (off_t, scale_t) = demo::run::accel_truth(&sim::SensorErrors::datasheet(opts.seed));
    println!(
        "  accel six-position     6/6 faces, max |offset error| {:.2} mg, max |scale error| {:.3} %, residual |a|-1g RMS {:.2} mg",
        max_abs_diff(a.calibration.offset.map(f64::from), off_t) * 1000.0,
        max_abs_diff(a.calibration.scale.map(f64::from), scale_t) * 100.0,
        a.rms_residual_g * 1000.0
    );
    let m = &r.mag_cal;
    println!(
        "  magnetometer           {} on {} samples{}",
        m.method,
        m.raw_mpu_ut.len(),
        m.rms_error
            .map(|e| format!(", fit residual RMS {:.2} % of the radius", e * 100.0))
            .unwrap_or_default()
    );
    println!(
        "attitude RMS {:.2}° (heading {:.2}°, inclination {:.2}°), max {:.2}°",
        s.attitude_rms_deg, s.heading_rms_deg, s.inclination_rms_deg, s.attitude_max_deg
    );
    println!(
        "height RMS {:.3} m, vertical speed RMS {:.3} m/s",
        s.height_rms_m, s.vspeed_rms_mps
    );
    println!(
        "{} samples scored (after 1 s); {:.0} s simulated in {:.2} s",
        s.samples, opts.duration_s, s.wall_s
    );
}

fn max_abs_diff(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max)
}
