//! `replay`: run recorded IMU data (BROAD CSV format) through the AHRS and score it.

use replay::{parse_csv, run, score, FilterKind, Mode, Score};
use std::io::Write;
use std::process::ExitCode;

const HELP: &str = "\
replay — run CSV IMU recordings through the fc-ahrs Madgwick filter and score them

USAGE:
    replay [OPTIONS] FILE.csv [FILE.csv ...]

CSV columns (header line, named): t_s, gyr_{x,y,z}_rad_s, acc_{x,y,z}_m_s2, mag_{x,y,z}_ut,
optional ref_q{w,x,y,z} (sensor relative to ENU; nan = none) and moving (0/1).
Where a reference exists, prints BROAD-style RMS errors (deg) over moving rows with a valid
reference, per file and the mean over files.

OPTIONS:
    --filter f32|fixed|textbook|textbook-fixed
                                implementation (default f32); textbook = Madgwick's 2010
                                filter as published (one β, no extensions), in f32 or fixed
    --mode imu|marg             sensors to fuse (default marg)
    --beta RAD_S                Madgwick gain β (default from fc_ahrs::Config::DEFAULT)
    --beta-mag RAD_S            magnetometer (heading) gain
    --startup-beta RAD_S        start-up gain
    --startup-s S               start-up ramp duration (0 = off)
    --tilt-tau S                time constant of each earth-frame accelerometer low-pass stage
    --no-bias-est               disable gyro bias estimation at rest
    --rest-gyro RAD_S           rest threshold on |ω|
    --rest-time S               minimum rest duration before the bias is updated
    --bias-tau S                bias averaging time constant
    --accel-rejection           enable accelerometer rejection (off by default)
    --no-accel-rejection        disable accelerometer rejection
    --accel-norm-tol FRAC       accel norm tolerance (fraction of g)
    --accel-angle DEG           accel error angle threshold
    --accel-recovery S          accel rejection recovery timeout
    --no-mag-rejection          disable magnetic disturbance rejection
    --mag-norm-tol FRAC         field strength tolerance (fraction)
    --mag-dip-tol DEG           dip angle tolerance
    --mag-recovery S            time a new stable field needs (while rotating) to be adopted
    --gyro-scale-tol FRAC       gyro scale-factor tolerance behind the heading gain schedule
                                (default 0.03; 0 = constant gains)
    --gyro-scale-tau S          time constant of the mean vertical rate for that schedule
    --out FILE                  write q_enu_from_sensor per row (t_s,qw,qx,qy,qz); with several
                                inputs, FILE gets the input's stem appended (FILE_stem.csv)
    -h, --help                  this text
";

struct Args {
    files: Vec<String>,
    kind: FilterKind,
    mode: Mode,
    cfg: fc_ahrs::Config,
    out: Option<String>,
}

fn parse_args(argv: &[String]) -> Result<Option<Args>, String> {
    let mut a = Args {
        files: Vec::new(),
        kind: FilterKind::F32,
        mode: Mode::Marg,
        cfg: fc_ahrs::Config::DEFAULT,
        out: None,
    };
    let mut it = argv.iter();
    while let Some(arg) = it.next() {
        let mut val = |name: &str| -> Result<String, String> {
            it.next()
                .cloned()
                .ok_or_else(|| format!("option {name} needs a value"))
        };
        let num = |name: &str, v: String| -> Result<f32, String> {
            v.parse::<f32>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("option {name}: `{v}` is not a finite number"))
        };
        match arg.as_str() {
            "-h" | "--help" => return Ok(None),
            "--filter" => {
                a.kind = match val(arg)?.as_str() {
                    "f32" => FilterKind::F32,
                    "fixed" => FilterKind::Fixed,
                    "textbook" | "textbook-f32" => {
                        a.cfg.algorithm = fc_ahrs::Algorithm::Textbook;
                        FilterKind::F32
                    }
                    "textbook-fixed" => {
                        a.cfg.algorithm = fc_ahrs::Algorithm::Textbook;
                        FilterKind::Fixed
                    }
                    v => {
                        return Err(format!(
                            "--filter: expected f32, fixed, textbook or textbook-fixed, got `{v}`"
                        ))
                    }
                }
            }
            "--mode" => {
                a.mode = match val(arg)?.as_str() {
                    "imu" => Mode::Imu,
                    "marg" => Mode::Marg,
                    v => return Err(format!("--mode: expected imu or marg, got `{v}`")),
                }
            }
            "--beta" => a.cfg.beta = num(arg, val(arg)?)?,
            "--beta-mag" => a.cfg.beta_mag = num(arg, val(arg)?)?,
            "--startup-beta" => a.cfg.startup_beta = num(arg, val(arg)?)?,
            "--startup-s" => a.cfg.startup_s = num(arg, val(arg)?)?,
            "--no-bias-est" => a.cfg.bias.enabled = false,
            "--rest-gyro" => a.cfg.bias.rest_gyro_rps = num(arg, val(arg)?)?,
            "--rest-time" => a.cfg.bias.rest_time_s = num(arg, val(arg)?)?,
            "--bias-tau" => a.cfg.bias.tau_s = num(arg, val(arg)?)?,
            "--no-accel-rejection" => a.cfg.accel_rejection.enabled = false,
            "--accel-rejection" => a.cfg.accel_rejection.enabled = true,
            "--tilt-tau" => a.cfg.tilt_tau_s = num(arg, val(arg)?)?,
            "--accel-norm-tol" => a.cfg.accel_rejection.norm_tol = num(arg, val(arg)?)?,
            "--accel-angle" => a.cfg.accel_rejection.angle_deg = num(arg, val(arg)?)?,
            "--accel-recovery" => a.cfg.accel_rejection.recovery_s = num(arg, val(arg)?)?,
            "--no-mag-rejection" => a.cfg.mag_rejection.enabled = false,
            "--mag-norm-tol" => a.cfg.mag_rejection.norm_tol = num(arg, val(arg)?)?,
            "--mag-dip-tol" => a.cfg.mag_rejection.dip_tol_deg = num(arg, val(arg)?)?,
            "--mag-recovery" => a.cfg.mag_rejection.recovery_s = num(arg, val(arg)?)?,
            "--gyro-scale-tol" => a.cfg.gyro_scale_tol = num(arg, val(arg)?)?,
            "--gyro-scale-tau" => a.cfg.gyro_scale_tau_s = num(arg, val(arg)?)?,
            "--out" => a.out = Some(val(arg)?),
            s if s.starts_with('-') => return Err(format!("unknown option `{s}` (see --help)")),
            s => a.files.push(s.to_string()),
        }
    }
    if a.files.is_empty() {
        return Err("no input files (see --help)".into());
    }
    Ok(Some(a))
}

