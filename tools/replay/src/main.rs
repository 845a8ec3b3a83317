//! `replay`: run recorded IMU data (BROAD CSV format) through the AHRS and score it.
//!
//! `replay --help` lists the options. Exit status: 0 every file replayed,
//! 1 at least one file failed (the others are still replayed and the mean is
//! over those), 2 bad arguments (nothing was read). A closed stdout is not
//! an error: the table stops, the `--out` files are still written.

use clap::Parser;
use host_console::{canonical_path, note, say, SafeFile};
use replay::{
    read, run_counted, same_hemisphere, score, FilterKind, MagCounts, Mode, ReadOptions, Recording,
    Score,
};
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

const ABOUT: &str = "\
Run CSV IMU recordings through the fc-ahrs Madgwick filter and score them.

CSV columns (header line, named): t_s, gyr_{x,y,z}_rad_s, acc_{x,y,z}_m_s2, mag_{x,y,z}_ut,
optional ref_q{w,x,y,z} (sensor relative to ENU; nan = none) and moving (0/1).
Where a reference exists, prints BROAD-style RMS errors (deg) over moving rows with a valid
reference, per file and the mean over files.";

const AFTER: &str = "\
Input rules: t_s in seconds, finite, strictly increasing, 50 µs..0.5 s between rows;
samples finite and within ±40 rad/s, ±160 m/s², ±5000 µT (--skip-invalid skips
such rows and counts them); the header repeated starts a new segment (the filter
restarts); a last line cut short is dropped with a warning; at least 2 rows.";

