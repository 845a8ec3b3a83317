//! Drives a simulated flight through the [`Stack`](super::stack::Stack) and
//! scores it against the truth.

use super::stack::{self, AccelCalRun, MagCalRun, Stack};
use sim::{Environment, Quat, SensorErrors, SimBus, SimClock, SimConfig, Trajectory};

/// What to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// The flight.
    pub trajectory: Trajectory,
    /// Seed of the board's errors and of all noise.
    pub seed: u64,
    /// Simulated flight time (s).
    pub duration_s: f64,
    /// Print a status line every this many simulated seconds (0 = never).
    pub print_every_s: f64,
    /// Length of the magnetometer calibration dance (s).
    pub mag_dance_s: f64,
}

/// One row of the run (one MPU sample).
#[derive(Clone, Copy, Debug)]
pub struct Record {
    /// Simulated time of the sample (s).
    pub t_s: f64,
    /// Estimated `q_ned_from_body`.
    pub est: Quat,
    /// True `q_ned_from_body`.
    pub truth: Quat,
    /// Estimated height (m).
    pub est_height_m: Option<f64>,
    /// True height (m).
    pub true_height_m: f64,
    /// Estimated vertical speed, up (m/s).
    pub est_vspeed_mps: Option<f64>,
    /// True vertical speed, up (m/s).
    pub true_vspeed_mps: f64,
    /// Bias-corrected gyro, MPU frame (rad/s).
    pub gyro_mpu_rps: [f32; 3],
    /// Accelerometer, MPU frame (m/s²).
    pub accel_mpu_mps2: [f32; 3],
    /// Calibrated magnetometer, MPU frame (µT).
    pub mag_mpu_ut: Option<[f32; 3]>,
    /// The body moves.
    pub moving: bool,
}

/// Summary errors.
#[derive(Clone, Copy, Debug, Default)]
pub struct Summary {
    /// RMS total attitude error (°).
    pub attitude_rms_deg: f64,
    /// RMS heading error (°).
    pub heading_rms_deg: f64,
    /// RMS inclination (tilt) error (°).
    pub inclination_rms_deg: f64,
    /// Largest attitude error (°).
    pub attitude_max_deg: f64,
    /// RMS height error (m).
    pub height_rms_m: f64,
    /// RMS vertical speed error (m/s).
    pub vspeed_rms_mps: f64,
    /// Samples scored.
    pub samples: usize,
    /// Wall-clock time of the run (s).
    pub wall_s: f64,
}

/// The start-up gyro bias the flight measured, against the truth.
#[derive(Clone, Copy, Debug)]
pub struct GyroBiasRun {
    /// Measured (rad/s, MPU frame), as the pipeline uses it (whole counts).
    pub measured_rps: [f32; 3],
    /// The simulated board's bias when it was measured (rad/s, MPU frame).
    pub truth_rps: [f64; 3],
    /// Simulated time it became available (s).
    pub at_s: f64,
}

/// Everything a run produced.
pub struct RunResult {
    /// Per-sample records.
    pub records: Vec<Record>,
    /// The accelerometer six-position calibration.
    pub accel_cal: AccelCalRun,
    /// The magnetometer calibration.
    pub mag_cal: MagCalRun,
    /// The start-up gyro bias, if the board held still long enough.
    pub gyro_bias: Option<GyroBiasRun>,
    /// Scores.
    pub summary: Summary,
}

fn q_from(a: [f32; 4]) -> Quat {
    Quat::new(
        f64::from(a[0]),
        f64::from(a[1]),
        f64::from(a[2]),
        f64::from(a[3]),
    )
}

/// Errors of `est` against `truth` as BROAD scores them: (total, heading, inclination), rad.
pub fn attitude_errors(est: &Quat, truth: &Quat) -> (f64, f64, f64) {
    // e = q_est ⊗ conj(q_ref), earth frame (NED: the heading axis is z).
    let e = est.mul(&truth.conj());
    let w = e.w.abs();
    let total = 2.0 * w.min(1.0).acos();
    let heading = 2.0 * (e.z / e.w).abs().atan();
    let incl = 2.0 * (e.w * e.w + e.z * e.z).sqrt().min(1.0).acos();
    (total, heading, incl)
}

