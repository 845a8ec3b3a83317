//! Drives a simulated flight through the [`Stack`](super::stack::Stack) and
//! scores it against the truth.

use super::stack::{self, AccelCalRun, BootConfig, MagCalRun, Stack};
use host_console::{note, say};
use sim::faults::{FaultSchedule, FaultSpec};
use sim::{Environment, Quat, SensorErrors, SimBus, SimClock, SimConfig, Trajectory};
use std::io::Write;

/// What to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// The flight.
    pub trajectory: Trajectory,
    /// Seed of all noise (sensor noise, random walks, vibration phases).
    pub seed: u64,
    /// Seed of the board's fixed errors (biases, scale, misalignment, iron).
    pub board_seed: u64,
    /// Simulated flight time (s).
    pub duration_s: f64,
    /// Print a status line every this many simulated seconds (0 = never).
    pub print_every_s: f64,
    /// Length of the magnetometer calibration dance (s).
    pub mag_dance_s: f64,
    /// Faults injected during the flight.
    pub faults: Vec<FaultSpec>,
    /// Show a progress line on stderr during long runs.
    pub progress: bool,
    /// The gyro's sensitivity error on every axis (fraction), instead of the
    /// one drawn with the board (`None`: the board's).
    pub gyro_scale: Option<f64>,
}

