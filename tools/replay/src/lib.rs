//! Replay CSV IMU recordings (BROAD format) through `fc-ahrs` and score the result.
//!
//! [`csv::read`] validates a recording (see its rules); [`run`] feeds each
//! segment to the filter chosen by [`FilterKind`]; [`score`] computes the
//! BROAD error figures. The "body" is the sensor frame itself (identity
//! alignment).

pub mod csv;

pub use csv::{read, ParseError, ReadOptions, Recording, Sample, Segment};
use fc_ahrs::fixed::{self, FixedConfig, MadgwickFixed};
use fc_ahrs::{frames, Algorithm, Config, Madgwick, MagState, Quaternion, UpdateStatus};

/// How many updates ended in each [`MagState`] (the magnetic disturbance handling).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MagCounts {
    /// Counts in the order of [`MagCounts::NAMES`].
    pub counts: [usize; MagState::COUNT],
}

impl MagCounts {
    /// Column names, one per [`MagState`].
    pub const NAMES: [&'static str; MagState::COUNT] = [
        "absent",
        "invalid",
        "undisturbed",
        "learning",
        "rejected",
        "recovered",
        "fallback",
    ];

    /// Counts one update.
    pub fn add(&mut self, st: &UpdateStatus) {
        self.counts[st.mag_state.index()] += 1;
    }

    /// The sum of two counts.
    #[must_use]
    pub fn merged(mut self, other: &MagCounts) -> MagCounts {
        for (a, b) in self.counts.iter_mut().zip(other.counts) {
            *a += b;
        }
        self
    }
}

/// Which implementation to run. Every filter the tool offers is one variant
/// here, with its name in [`FilterKind::NAMES`] and its loop in [`run`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FilterKind {
    /// `fc_ahrs::Madgwick`.
    F32,
    /// `fc_ahrs::fixed::MadgwickFixed`.
    Fixed,
    /// `fc_ahrs::Madgwick` with `Algorithm::Textbook`: Madgwick's 2010
    /// filter as published (one β, no extensions).
    Textbook,
    /// `fc_ahrs::fixed::MadgwickFixed` with `Algorithm::Textbook`.
    TextbookFixed,
    /// `vqf-rs` (VQF, Laidig & Seel 2023) with its default parameters, as the
    /// published reference: none of the `Config` options apply to it.
    Vqf,
}

impl FilterKind {
    /// Every kind, in the order of [`FilterKind::NAMES`].
    pub const ALL: [FilterKind; 5] = [
        FilterKind::F32,
        FilterKind::Fixed,
        FilterKind::Textbook,
        FilterKind::TextbookFixed,
        FilterKind::Vqf,
    ];
    /// Command-line names.
    pub const NAMES: [&'static str; 5] = ["f32", "fixed", "textbook", "textbook-fixed", "vqf"];

    /// The kind with command-line name `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::NAMES
            .iter()
            .position(|n| *n == name)
            .and_then(|i| Self::ALL.get(i).copied())
    }
}

/// Which sensors to fuse.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Gyro + accelerometer.
    Imu,
    /// Gyro + accelerometer + magnetometer.
    Marg,
}

impl FilterKind {
    /// The filter in words, for the tool's output.
    pub fn describe(self) -> &'static str {
        match self {
            Self::F32 => "Madgwick, f32",
            Self::Fixed => "Madgwick, fixed point (the firmware's)",
            Self::Textbook => "Madgwick's 2010 filter as published, f32",
            Self::TextbookFixed => "Madgwick's 2010 filter as published, fixed point",
            Self::Vqf => "VQF (vqf-rs, its defaults)",
        }
    }
}

impl Mode {
    /// The sensors used, in words.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Imu => "gyro + accelerometer",
            Self::Marg => "gyro + accelerometer + magnetometer",
        }
    }
}

/// Runs a filter over one segment; returns `q_enu_from_sensor` per row.
/// The filter starts from the first sample's accelerometer and magnetometer
/// (in both modes: IMU mode then keeps that initial heading). dt is taken
/// from consecutive `t_s` (the first row uses the second row's step); the
/// reader has checked that every step is positive and bounded.
pub fn run(samples: &[Sample], kind: FilterKind, mode: Mode, cfg: &Config) -> Vec<Quaternion> {
    run_counted(samples, kind, mode, cfg).0
}