/// Command-line options (see `--help`).
#[derive(Parser, Debug)]
#[command(name = "replay", version, about = ABOUT, after_help = AFTER, allow_negative_numbers = true)]
struct Cli {
    /// Recordings to replay (`-` = stdin, once).
    #[arg(value_name = "FILE.csv", required = true)]
    files: Vec<PathBuf>,
    /// Filter implementation: f32 or fixed point, the full filter or
    /// Madgwick's 2010 filter as published (`textbook`, `textbook-fixed`).
    #[arg(long, value_name = "KIND", default_value = "f32",
          value_parser = clap::builder::PossibleValuesParser::new(FilterKind::NAMES))]
    filter: String,
    /// Sensors to fuse.
    #[arg(long, value_enum, default_value = "marg")]
    mode: ModeArg,
    /// Madgwick gain β, rad/s, >= 0 [default: fc_ahrs::Config::DEFAULT].
    #[arg(long, value_name = "RAD_S", value_parser = at_least(0.0))]
    beta: Option<f32>,
    /// What the recording's gyro is, which sets the heading correction's two
    /// defaults (the options below override them): `calibrated`, a laboratory
    /// IMU whose gyro scale factor was calibrated (scale tolerance 0.5 %,
    /// heading τ 80 s: chosen by leave-one-out on the seven BROAD dev trials,
    /// the same pair in every fold), or `mpu9250`, the firmware's datasheet values
    /// (±3 % sensitivity tolerance, τ 40 s; `fc_ahrs::Config::DEFAULT`).
    #[arg(long, value_enum, default_value = "calibrated")]
    sensor: SensorArg,
    /// Time constant of the magnetometer's heading correction, s, > 0.
    #[arg(long, value_name = "S", value_parser = above(0.0))]
    heading_tau: Option<f32>,
    /// Start-up gain, rad/s, >= 0.
    #[arg(long, value_name = "RAD_S", value_parser = at_least(0.0))]
    startup_beta: Option<f32>,
    /// Start-up ramp duration, s, >= 0 (0 = off).
    #[arg(long, value_name = "S", value_parser = at_least(0.0))]
    startup_s: Option<f32>,
    /// Time constant of each of the two earth-frame low-pass stages the
    /// accelerometer's tilt correction goes through, s, > 0.
    #[arg(long, value_name = "S", value_parser = above(0.0))]
    tilt_tau: Option<f32>,
    /// The same stages' time constant at rest (the bias estimator's test)
    /// where shorter, s, > 0 (`--tilt-tau`'s value or more: off).
    #[arg(long, value_name = "S", value_parser = above(0.0))]
    rest_tilt_tau: Option<f32>,
    /// Disable gyro bias estimation at rest.
    #[arg(long)]
    no_bias_est: bool,
    /// Rest threshold on |ω|, rad/s, > 0.
    #[arg(long, value_name = "RAD_S", value_parser = above(0.0))]
    rest_gyro: Option<f32>,
    /// Minimum rest before the bias is updated, s, >= 0.
    #[arg(long, value_name = "S", value_parser = at_least(0.0))]
    rest_time: Option<f32>,
    /// Bias averaging time constant, s, > 0.
    #[arg(long, value_name = "S", value_parser = above(0.0))]
    bias_tau: Option<f32>,
    /// Enable accelerometer rejection.
    #[arg(long, overrides_with = "no_accel_rejection")]
    accel_rejection: bool,
    /// Disable accelerometer rejection.
    #[arg(long)]
    no_accel_rejection: bool,
    /// Accelerometer norm tolerance, fraction of g, in (0, 1].
    #[arg(long, value_name = "FRAC", value_parser = fraction)]
    accel_norm_tol: Option<f32>,
    /// Accelerometer error angle threshold, degrees, > 0.
    #[arg(long, value_name = "DEG", value_parser = above(0.0))]
    accel_angle: Option<f32>,
    /// Accelerometer rejection recovery timeout, s, >= 0.
    #[arg(long, value_name = "S", value_parser = at_least(0.0))]
    accel_recovery: Option<f32>,
    /// Disable magnetic disturbance rejection.
    #[arg(long)]
    no_mag_rejection: bool,
    /// Field strength tolerance, fraction, in (0, 1].
    #[arg(long, value_name = "FRAC", value_parser = fraction)]
    mag_norm_tol: Option<f32>,
    /// Dip angle tolerance, degrees, > 0.
    #[arg(long, value_name = "DEG", value_parser = above(0.0))]
    mag_dip_tol: Option<f32>,
    /// Time a new stable field needs (while rotating) to be adopted, s, >= 0.
    #[arg(long, value_name = "S", value_parser = at_least(0.0))]
    mag_recovery: Option<f32>,
    /// Time rejected without a break after which the current field is adopted, s, >= 0.
    #[arg(long, value_name = "S", value_parser = at_least(0.0))]
    mag_fallback: Option<f32>,
    /// Time constant with which the field reference follows an accepted field
    /// while moving, s, >= 0 (0 = frozen after start-up).
    #[arg(long, value_name = "S", value_parser = at_least(0.0))]
    mag_ref_tau: Option<f32>,
    /// Gyro scale-factor tolerance behind the heading gain schedule, fraction
    /// in [0, 1] (0 = constant gains).
    #[arg(long, value_name = "FRAC", value_parser = at_least(0.0))]
    gyro_scale_tol: Option<f32>,
    /// Time constant of the mean vertical rate for that schedule, s, > 0.
    #[arg(long, value_name = "S", value_parser = above(0.0))]
    gyro_scale_tau: Option<f32>,
    /// After each file's scores, print how many updates ended in each state of the
    /// magnetic disturbance handling (undisturbed, learning, rejected, recovered,
    /// fallback, ...), and their total after the mean.
    #[arg(long)]
    stats: bool,
    /// Skip rows with a non-finite or out-of-range sample (counted) instead of failing.
    #[arg(long)]
    skip_invalid: bool,
    /// Write q_enu_from_sensor per row (t_s,qw,qx,qy,qz); `-` = stdout (one
    /// input). Each q is in its reference's hemisphere (−q, the same
    /// rotation, where q·ref < 0; w >= 0 without a reference), so the
    /// columns compare directly with ref_q*. Says on stderr what it wrote. With several inputs FILE is a prefix: FILE_<input>.csv, named
    /// from each input's path so no two collide. Never an input; folders are created.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum SensorArg {
    /// A calibrated laboratory IMU (BROAD): scale tolerance 0.5 %, heading τ 80 s.
    Calibrated,
    /// The MPU-9250 as its datasheet bounds it: the crate's defaults.
    Mpu9250,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum ModeArg {
    /// Gyro + accelerometer.
    Imu,
    /// Gyro + accelerometer + magnetometer.
    Marg,
}

fn finite(s: &str) -> Result<f32, String> {
    s.parse::<f32>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("`{s}` is not a finite number"))
}