fn out_path(base: &str, input: &str, several: bool) -> String {
    if !several {
        return base.to_string();
    }
    let stem = std::path::Path::new(input)
        .file_stem()
        .map_or_else(|| "out".to_string(), |s| s.to_string_lossy().into_owned());
    let b = base.strip_suffix(".csv").unwrap_or(base);
    format!("{b}_{stem}.csv")
}

fn main() -> ExitCode {
    let argv: Vec<String> = std::env::args().skip(1).collect();
    let args = match parse_args(&argv) {
        Ok(Some(a)) => a,
        Ok(None) => {
            print!("{HELP}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("replay: {e}");
            return ExitCode::from(2);
        }
    };
    println!(
        "filter {:?}, mode {:?}, beta {}",
        args.kind, args.mode, args.cfg.beta
    );
    println!(
        "{:<40} {:>8} {:>9} {:>9} {:>9}",
        "file", "rows", "total°", "heading°", "incl°"
    );
    let mut scores: Vec<Score> = Vec::new();
    let several = args.files.len() > 1;
    for file in &args.files {
        let text = match std::fs::read_to_string(file) {
            Ok(t) => t,
            Err(e) => {
                eprintln!("replay: {file}: {e}");
                return ExitCode::FAILURE;
            }
        };
        let samples = match parse_csv(&text) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("replay: {file}: {e}");
                return ExitCode::FAILURE;
            }
        };
        let est = run(&samples, args.kind, args.mode, &args.cfg);
        if let Some(base) = &args.out {
            let path = out_path(base, file, several);
            if let Err(e) = write_out(&path, &samples, &est) {
                eprintln!("replay: {path}: {e}");
                return ExitCode::FAILURE;
            }
        }
        let name = std::path::Path::new(file)
            .file_stem()
            .map_or_else(|| file.clone(), |s| s.to_string_lossy().into_owned());
        match score(&samples, &est) {
            Some(s) => {
                println!(
                    "{:<40} {:>8} {:>9.3} {:>9.3} {:>9.3}",
                    name, s.rows, s.total_deg, s.heading_deg, s.inclination_deg
                );
                scores.push(s);
            }
            None => println!("{:<40} {:>8} (no reference)", name, samples.len()),
        }
    }
    if !scores.is_empty() {
        let n = scores.len() as f64;
        let m = |f: fn(&Score) -> f64| scores.iter().map(f).sum::<f64>() / n;
        println!(
            "{:<40} {:>8} {:>9.3} {:>9.3} {:>9.3}",
            format!("MEAN over {} file(s)", scores.len()),
            "",
            m(|s| s.total_deg),
            m(|s| s.heading_deg),
            m(|s| s.inclination_deg)
        );
    }
    ExitCode::SUCCESS
}

fn write_out(
    path: &str,
    samples: &[replay::Sample],
    est: &[fc_ahrs::Quaternion],
) -> std::io::Result<()> {
    let f = std::fs::File::create(path)?;
    let mut w = std::io::BufWriter::new(f);
    writeln!(w, "t_s,qw,qx,qy,qz")?;
    for (s, q) in samples.iter().zip(est) {
        writeln!(
            w,
            "{:.6},{:.7},{:.7},{:.7},{:.7}",
            s.t_s, q.w, q.x, q.y, q.z
        )?;
    }
    w.flush()
}
