//! The multirotor mode (`Config::rotor_drag_per_s`, `Config::form_drag_per_m`) on a
//! multirotor's own physics.
//!
//! A point-mass quadrotor holds its height with thrust along body z while it rolls to
//! 15° for 2 s and back: the tilt accelerates it sideways at g·tan 15° = 2.6 m/s²,
//! opposed only by drag in the rotor plane, −(μ·v + κ·v·|v|) per body axis. The
//! accelerometer reads thrust and drag, nothing of the tilt's acceleration. The plain
//! filter's two low-pass stages (τ = 3 s each) then let a step of horizontal specific
//! force through as 1 − e^(−t/τ)·(1 + t/τ): 14.5 % after 2 s, a false tilt of about 2°
//! towards level. The multirotor mode takes the rotor-plane specific force as the
//! velocity and subtracts its rate of change; what is left is its model error.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
// The mode is what these test: left out, there is nothing to run.
#![cfg(not(feature = "no-multirotor"))]

use fc_ahrs::fixed::{dt_s_to_q31, rps_to_q20, FixedConfig, MadgwickFixed};
use fc_ahrs::{Config, Madgwick, Quaternion};

const G: f64 = 9.80665;
const DT_S: f64 = 0.001;
/// The simulator's 250-class quad: 0.1 N per m/s and 0.006 N per (m/s)² on 0.60 kg.
const MU_PER_S: f64 = 0.1 / 0.60;
const KAPPA_PER_M: f64 = 0.006 / 0.60;
/// The roll step: from here (s, after the 3 s start-up and 2 s of hover)...
const STEP_S: f64 = 5.0;
/// ...held this long (s)...
const HOLD_S: f64 = 2.0;
/// ...at this roll (rad), reached and left in this long (s).
const ROLL_RAD: f64 = 15.0 * std::f64::consts::PI / 180.0;
const RAMP_S: f64 = 0.2;
/// Scored until here (s): 2 s after the release.
const END_S: f64 = STEP_S + HOLD_S + RAMP_S + 2.0;
/// Fixed-point accelerometer counts per m/s² (±8 g at 4096 counts/g).
const ACC_PER_MPS2: f64 = 4096.0 / G;

/// The airframe the trajectory flies.
#[derive(Clone, Copy)]
struct Airframe {
    mu_per_s: f64,
    kappa_per_m: f64,
    /// Velocity of the air (m/s, NED) from [`WIND_FROM_S`] on; still before.
    wind_ned: [f64; 3],
}

/// A wind starts blowing here (s): 1 s before the step, in the hover.
const WIND_FROM_S: f64 = STEP_S - 1.0;

const NOMINAL: Airframe = Airframe {
    mu_per_s: MU_PER_S,
    kappa_per_m: KAPPA_PER_M,
    wind_ned: [0.0; 3],
};

/// Roll (rad) and roll rate (rad/s) at `t`: smooth ramps (a half cosine) in and out.
fn roll(t: f64) -> (f64, f64) {
    let ramp = |s: f64| {
        let x = (s / RAMP_S).clamp(0.0, 1.0);
        let d = if (0.0..1.0).contains(&(s / RAMP_S)) {
            0.5 * std::f64::consts::PI / RAMP_S * (std::f64::consts::PI * x).sin()
        } else {
            0.0
        };
        (0.5 - 0.5 * (std::f64::consts::PI * x).cos(), d)
    };
    let (up, dup) = ramp(t - STEP_S);
    let (down, ddown) = ramp(t - STEP_S - HOLD_S);
    (ROLL_RAD * (up - down), ROLL_RAD * (dup - ddown))
}

/// One sample of the flight: the true attitude, the gyro (rad/s, body FRD) and the
/// accelerometer (m/s², body FRD).
struct Sample {
    t: f64,
    q: [f64; 4],
    gyro: [f64; 3],
    accel: [f64; 3],
}

/// Rotation matrix (body → NED) of roll `r` after a fixed heading `yaw`.
fn matrix(yaw: f64, r: f64) -> [[f64; 3]; 3] {
    let (sy, cy, sr, cr) = (yaw.sin(), yaw.cos(), r.sin(), r.cos());
    [
        [cy, -sy * cr, sy * sr],
        [sy, cy * cr, -cy * sr],
        [0.0, sr, cr],
    ]
}