impl RunOptions {
    /// The board's errors: drawn from `board_seed`, with the gyro's sensitivity
    /// error replaced by `gyro_scale` where given (cross-axis terms kept).
    pub fn errors(&self) -> SensorErrors {
        let mut e = SensorErrors::datasheet(self.board_seed);
        if let Some(s) = self.gyro_scale {
            for (i, row) in e.gyro_dps.misalignment.iter_mut().enumerate() {
                row[i] = 1.0 + s;
            }
        }
        e
    }
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
    /// MPU data-ready interrupts whose read failed (bus faults): no sample.
    pub missed: usize,
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

/// Everything a run produced (the records went to the sinks).
pub struct RunResult {
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
    // atan2, not atan(z/w): a 180° error has w = 0 and must score 180°, not NaN.
    let heading = 2.0 * e.z.abs().atan2(w);
    let incl = 2.0 * (e.w * e.w + e.z * e.z).sqrt().min(1.0).acos();
    (total, heading, incl)
}

/// Where each record goes as it is produced (the run keeps none of them).
pub trait RecordSink {
    /// Takes one record.
    fn push(&mut self, record: &Record) -> Result<(), String>;
}

/// Runs the demo: the ground calibrations, then the flight, handing every
/// record to `sinks` as it is produced and scoring it on the way, so the
/// memory used does not grow with the duration.
pub fn run(opts: &RunOptions, sinks: &mut [&mut dyn RecordSink]) -> Result<RunResult, String> {
    let wall = std::time::Instant::now();
    let base = SimConfig {
        trajectory: opts.trajectory.clone(),
        env: Environment::default(),
        errors: opts.errors(),
        seed: opts.seed,
        ..SimConfig::default()
    };
    say!(
        "sim: trajectory {}, seed {} (board {}), {} s; firmware pipeline (flight) with the {}",
        opts.trajectory.name(),
        opts.seed,
        opts.board_seed,
        opts.duration_s,
        sensor_stack::pipeline::AHRS_KIND
    );
    if let Some(scale) = opts.gyro_scale {
        say!(
            "sim: gyro sensitivity error {:+.1} % on every axis (--gyro-scale)",
            100.0 * scale
        );
    }
    let (accel_cal, mag_cal) = ground_calibrations(&base, opts.mag_dance_s)?;
    let record = stack::calibration_record(&accel_cal.calibration, &mag_cal.calibration)?;
    let flight = fly(opts, &base, &record, sinks, wall)?;
    let mut summary = flight.scorer.summary();
    summary.wall_s = wall.elapsed().as_secs_f64();
    summary.missed = flight.missed;
    Ok(RunResult {
        accel_cal,
        mag_cal,
        gyro_bias: flight.gyro_bias,
        summary,
    })
}

/// The calibrations a user runs once and stores in flash (separate sessions
/// of the same board): accelerometer six-position, then the magnetometer dance.
fn ground_calibrations(
    base: &SimConfig,
    mag_dance_s: f64,
) -> Result<(AccelCalRun, MagCalRun), String> {
    let accel_cal = stack::calibrate_accel_six_position(base)?;
    print_accel_cal(&accel_cal, &base.errors);
    let mag_cal = stack::calibrate_mag_on_dance(base, mag_dance_s)?;
    print_mag_cal(&mag_cal, &base.errors);
    Ok((accel_cal, mag_cal))
}

struct Flight {
    scorer: Scorer,
    gyro_bias: Option<GyroBiasRun>,
    missed: usize,
}

/// The flight as the firmware runs it: boot probe, stored calibration,
/// start-up gyro bias while still, the 1 kHz pipeline; faults injected on
/// schedule.
fn fly(
    opts: &RunOptions,
    base: &SimConfig,
    record: &sensor_stack::storage::CalibrationRecord,
    sinks: &mut [&mut dyn RecordSink],
    wall: std::time::Instant,
) -> Result<Flight, String> {
    let clock = SimClock::new();
    let bus = SimBus::new(&clock, base.clone());
    let mut delay = clock.delay();
    let mut stack = Stack::boot(
        &bus,
        &mut delay,
        record,
        &BootConfig::with_ahrs(fc_ahrs::Config::DEFAULT),
    )?;
    print_boot(&stack);
    let mut faults = FaultSchedule::new(&opts.faults);
    let mut progress = Progress::new(opts.duration_s, opts.progress, wall);
    let mut out = Flight {
        scorer: Scorer::default(),
        gyro_bias: None,
        missed: 0,
    };
    let mut next_print = 0.0;
    while clock.now_s() < opts.duration_s {
        faults.apply_due(clock.now_s(), &bus, |f| {
            say!("t {:.2} s: fault {f}", clock.now_s());
        })?;
        bus.advance_to_next_mpu_sample();
        progress.tick(clock.now_s());
        if !bus.data_ready() {
            continue;
        }
        let Some(r) = sample(&bus, &clock, &mut stack, &mut out.gyro_bias) else {
            out.missed += 1;
            continue;
        };
        if opts.print_every_s > 0.0 && r.t_s >= next_print {
            next_print += opts.print_every_s;
            print_status(&r);
        }
        out.scorer.push(&r);
        for sink in sinks.iter_mut() {
            sink.push(&r)?;
        }
    }
    progress.finish();
    Ok(out)
}

/// One MPU data-ready through the stack, with its truth; `None` when the
/// read failed.
fn sample(
    bus: &SimBus,
    clock: &SimClock,
    stack: &mut Stack,
    gyro_bias: &mut Option<GyroBiasRun>,
) -> Option<Record> {
    let est = stack.on_data_ready(clock.now_us())?;
    let truth = bus.truth_at_last_mpu_sample()?;
    if let (None, Some(measured_rps)) = (*gyro_bias, stack.gyro_bias_rps()) {
        let g = GyroBiasRun {
            measured_rps,
            truth_rps: bus.state().world.gyro_bias_dps().map(f64::to_radians),
            at_s: truth.t_s,
        };
        print_gyro_bias(&g);
        *gyro_bias = Some(g);
    }
    Some(Record {
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
    })
}

/// A progress line on stderr for runs that take a while: nothing for the
/// first two seconds of wall time, then one line a second (rewritten in
/// place on a terminal).
struct Progress {
    duration_s: f64,
    enabled: bool,
    wall: std::time::Instant,
    next_wall_s: f64,
    tty: bool,
    shown: bool,
}

impl Progress {
    fn new(duration_s: f64, enabled: bool, wall: std::time::Instant) -> Self {
        use std::io::IsTerminal;
        Self {
            duration_s,
            enabled,
            wall,
            next_wall_s: 2.0,
            tty: std::io::stderr().is_terminal(),
            shown: false,
        }
    }