/// Runs the demo.
pub fn run(opts: &RunOptions) -> Result<RunResult, String> {
    let wall = std::time::Instant::now();
    let base = SimConfig {
        trajectory: opts.trajectory.clone(),
        env: Environment::default(),
        errors: SensorErrors::datasheet(opts.seed),
        seed: opts.seed,
        ..SimConfig::default()
    };
    println!(
        "sim: trajectory {}, seed {}, {:.0} s; firmware pipeline (flight) with the {}",
        opts.trajectory.name(),
        opts.seed,
        opts.duration_s,
        flight::pipeline::AHRS_KIND
    );
    // 1. Ground calibrations (separate sessions, same board), as stored in
    //    flash on the real board: accelerometer six-position, then the
    //    magnetometer dance.
    let accel_cal = stack::calibrate_accel_six_position(&base)?;
    print_accel_cal(&accel_cal, &base.errors);

    let mag_cal = stack::calibrate_mag_on_dance(&base, opts.mag_dance_s)?;
    let c = &mag_cal.calibration;
    println!(
        "mag calibration ({}, {} samples{}): offset [{:.1}, {:.1}, {:.1}] µT",
        mag_cal.method,
        mag_cal.raw_mpu_ut.len(),
        mag_cal
            .rms_error
            .map(|r| format!(", rms residual {:.2} %", r * 100.0))
            .unwrap_or_default(),
        c.offset[0],
        c.offset[1],
        c.offset[2]
    );
    let hi = base.errors.mag.hard_iron_ut;
    println!(
        "  injected hard iron (MPU frame) [{:.1}, {:.1}, {:.1}] µT",
        hi[1], hi[0], -hi[2]
    );

    // 2. The flight, as the firmware runs it: boot probe, stored
    //    calibration, start-up gyro bias while still, the 1 kHz pipeline.
    let record = stack::calibration_record(&accel_cal.calibration, &mag_cal.calibration)?;
    let clock = SimClock::new();
    let bus = SimBus::new(&clock, base.clone());
    let mut delay = clock.delay();
    let mut stack = Stack::boot(&bus, &mut delay, &record)?;
    let b = stack.boot_report();
    let caps = b.capabilities();
    println!(
        "boot: MPU-9250 {}, AK8963 {}, MS5611 {} -> AHRS {:?}, altitude {}",
        if b.mpu.present() { "ok" } else { "MISSING" },
        if b.mag.present() { "ok" } else { "MISSING" },
        if b.baro.present() { "ok" } else { "MISSING" },
        caps.ahrs,
        caps.altitude
    );
    let mut gyro_bias = None;
    let mut records = Vec::with_capacity((opts.duration_s * 1000.0) as usize + 16);
    let mut next_print = 0.0;
    while clock.now_s() < opts.duration_s {
        bus.advance_to_next_mpu_sample();
        if !bus.data_ready() {
            continue;
        }
        let Some(est) = stack.on_data_ready(clock.now_us()) else {
            continue;
        };
        let Some(truth) = bus.truth_at_last_mpu_sample() else {
            continue;
        };
        if let (None, Some(measured_rps)) = (gyro_bias, stack.gyro_bias_rps()) {
            let g = GyroBiasRun {
                measured_rps,
                truth_rps: bus.state().world.gyro_bias_dps().map(f64::to_radians),
                at_s: truth.t_s,
            };
            println!(
                "gyro bias at start-up (t {:.2} s): [{:.4}, {:.4}, {:.4}] rad/s (truth [{:.4}, {:.4}, {:.4}])",
                g.at_s,
                g.measured_rps[0],
                g.measured_rps[1],
                g.measured_rps[2],
                g.truth_rps[0],
                g.truth_rps[1],
                g.truth_rps[2]
            );
            gyro_bias = Some(g);
        }
        let r = Record {
            t_s: truth.t_s,
            est: q_from(est.q_ned_from_body),
            truth: truth.q_ned_from_body,
            est_height_m: est.height_m.map(f64::from),
            true_height_m: truth.height_m,
            est_vspeed_mps: est.vertical_speed_mps.map(f64::from),
            true_vspeed_mps: -truth.velocity_ned_mps[2],
            gyro_mpu_rps: est.gyro_mpu_rps,
            accel_mpu_mps2: est.accel_mpu_mps2,
            mag_mpu_ut: est.mag_mpu_ut,
            moving: truth.moving,
        };
        if opts.print_every_s > 0.0 && r.t_s >= next_print {
            next_print += opts.print_every_s;
            print_status(&r);
        }
        records.push(r);
    }
    let summary = summarize(&records, wall.elapsed().as_secs_f64());
    Ok(RunResult {
        records,
        accel_cal,
        mag_cal,
        gyro_bias,
        summary,
    })
}

