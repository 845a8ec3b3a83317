//! Rigid-body truth: trajectories, the Earth's magnetic field and the ISA
//! atmosphere.
//!
//! Frames: body FRD (x forward, y right, z down), earth NED. A trajectory
//! gives the pose (position in NED, `q_ned_from_body`) as a smooth function of
//! time; angular rate and specific force are obtained by differentiating it
//! numerically (central differences in f64, errors < 1e-6 of the signal).

use crate::math::{self, Quat, Vec3};
use std::f64::consts::PI;
use std::fmt;
use std::rc::Rc;

/// Standard gravity (m/s²), used by the simulator as the local gravity.
pub const G0_MPS2: f64 = 9.80665;

/// Everything true about the body at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthSample {
    /// Simulated time (s).
    pub t_s: f64,
    /// Orientation: rotates body (FRD) vectors into NED.
    pub q_ned_from_body: Quat,
    /// Angular rate of the body relative to NED, in the body frame (rad/s).
    pub omega_body_rps: Vec3,
    /// Specific force (what an accelerometer measures: a − g) in the body frame (m/s²).
    pub specific_force_body_mps2: Vec3,
    /// Position relative to the start point, NED (m).
    pub position_ned_m: Vec3,
    /// Velocity, NED (m/s).
    pub velocity_ned_mps: Vec3,
    /// Height above the start point (m, up).
    pub height_m: f64,
    /// True while the body rotates or accelerates noticeably.
    pub moving: bool,
}

/// A pose at one instant: (position NED in m, `q_ned_from_body`).
pub type Pose = (Vec3, Quat);

/// Built-in trajectories. Every built-in starts with a rest phase of
/// [`Trajectory::REST_S`] seconds (level, facing north) so that a gyro bias
/// calibration can run first, then blends smoothly into its motion.
#[derive(Clone)]
pub enum Trajectory {
    /// Motionless at the given orientation for ever.
    AtRest {
        /// Orientation of the body.
        q_ned_from_body: Quat,
    },
    /// Constant angular rate about a body axis, from the start (no rest phase).
    ConstantRate {
        /// Body rate (rad/s).
        omega_body_rps: Vec3,
    },
    /// Gentle rotations (≤ ~40°/s) in all three axes, no translation.
    SlowRotations,
    /// The figure-eight calibration dance: full yaw turns, pitch ±75°, roll
    /// ±180°, small translations — covers all field directions for a
    /// magnetometer calibration.
    FigureEight,
    /// Hover with climbs and descents (0 → 10 → 25 → 5 m, repeating) and
    /// small attitude wobbles.
    Hover,
    /// Aggressive manoeuvres: flips (up to ~700°/s), fast yaw, accelerations
    /// of about 1 g on top of gravity.
    Aggressive,
    /// The accelerometer six-position calibration as done by hand: the
    /// board held still on each face in turn ([`Trajectory::SIX_POSITION_POSES`],
    /// [`Trajectory::SIX_POSITION_HOLD_S`] each, the first one starting with
    /// the usual rest phase), turned between faces in
    /// [`Trajectory::SIX_POSITION_MOVE_S`], then back to level for ever.
    SixPosition,
    /// Sustained centripetal acceleration at high rotation rates: the board on a
    /// 0.15 m arm whirled about the vertical at up to 360 °/s (|a| − g of about
    /// 6 m/s² for 3 s at a time), alternating direction, with 2 s pauses and a
    /// slow tilt wobble.
    Whirl,
    /// Slow rotations with broadband translational vibration: seven tones of
    /// 50–300 Hz, 1 m/s² each (about 2.6 m/s² RMS, a motor-driven frame).
    Vibration,
    /// Hand-held: the board turned from one attitude to the next of
    /// [`Trajectory::HAND_HELD_POSES`] (roll/pitch up to ±60°, headings all
    /// round) in [`Trajectory::HAND_HELD_MOVE_S`] (peak ~70 °/s), held there for
    /// [`Trajectory::HAND_HELD_HOLD_S`] with a 1.5° hand tremor at 0.4 Hz.
    HandHeld,
    /// Fast turns with rest breaks: level, 2.5 turns (900°) about the vertical
    /// at [`Trajectory::FAST_TURN_RATES_DPS`] (300–500 °/s, 0.25 s smooth
    /// ramps), then still until the next [`Trajectory::FAST_TURN_CYCLE_S`]
    /// cycle; three turns one way, then three the other.
    FastTurns,
    /// [`Trajectory::HandHeld`]'s attitudes and holds with slower moves
    /// ([`Trajectory::HAND_HELD_SLOW_MOVE_S`], peak ~30 °/s).
    HandHeldSlow,
    /// Fast rotations about varied axes with short rests: from each attitude
    /// of [`Trajectory::FAST_AXES_POSES`], two whole turns about the earth-fixed
    /// axis of [`Trajectory::FAST_AXES_AXES`] at [`Trajectory::FAST_TURN_RATES_DPS`]
    /// (300–500 °/s, 0.25 s smooth ramps), back where it started; then moved by
    /// hand to the next attitude in [`Trajectory::FAST_AXES_MOVE_S`] and held
    /// still for [`Trajectory::FAST_AXES_REST_S`].
    FastAxes,
    /// A user-supplied pose function of time (s).
    Custom(Rc<dyn Fn(f64) -> Pose>),
    /// A user-supplied truth function of time (s): the pose with its
    /// derivatives given, not differentiated numerically (for motion with
    /// content too fast for the differences, such as a frame's vibration).
    Motion(Rc<dyn Fn(f64) -> TruthSample>),
}

