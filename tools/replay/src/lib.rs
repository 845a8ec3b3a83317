//! Replay CSV IMU recordings (BROAD format) through `fc-ahrs` and score the result.
//!
//! CSV: a header line with named columns; `t_s`, `gyr_{x,y,z}_rad_s`,
//! `acc_{x,y,z}_m_s2`, `mag_{x,y,z}_ut` are required; `ref_q{w,x,y,z}` (sensor
//! relative to ENU, `nan` = no reference) and `moving` are optional.
//! The "body" is the sensor frame itself (identity alignment).

use fc_ahrs::fixed::{self, FixedConfig, MadgwickFixed};
use fc_ahrs::{frames, Config, Madgwick, Quaternion};
use std::fmt;

/// One CSV row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time (s).
    pub t_s: f32,
    /// Gyro (rad/s, sensor frame).
    pub gyr_rps: [f32; 3],
    /// Accelerometer specific force (m/s², sensor frame).
    pub acc_mps2: [f32; 3],
    /// Magnetometer (µT, sensor frame).
    pub mag_ut: [f32; 3],
    /// Reference q_enu_from_sensor, if present and valid.
    pub reference: Option<Quaternion>,
    /// Movement phase flag (true if the column is absent).
    pub moving: bool,
}

/// A parse error, with the 1-based line number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ParseError {
    /// The file is empty.
    Empty,
    /// A required column is missing from the header.
    MissingColumn(&'static str),
    /// A field is not a number.
    BadNumber {
        /// Line number (1-based).
        line: usize,
        /// Column name.
        column: String,
    },
    /// A row has fewer fields than the header.
    ShortRow {
        /// Line number (1-based).
        line: usize,
    },
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParseError::Empty => write!(f, "empty file"),
            ParseError::MissingColumn(c) => write!(f, "missing column `{c}` in header"),
            ParseError::BadNumber { line, column } => {
                write!(f, "line {line}: column `{column}` is not a number")
            }
            ParseError::ShortRow { line } => write!(f, "line {line}: too few fields"),
        }
    }
}

impl std::error::Error for ParseError {}

const REQUIRED: [&str; 10] = [
    "t_s",
    "gyr_x_rad_s",
    "gyr_y_rad_s",
    "gyr_z_rad_s",
    "acc_x_m_s2",
    "acc_y_m_s2",
    "acc_z_m_s2",
    "mag_x_ut",
    "mag_y_ut",
    "mag_z_ut",
];
const REF: [&str; 4] = ["ref_qw", "ref_qx", "ref_qy", "ref_qz"];

/// Parse a whole CSV text.
pub fn parse_csv(text: &str) -> Result<Vec<Sample>, ParseError> {
    let mut lines = text.lines().enumerate();
    let (_, header) = lines.next().ok_or(ParseError::Empty)?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |n: &str| names.iter().position(|h| *h == n);
    let mut req = [0usize; 10];
    for (slot, name) in req.iter_mut().zip(REQUIRED) {
        *slot = find(name).ok_or(ParseError::MissingColumn(name))?;
    }
    let refs: Option<Vec<usize>> = REF.iter().map(|n| find(n)).collect();
    let moving = find("moving");
    let mut out = Vec::with_capacity(text.len() / 120);
    let mut fields: Vec<&str> = Vec::with_capacity(names.len());
    for (i, line) in lines {
        let line_no = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        fields.clear();
        fields.extend(line.split(',').map(str::trim));
        let get = |idx: usize, name: &str| -> Result<f32, ParseError> {
            let s = fields
                .get(idx)
                .ok_or(ParseError::ShortRow { line: line_no })?;
            s.parse::<f32>().map_err(|_| ParseError::BadNumber {
                line: line_no,
                column: name.to_string(),
            })
        };
        let mut v = [0f32; 10];
        for ((slot, &idx), name) in v.iter_mut().zip(req.iter()).zip(REQUIRED) {
            *slot = get(idx, name)?;
        }
        let reference = match &refs {
            Some(r) => {
                let mut q = [0f32; 4];
                for ((slot, &idx), name) in q.iter_mut().zip(r.iter()).zip(REF) {
                    *slot = get(idx, name)?;
                }
                let q = Quaternion::new(q[0], q[1], q[2], q[3]);
                if q.is_finite() {
                    q.normalized()
                } else {
                    None
                }
            }
            None => None,
        };
        let moving = match moving {
            Some(idx) => get(idx, "moving")? != 0.0,
            None => true,
        };
        out.push(Sample {
            t_s: v[0],
            gyr_rps: [v[1], v[2], v[3]],
            acc_mps2: [v[4], v[5], v[6]],
            mag_ut: [v[7], v[8], v[9]],
            reference,
            moving,
        });
    }
    Ok(out)
}