/// The flight at heading `yaw` (rad) on airframe `a`, sampled at 1 kHz.
fn fly(a: Airframe, yaw: f64) -> Vec<Sample> {
    let mut v = [0.0f64; 3];
    let n = (END_S / DT_S).round() as usize;
    let mut out = Vec::with_capacity(n);
    for i in 0..=n {
        let t = i as f64 * DT_S;
        let (r, dr) = roll(t);
        let m = matrix(yaw, r);
        let w = if t >= WIND_FROM_S {
            a.wind_ned
        } else {
            [0.0; 3]
        };
        let v_air = [v[0] - w[0], v[1] - w[1], v[2] - w[2]];
        // Body velocity through the air: Rᵀ·v.
        let vb: Vec<f64> = (0..3)
            .map(|k| (0..3).map(|j| m[j][k] * v_air[j]).sum())
            .collect();
        let drag = |x: f64| -(a.mu_per_s * x + a.kappa_per_m * x * x.abs());
        let (dx, dy) = (drag(vb[0]), drag(vb[1]));
        // Thrust (per unit mass) that keeps the height: NED z acceleration 0.
        let thrust = (G + m[2][0] * dx + m[2][1] * dy) / m[2][2];
        let f_body = [dx, dy, -thrust];
        let acc: Vec<f64> = (0..3)
            .map(|j| {
                (0..3).map(|k| m[j][k] * f_body[k]).sum::<f64>() + if j == 2 { G } else { 0.0 }
            })
            .collect();
        let (h, hr) = (0.5 * yaw, 0.5 * r);
        let q = [
            h.cos() * hr.cos(),
            h.cos() * hr.sin(),
            h.sin() * hr.sin(),
            h.sin() * hr.cos(),
        ];
        out.push(Sample {
            t,
            q,
            gyro: [dr, 0.0, 0.0],
            accel: f_body,
        });
        for k in 0..3 {
            v[k] += acc[k] * DT_S;
        }
    }
    out
}

fn f32q(q: [f64; 4]) -> Quaternion {
    Quaternion::new(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32)
}

/// Tilt error (°): the angle between the true and the estimated body-down direction.
fn tilt_err_deg(est: &Quaternion, truth: &Quaternion) -> f64 {
    let d_est = est.rotate_inverse([0.0, 0.0, 1.0]);
    let d_true = truth.rotate_inverse([0.0, 0.0, 1.0]);
    let dot: f32 = d_est.iter().zip(d_true).map(|(a, b)| a * b).sum();
    f64::from(dot.clamp(-1.0, 1.0).acos()).to_degrees()
}

/// What a flight's tilt error was.
#[derive(Debug)]
struct Errors {
    /// RMS over the hold (°).
    hold_rms: f64,
    /// At the end of the hold (°).
    hold_end: f64,
    /// Largest from 1 s after the release to the end (°).
    after_1s: f64,
}

fn score(err: &[(f64, f64)]) -> Errors {
    let release = STEP_S + HOLD_S + RAMP_S;
    let hold: Vec<f64> = err
        .iter()
        .filter(|(t, _)| *t >= STEP_S && *t < release)
        .map(|p| p.1)
        .collect();
    Errors {
        hold_rms: (hold.iter().map(|e| e * e).sum::<f64>() / hold.len() as f64).sqrt(),
        hold_end: *hold.last().unwrap(),
        after_1s: err
            .iter()
            .filter(|(t, _)| *t >= release + 1.0)
            .map(|p| p.1)
            .fold(0.0, f64::max),
    }
}

/// The f32 filter with `cfg` on `flight`, told it flies from `in_flight_s`: the tilt
/// error per sample, and the estimates.
fn run_f32_from(
    cfg: Config,
    flight: &[Sample],
    in_flight_s: f64,
) -> (Vec<(f64, f64)>, Vec<Quaternion>) {
    let mut f = Madgwick::new(cfg);
    f.set_quaternion(f32q(flight[0].q));
    let mut errs = Vec::new();
    let mut qs = Vec::new();
    for s in flight {
        f.set_in_flight(s.t >= in_flight_s);
        f.update_imu(
            s.gyro.map(|x| x as f32),
            s.accel.map(|x| x as f32),
            DT_S as f32,
        );
        errs.push((s.t, tilt_err_deg(&f.quaternion(), &f32q(s.q))));
        qs.push(f.quaternion());
    }
    (errs, qs)
}

/// [`run_f32_from`] flying from the start.
fn run_f32(cfg: Config, flight: &[Sample]) -> (Vec<(f64, f64)>, Vec<Quaternion>) {
    run_f32_from(cfg, flight, 0.0)
}