/// The accelerometer errors the six-position calibration should find, in
/// its terms (g, MPU frame): offset = injected bias, scale = 1 / the
/// diagonal of the injected scale/misalignment matrix (the cross-axis terms
/// are outside its model).
pub fn accel_truth(errors: &SensorErrors) -> ([f64; 3], [f64; 3]) {
    let e = &errors.accel_mps2;
    let g = sim::physics::G0_MPS2;
    (
        e.bias.map(|b| b / g),
        [0, 1, 2].map(|i| 1.0 / e.misalignment[i][i]),
    )
}

fn print_accel_cal(run: &AccelCalRun, errors: &SensorErrors) {
    let c = &run.calibration;
    let (offset, scale) = accel_truth(errors);
    let order: Vec<String> = run
        .captured
        .iter()
        .map(|(p, t)| format!("{p:?}@{t:.0}s"))
        .collect();
    println!(
        "accel six-position ({}; {} window restarts while moving): residual |a|−1g RMS {:.2} mg",
        order.join(" "),
        run.refused_windows,
        run.rms_residual_g * 1000.0
    );
    println!(
        "  offset [{:+.1}, {:+.1}, {:+.1}] mg (truth [{:+.1}, {:+.1}, {:+.1}]), scale [{:.4}, {:.4}, {:.4}] (truth [{:.4}, {:.4}, {:.4}])",
        c.offset[0] * 1000.0,
        c.offset[1] * 1000.0,
        c.offset[2] * 1000.0,
        offset[0] * 1000.0,
        offset[1] * 1000.0,
        offset[2] * 1000.0,
        c.scale[0],
        c.scale[1],
        c.scale[2],
        scale[0],
        scale[1],
        scale[2]
    );
}

fn deg3(q: &Quat) -> [f64; 3] {
    q.to_euler().map(f64::to_degrees)
}

fn print_status(r: &Record) {
    let e = deg3(&r.est);
    let t = deg3(&r.truth);
    let (err, _, _) = attitude_errors(&r.est, &r.truth);
    let h = r
        .est_height_m
        .map_or("   -  ".to_string(), |h| format!("{h:6.2}"));
    println!(
        "t {:6.1} s | roll/pitch/yaw est {:7.1} {:6.1} {:7.1} true {:7.1} {:6.1} {:7.1} | err {:5.2}° | height est {} m true {:6.2} m",
        r.t_s,
        e[0],
        e[1],
        e[2],
        t[0],
        t[1],
        t[2],
        err.to_degrees(),
        h,
        r.true_height_m
    );
}

/// Scores the records after a 1 s settling time.
pub fn summarize(records: &[Record], wall_s: f64) -> Summary {
    let mut s = Summary {
        wall_s,
        ..Summary::default()
    };
    let (mut a2, mut h2, mut i2, mut z2, mut nz) = (0.0, 0.0, 0.0, 0.0, 0usize);
    let (mut v2, mut nv) = (0.0, 0usize);
    for r in records.iter().filter(|r| r.t_s >= 1.0) {
        let (t, h, i) = attitude_errors(&r.est, &r.truth);
        a2 += t * t;
        h2 += h * h;
        i2 += i * i;
        s.attitude_max_deg = s.attitude_max_deg.max(t.to_degrees());
        s.samples += 1;
        if let Some(eh) = r.est_height_m {
            z2 += (eh - r.true_height_m).powi(2);
            nz += 1;
        }
        if let Some(ev) = r.est_vspeed_mps {
            v2 += (ev - r.true_vspeed_mps).powi(2);
            nv += 1;
        }
    }
    let n = s.samples.max(1) as f64;
    s.attitude_rms_deg = (a2 / n).sqrt().to_degrees();
    s.heading_rms_deg = (h2 / n).sqrt().to_degrees();
    s.inclination_rms_deg = (i2 / n).sqrt().to_degrees();
    s.height_rms_m = (z2 / nz.max(1) as f64).sqrt();
    s.vspeed_rms_mps = (v2 / nv.max(1) as f64).sqrt();
    s
}