fn at_least(lo: f32) -> impl Fn(&str) -> Result<f32, String> + Clone {
    move |s| {
        let v = finite(s)?;
        if v < lo {
            return Err(format!("{v} is below {lo}"));
        }
        Ok(v)
    }
}

fn above(lo: f32) -> impl Fn(&str) -> Result<f32, String> + Clone {
    move |s| {
        let v = finite(s)?;
        if v <= lo {
            return Err(format!("{v} must be greater than {lo}"));
        }
        Ok(v)
    }
}

fn fraction(s: &str) -> Result<f32, String> {
    let v = finite(s)?;
    if !(v > 0.0 && v <= 1.0) {
        return Err(format!("{v} is not in (0, 1]"));
    }
    Ok(v)
}

/// Gyro scale-factor tolerance of a calibrated recording (`--sensor calibrated`).
const CALIBRATED_GYRO_SCALE_TOL: f32 = 0.005;
/// Heading time constant for a calibrated recording, s (`--sensor calibrated`).
const CALIBRATED_HEADING_TAU_S: f32 = 80.0;

/// The filter configuration the options describe.
fn config(cli: &Cli) -> fc_ahrs::Config {
    let mut c = fc_ahrs::Config::DEFAULT;
    if let SensorArg::Calibrated = cli.sensor {
        c.gyro_scale_tol = CALIBRATED_GYRO_SCALE_TOL;
        c.heading_tau_s = CALIBRATED_HEADING_TAU_S;
    }
    let set = |slot: &mut f32, v: Option<f32>| {
        if let Some(v) = v {
            *slot = v;
        }
    };
    set(&mut c.beta, cli.beta);
    set(&mut c.heading_tau_s, cli.heading_tau);
    set(&mut c.startup_beta, cli.startup_beta);
    set(&mut c.startup_s, cli.startup_s);
    set(&mut c.bias.rest_gyro_rps, cli.rest_gyro);
    set(&mut c.bias.rest_time_s, cli.rest_time);
    set(&mut c.bias.tau_s, cli.bias_tau);
    set(&mut c.accel_rejection.norm_tol, cli.accel_norm_tol);
    set(&mut c.accel_rejection.angle_deg, cli.accel_angle);
    set(&mut c.accel_rejection.recovery_s, cli.accel_recovery);
    set(&mut c.mag_rejection.norm_tol, cli.mag_norm_tol);
    set(&mut c.mag_rejection.dip_tol_deg, cli.mag_dip_tol);
    set(&mut c.mag_rejection.recovery_s, cli.mag_recovery);
    set(&mut c.mag_rejection.fallback_s, cli.mag_fallback);
    set(&mut c.mag_rejection.ref_tau_s, cli.mag_ref_tau);
    set(&mut c.gyro_scale_tol, cli.gyro_scale_tol);
    set(&mut c.gyro_scale_tau_s, cli.gyro_scale_tau);
    set(&mut c.tilt_tau_s, cli.tilt_tau);
    set(&mut c.rest_tilt_tau_s, cli.rest_tilt_tau);
    if cli.no_bias_est {
        c.bias.enabled = false;
    }
    if cli.accel_rejection {
        c.accel_rejection.enabled = true;
    }
    if cli.no_accel_rejection {
        c.accel_rejection.enabled = false;
    }
    if cli.no_mag_rejection {
        c.mag_rejection.enabled = false;
    }
    c
}

/// An opened output: its path (`-` = stdout), its writer and, for a file,
/// the temporary file it writes, renamed over the path once the input has
/// replayed and every row is written (`host_console::SafeFile`).
struct Output {
    path: PathBuf,
    writer: Box<dyn Write>,
    file: Option<SafeFile>,
}

/// One input with its output, checked and opened before any replay.
struct Job {
    input: PathBuf,
    out: Option<Output>,
}

/// Everything validated: the jobs and the filter settings.
struct Plan {
    jobs: Vec<Job>,
    kind: FilterKind,
    mode: Mode,
    cfg: fc_ahrs::Config,
    read: ReadOptions,
    stats: bool,
}

fn is_stdio(p: &Path) -> bool {
    p == Path::new("-")
}