impl fmt::Debug for Trajectory {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

fn smoothstep(t: f64, t0: f64, t1: f64) -> f64 {
    let x = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
    x * x * x * (x * (6.0 * x - 15.0) + 10.0)
}

fn sin_hz(t: f64, hz: f64, phase: f64) -> f64 {
    (2.0 * PI * hz * t + phase).sin()
}

/// Hand-held dance: yaw turns, nose up/down, full rolls.
fn figure_eight_pose(tau: f64, env: f64) -> Pose {
    let yaw = env * 2.0 * PI * tau / 9.0;
    let pitch = env * 1.3 * sin_hz(tau, 1.0 / 5.3, 0.0);
    let roll = env * PI * sin_hz(tau, 1.0 / 7.1, 0.0);
    let pos = [
        env * 0.4 * sin_hz(tau, 0.25, 0.0),
        env * 0.2 * sin_hz(tau, 0.5, 0.0),
        env * 0.1 * sin_hz(tau, 0.37, 0.0),
    ];
    (pos, Quat::from_euler(roll, pitch, yaw))
}

/// Take-off to 10 m, then 25 m, 5 m and back to 10 m in 80 s laps, with
/// small attitude wobbles and a slow horizontal drift.
fn hover_pose(tau: f64, env: f64) -> Pose {
    let period = 80.0;
    let c = if tau > 0.0 { tau % period } else { 0.0 };
    let laps = if tau > 0.0 {
        (tau / period).floor()
    } else {
        0.0
    };
    // 0 → 10 m (take-off), → 25 m, → 5 m, → 10 m (then repeats from 10 m).
    let base = if laps > 0.0 { 10.0 } else { 0.0 };
    let h = base + (10.0 - base) * smoothstep(c, 2.0, 10.0) + 15.0 * smoothstep(c, 20.0, 32.0)
        - 20.0 * smoothstep(c, 42.0, 56.0)
        + 5.0 * smoothstep(c, 66.0, 72.0);
    let roll = env * (0.05 * sin_hz(tau, 0.31, 0.0) + 0.02 * sin_hz(tau, 1.7, 1.0));
    let pitch = env * (0.05 * sin_hz(tau, 0.23, 0.5) + 0.02 * sin_hz(tau, 1.3, 0.0));
    let yaw = env * 0.6 * sin_hz(tau, 0.017, 0.0);
    let pos = [
        env * 2.0 * sin_hz(tau, 0.02, 0.0),
        env * 1.5 * sin_hz(tau, 0.027, 0.0),
        -h,
    ];
    (pos, Quat::from_euler(roll, pitch, yaw))
}

/// A 360° roll flip in 0.9 s every 8 s, on top of fast wobbles; the position
/// swings under its own, slower envelope `env_pos`.
fn aggressive_pose(tau: f64, env: f64, env_pos: f64) -> Pose {
    let mut flip = 0.0;
    if tau > 0.0 {
        let k = (tau / 8.0).floor();
        let c = tau - 8.0 * k;
        flip = 2.0 * PI * (k + smoothstep(c, 4.0, 4.9));
    }
    let roll = env * 0.9 * sin_hz(tau, 0.7, 0.0) + flip;
    let pitch = env * 0.7 * sin_hz(tau, 0.53, 1.0);
    let yaw = env * 2.5 * sin_hz(tau, 0.2, 0.0);
    let pos = [
        env_pos * 4.0 * sin_hz(tau, 0.25, 0.0),
        env_pos * 3.0 * sin_hz(tau, 0.19, 0.3),
        -(env_pos * (8.0 + 2.0 * sin_hz(tau, 0.3, 0.0))),
    ];
    (pos, Quat::from_euler(roll, pitch, yaw))
}

/// A 15 cm arm whirled about the vertical: 5 s cycles of a 3 s whirl
/// (smooth 0.5 s ramps to 2π rad/s) and a 2 s pause, direction alternating.
fn whirl_pose(tau: f64, env: f64) -> Pose {
    let mut angle = 0.0;
    if tau > 0.0 {
        let k = (tau / 5.0).floor();
        let c = tau - 5.0 * k;
        // Rate 2π·(S(x; 0, 0.5) − S(x; 2.5, 3.0)), S the smoothstep; its
        // integral in closed form: ∫S = T·(u⁶ − 3u⁵ + 2.5u⁴) on the ramp.
        let ramp_int = |x: f64, a: f64| {
            let t = 0.5;
            let u = ((x - a) / t).clamp(0.0, 1.0);
            t * u * u * u * u * (u * (u - 3.0) + 2.5) + (x - a - t).max(0.0)
        };
        let turn = |x: f64| 2.0 * PI * (ramp_int(x, 0.0) - ramp_int(x, 2.5));
        let per = turn(5.0);
        let dir = if (k as i64) % 2 == 0 { 1.0 } else { -1.0 };
        // Net angle after an even number of cycles returns to 0.
        let base = if (k as i64) % 2 == 0 { 0.0 } else { per };
        angle = base + dir * turn(c);
    }
    let r = 0.15;
    let pos = [r * angle.cos() - r, r * angle.sin(), 0.0];
    let roll = env * 0.3 * sin_hz(tau, 0.11, 0.0);
    let pitch = env * 0.25 * sin_hz(tau, 0.07, 1.0);
    (pos, Quat::from_euler(roll, pitch, angle))
}

/// Slow rotations under seven vibration tones of 1 m/s² each, 50–290 Hz.
fn vibration_pose(tau: f64, env: f64) -> Pose {
    let roll = env * 0.5 * sin_hz(tau, 0.05, 0.0);
    let pitch = env * 0.4 * sin_hz(tau, 0.037, 0.0);
    let yaw = env * 1.5 * sin_hz(tau, 0.021, 0.0);
    let mut pos = [0.0; 3];
    if tau > 0.0 {
        for (i, f) in [50.0, 83.0, 120.0, 155.0, 197.0, 240.0, 290.0]
            .iter()
            .enumerate()
        {
            // 1 m/s² per tone: amplitude a/(2πf)², each axis its own phase.
            let amp = env / (2.0 * PI * f).powi(2);
            for (j, p) in pos.iter_mut().enumerate() {
                *p += amp * sin_hz(tau, *f, (i * 3 + j) as f64 * 1.3);
            }
        }
    }
    (pos, Quat::from_euler(roll, pitch, yaw))
}

/// The hand-held attitude `tau` s after the rest phase: a smooth turn from one of
/// [`Trajectory::HAND_HELD_POSES`] to the next in `move_s`, then a hold with a
/// hand's tremor.
fn hand_held_attitude(tau: f64, move_s: f64) -> Quat {
    let seg = move_s + Trajectory::HAND_HELD_HOLD_S;
    let pose = |k: usize| {
        let [r, p, y] = Trajectory::HAND_HELD_POSES[k % Trajectory::HAND_HELD_POSES.len()];
        Quat::from_euler(r.to_radians(), p.to_radians(), y.to_radians())
    };
    if tau <= 0.0 {
        return pose(0);
    }
    let k = (tau / seg).floor();
    let x = tau - k * seg;
    let k = k as usize;
    let s = smoothstep(x, 0.0, move_s);
    let base = pose(k).slerp(&pose(k + 1), s);
    // The tremor fades in after the move and out before the next, so the attitude
    // stays smooth.
    let hold = smoothstep(x, move_s, move_s + 0.5) * (1.0 - smoothstep(x, seg - 0.5, seg));
    let a = hold * 1.5f64.to_radians();
    base.mul(&Quat::from_euler(
        a * sin_hz(x, 0.4, 0.0),
        a * sin_hz(x, 0.4, 1.6),
        0.0,
    ))
}

/// Heading (rad) `tau` s after the rest phase of [`Trajectory::FastTurns`].
fn fast_turns_yaw(tau: f64) -> f64 {
    if tau <= 0.0 {
        return 0.0;
    }
    let cycle = Trajectory::FAST_TURN_CYCLE_S;
    let k = (tau / cycle).floor() as usize;
    let x = tau - k as f64 * cycle;
    let dir = |k: usize| if k % 6 < 3 { 1.0 } else { -1.0 };
    // Whole turns before this cycle (the six-cycle pattern's net angle is 0).
    let done: f64 = (6 * (k / 6)..k)
        .map(|j| dir(j) * Trajectory::FAST_TURN_ANGLE_RAD)
        .sum();
    // Rate ω·(S(x; 0, r) − S(x; T − r, T)), S the smoothstep; ∫S in closed form
    // as for the whirl.
    let r = Trajectory::FAST_TURN_RAMP_S;
    let t = Trajectory::fast_turn_duration_s(k);
    let rate = Trajectory::FAST_TURN_RATES_DPS[k % 6].to_radians();
    done + dir(k) * rate * (ramp_integral(x, 0.0, r) - ramp_integral(x, t - r, r))
}

/// ∫ of a rate that ramps up smoothly over `r` s from `a` (the smoothstep),
/// then stays at 1, from −∞ to `x`: the angle turned at unit rate.
fn ramp_integral(x: f64, a: f64, r: f64) -> f64 {
    let u = ((x - a) / r).clamp(0.0, 1.0);
    r * u * u * u * u * (u * (u - 3.0) + 2.5) + (x - a - r).max(0.0)
}

/// The attitude of [`Trajectory::FastAxes`] `tau` s after the rest phase.
fn fast_axes_attitude(tau: f64) -> Quat {
    if tau <= 0.0 {
        return Quat::IDENTITY;
    }
    let mut k = 6 * (tau / Trajectory::fast_axes_start_s(6)).floor() as usize;
    while Trajectory::fast_axes_start_s(k + 1) <= tau {
        k += 1;
    }
    let x = tau - Trajectory::fast_axes_start_s(k);
    let t = Trajectory::fast_axes_turn_s(k);
    let pose = Trajectory::fast_axes_pose(k);
    if x < t {
        let r = Trajectory::FAST_TURN_RAMP_S;
        let rate = Trajectory::FAST_TURN_RATES_DPS[k % 6].to_radians();
        let angle = rate * (ramp_integral(x, 0.0, r) - ramp_integral(x, t - r, r));
        let axis = Trajectory::FAST_AXES_AXES[k % 6];
        return Quat::from_axis_angle(axis, angle).mul(&pose);
    }
    let s = smoothstep(x, t, t + Trajectory::FAST_AXES_MOVE_S);
    pose.slerp(&Trajectory::fast_axes_pose(k + 1), s)
}

/// The field (µT) at the sensor of a magnetic dipole of moment `moment_am2` (A·m²)
/// at `offset_m` (m) from it, both in the body frame:
/// B = μ0/(4π)·(3(m·r̂)r̂ − m)/r³ (the same at −r). A dipole fixed to the body
/// adds a body-fixed field: to the magnetometer, a hard-iron offset. Zero at
/// r = 0 (no field is defined there).
pub fn dipole_field_ut(moment_am2: Vec3, offset_m: Vec3) -> Vec3 {
    let r = math::norm(offset_m);
    if r <= 0.0 {
        return [0.0; 3];
    }
    let u = math::scale(offset_m, 1.0 / r);
    // μ0/(4π) = 1e-7 T·m/A; ×1e6 for µT.
    let k = 1e-7 * 1e6 / (r * r * r);
    let radial = math::scale(u, 3.0 * math::dot(moment_am2, u));
    math::scale(math::sub(radial, moment_am2), k)
}

impl Trajectory {
    /// Length of the rest phase at the start of the moving built-ins (s).
    pub const REST_S: f64 = 3.0;

