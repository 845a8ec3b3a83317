//! The command line's side of the loop measurements: `--bode`,
//! `--analyse` and `--sweep` checked before anything runs, then the
//! chirp's report, a log's report, a sweep.

use super::closed_loop::{ClosedLoopOptions, FlightLog};
use super::sweep::{self, SweepSpec};
use super::{analyse, tuning};
use host_console::{say, SafeFile};
use std::path::Path;

/// Checks the options' combination and opens the Bode plot's file.
pub fn check(
    scenario: Option<&str>,
    input: Option<&Path>,
    bode: Option<&Path>,
    sweeping: bool,
) -> Result<Option<SafeFile>, String> {
    let chirp = scenario == Some("chirp");
    if let Some(i) = input {
        if !i.is_file() {
            return Err(format!("--analyse {}: no such file", i.display()));
        }
    }
    if sweeping && !chirp {
        return Err("--sweep flies the chirp: use it with --scenario chirp".into());
    }
    let Some(b) = bode else { return Ok(None) };
    if !chirp && input.is_none() {
        return Err(
            "--bode measures the rate loop: use it with --scenario chirp or --analyse FILE".into(),
        );
    }
    sim::plot::check_plot_path(b)?;
    if let Some(i) = input {
        if i == b || host_console::canonical_path(i) == host_console::canonical_path(b) {
            return Err(format!("--bode {} would overwrite the input", b.display()));
        }
    }
    SafeFile::create(b)
        .map(|(f, _)| Some(f))
        .map_err(|e| format!("--bode {}: {e}", b.display()))
}

/// Prints the table, writes the Bode plot (when asked) under `title`.
fn report(
    reports: &[tuning::AxisReport],
    title: &str,
    bode: Option<SafeFile>,
) -> Result<(), String> {
    say!("== rate loop: {title} ==");
    for l in tuning::table(reports) {
        say!("{l}");
    }
    if let Some(out) = bode {
        tuning::write_bode(out.temp_path(), title, reports)
            .map_err(|e| format!("plotting {}: {e}", out.target().display()))?;
        let name = out.target().display().to_string();
        out.commit().map_err(|e| format!("writing {name}: {e}"))?;
        say!("wrote {name}");
    }
    Ok(())
}

/// The chirp flight's rate loop, measured.
pub fn report_chirp(log: &FlightLog, seed: u64, bode: Option<SafeFile>) -> Result<(), String> {
    let reports = tuning::analyse_chirp(log)?;
    report(&reports, &format!("chirp seed {seed}"), bode)?;
    if let Some(n) = sweep::hover_noise(log) {
        say!(
            "torque noise in the hover before the sweeps (RMS above ≈ 20 Hz, % of range): roll {:.2}, pitch {:.2}, yaw {:.2}",
            n[0],
            n[1],
            n[2]
        );
    }
    Ok(())
}

/// `--analyse FILE`: a log's rate loop, measured.
pub fn analyse_file(input: &Path, bode: Option<SafeFile>) -> Result<(), String> {
    let s = analyse::read(input)?;
    say!(
        "{}: {} rows at {:.1} Hz ({:.1} s)",
        input.display(),
        s.rows,
        s.fs_hz,
        s.rows as f64 / s.fs_hz
    );
    let reports = analyse::analyse(&s)?;
    report(&reports, &input.display().to_string(), bode)
}

/// `--sweep SPEC`: the chirp once per multiplier, the table, the plot.
pub fn sweep(
    spec: &SweepSpec,
    opts: &ClosedLoopOptions,
    plot: Option<SafeFile>,
) -> Result<(), String> {
    let base = settings::flight_config();
    say!(
        "sim: sweeping {} over {:?}, chirp seed {} each",
        spec.name(),
        spec.values(),
        opts.seed
    );
    let rows = sweep::run(spec, opts, &base)?;
    for l in sweep::table(spec, &rows) {
        say!("{l}");
    }
    if let Some(out) = plot {
        sweep::write_plot(out.temp_path(), spec, &rows)
            .map_err(|e| format!("plotting {}: {e}", out.target().display()))?;
        let name = out.target().display().to_string();
        out.commit().map_err(|e| format!("writing {name}: {e}"))?;
        say!("wrote {name}");
    }
    Ok(())
}