/// The fixed-point filter with `cfg` on `flight` (counts at ±8 g), flying: its
/// estimates.
fn run_fixed(cfg: Config, flight: &[Sample]) -> Vec<Quaternion> {
    let c = FixedConfig::from_config(&Config {
        gravity_norm: (G * ACC_PER_MPS2) as f32,
        ..cfg
    });
    let mut f = MadgwickFixed::new(c);
    f.set_in_flight(true);
    let counts = |a: [f64; 3]| a.map(|x| (x * ACC_PER_MPS2).round() as i32);
    // Start at the true attitude: the first sample's accelerometer and a field of
    // 20 µT north, 45 µT down (0.01 µT counts) in the body frame.
    let m = f32q(flight[0].q).rotate_inverse([2000.0, 0.0, 4500.0]);
    f.init_from_accel_mag(counts(flight[0].accel), m.map(|x| x.round() as i32));
    let dt = dt_s_to_q31(DT_S as f32);
    flight
        .iter()
        .map(|s| {
            f.update_imu(s.gyro.map(|x| rps_to_q20(x as f32)), counts(s.accel), dt);
            f.quaternion_f32()
        })
        .collect()
}

fn multirotor(scale: f32) -> Config {
    Config::multirotor(MU_PER_S as f32 * scale, KAPPA_PER_M as f32 * scale)
}

#[test]
fn the_plain_filter_reads_too_little_tilt_while_a_multirotor_accelerates() {
    let (err, _) = run_f32(Config::DEFAULT, &fly(NOMINAL, 0.0));
    let e = score(&err);
    // 14.5 % of 15° at the end of the hold, less the drag's share: about 2°.
    assert!(e.hold_end > 1.5 && e.hold_end < 2.5, "{e:?}");
}

#[test]
fn the_multirotor_mode_holds_tilt_through_the_step_and_after_it() {
    for yaw_deg in [0.0f64, 30.0, -120.0] {
        let (err, _) = run_f32(multirotor(1.0), &fly(NOMINAL, yaw_deg.to_radians()));
        let e = score(&err);
        // What is left: the body-z velocity the rotor-plane drag cannot see
        // (sin² 15° = 7 % of the velocity) and the iteration's lag.
        assert!(e.hold_rms < 0.5 && e.hold_end < 0.5, "yaw {yaw_deg}: {e:?}");
        assert!(e.after_1s < 0.5, "yaw {yaw_deg}: {e:?}");
    }
}

#[test]
fn a_gust_is_read_as_acceleration_within_its_physical_bound() {
    // The drag measures the velocity through the air; the filter needs it over
    // ground. A steady wind changes neither's rate of change; a gust does: a wind
    // that rises by Δw at once is, to the drag model, a velocity step, and its rate of
    // change through the two stages is the impulse response Δw·t/τ²·e^(−t/τ), at most
    // Δw/(τ·e) at t = τ: a false tilt of Δw/(g·τ·e) rad, 0.72° per m/s at τ = 3 s.
    // (The plain filter reads the drag the gust adds as a true acceleration, which
    // it is, and errs through its stages as in the steps.)
    for wind_ned in [[3.0f64, -2.0, 0.0], [-4.0, 0.0, 0.0]] {
        let a = Airframe {
            wind_ned,
            ..NOMINAL
        };
        let (err, _) = run_f32(multirotor(1.0), &fly(a, 0.0));
        let gust = wind_ned[0].hypot(wind_ned[1]);
        let bound = (gust / (G * 3.0 * std::f64::consts::E)).to_degrees();
        let peak = err
            .iter()
            .filter(|(t, _)| *t >= WIND_FROM_S)
            .map(|p| p.1)
            .fold(0.0, f64::max);
        assert!(
            peak > 0.5 * bound && peak < 1.2 * bound,
            "wind {wind_ned:?}: {peak}° vs {bound}°"
        );
    }
}

#[test]
fn a_drag_coefficient_wrong_by_half_leaves_about_half_the_plain_filters_error() {
    let plain = score(&run_f32(Config::DEFAULT, &fly(NOMINAL, 0.0)).0);
    // The airframe's drag 50 % above and below what the filter assumes: with the
    // linear law alone the velocity it infers would be 1.5× and 0.5× the true one,
    // removing 150 % and 50 % of the acceleration's false tilt, half of the plain
    // filter's error left with opposite signs; the quadratic term bends the
    // inversion towards the truth (an x·1.5 reads as less than p·1.5), so less is
    // left: between a sixth and seven tenths of it.
    for scale in [1.5, 0.5] {
        let a = Airframe {
            mu_per_s: MU_PER_S * scale,
            kappa_per_m: KAPPA_PER_M * scale,
            ..NOMINAL
        };
        let e = score(&run_f32(multirotor(1.0), &fly(a, 0.0)).0);
        println!("drag × {scale}: {e:?}, plain {plain:?}");
        assert!(
            e.hold_rms > 0.15 * plain.hold_rms && e.hold_rms < 0.7 * plain.hold_rms,
            "drag × {scale}: {e:?}, plain {plain:?}"
        );
    }
}