    /// Names accepted by [`Trajectory::from_name`].
    pub const NAMES: [&'static str; 13] = [
        "rest",
        "spin",
        "slow",
        "figure8",
        "hover",
        "aggressive",
        "sixpos",
        "whirl",
        "vibration",
        "handheld",
        "fastturns",
        "handheld-slow",
        "fastaxes",
    ];

    /// The attitudes of [`Trajectory::HandHeld`], (roll, pitch, yaw) in degrees,
    /// visited in turn (then again from the first).
    pub const HAND_HELD_POSES: [[f64; 3]; 10] = [
        [0.0, 0.0, 0.0],
        [30.0, -20.0, 90.0],
        [-40.0, 10.0, 200.0],
        [10.0, 50.0, 300.0],
        [60.0, 0.0, 45.0],
        [-20.0, -45.0, 150.0],
        [0.0, 30.0, 260.0],
        [-60.0, 20.0, 10.0],
        [20.0, -30.0, 120.0],
        [0.0, 0.0, 330.0],
    ];
    /// Time to turn from one hand-held attitude to the next (s).
    pub const HAND_HELD_MOVE_S: f64 = 2.5;
    /// The same in [`Trajectory::HandHeldSlow`] (s).
    pub const HAND_HELD_SLOW_MOVE_S: f64 = 6.0;
    /// The rest attitudes of [`Trajectory::FastAxes`], (roll, pitch, yaw) in
    /// degrees; the first is the start's level, north.
    pub const FAST_AXES_POSES: [[f64; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [15.0, -10.0, 100.0],
        [-20.0, 15.0, 210.0],
        [10.0, 25.0, 300.0],
        [-15.0, -20.0, 40.0],
        [25.0, 5.0, 160.0],
    ];
    /// The turn axes of [`Trajectory::FastAxes`] in the earth frame (NED, not
    /// normalised): yaw, roll, pitch and three oblique axes, signs mixed.
    pub const FAST_AXES_AXES: [[f64; 3]; 6] = [
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [1.0, 0.0, -1.0],
        [0.0, 1.0, 1.0],
        [-1.0, 1.0, -1.0],
    ];
    /// Angle of each turn of [`Trajectory::FastAxes`] (rad): two whole turns.
    pub const FAST_AXES_ANGLE_RAD: f64 = 4.0 * PI;
    /// The hand's move to the next rest attitude (s).
    pub const FAST_AXES_MOVE_S: f64 = 1.0;
    /// The rest after each move (s).
    pub const FAST_AXES_REST_S: f64 = 3.0;
    /// Time each hand-held attitude is held (s).
    pub const HAND_HELD_HOLD_S: f64 = 3.5;
    /// Turn rates of the cycles of [`Trajectory::FastTurns`] (°/s), in turn;
    /// the first three turn nose right, the next three nose left.
    pub const FAST_TURN_RATES_DPS: [f64; 6] = [400.0, 300.0, 500.0, 400.0, 300.0, 500.0];
    /// Angle of each fast turn (rad): 2.5 turns.
    pub const FAST_TURN_ANGLE_RAD: f64 = 5.0 * PI;
    /// Length of one fast-turn cycle, the turn and the rest after it (s).
    pub const FAST_TURN_CYCLE_S: f64 = 11.0;
    /// Length of each smooth rate ramp of a fast turn (s).
    pub const FAST_TURN_RAMP_S: f64 = 0.25;

    /// Duration of the turn of fast-turn cycle `k` (s), ramps included: the
    /// rate's integral is [`Trajectory::FAST_TURN_ANGLE_RAD`].
    pub fn fast_turn_duration_s(k: usize) -> f64 {
        let rate = Self::FAST_TURN_RATES_DPS[k % 6].to_radians();
        Self::FAST_TURN_ANGLE_RAD / rate + Self::FAST_TURN_RAMP_S
    }

    /// Duration of the turn of [`Trajectory::FastAxes`]'s cycle `k` (s).
    pub fn fast_axes_turn_s(k: usize) -> f64 {
        let rate = Self::FAST_TURN_RATES_DPS[k % 6].to_radians();
        Self::FAST_AXES_ANGLE_RAD / rate + Self::FAST_TURN_RAMP_S
    }

    /// Start (s after the rest phase) of [`Trajectory::FastAxes`]'s cycle `k`:
    /// its turn, then the move and the rest.
    pub fn fast_axes_start_s(k: usize) -> f64 {
        let six: f64 = (0..6).map(Self::fast_axes_cycle_s).sum();
        (k / 6) as f64 * six + (0..k % 6).map(Self::fast_axes_cycle_s).sum::<f64>()
    }

    fn fast_axes_cycle_s(k: usize) -> f64 {
        Self::fast_axes_turn_s(k) + Self::FAST_AXES_MOVE_S + Self::FAST_AXES_REST_S
    }

    /// The rest attitude `k` of [`Trajectory::FastAxes`] (cyclic).
    pub fn fast_axes_pose(k: usize) -> Quat {
        let [r, p, y] = Self::FAST_AXES_POSES[k % Self::FAST_AXES_POSES.len()];
        Quat::from_euler(r.to_radians(), p.to_radians(), y.to_radians())
    }

    /// How long each face is held still in [`Trajectory::SixPosition`] (s).
    pub const SIX_POSITION_HOLD_S: f64 = 4.0;
    /// How long the turn from one face to the next takes (s).
    pub const SIX_POSITION_MOVE_S: f64 = 2.0;
    /// The six faces of [`Trajectory::SixPosition`] in order, as
    /// (MPU axis pointing up, `+1` up / `−1` down). Body FRD = (x, −y, −z)
    /// of the MPU frame, so: level, upside down, nose up, nose down, right
    /// side down, left side down.
    pub const SIX_POSITION_POSES: [(usize, i8); 6] =
        [(2, 1), (2, -1), (0, 1), (0, -1), (1, 1), (1, -1)];

    /// `q_ned_from_body` of a face of [`Trajectory::SIX_POSITION_POSES`]:
    /// MPU axis `axis` (0 = x, 1 = y, 2 = z) pointing up (`up`) or down.
    pub fn six_position_pose(axis: usize, up: bool) -> Quat {
        let half = PI / 2.0;
        match (axis, up) {
            // z_mpu = −z_body: up when level, down upside down (roll 180°).
            (2, true) => Quat::IDENTITY,
            (2, false) => Quat::from_euler(PI, 0.0, 0.0),
            // x_mpu = x_body: nose up / nose down.
            (0, true) => Quat::from_euler(0.0, half, 0.0),
            (0, false) => Quat::from_euler(0.0, -half, 0.0),
            // y_mpu = −y_body: up when the right side (y_body) points down (roll +90°).
            (_, true) => Quat::from_euler(half, 0.0, 0.0),
            (_, false) => Quat::from_euler(-half, 0.0, 0.0),
        }
    }

    /// The still intervals `(start_s, end_s)` of [`Trajectory::SixPosition`],
    /// one per entry of [`Trajectory::SIX_POSITION_POSES`].
    pub fn six_position_still_intervals() -> [(f64, f64); 6] {
        let mut out = [(0.0, 0.0); 6];
        for (k, o) in out.iter_mut().enumerate() {
            let start = Self::six_position_start_s(k);
            *o = (
                if k == 0 { 0.0 } else { start },
                start + Self::SIX_POSITION_HOLD_S,
            );
        }
        out
    }

    /// Start of the hold of face `k` (the first face also holds through the
    /// rest phase before it).
    fn six_position_start_s(k: usize) -> f64 {
        Self::REST_S + k as f64 * (Self::SIX_POSITION_HOLD_S + Self::SIX_POSITION_MOVE_S)
    }

    /// Total length of [`Trajectory::SixPosition`] until it is back to level (s).
    pub fn six_position_duration_s() -> f64 {
        Self::six_position_start_s(6)
    }

    fn six_position_at(t_s: f64) -> Quat {
        let faces = Self::SIX_POSITION_POSES.map(|(a, s)| Self::six_position_pose(a, s > 0));
        let period = Self::SIX_POSITION_HOLD_S + Self::SIX_POSITION_MOVE_S;
        let tau = t_s - Self::REST_S;
        if tau <= 0.0 {
            return faces[0];
        }
        let k = (tau / period).floor() as usize;
        let c = tau - k as f64 * period;
        let from = faces.get(k).copied().unwrap_or(Quat::IDENTITY);
        let to = faces.get(k + 1).copied().unwrap_or(Quat::IDENTITY);
        if k >= faces.len() {
            return Quat::IDENTITY;
        }
        let s = smoothstep(
            c,
            Self::SIX_POSITION_HOLD_S,
            Self::SIX_POSITION_HOLD_S + Self::SIX_POSITION_MOVE_S,
        );
        from.slerp(&to, s)
    }

    /// Level at rest, facing north.
    pub fn at_rest() -> Self {
        Trajectory::AtRest {
            q_ned_from_body: Quat::IDENTITY,
        }
    }

    /// Rest for [`Trajectory::REST_S`], then a 1 s linear ramp up to a constant
    /// body rate `omega_body_rps` (rad/s) kept for ever.
    pub fn spin(omega_body_rps: Vec3) -> Self {
        let w = omega_body_rps;
        let rate = math::norm(w);
        Trajectory::Custom(Rc::new(move |t_s: f64| {
            let tau = t_s - Self::REST_S;
            let angle = if tau <= 0.0 {
                0.0
            } else if tau < 1.0 {
                0.5 * rate * tau * tau
            } else {
                rate * (tau - 0.5)
            };
            ([0.0; 3], Quat::from_axis_angle(w, angle))
        }))
    }

    /// Built-in by name: `rest`, `spin` (rest, then yaw at 90°/s), `slow`, `figure8`,
    /// `hover`, `aggressive`, `sixpos`, `whirl`, `vibration`, `handheld`, `fastturns`,
    /// `handheld-slow`, `fastaxes`.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "rest" => Self::at_rest(),
            "spin" => Self::spin([0.0, 0.0, 90f64.to_radians()]),
            "slow" => Trajectory::SlowRotations,
            "figure8" | "figure-eight" => Trajectory::FigureEight,
            "hover" => Trajectory::Hover,
            "aggressive" => Trajectory::Aggressive,
            "sixpos" | "six-position" => Trajectory::SixPosition,
            "whirl" => Trajectory::Whirl,
            "vibration" => Trajectory::Vibration,
            "handheld" => Trajectory::HandHeld,
            "fastturns" => Trajectory::FastTurns,
            "handheld-slow" => Trajectory::HandHeldSlow,
            "fastaxes" => Trajectory::FastAxes,
            _ => return None,
        })
    }

    /// Short name.
    pub fn name(&self) -> &'static str {
        match self {
            Trajectory::AtRest { .. } => "rest",
            Trajectory::ConstantRate { .. } => "spin",
            Trajectory::SlowRotations => "slow",
            Trajectory::FigureEight => "figure8",
            Trajectory::Hover => "hover",
            Trajectory::Aggressive => "aggressive",
            Trajectory::SixPosition => "sixpos",
            Trajectory::Whirl => "whirl",
            Trajectory::Vibration => "vibration",
            Trajectory::HandHeld => "handheld",
            Trajectory::FastTurns => "fastturns",
            Trajectory::HandHeldSlow => "handheld-slow",
            Trajectory::FastAxes => "fastaxes",
            Trajectory::Custom(_) => "custom/spin",
            Trajectory::Motion(_) => "motion",
        }
    }

    /// Pose at time `t_s`.
    pub fn pose(&self, t_s: f64) -> Pose {
        let tau = t_s - Self::REST_S;
        let env = smoothstep(t_s, Self::REST_S, Self::REST_S + 1.5);
        match self {
            Trajectory::AtRest { q_ned_from_body } => ([0.0; 3], *q_ned_from_body),
            Trajectory::ConstantRate { omega_body_rps } => {
                let w = *omega_body_rps;
                ([0.0; 3], Quat::from_axis_angle(w, math::norm(w) * t_s))
            }
            Trajectory::SlowRotations => {
                let roll = env * 0.6 * sin_hz(tau, 0.05, 0.0);
                let pitch = env * 0.45 * sin_hz(tau, 0.037, 0.0);
                let yaw = env * (1.8 * sin_hz(tau, 0.021, 0.0) + 0.4 * sin_hz(tau, 0.061, 0.0));
                ([0.0; 3], Quat::from_euler(roll, pitch, yaw))
            }
            Trajectory::FigureEight => figure_eight_pose(tau, env),
            Trajectory::Hover => hover_pose(tau, env),
            Trajectory::Aggressive => {
                let env_pos = smoothstep(t_s, Self::REST_S, Self::REST_S + 5.0);
                aggressive_pose(tau, env, env_pos)
            }
            Trajectory::SixPosition => ([0.0; 3], Self::six_position_at(t_s)),
            Trajectory::Whirl => whirl_pose(tau, env),
            Trajectory::Vibration => vibration_pose(tau, env),
            Trajectory::HandHeld => ([0.0; 3], hand_held_attitude(tau, Self::HAND_HELD_MOVE_S)),
            Trajectory::HandHeldSlow => (
                [0.0; 3],
                hand_held_attitude(tau, Self::HAND_HELD_SLOW_MOVE_S),
            ),
            Trajectory::FastAxes => ([0.0; 3], fast_axes_attitude(tau)),
            Trajectory::FastTurns => ([0.0; 3], Quat::from_euler(0.0, 0.0, fast_turns_yaw(tau))),
            Trajectory::Custom(f) => f(t_s),
            Trajectory::Motion(f) => {
                let s = f(t_s);
                (s.position_ned_m, s.q_ned_from_body)
            }
        }
    }

    /// Full truth at `t_s`: pose plus its derivatives.
    pub fn sample(&self, t_s: f64) -> TruthSample {
        if let Trajectory::Motion(f) = self {
            return f(t_s);
        }
        let (p0, q0) = self.pose(t_s);
        // Angular rate: ω_body = 2·vec(q* ⊗ dq/dt).
        let h = 1e-4;
        let (_, qp) = self.pose(t_s + h);
        let (_, qm) = self.pose(t_s - h);
        let qp = if qp.w * q0.w + qp.x * q0.x + qp.y * q0.y + qp.z * q0.z < 0.0 {
            Quat::new(-qp.w, -qp.x, -qp.y, -qp.z)
        } else {
            qp
        };
        let qm = if qm.w * q0.w + qm.x * q0.x + qm.y * q0.y + qm.z * q0.z < 0.0 {
            Quat::new(-qm.w, -qm.x, -qm.y, -qm.z)
        } else {
            qm
        };
        let dq = Quat::new(
            (qp.w - qm.w) / (2.0 * h),
            (qp.x - qm.x) / (2.0 * h),
            (qp.y - qm.y) / (2.0 * h),
            (qp.z - qm.z) / (2.0 * h),
        );
        let w = q0.conj().mul(&dq);
        let omega_body_rps = [2.0 * w.x, 2.0 * w.y, 2.0 * w.z];
        // Linear acceleration by second difference.
        let ha = 1e-3;
        let (pp, _) = self.pose(t_s + ha);
        let (pm, _) = self.pose(t_s - ha);
        let acc_ned = [
            (pp[0] - 2.0 * p0[0] + pm[0]) / (ha * ha),
            (pp[1] - 2.0 * p0[1] + pm[1]) / (ha * ha),
            (pp[2] - 2.0 * p0[2] + pm[2]) / (ha * ha),
        ];
        let vel = math::scale(math::sub(pp, pm), 1.0 / (2.0 * ha));
        let f_ned = math::sub(acc_ned, [0.0, 0.0, G0_MPS2]);
        let specific_force_body_mps2 = q0.conj().rotate(f_ned);
        let moving = math::norm(omega_body_rps) > 0.05 || math::norm(acc_ned) > 0.2;
        TruthSample {
            t_s,
            q_ned_from_body: q0,
            omega_body_rps,
            specific_force_body_mps2,
            position_ned_m: p0,
            velocity_ned_mps: vel,
            height_m: -p0[2],
            moving,
        }
    }
}