/// [`run`], with the count of each magnetic disturbance state over the updates (all
/// zero for VQF, which does not report one).
pub fn run_counted(
    samples: &[Sample],
    kind: FilterKind,
    mode: Mode,
    cfg: &Config,
) -> (Vec<Quaternion>, MagCounts) {
    let Some(first) = samples.first() else {
        return (Vec::new(), MagCounts::default());
    };
    let dt0 = samples.get(1).map_or(0.0035, |s| s.t_s - first.t_s);
    let steps = samples.iter().scan(first.t_s - dt0, |prev, s| {
        let dt_s = (s.t_s - *prev) as f32;
        *prev = s.t_s;
        Some((s, dt_s))
    });
    let textbook = Config {
        algorithm: Algorithm::Textbook,
        ..*cfg
    };
    match kind {
        FilterKind::F32 => run_f32(first, steps, mode, cfg),
        FilterKind::Fixed => run_fixed(first, steps, mode, cfg),
        FilterKind::Textbook => run_f32(first, steps, mode, &textbook),
        FilterKind::TextbookFixed => run_fixed(first, steps, mode, &textbook),
        FilterKind::Vqf => (
            run_vqf(steps, mode, f64::from(dt0 as f32)),
            MagCounts::default(),
        ),
    }
}

/// VQF with its defaults at the recording's first step as its fixed sample time (it
/// has no per-sample dt); it starts from its own first sample, in ENU already.
fn run_vqf<'a>(
    steps: impl Iterator<Item = (&'a Sample, f32)>,
    mode: Mode,
    dt_s: f64,
) -> Vec<Quaternion> {
    let mut f = vqf_rs::VQF::new(dt_s, None, None, None);
    let d = |v: [f32; 3]| v.map(f64::from);
    steps
        .map(|(s, _)| {
            let q = match mode {
                Mode::Imu => {
                    f.update(d(s.gyr_rps), d(s.acc_mps2), None);
                    f.quat_6d()
                }
                Mode::Marg => {
                    f.update(d(s.gyr_rps), d(s.acc_mps2), Some(d(s.mag_ut)));
                    f.quat_9d()
                }
            };
            Quaternion::new(q.0 as f32, q.1 as f32, q.2 as f32, q.3 as f32)
        })
        .collect()
}

fn run_f32<'a>(
    first: &Sample,
    steps: impl Iterator<Item = (&'a Sample, f32)>,
    mode: Mode,
    cfg: &Config,
) -> (Vec<Quaternion>, MagCounts) {
    let mut f = Madgwick::from_accel_mag(*cfg, first.acc_mps2, first.mag_ut);
    let mut n = MagCounts::default();
    let est = steps
        .map(|(s, dt)| {
            let st = match mode {
                Mode::Imu => f.update_imu(s.gyr_rps, s.acc_mps2, dt),
                Mode::Marg => f.update_marg(s.gyr_rps, s.acc_mps2, s.mag_ut, dt),
            };
            n.add(&st);
            frames::enu_from_ned(f.quaternion())
        })
        .collect();
    (est, n)
}

