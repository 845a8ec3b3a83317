//! `sim`: the whole sensor stack on a simulated board, no hardware needed.
//!
//! ```text
//! cargo sim -- [--trajectory NAME] [--seed N] [--duration S] [--filter f32|fixed]
//!              [--csv FILE] [--plot FILE.png] [--print-every S] [--mag-dance S]
//! ```
//! Trajectories: rest, spin, slow, figure8, hover (default), aggressive.

mod demo;

use demo::run::{run, RunOptions};
use demo::stack::Filter;
use sim::Trajectory;

const USAGE: &str = "usage: sim [--trajectory rest|spin|slow|figure8|hover|aggressive] [--seed N] \
[--duration S] [--filter f32|fixed] [--csv FILE] [--plot FILE.png] [--print-every S] [--mag-dance S]";

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
        filter: Filter::F32,
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
                opts.filter = match val()?.as_str() {
                    "f32" => Filter::F32,
                    "fixed" => Filter::Fixed,
                    v => return Err(format!("--filter: `{v}` is not f32 or fixed")),
                }
            }
            "--print-every" => {
                opts.print_every_s = val()?.parse().map_err(|e| format!("--print-every: {e}"))?
            }
            "--mag-dance" => {
                opts.mag_dance_s = val()?.parse().map_err(|e| format!("--mag-dance: {e}"))?
            }
            "--csv" => csv = Some(val()?),
            "--plot" => plot = Some(val()?),
            "-h" | "--help" => {
                println!("{USAGE}");
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
    let s = result.summary;
    println!(
        "summary: {} samples, attitude RMS {:.2}° (heading {:.2}°, inclination {:.2}°, max {:.2}°), height RMS {:.3} m; {:.0} s simulated in {:.2} s",
        s.samples,
        s.attitude_rms_deg,
        s.heading_rms_deg,
        s.inclination_rms_deg,
        s.attitude_max_deg,
        s.height_rms_m,
        args.opts.duration_s,
        s.wall_s
    );
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
            "sim: {} seed {}",
            args.opts.trajectory.name(),
            args.opts.seed
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
}