#[test]
fn fixed_point_follows_the_f32_filter_in_multirotor_mode() {
    let flight = fly(NOMINAL, 30f64.to_radians());
    let (_, f32_q) = run_f32(multirotor(1.0), &flight);
    let fixed_q = run_fixed(multirotor(1.0), &flight);
    let worst = f32_q
        .iter()
        .zip(&fixed_q)
        .map(|(a, b)| f64::from(a.angle_to(b)).to_degrees())
        .fold(0.0, f64::max);
    assert!(worst < 0.01, "{worst}°");
}

/// A take-off from a slope: sitting on the ground tilted by `slope` (rad) in roll,
/// the accelerometer reads the ground's reaction, g·sin(slope) in the rotor plane;
/// from [`STEP_S`] the craft is in the air and levels within [`RAMP_S`]: thrust and
/// drag only from then on.
fn slope_take_off(slope: f64) -> Vec<Sample> {
    let n = (END_S / DT_S).round() as usize;
    (0..=n)
        .map(|i| {
            let t = i as f64 * DT_S;
            let x = ((t - STEP_S) / RAMP_S).clamp(0.0, 1.0);
            let r = slope * (0.5 + 0.5 * (std::f64::consts::PI * x).cos());
            let dr = if (0.0..1.0).contains(&((t - STEP_S) / RAMP_S)) {
                -slope * 0.5 * std::f64::consts::PI / RAMP_S * (std::f64::consts::PI * x).sin()
            } else {
                0.0
            };
            let accel = if t < STEP_S {
                // At rest: −g in the body frame (the reaction to gravity).
                [0.0, -G * r.sin(), -G * r.cos()]
            } else {
                // In the air, barely moving yet: thrust holding the height.
                [0.0, 0.0, -G / r.cos()]
            };
            let hr = 0.5 * r;
            Sample {
                t,
                q: [hr.cos(), hr.sin(), 0.0, 0.0],
                gyro: [dr, 0.0, 0.0],
                accel,
            }
        })
        .collect()
}

#[test]
fn the_drag_model_waits_for_the_flight_controllers_in_flight() {
    // 5° of slope: the ground's reaction in the rotor plane goes from g·sin 5° to
    // nothing at lift-off, which the drag model would read as a velocity change of
    // g·sin 5°/μ = 5.1 m/s: sin 5°/(μ·τ·e) rad of false tilt, 3.7°, were it on.
    let slope = 5f64.to_radians();
    let flight = slope_take_off(slope);
    let peak = |in_flight_s: f64| {
        run_f32_from(multirotor(1.0), &flight, in_flight_s)
            .0
            .iter()
            .map(|p| p.1)
            .fold(0.0, f64::max)
    };
    let on_the_ground = peak(0.0);
    let bound = (slope.sin() / (MU_PER_S * 3.0 * std::f64::consts::E)).to_degrees();
    assert!(on_the_ground > 0.5 * bound, "{on_the_ground}° vs {bound}°");
    // From when the flight controller says so (1.5 s after the take-off began).
    let gated = peak(STEP_S + 1.5);
    assert!(gated < 0.3, "{gated}°");
}

#[test]
fn samples_the_rejection_skips_leave_the_drag_model_in_step() {
    // Every other accelerometer sample 1.5 g too large: the rejection (on) skips
    // it, and the drag model restarts from the next sample instead of taking the
    // velocity change across the gap as one sample's.
    let cfg = Config {
        accel_rejection: fc_ahrs::AccelRejectionConfig {
            enabled: true,
            ..Config::DEFAULT.accel_rejection
        },
        ..multirotor(1.0)
    };
    let mut flight = fly(NOMINAL, 0.0);
    for (i, s) in flight.iter_mut().enumerate() {
        if i % 2 == 1 {
            s.accel = s.accel.map(|a| a * 1.5);
        }
    }
    let e = score(&run_f32(cfg, &flight).0);
    assert!(e.hold_rms < 0.5 && e.after_1s < 0.5, "{e:?}");
}