/// The Earth's magnetic field at the flying site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagneticField {
    /// Total intensity (µT).
    pub total_ut: f64,
    /// Inclination (dip), positive down (degrees).
    pub inclination_deg: f64,
    /// Declination, positive east of true north (degrees).
    pub declination_deg: f64,
}

impl Default for MagneticField {
    /// 50 µT, 60° dip, 0° declination (central Europe-like).
    fn default() -> Self {
        Self {
            total_ut: 50.0,
            inclination_deg: 60.0,
            declination_deg: 0.0,
        }
    }
}

impl MagneticField {
    /// The field vector in NED (µT).
    pub fn ned_ut(&self) -> Vec3 {
        let (si, ci) = self.inclination_deg.to_radians().sin_cos();
        let (sd, cd) = self.declination_deg.to_radians().sin_cos();
        [
            self.total_ut * ci * cd,
            self.total_ut * ci * sd,
            self.total_ut * si,
        ]
    }
}

/// ISA (troposphere) pressure at geopotential altitude `alt_m` above mean sea level (Pa).
pub fn isa_pressure_pa(alt_m: f64) -> f64 {
    101_325.0 * (1.0 - 2.255_77e-5 * alt_m).powf(5.255_88)
}

/// ISA temperature at `alt_m` (°C).
pub fn isa_temperature_c(alt_m: f64) -> f64 {
    15.0 - 0.0065 * alt_m
}

