//! The recording reader: BROAD-format CSV, validated like a measurement.
//!
//! * A header line names the columns; `t_s`, `gyr_{x,y,z}_rad_s`,
//!   `acc_{x,y,z}_m_s2`, `mag_{x,y,z}_ut` are required, `ref_q{w,x,y,z}`
//!   (sensor relative to ENU, `nan` = no reference) and `moving` (0/1) optional.
//! * `t_s` is parsed as f64 (an f32 loses milliseconds after a day of
//!   uptime), must be finite and strictly increasing, and consecutive rows
//!   must be [`DT_MIN_S`]..=[`DT_MAX_S`] apart; outside that the error says
//!   what the unit probably was.
//! * Every sample must be finite and within [`LIMITS`] (beyond any MEMS
//!   IMU/magnetometer's full scale: a value there is corruption, not motion).
//!   With [`ReadOptions::skip_invalid`] such rows are skipped and counted instead.
//! * The header repeated later in the file (the firmware prints it each
//!   time raw-log mode is switched on) starts a new [`Segment`].
//! * A last line cut short (a capture stopped with Ctrl-C) is dropped with a
//!   warning; anywhere else a short row is an error.
//! * A segment needs at least two rows (one time step).

use fc_ahrs::Quaternion;
use std::fmt;

/// One CSV row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time (s).
    pub t_s: f64,
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

/// A run of rows under one header: time increases within it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Segment {
    /// Line number (1-based) of the segment's header.
    pub header_line: usize,
    /// The rows.
    pub samples: Vec<Sample>,
}

/// What was read, with what was left out.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recording {
    /// One or more segments, each with at least two rows.
    pub segments: Vec<Segment>,
    /// Rows skipped as invalid (only with [`ReadOptions::skip_invalid`]).
    pub skipped_rows: usize,
    /// Rows in segments too short to use (fewer than two rows).
    pub dropped_rows: usize,
    /// Things the reader dropped or assumed, one sentence each.
    pub warnings: Vec<String>,
}

impl Recording {
    /// Rows over all segments.
    pub fn rows(&self) -> usize {
        self.segments.iter().map(|s| s.samples.len()).sum()
    }
}

/// How to treat invalid samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReadOptions {
    /// Skip rows with a non-finite or out-of-range sample (counted in
    /// [`Recording::skipped_rows`]) instead of failing.
    pub skip_invalid: bool,
}

/// Smallest accepted time step (s): 20 kHz, above any IMU's output rate.
pub const DT_MIN_S: f64 = 50e-6;
/// Largest accepted time step (s): a longer gap is a lost stretch of data.
pub const DT_MAX_S: f64 = 0.5;

/// Largest magnitude accepted per column group, with the unit:
/// gyro 40 rad/s (2290 °/s; MPU-9250 full scale 2000 °/s), accelerometer
/// 160 m/s² (16.3 g; full scale 16 g), magnetometer 5000 µT (AK8963 full
/// scale 4912 µT).
pub const LIMITS: [(&str, f32, &str); 3] = [
    ("gyr_", 40.0, "rad/s"),
    ("acc_", 160.0, "m/s²"),
    ("mag_", 5000.0, "µT"),
];

/// A reference quaternion's norm must be within this of 1 (else the column is
/// not a unit quaternion: wrong column order or scale).
pub const REF_NORM_TOL: f32 = 0.01;