/// A name for `input` unique among `all`: its file stem, or where stems
/// collide, its whole path with separators as `_`.
fn unique_name(input: &Path, all: &[PathBuf]) -> String {
    let stem = |p: &Path| {
        if is_stdio(p) {
            "stdin".to_string()
        } else {
            p.file_stem()
                .map_or_else(|| "input".into(), |s| s.to_string_lossy().into_owned())
        }
    };
    let mine = stem(input);
    if all.iter().filter(|p| stem(p) == mine).count() <= 1 {
        return mine;
    }
    let path = input.with_extension("");
    path.components()
        .filter_map(|c| match c {
            std::path::Component::Normal(s) => Some(s.to_string_lossy().into_owned()),
            std::path::Component::ParentDir => Some("up".into()),
            _ => None,
        })
        .collect::<Vec<_>>()
        .join("_")
}

fn out_path(base: &Path, input: &Path, all: &[PathBuf]) -> PathBuf {
    if all.len() == 1 {
        return base.to_path_buf();
    }
    let b = base.to_string_lossy();
    let b = b.strip_suffix(".csv").unwrap_or(&b);
    PathBuf::from(format!("{b}_{}.csv", unique_name(input, all)))
}

fn plan(cli: &Cli) -> Result<Plan, String> {
    let kind = FilterKind::from_name(&cli.filter)
        .ok_or_else(|| format!("--filter: unknown filter `{}`", cli.filter))?;
    let mode = match cli.mode {
        ModeArg::Imu => Mode::Imu,
        ModeArg::Marg => Mode::Marg,
    };
    check_inputs(&cli.files)?;
    let outs: Vec<Option<Output>> = match &cli.out {
        None => cli.files.iter().map(|_| None).collect(),
        Some(base) => open_outputs(base, &cli.files)?
            .into_iter()
            .map(Some)
            .collect(),
    };
    let jobs = cli
        .files
        .iter()
        .zip(outs)
        .map(|(input, out)| Job {
            input: input.clone(),
            out,
        })
        .collect();
    Ok(Plan {
        jobs,
        kind,
        mode,
        cfg: config(cli),
        read: ReadOptions {
            skip_invalid: cli.skip_invalid,
        },
        stats: cli.stats,
    })
}

fn check_inputs(files: &[PathBuf]) -> Result<(), String> {
    if files.iter().filter(|p| is_stdio(p)).count() > 1 {
        return Err("`-` (stdin) can be given once".into());
    }
    let mut seen: Vec<PathBuf> = Vec::new();
    for f in files.iter().filter(|p| !is_stdio(p)) {
        let meta = std::fs::metadata(f).map_err(|e| format!("{}: {e}", f.display()))?;
        if meta.is_dir() {
            return Err(format!("{}: is a folder, not a recording", f.display()));
        }
        let c = canonical_path(f);
        if seen.contains(&c) {
            return Err(format!("{}: given twice", f.display()));
        }
        seen.push(c);
    }
    Ok(())
}

/// Creates every output (and its folders) now, refusing any that is an input.
fn open_outputs(base: &Path, files: &[PathBuf]) -> Result<Vec<Output>, String> {
    if is_stdio(base) {
        if files.len() > 1 {
            return Err("--out -: stdout takes the estimates of one input only".into());
        }
        host_console::use_stderr();
        return Ok(vec![Output {
            path: base.to_path_buf(),
            writer: Box::new(std::io::stdout()),
            file: None,
        }]);
    }
    let inputs: Vec<PathBuf> = files.iter().map(|f| canonical_path(f)).collect();
    let paths: Vec<PathBuf> = files.iter().map(|f| out_path(base, f, files)).collect();
    check_distinct(&paths, files)?;
    for p in &paths {
        if inputs.contains(&canonical_path(p)) {
            return Err(format!(
                "--out {}: that is an input; refusing to overwrite a recording",
                p.display()
            ));
        }
    }
    let mut outs: Vec<Output> = Vec::new();
    for path in paths {
        let (file, f) =
            SafeFile::create(&path).map_err(|e| format!("--out {}: {e}", path.display()))?;
        outs.push(Output {
            path,
            writer: Box::new(f),
            file: Some(file),
        });
    }
    Ok(outs)
}