/// The environment the body flies in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Environment {
    /// Earth's field.
    pub field: MagneticField,
    /// Altitude of the start point above mean sea level (m).
    pub ground_altitude_m: f64,
    /// Chips' temperature minus the ISA air temperature (°C), e.g. self-heating.
    pub chip_temp_offset_c: f64,
}

impl Default for Environment {
    fn default() -> Self {
        Self {
            field: MagneticField::default(),
            ground_altitude_m: 0.0,
            chip_temp_offset_c: 0.0,
        }
    }
}

impl Environment {
    /// True static pressure at height `height_m` above the start point (Pa).
    pub fn pressure_pa(&self, height_m: f64) -> f64 {
        isa_pressure_pa(self.ground_altitude_m + height_m)
    }
    /// True chip temperature at height `height_m` (°C).
    pub fn temperature_c(&self, height_m: f64) -> f64 {
        isa_temperature_c(self.ground_altitude_m + height_m) + self.chip_temp_offset_c
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use crate::math::norm;

    #[test]
    fn rest_gives_gravity_up_in_body() {
        let s = Trajectory::at_rest().sample(1.0);
        assert!(norm(math::sub(s.specific_force_body_mps2, [0.0, 0.0, -G0_MPS2])) < 1e-6);
        assert!(norm(s.omega_body_rps) < 1e-9);
        assert!(!s.moving);
    }

    #[test]
    fn constant_rate_is_recovered() {
        let w = [0.3, -0.2, 1.1];
        let s = Trajectory::ConstantRate { omega_body_rps: w }.sample(2.7);
        assert!(
            norm(math::sub(s.omega_body_rps, w)) < 1e-6,
            "{:?}",
            s.omega_body_rps
        );
    }

    #[test]
    fn dipole_field_matches_the_textbook_axial_and_equatorial_values() {
        // 1 A·m² at 0.1 m: μ0/(4π)·m/r³ = 1e-7/1e-3 T = 100 µT equatorial,
        // twice that on the axis, pointing along the moment on the axis and
        // against it in the equatorial plane.
        let m = [0.0, 0.0, 1.0];
        let axial = dipole_field_ut(m, [0.0, 0.0, 0.1]);
        let equatorial = dipole_field_ut(m, [0.1, 0.0, 0.0]);
        assert!((axial[2] - 200.0).abs() < 1e-9 && axial[0].abs() < 1e-12);
        assert!((equatorial[2] + 100.0).abs() < 1e-9 && equatorial[0].abs() < 1e-12);
        // r⁻³: twice as far, an eighth.
        let far = dipole_field_ut(m, [0.2, 0.0, 0.0]);
        assert!((far[2] * 8.0 - equatorial[2]).abs() < 1e-9);
        assert_eq!(dipole_field_ut(m, [0.0; 3]), [0.0; 3]);
    }

    #[test]
    fn fast_turns_turn_900_degrees_per_cycle_at_their_rate_and_rest_between() {
        let tr = Trajectory::FastTurns;
        let r0 = Trajectory::REST_S;
        let cycle = Trajectory::FAST_TURN_CYCLE_S;
        let mut yaw0 = 0.0;
        for k in 0..7 {
            let start = r0 + k as f64 * cycle;
            let t = Trajectory::fast_turn_duration_s(k);
            let mid = tr.sample(start + 0.5 * t);
            let rate = Trajectory::FAST_TURN_RATES_DPS[k % 6];
            let dir = if k % 6 < 3 { 1.0 } else { -1.0 };
            assert!((mid.omega_body_rps[2].to_degrees() - dir * rate).abs() < 1e-3);
            let rest = tr.sample(start + t + 1.0);
            assert!(math::norm(rest.omega_body_rps) < 1e-6 && !rest.moving);
            let yaw = rest.q_ned_from_body.to_euler()[2];
            // 2.5 turns: the heading ends 180° from where it started.
            let turned = (yaw - yaw0 - PI).rem_euclid(2.0 * PI);
            assert!(turned.min(2.0 * PI - turned) < 1e-6, "cycle {k}");
            assert!(t < cycle - 7.0, "each rest lasts at least 7 s");
            yaw0 = yaw;
        }
    }

    #[test]
    fn fast_axes_turn_twice_about_each_axis_at_their_rate_and_rest_between() {
        let tr = Trajectory::FastAxes;
        for k in 0..7 {
            let start = Trajectory::REST_S + Trajectory::fast_axes_start_s(k);
            let t = Trajectory::fast_axes_turn_s(k);
            // Mid-turn: the rate is the cycle's, about the cycle's earth axis.
            let mid = tr.sample(start + 0.5 * t);
            let w_ned = mid.q_ned_from_body.rotate(mid.omega_body_rps);
            let axis = Trajectory::FAST_AXES_AXES[k % 6];
            let want = math::scale(
                axis,
                Trajectory::FAST_TURN_RATES_DPS[k % 6].to_radians() / norm(axis),
            );
            assert!(norm(math::sub(w_ned, want)) < 1e-3, "cycle {k}: {w_ned:?}");
            // Two whole turns: back at the attitude it started from.
            let pose = Trajectory::fast_axes_pose(k);
            assert!(tr.pose(start + t).1.angle_to(&pose) < 1e-6, "cycle {k}");
            assert!(tr.pose(start).1.angle_to(&pose) < 1e-6, "cycle {k}");
            // Still for the rest, at the next attitude.
            let rest0 = start + t + Trajectory::FAST_AXES_MOVE_S;
            for x in [
                0.01,
                0.5 * Trajectory::FAST_AXES_REST_S,
                Trajectory::FAST_AXES_REST_S - 0.01,
            ] {
                let s = tr.sample(rest0 + x);
                assert!(
                    !s.moving && norm(s.omega_body_rps) < 1e-6,
                    "cycle {k} at {x}"
                );
                assert!(
                    s.q_ned_from_body
                        .angle_to(&Trajectory::fast_axes_pose(k + 1))
                        < 1e-6
                );
            }
        }
    }

    #[test]
    fn hand_held_slow_visits_the_same_poses_at_under_half_the_rate() {
        let peak = |tr: &Trajectory| {
            (0..(60.0 / 0.01) as usize)
                .map(|i| {
                    norm(
                        tr.sample(Trajectory::REST_S + i as f64 * 0.01)
                            .omega_body_rps,
                    )
                })
                .fold(0.0f64, f64::max)
        };
        let (fast, slow) = (peak(&Trajectory::HandHeld), peak(&Trajectory::HandHeldSlow));
        // Same angles over 6 s instead of 2.5 s: the peak rate scales by 2.5/6.
        assert!(
            slow < 0.5 * fast && slow.to_degrees() > 15.0,
            "{slow} vs {fast}"
        );
        let seg = Trajectory::HAND_HELD_SLOW_MOVE_S + Trajectory::HAND_HELD_HOLD_S;
        for k in 1..10 {
            let [r, p, y] = Trajectory::HAND_HELD_POSES[k];
            let want = Quat::from_euler(r.to_radians(), p.to_radians(), y.to_radians());
            let t = Trajectory::REST_S + (k - 1) as f64 * seg + Trajectory::HAND_HELD_SLOW_MOVE_S;
            assert!(
                Trajectory::HandHeldSlow.pose(t).1.angle_to(&want) < 1e-6,
                "pose {k}"
            );
        }
    }

    #[test]
    fn hand_held_reaches_each_pose_and_keeps_a_hand_rate() {
        let tr = Trajectory::HandHeld;
        let seg = Trajectory::HAND_HELD_MOVE_S + Trajectory::HAND_HELD_HOLD_S;
        let mut peak = 0.0f64;
        for i in 0..(60.0 / 0.01) as usize {
            let s = tr.sample(Trajectory::REST_S + i as f64 * 0.01);
            peak = peak.max(math::norm(s.omega_body_rps));
        }
        assert!(
            peak.to_degrees() > 40.0 && peak.to_degrees() < 150.0,
            "{} °/s",
            peak.to_degrees()
        );
        for k in 1..10 {
            let [r, p, y] = Trajectory::HAND_HELD_POSES[k];
            let want = Quat::from_euler(r.to_radians(), p.to_radians(), y.to_radians());
            // At the end of the move, before the tremor starts.
            let got = tr
                .pose(Trajectory::REST_S + (k - 1) as f64 * seg + Trajectory::HAND_HELD_MOVE_S)
                .1;
            assert!(got.angle_to(&want) < 1e-6, "pose {k}");
        }
    }

    #[test]
    fn isa_reference_points() {
        assert!((isa_pressure_pa(0.0) - 101_325.0).abs() < 1e-6);
        // ISA table: 1000 m → 89 874.6 Pa, 8.5 °C.
        assert!((isa_pressure_pa(1000.0) - 89_874.6).abs() < 5.0);
        assert!((isa_temperature_c(1000.0) - 8.5).abs() < 1e-9);
    }

    #[test]
    fn six_position_holds_each_face_still_with_gravity_on_one_mpu_axis() {
        let tr = Trajectory::SixPosition;
        for ((axis, sign), (t0, t1)) in Trajectory::SIX_POSITION_POSES
            .into_iter()
            .zip(Trajectory::six_position_still_intervals())
        {
            for t in [t0 + 0.01, 0.5 * (t0 + t1), t1 - 0.01] {
                let s = tr.sample(t);
                assert!(!s.moving, "moving at {t}");
                // Specific force at rest points up: +g on the axis that is up.
                let f = math::body_to_mpu(s.specific_force_body_mps2);
                for (i, fi) in f.iter().enumerate() {
                    let expect = if i == axis {
                        f64::from(sign) * G0_MPS2
                    } else {
                        0.0
                    };
                    assert!((fi - expect).abs() < 1e-6, "{t}: {f:?}");
                }
            }
            // Moving between faces.
            assert!(tr.sample(t1 + 0.5 * Trajectory::SIX_POSITION_MOVE_S).moving);
        }
        let end = Trajectory::six_position_duration_s();
        assert!(
            tr.sample(end + 1.0)
                .q_ned_from_body
                .angle_to(&Quat::IDENTITY)
                < 1e-9
        );
    }

    #[test]
    fn field_has_dip() {
        let b = MagneticField::default().ned_ut();
        assert!((norm(b) - 50.0).abs() < 1e-9);
        assert!((b[2] / b[0] - 60f64.to_radians().tan()).abs() < 1e-9);
    }

    #[test]
    fn trajectories_are_smooth_and_start_at_rest() {
        for name in Trajectory::NAMES {
            let tr = Trajectory::from_name(name).unwrap_or_else(Trajectory::at_rest);
            let mut prev = tr.sample(0.0);
            let mut t = 0.0;
            while t < 30.0 {
                t += 0.01;
                let s = tr.sample(t);
                // Bounded rates and forces, no jumps.
                assert!(
                    norm(s.omega_body_rps) < 2000f64.to_radians(),
                    "{name} ω at {t}"
                );
                assert!(
                    norm(s.specific_force_body_mps2) < 4.0 * G0_MPS2,
                    "{name} f at {t}"
                );
                assert!(
                    s.q_ned_from_body.angle_to(&prev.q_ned_from_body) < 0.2,
                    "{name} jump at {t}"
                );
                prev = s;
            }
            assert!(!tr.sample(1.0).moving, "{name} not at rest at start");
        }
    }
}