/// Which implementation to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FilterKind {
    /// `fc_ahrs::Madgwick`.
    F32,
    /// `fc_ahrs::fixed::MadgwickFixed`.
    Fixed,
}

/// Which sensors to fuse.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Gyro + accelerometer.
    Imu,
    /// Gyro + accelerometer + magnetometer.
    Marg,
}

/// Run a filter over the samples; returns `q_enu_from_sensor` per row.
/// The filter is initialised from the first sample's accelerometer and magnetometer
/// (in both modes: IMU mode then keeps that initial heading). dt is taken from consecutive `t_s`
/// (the first row uses the second row's step).
pub fn run(samples: &[Sample], kind: FilterKind, mode: Mode, cfg: &Config) -> Vec<Quaternion> {
    let mut out = Vec::with_capacity(samples.len());
    let Some(first) = samples.first() else {
        return out;
    };
    // Heading at start comes from the first magnetometer sample in both modes.
    let init_mag = first.mag_ut;
    let dt0 = samples.get(1).map_or(0.0035, |s| s.t_s - first.t_s);
    let mut prev_t = first.t_s - dt0;
    match kind {
        FilterKind::F32 => {
            let mut f = Madgwick::from_accel_mag(*cfg, first.acc_mps2, init_mag);
            for s in samples {
                let dt = s.t_s - prev_t;
                prev_t = s.t_s;
                match mode {
                    Mode::Imu => f.update_imu(s.gyr_rps, s.acc_mps2, dt),
                    Mode::Marg => f.update_marg(s.gyr_rps, s.acc_mps2, s.mag_ut, dt),
                };
                out.push(frames::enu_from_ned(f.quaternion()));
            }
        }
        FilterKind::Fixed => {
            // Accelerometer and magnetometer fed as Q16 (m/s², µT): gravity_norm follows.
            let fcfg = FixedConfig::from_config(&Config {
                gravity_norm: cfg.gravity_norm * 65536.0,
                ..*cfg
            });
            let q16 = |v: [f32; 3]| v.map(|x| fixed::float_to_q(x, 16));
            let mut f = MadgwickFixed::from_accel_mag(fcfg, q16(first.acc_mps2), q16(init_mag));
            for s in samples {
                let dt = fixed::dt_s_to_q31(s.t_s - prev_t);
                prev_t = s.t_s;
                let g = s.gyr_rps.map(fixed::rps_to_q20);
                match mode {
                    Mode::Imu => f.update_imu(g, q16(s.acc_mps2), dt),
                    Mode::Marg => f.update_marg(g, q16(s.acc_mps2), q16(s.mag_ut), dt),
                };
                out.push(frames::enu_from_ned(f.quaternion_f32()));
            }
        }
    }
    out
}

/// Accelerometer fed to the fixed filter as Q16 m/s² (its `one_g` is set accordingly).
pub const fn fcfg_acc_bits() -> u32 {
    16
}

/// BROAD-style error figures (degrees RMS).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Score {
    /// Total orientation error.
    pub total_deg: f64,
    /// Heading (about the vertical) error.
    pub heading_deg: f64,
    /// Inclination error.
    pub inclination_deg: f64,
    /// Rows scored.
    pub rows: usize,
}

/// Score estimates against the reference over rows with `moving` and a valid
/// reference: e = q_est ⊗ conj(q_ref); total = 2·acos|e_w|,
/// heading = 2·atan|e_z/e_w|, inclination = 2·acos√(e_w²+e_z²).
/// `None` if no row qualifies.
pub fn score(samples: &[Sample], est: &[Quaternion]) -> Option<Score> {
    let (mut st, mut sh, mut si, mut n) = (0f64, 0f64, 0f64, 0usize);
    for (s, q) in samples.iter().zip(est) {
        let Some(r) = s.reference else { continue };
        if !s.moving {
            continue;
        }
        let e = q.mul(&r.conj());
        let (w, z) = (f64::from(e.w), f64::from(e.z));
        let total = 2.0 * w.abs().min(1.0).acos();
        let heading = 2.0 * (z / w).abs().atan();
        let incl = 2.0 * (w * w + z * z).sqrt().min(1.0).acos();
        st += total * total;
        sh += heading * heading;
        si += incl * incl;
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let rms = |x: f64| (x / n as f64).sqrt().to_degrees();
    Some(Score {
        total_deg: rms(st),
        heading_deg: rms(sh),
        inclination_deg: rms(si),
        rows: n,
    })
}