    fn tick(&mut self, t_s: f64) {
        if !self.enabled {
            return;
        }
        let w = self.wall.elapsed().as_secs_f64();
        if w < self.next_wall_s {
            return;
        }
        self.next_wall_s = w + 1.0;
        let pct = 100.0 * t_s / self.duration_s;
        let text = format!(
            "sim: {t_s:.0} of {} s simulated ({pct:.0} %), {w:.0} s",
            self.duration_s
        );
        if self.tty {
            let _ = write!(std::io::stderr(), "\r{text}");
        } else {
            note!("{text}");
        }
        self.shown = true;
    }

    fn finish(&self) {
        if self.shown && self.tty {
            note!("");
        }
    }
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
        .map(|(p, t)| {
            let face = sensor_stack::Mounting::default().face(*p);
            format!("{face} at {t:.0} s")
        })
        .collect();
    say!(
        "accel six-position (faces: {}; {} window restarts while moving): residual |a|−1g RMS {:.2} mg",
        order.join(", "),
        run.refused_windows,
        run.rms_residual_g * 1000.0
    );
    say!(
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

fn print_mag_cal(mag_cal: &MagCalRun, errors: &SensorErrors) {
    let c = &mag_cal.calibration;
    say!(
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
    let hi = errors.mag.hard_iron_ut;
    say!(
        "  injected hard iron (MPU frame) [{:.1}, {:.1}, {:.1}] µT",
        hi[1],
        hi[0],
        -hi[2]
    );
}

fn print_boot(stack: &Stack) {
    let b = stack.boot_report();
    let caps = b.capabilities();
    let ok = |present: bool| if present { "ok" } else { "MISSING" };
    say!(
        "boot: MPU-9250 {}, AK8963 {}, MS5611 {} -> AHRS {}, altitude {}",
        ok(b.mpu.present()),
        ok(b.mag.present()),
        ok(b.baro.present()),
        caps.ahrs,
        caps.altitude
    );
}

fn print_gyro_bias(g: &GyroBiasRun) {
    say!(
        "gyro bias at start-up (t {:.2} s): [{:.4}, {:.4}, {:.4}] rad/s (truth [{:.4}, {:.4}, {:.4}])",
        g.at_s,
        g.measured_rps[0],
        g.measured_rps[1],
        g.measured_rps[2],
        g.truth_rps[0],
        g.truth_rps[1],
        g.truth_rps[2]
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
    say!(
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

/// Scores records as they come, after a 1 s settling time.
#[derive(Clone, Copy, Debug, Default)]
pub struct Scorer {
    attitude_sq: f64,
    heading_sq: f64,
    inclination_sq: f64,
    attitude_max_deg: f64,
    height_sq: f64,
    heights: usize,
    vspeed_sq: f64,
    vspeeds: usize,
    samples: usize,
}

impl Scorer {
    /// Adds one record.
    pub fn push(&mut self, r: &Record) {
        if r.t_s < 1.0 {
            return;
        }
        let (t, h, i) = attitude_errors(&r.est, &r.truth);
        self.attitude_sq += t * t;
        self.heading_sq += h * h;
        self.inclination_sq += i * i;
        self.attitude_max_deg = self.attitude_max_deg.max(t.to_degrees());
        self.samples += 1;
        if let Some(eh) = r.est_height_m {
            self.height_sq += (eh - r.true_height_m).powi(2);
            self.heights += 1;
        }
        if let Some(ev) = r.est_vspeed_mps {
            self.vspeed_sq += (ev - r.true_vspeed_mps).powi(2);
            self.vspeeds += 1;
        }
    }

    /// The scores so far (`wall_s` left at 0).
    pub fn summary(&self) -> Summary {
        let rms = |sq: f64, n: usize| (sq / n.max(1) as f64).sqrt();
        Summary {
            attitude_rms_deg: rms(self.attitude_sq, self.samples).to_degrees(),
            heading_rms_deg: rms(self.heading_sq, self.samples).to_degrees(),
            inclination_rms_deg: rms(self.inclination_sq, self.samples).to_degrees(),
            attitude_max_deg: self.attitude_max_deg,
            height_rms_m: rms(self.height_sq, self.heights),
            vspeed_rms_mps: rms(self.vspeed_sq, self.vspeeds),
            samples: self.samples,
            missed: 0,
            wall_s: 0.0,
        }
    }
}