/// What is wrong with a recording, with the 1-based line (and column) where it is.
#[derive(Debug, Clone, PartialEq)]
pub enum ParseError {
    /// The file is empty.
    Empty,
    /// A required column is missing from the header.
    MissingColumn(&'static str),
    /// No segment has two rows (no time step).
    TooFewRows {
        /// Line of the segment's header.
        header_line: usize,
        /// Rows it has.
        rows: usize,
    },
    /// A field is not a number.
    BadNumber {
        /// Line number.
        line: usize,
        /// Column name.
        column: String,
        /// The text found.
        text: String,
    },
    /// A sample is NaN or infinite.
    NonFinite {
        /// Line number.
        line: usize,
        /// Column name.
        column: String,
    },
    /// A sample is beyond [`LIMITS`].
    OutOfRange {
        /// Line number.
        line: usize,
        /// Column name.
        column: String,
        /// The value.
        value: f32,
        /// The limit (magnitude).
        limit: f32,
        /// Its unit.
        unit: &'static str,
    },
    /// A reference quaternion that is not unit length.
    BadReference {
        /// Line number.
        line: usize,
        /// Its norm.
        norm: f32,
    },
    /// `moving` is neither 0 nor 1.
    BadMoving {
        /// Line number.
        line: usize,
    },
    /// A row with fewer fields than the header (not the last line).
    ShortRow {
        /// Line number.
        line: usize,
        /// Fields in the header.
        expected: usize,
        /// Fields found.
        found: usize,
    },
    /// `t_s` not finite.
    BadTime {
        /// Line number.
        line: usize,
    },
    /// `t_s` does not increase.
    TimeNotIncreasing {
        /// Line number.
        line: usize,
        /// Previous time (s).
        prev_s: f64,
        /// This time (s).
        t_s: f64,
    },
    /// The step between rows is outside [`DT_MIN_S`]..=[`DT_MAX_S`].
    DtOutOfRange {
        /// Line number.
        line: usize,
        /// The step (in the file's unit, taken as s).
        dt_s: f64,
        /// Whether the step before it was accepted (then a long step is a
        /// gap; otherwise the unit is the likelier cause).
        after_good_step: bool,
    },
}

impl ParseError {
    /// A hint at the probable cause, if there is one.
    pub fn hint(&self) -> Option<&'static str> {
        match self {
            ParseError::DtOutOfRange {
                dt_s,
                after_good_step: false,
                ..
            } if (1.0..=100.0).contains(dt_s) => {
                Some("timestamps look like milliseconds; t_s must be in seconds")
            }
            ParseError::DtOutOfRange {
                dt_s,
                after_good_step: false,
                ..
            } if *dt_s > 100.0 => {
                Some("timestamps look like microseconds; t_s must be in seconds")
            }
            ParseError::DtOutOfRange { dt_s, .. } if *dt_s > DT_MAX_S => Some(
                "a gap in the recording: split the file there (or repeat the header to start a new segment)",
            ),
            ParseError::DtOutOfRange { .. } => {
                Some("timestamps too close: duplicated rows, or a unit other than seconds")
            }
            ParseError::TimeNotIncreasing { .. } => Some(
                "rows out of order, or a new capture appended without repeating the header",
            ),
            ParseError::OutOfRange { .. } | ParseError::NonFinite { .. } => {
                Some("--skip-invalid drops such rows and counts them")
            }
            _ => None,
        }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParseError::Empty => write!(f, "empty file"),
            ParseError::MissingColumn(c) => write!(f, "line 1: missing column `{c}` in the header"),
            ParseError::TooFewRows { header_line, rows } => write!(
                f,
                "line {header_line}: the header is followed by {rows} data row(s); at least 2 are needed"
            ),
            ParseError::BadNumber { line, column, text } => {
                write!(f, "line {line}, column `{column}`: `{text}` is not a number")
            }
            ParseError::NonFinite { line, column } => {
                write!(f, "line {line}, column `{column}`: not a finite number")
            }
            ParseError::OutOfRange {
                line,
                column,
                value,
                limit,
                unit,
            } => write!(
                f,
                "line {line}, column `{column}`: {value} is beyond ±{limit} {unit}, physically impossible for this sensor"
            ),
            ParseError::BadReference { line, norm } => write!(
                f,
                "line {line}, columns `ref_q*`: the reference quaternion has norm {norm}, not 1"
            ),
            ParseError::BadMoving { line } => {
                write!(f, "line {line}, column `moving`: must be 0 or 1")
            }
            ParseError::ShortRow {
                line,
                expected,
                found,
            } => write!(f, "line {line}: {found} fields, the header has {expected}"),
            ParseError::BadTime { line } => {
                write!(f, "line {line}, column `t_s`: not a finite time")
            }
            ParseError::TimeNotIncreasing { line, prev_s, t_s } => write!(
                f,
                "line {line}, column `t_s`: time {t_s} s does not increase (previous row {prev_s} s)"
            ),
            ParseError::DtOutOfRange { line, dt_s, .. } => write!(
                f,
                "line {line}, column `t_s`: step of {dt_s} s from the previous row, outside {DT_MIN_S}..={DT_MAX_S} s"
            ),
        }?;
        if let Some(h) = self.hint() {
            write!(f, " ({h})")?;
        }
        Ok(())
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

/// Where each column is.
struct Columns {
    header: String,
    count: usize,
    required: [usize; 10],
    reference: Option<[usize; 4]>,
    moving: Option<usize>,
}

impl Columns {
    fn from_header(header: &str) -> Result<Self, ParseError> {
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let find = |n: &str| names.iter().position(|h| *h == n);
        let mut required = [0usize; 10];
        for (slot, name) in required.iter_mut().zip(REQUIRED) {
            *slot = find(name).ok_or(ParseError::MissingColumn(name))?;
        }
        let reference = match REF.map(find) {
            [Some(w), Some(x), Some(y), Some(z)] => Some([w, x, y, z]),
            _ => None,
        };
        Ok(Self {
            header: normalize(header),
            count: names.len(),
            required,
            reference,
            moving: find("moving"),
        })
    }
}

fn normalize(line: &str) -> String {
    line.split(',').map(str::trim).collect::<Vec<_>>().join(",")
}

/// Why a row was not taken.
enum RowError {
    /// Fatal, or skippable with `skip_invalid`.
    Invalid(ParseError),
    Fatal(ParseError),
}

fn number(fields: &[&str], idx: usize, name: &str, line: usize) -> Result<f64, RowError> {
    let text = fields.get(idx).copied().unwrap_or("");
    text.parse::<f64>().map_err(|_| {
        RowError::Fatal(ParseError::BadNumber {
            line,
            column: name.to_string(),
            text: text.to_string(),
        })
    })
}

fn parse_row(fields: &[&str], c: &Columns, line: usize) -> Result<Sample, RowError> {
    let t_s = number(fields, c.required[0], REQUIRED[0], line)?;
    if !t_s.is_finite() {
        return Err(RowError::Fatal(ParseError::BadTime { line }));
    }
    let mut v = [0f32; 9];
    for (k, slot) in v.iter_mut().enumerate() {
        let name = REQUIRED[k + 1];
        let x = number(fields, c.required[k + 1], name, line)? as f32;
        if !x.is_finite() {
            return Err(RowError::Invalid(ParseError::NonFinite {
                line,
                column: name.to_string(),
            }));
        }
        if let Some((_, limit, unit)) = LIMITS.iter().find(|(p, _, _)| name.starts_with(p)) {
            if x.abs() > *limit {
                return Err(RowError::Invalid(ParseError::OutOfRange {
                    line,
                    column: name.to_string(),
                    value: x,
                    limit: *limit,
                    unit,
                }));
            }
        }
        *slot = x;
    }
    let reference = match c.reference {
        Some(idx) => reference(fields, idx, line)?,
        None => None,
    };
    let moving = match c.moving {
        Some(idx) => {
            let x = number(fields, idx, "moving", line)?;
            if x != 0.0 && x != 1.0 {
                return Err(RowError::Fatal(ParseError::BadMoving { line }));
            }
            x == 1.0
        }
        None => true,
    };
    Ok(Sample {
        t_s,
        gyr_rps: [v[0], v[1], v[2]],
        acc_mps2: [v[3], v[4], v[5]],
        mag_ut: [v[6], v[7], v[8]],
        reference,
        moving,
    })
}

/// A reference where all four components are finite; `nan` anywhere = none.
fn reference(
    fields: &[&str],
    idx: [usize; 4],
    line: usize,
) -> Result<Option<Quaternion>, RowError> {
    let mut q = [0f32; 4];
    for ((slot, i), name) in q.iter_mut().zip(idx).zip(REF) {
        *slot = number(fields, i, name, line)? as f32;
    }
    if !q.iter().all(|x| x.is_finite()) {
        return Ok(None);
    }
    let norm = q.iter().map(|x| x * x).sum::<f32>().sqrt();
    if (norm - 1.0).abs() > REF_NORM_TOL {
        return Err(RowError::Invalid(ParseError::BadReference { line, norm }));
    }
    Ok(Quaternion::new(q[0], q[1], q[2], q[3]).normalized())
}

/// Reads a whole recording (see the module docs for the rules).
pub fn read(text: &str, opts: ReadOptions) -> Result<Recording, ParseError> {
    let lines: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l))
        .filter(|(_, l)| !l.trim().is_empty())
        .collect();
    let Some(&(_, header)) = lines.first() else {
        return Err(ParseError::Empty);
    };
    let cols = Columns::from_header(header)?;
    let last_line = lines.last().map_or(0, |l| l.0);
    let ends_cleanly = text.ends_with('\n');
    let mut rec = Recording::default();
    let mut seg = Segment {
        header_line: 1,
        samples: Vec::with_capacity(text.len() / 120),
    };
    let mut fields: Vec<&str> = Vec::with_capacity(cols.count);
    for &(line, l) in &lines[1..] {
        if normalize(l) == cols.header {
            close_segment(&mut rec, std::mem::take(&mut seg))?;
            seg.header_line = line;
            continue;
        }
        fields.clear();
        fields.extend(l.split(',').map(str::trim));
        let is_last = line == last_line;
        if fields.len() < cols.count {
            if is_last {
                rec.warnings.push(format!(
                    "line {line}: last line cut short ({} of {} fields), dropped",
                    fields.len(),
                    cols.count
                ));
                continue;
            }
            return Err(ParseError::ShortRow {
                line,
                expected: cols.count,
                found: fields.len(),
            });
        }
        let sample = match parse_row(&fields, &cols, line) {
            Ok(s) => s,
            Err(RowError::Fatal(ParseError::BadNumber { .. })) if is_last && !ends_cleanly => {
                rec.warnings
                    .push(format!("line {line}: last line cut short, dropped"));
                continue;
            }
            Err(RowError::Invalid(_)) if opts.skip_invalid => {
                rec.skipped_rows += 1;
                continue;
            }
            Err(RowError::Invalid(e) | RowError::Fatal(e)) => return Err(e),
        };
        if let Some(prev) = seg.samples.last() {
            check_step(prev.t_s, sample.t_s, line, seg.samples.len() > 1)?;
        }
        seg.samples.push(sample);
    }
    close_segment(&mut rec, seg)?;
    if rec.segments.is_empty() {
        return Err(ParseError::TooFewRows {
            header_line: 1,
            rows: rec.dropped_rows,
        });
    }
    Ok(rec)
}

fn check_step(prev_s: f64, t_s: f64, line: usize, after_good_step: bool) -> Result<(), ParseError> {
    let dt_s = t_s - prev_s;
    if dt_s <= 0.0 {
        return Err(ParseError::TimeNotIncreasing { line, prev_s, t_s });
    }
    if !(DT_MIN_S..=DT_MAX_S).contains(&dt_s) {
        return Err(ParseError::DtOutOfRange {
            line,
            dt_s,
            after_good_step,
        });
    }
    Ok(())
}

/// Keeps a segment with a time step; one shorter is dropped with a warning
/// (raw-log mode switched off right after it was switched on).
fn close_segment(rec: &mut Recording, seg: Segment) -> Result<(), ParseError> {
    if seg.samples.len() < 2 {
        rec.dropped_rows += seg.samples.len();
        rec.warnings.push(format!(
            "line {}: segment with {} row(s) dropped (at least 2 are needed)",
            seg.header_line,
            seg.samples.len()
        ));
        return Ok(());
    }
    rec.segments.push(seg);
    Ok(())
}