/// Two inputs whose paths flatten to the same name (`a_b/x.csv`,
/// `a/b/x.csv`) would share an output: refuse rather than overwrite.
fn check_distinct(paths: &[PathBuf], files: &[PathBuf]) -> Result<(), String> {
    for (i, p) in paths.iter().enumerate() {
        if let Some(j) = paths[..i]
            .iter()
            .position(|q| canonical_path(q) == canonical_path(p))
        {
            return Err(format!(
                "--out: inputs {} and {} would both write {}; replay them in separate runs",
                files[j].display(),
                files[i].display(),
                p.display()
            ));
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let plan = match plan(&cli) {
        Ok(p) => p,
        Err(e) => {
            note!("replay: {e}");
            return ExitCode::from(2);
        }
    };
    let failed = replay_all(plan);
    if host_console::stdout_failed() {
        note!("replay: writing to stdout failed");
        return ExitCode::FAILURE;
    }
    if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// Replays every job, reporting failures as it goes; returns how many failed.
fn replay_all(plan: Plan) -> usize {
    say!(
        "filter: {}; {}; beta {}",
        plan.kind.describe(),
        plan.mode.describe(),
        plan.cfg.beta
    );
    say!(
        "{:<40} {:>8} {:>9} {:>9} {:>9}",
        "file",
        "rows",
        "total°",
        "heading°",
        "incl°"
    );
    let mut scores: Vec<Score> = Vec::new();
    let mut failed = Vec::new();
    let mut all = MagCounts::default();
    for job in plan.jobs {
        let name = job.input.display().to_string();
        let res = replay_one(job, plan.kind, plan.mode, &plan.cfg, plan.read);
        if let (true, Ok((_, _, n))) = (plan.stats, &res) {
            all = all.merged(n);
        }
        match res {
            Ok((rows, Some(s), n)) => {
                say!(
                    "{:<40} {:>8} {:>9.3} {:>9.3} {:>9.3}",
                    name,
                    rows,
                    s.total_deg,
                    s.heading_deg,
                    s.inclination_deg
                );
                scores.push(s);
                if plan.stats {
                    print_counts("  mag states", &n);
                }
            }
            Ok((rows, None, n)) => {
                say!("{:<40} {:>8} (no reference to score against)", name, rows);
                if plan.stats {
                    print_counts("  mag states", &n);
                }
            }
            Err(e) => {
                note!("replay: {name}: {e}");
                failed.push(name);
            }
        }
    }
    print_mean(&scores);
    if plan.stats {
        print_counts("mag states, all files", &all);
    }
    if !failed.is_empty() {
        note!(
            "replay: {} file(s) failed, not in the mean: {}",
            failed.len(),
            failed.join(", ")
        );
    }
    failed.len()
}

/// One line: each state's count and share of the updates (states that never
/// occurred included, so a reader sees that e.g. the fallback did not fire).
fn print_counts(label: &str, n: &MagCounts) {
    let total: usize = n.counts.iter().sum();
    let parts: Vec<String> = MagCounts::NAMES
        .iter()
        .zip(n.counts)
        .map(|(name, c)| {
            let pct = if total > 0 {
                100.0 * c as f64 / total as f64
            } else {
                0.0
            };
            format!("{name} {c} ({pct:.1} %)")
        })
        .collect();
    say!("{label}: {}", parts.join(", "));
}

fn print_mean(scores: &[Score]) {
    if scores.is_empty() {
        return;
    }
    let n = scores.len() as f64;
    let m = |f: fn(&Score) -> f64| scores.iter().map(f).sum::<f64>() / n;
    say!(
        "{:<40} {:>8} {:>9.3} {:>9.3} {:>9.3}",
        format!("MEAN over {} file(s)", scores.len()),
        "",
        m(|s| s.total_deg),
        m(|s| s.heading_deg),
        m(|s| s.inclination_deg)
    );
}

fn read_input(path: &Path) -> Result<String, String> {
    let mut text = String::new();
    let res = if is_stdio(path) {
        std::io::stdin().read_to_string(&mut text)
    } else {
        File::open(path).and_then(|mut f| f.read_to_string(&mut text))
    };
    res.map_err(|e| e.to_string())?;
    Ok(text)
}

/// Reads, replays and scores one input, writing its estimates; on failure
/// its output is discarded (an existing file there is left as it was).
fn replay_one(
    job: Job,
    kind: FilterKind,
    mode: Mode,
    cfg: &fc_ahrs::Config,
    opts: ReadOptions,
) -> Result<(usize, Option<Score>, MagCounts), String> {
    let Job { input, out } = job;
    let (samples, est, counts) = replay_recording(&input, kind, mode, cfg, opts)?;
    if let Some(Output { path, writer, file }) = out {
        let failed = |e: std::io::Error| format!("--out {}: {e}", path.display());
        write_out(writer, &samples, &est).map_err(failed)?;
        let whom = match file {
            Some(file) => {
                file.commit().map_err(failed)?;
                path.display().to_string()
            }
            None => "stdout".into(),
        };
        note!(
            "replay: wrote {whom}: {} rows of t_s,qw,qx,qy,qz (q_enu_from_sensor, in the reference's hemisphere)",
            samples.len()
        );
    }
    Ok((samples.len(), score(&samples, &est), counts))
}

/// The rows of every segment and the filter's estimate for each.
fn replay_recording(
    input: &Path,
    kind: FilterKind,
    mode: Mode,
    cfg: &fc_ahrs::Config,
    opts: ReadOptions,
) -> Result<(Vec<replay::Sample>, Vec<fc_ahrs::Quaternion>, MagCounts), String> {
    let text = read_input(input)?;
    let rec = read(&text, opts).map_err(|e| e.to_string())?;
    report(input, &rec);
    let mut counts = MagCounts::default();
    let mut est = Vec::new();
    for s in &rec.segments {
        let (e, n) = run_counted(&s.samples, kind, mode, cfg);
        est.extend(e);
        counts = counts.merged(&n);
    }
    let samples = rec
        .segments
        .iter()
        .flat_map(|s| s.samples.iter().copied())
        .collect();
    Ok((samples, est, counts))
}

fn report(input: &Path, rec: &Recording) {
    for w in &rec.warnings {
        note!("replay: {}: warning: {w}", input.display());
    }
    if rec.skipped_rows > 0 {
        note!(
            "replay: {}: skipped {} invalid row(s) of {}",
            input.display(),
            rec.skipped_rows,
            rec.skipped_rows + rec.rows()
        );
    }
    if rec.segments.len() > 1 {
        note!(
            "replay: {}: {} segments (header repeated), each replayed from a fresh filter",
            input.display(),
            rec.segments.len()
        );
    }
}

/// One row per sample: the estimate, put in its reference's hemisphere
/// ([`same_hemisphere`]).
fn write_out(
    w: Box<dyn Write>,
    samples: &[replay::Sample],
    est: &[fc_ahrs::Quaternion],
) -> std::io::Result<()> {
    let mut w = std::io::BufWriter::new(w);
    let res = (|| {
        writeln!(w, "t_s,qw,qx,qy,qz")?;
        for (s, q) in samples.iter().zip(est) {
            let q = same_hemisphere(q, s.reference.as_ref());
            writeln!(
                w,
                "{:.6},{:.7},{:.7},{:.7},{:.7}",
                s.t_s, q.w, q.x, q.y, q.z
            )?;
        }
        w.flush()
    })();
    match res {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::Cli;
    use proptest::prelude::*;

    /// clap's checks of the definitions; any command line parses or errs, never panics.
    #[test]
    fn the_command_line_is_well_defined() {
        host_console::testing::check_parser::<Cli>();
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

        /// Distinct inputs get distinct outputs, or the plan is refused.
        #[test]
        fn output_names_never_collide(
            names in proptest::collection::btree_set("[ab_]{1,3}(/[ab_]{1,3}){0,2}", 2..6)
        ) {
            let files: Vec<std::path::PathBuf> =
                names.iter().map(|n| format!("{n}.csv").into()).collect();
            let outs: Vec<_> = files
                .iter()
                .map(|f| super::out_path(std::path::Path::new("q.csv"), f, &files))
                .collect();
            if super::check_distinct(&outs, &files).is_ok() {
                let set: std::collections::BTreeSet<_> = outs.iter().collect();
                prop_assert_eq!(set.len(), outs.len());
            }
            for o in &outs {
                prop_assert!(!files.contains(o));
            }
        }
    }
}