fn run_fixed<'a>(
    first: &Sample,
    steps: impl Iterator<Item = (&'a Sample, f32)>,
    mode: Mode,
    cfg: &Config,
) -> (Vec<Quaternion>, MagCounts) {
    // Accelerometer and magnetometer fed as Q16 (m/s², µT): gravity_norm follows.
    let fcfg = FixedConfig::from_config(&Config {
        gravity_norm: cfg.gravity_norm * 65536.0,
        ..*cfg
    });
    let q16 = |v: [f32; 3]| v.map(|x| fixed::float_to_q(x, 16));
    let mut f = MadgwickFixed::from_accel_mag(fcfg, q16(first.acc_mps2), q16(first.mag_ut));
    let mut n = MagCounts::default();
    let est = steps
        .map(|(s, dt)| {
            let dt = fixed::dt_s_to_q31(dt);
            let g = s.gyr_rps.map(fixed::rps_to_q20);
            let st = match mode {
                Mode::Imu => f.update_imu(g, q16(s.acc_mps2), dt),
                Mode::Marg => f.update_marg(g, q16(s.acc_mps2), q16(s.mag_ut), dt),
            };
            n.add(&st);
            frames::enu_from_ned(f.quaternion_f32())
        })
        .collect();
    (est, n)
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

/// The BROAD errors of one estimate against its reference (rad): total,
/// heading, inclination. e = q_est ⊗ conj(q_ref); total = 2·acos|e_w|,
/// heading = 2·atan2(|e_z|, |e_w|), inclination = 2·acos√(e_w²+e_z²).
/// atan2 rather than atan(e_z/e_w): at a 180° error e_w = 0.
pub fn errors(est: &Quaternion, reference: &Quaternion) -> (f64, f64, f64) {
    let e = est.mul(&reference.conj());
    let (w, z) = (f64::from(e.w).abs(), f64::from(e.z).abs());
    let total = 2.0 * w.min(1.0).acos();
    let heading = 2.0 * z.atan2(w);
    let incl = 2.0 * (w * w + z * z).sqrt().min(1.0).acos();
    (total, heading, incl)
}

/// `q` or `-q` (the same rotation), whichever lies in the reference's
/// hemisphere: flipped when its dot product with `reference` is negative,
/// so an estimate and its reference can be compared column by column.
/// Without a reference, the one with `w >= 0`.
pub fn same_hemisphere(q: &Quaternion, reference: Option<&Quaternion>) -> Quaternion {
    let dot = match reference {
        Some(r) => q.w * r.w + q.x * r.x + q.y * r.y + q.z * r.z,
        None => q.w,
    };
    if dot < 0.0 {
        Quaternion::new(-q.w, -q.x, -q.y, -q.z)
    } else {
        *q
    }
}

/// Scores estimates against the reference over rows with `moving` and a
/// valid reference (see [`errors`]). `None` if no row qualifies.
pub fn score(samples: &[Sample], est: &[Quaternion]) -> Option<Score> {
    let (mut st, mut sh, mut si, mut n) = (0f64, 0f64, 0f64, 0usize);
    for (s, q) in samples.iter().zip(est) {
        let Some(r) = s.reference.filter(|_| s.moving) else {
            continue;
        };
        let (total, heading, incl) = errors(q, &r);
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

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn a_180_degree_error_is_180_not_nan() {
        let id = Quaternion::new(1.0, 0.0, 0.0, 0.0);
        let yaw180 = Quaternion::new(0.0, 0.0, 0.0, 1.0);
        let (t, h, i) = errors(&yaw180, &id);
        assert!((t.to_degrees() - 180.0).abs() < 1e-3, "{t}");
        assert!((h.to_degrees() - 180.0).abs() < 1e-3, "{h}");
        assert!(i.to_degrees().abs() < 1e-3, "{i}");
        let roll180 = Quaternion::new(0.0, 1.0, 0.0, 0.0);
        let (t, h, i) = errors(&roll180, &id);
        assert!((t.to_degrees() - 180.0).abs() < 1e-3 && (i.to_degrees() - 180.0).abs() < 1e-3);
        assert!(h.is_finite(), "{h}");
    }

    /// Flipped into the reference's hemisphere; the rotation is unchanged.
    #[test]
    fn estimates_are_put_in_the_reference_hemisphere() {
        let q = Quaternion::new(0.6, 0.0, 0.0, -0.8);
        let r = Quaternion::new(-0.5, 0.1, 0.0, 0.86);
        let f = same_hemisphere(&q, Some(&r));
        assert_eq!((f.w, f.x, f.y, f.z), (-0.6, -0.0, -0.0, 0.8));
        assert!(f.w * r.w + f.z * r.z > 0.0);
        assert!(errors(&f, &q).0 < 1e-3, "the same rotation");
        let near = same_hemisphere(&q, Some(&q));
        assert_eq!(near.w, 0.6);
        assert_eq!(
            same_hemisphere(&Quaternion::new(-1.0, 0.0, 0.0, 0.0), None).w,
            1.0
        );
    }

    #[test]
    fn filter_names_round_trip() {
        for (k, n) in FilterKind::ALL.iter().zip(FilterKind::NAMES) {
            assert_eq!(FilterKind::from_name(n), Some(*k));
        }
        assert_eq!(FilterKind::from_name("kalman"), None);
    }
}
