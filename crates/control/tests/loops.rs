//! Rate and self-level loops: the quaternion attitude error, and step
//! responses closed around the mixer and a rigid-body quad model.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use control::controllers::{BodyRates, TorqueCommand};
use control::loops::{
    attitude_error, LevelConfig, LevelController, Quat, RateConfig, RateController,
};
use control::mixer::{unmix, Mixer, MixerConfig, MOTORS};
use control::shaping::TiltSetpoint;

fn tilt(roll_deg: f32, pitch_deg: f32) -> TiltSetpoint {
    TiltSetpoint {
        roll_rad: roll_deg.to_radians(),
        pitch_rad: pitch_deg.to_radians(),
    }
}

#[test]
fn error_is_the_rotation_vector_for_small_angles() {
    let e = attitude_error(&Quat::IDENTITY, &tilt(10.0, 0.0));
    assert!((e[0] - 2.0 * (5f32.to_radians()).sin()).abs() < 1e-6);
    assert!(e[1].abs() < 1e-6 && e[2].abs() < 1e-6);
    let e = attitude_error(&Quat::from_euler(0.0, 0.1, 0.0), &tilt(0.0, 0.0));
    assert!((e[1] + 0.1).abs() < 1e-3 && e[0].abs() < 1e-6);
}

#[test]
fn error_ignores_heading_and_scale() {
    for yaw in [-3.0f32, -1.0, 0.0, 0.7, 2.5] {
        let q = Quat::from_euler(0.2, -0.1, yaw);
        let e = attitude_error(
            &q,
            &TiltSetpoint {
                roll_rad: 0.2,
                pitch_rad: -0.1,
            },
        );
        assert!(e.iter().all(|v| v.abs() < 1e-5), "yaw {yaw}: {e:?}");
        // A slightly non-unit quaternion (fixed-point rounding).
        let q2 = Quat {
            w: q.w * 1.01,
            x: q.x * 1.01,
            y: q.y * 1.01,
            z: q.z * 1.01,
        };
        let e0 = attitude_error(&q, &tilt(0.0, 0.0));
        let e2 = attitude_error(&q2, &tilt(0.0, 0.0));
        for k in 0..3 {
            assert!((e0[k] - e2[k]).abs() < 1e-4, "{e0:?} {e2:?}");
        }
    }
}

#[test]
fn error_matches_the_exact_rotation_vector() {
    // Against the textbook construction with atan2 heading and normalised
    // quaternions, over a grid of attitudes and setpoints.
    for (r, p, y) in [
        (0.3f32, -0.2f32, 2.9f32),
        (-1.2, 0.4, -3.1),
        (2.8, 0.1, 1.0),
        (0.0, 1.4, -0.5),
    ] {
        let q = Quat::from_euler(r, p, y);
        let yaw = (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z));
        for (sr, sp) in [(0.0f32, 0.0f32), (0.5, -0.3), (-0.2, 0.6)] {
            let qd = Quat::from_euler(sr, sp, yaw);
            let mut e = q.conj().mul(&qd);
            if e.w < 0.0 {
                e = Quat {
                    w: -e.w,
                    x: -e.x,
                    y: -e.y,
                    z: -e.z,
                };
            }
            let got = attitude_error(
                &q,
                &TiltSetpoint {
                    roll_rad: sr,
                    pitch_rad: sp,
                },
            );
            for (g, want) in got.iter().zip([2.0 * e.x, 2.0 * e.y, 2.0 * e.z]) {
                assert!(
                    (g - want).abs() < 1e-4,
                    "({r}, {p}, {y}) → ({sr}, {sp}): {got:?} vs {e:?}"
                );
            }
        }
    }
}

#[test]
fn error_is_in_the_body_frame() {
    // Yawed 90° right and rolled 10° right: the roll error is about body x
    // even though body x now points east.
    let q = Quat::from_euler(10f32.to_radians(), 0.0, 90f32.to_radians());
    let e = attitude_error(&q, &tilt(0.0, 0.0));
    assert!(e[0] < -0.15 && e[1].abs() < 1e-3, "{e:?}");
}

#[test]
fn inverted_gives_a_finite_bounded_demand() {
    let level = LevelController::new(LevelConfig::default()).unwrap();
    for q in [
        Quat::from_euler(core::f32::consts::PI, 0.0, 0.0),
        Quat {
            w: 0.0,
            x: 1.0,
            y: 0.0,
            z: 0.0,
        },
        Quat::from_euler(3.0, 0.1, 1.0),
    ] {
        let sp = level.rate_setpoint(&q, &tilt(0.0, 0.0), 0.0).unwrap();
        let m = level.config().max_rate_rps;
        assert!(sp.roll_rps.is_finite() && sp.pitch_rps.is_finite());
        assert!(sp.roll_rps.abs() <= m && sp.pitch_rps.abs() <= m);
        assert!(sp.roll_rps.abs() + sp.pitch_rps.abs() > 0.5 * m, "{sp:?}");
    }
}

#[test]
fn rejects_bad_inputs() {
    let level = LevelController::new(LevelConfig::default()).unwrap();
    let zero = Quat {
        w: 0.0,
        x: 0.0,
        y: 0.0,
        z: 0.0,
    };
    assert!(level.rate_setpoint(&zero, &tilt(0.0, 0.0), 0.0).is_err());
    assert!(level
        .rate_setpoint(&Quat::IDENTITY, &tilt(f32::NAN, 0.0), 0.0)
        .is_err());
    assert!(LevelController::new(LevelConfig {
        kp_per_s: -1.0,
        ..LevelConfig::default()
    })
    .is_err());
    let mut rate = RateController::new(RateConfig::default()).unwrap();
    let before = rate;
    let nan = BodyRates {
        roll_rps: f32::NAN,
        ..BodyRates::default()
    };
    assert!(rate.update(&nan, &BodyRates::default(), 0.001).is_err());
    assert!(rate
        .update(&BodyRates::default(), &BodyRates::default(), 0.0)
        .is_err());
    assert_eq!(rate, before);
}

/// Rigid quad: angular acceleration per unit of *achieved* normalised
/// torque (from the lagged motors through the mixer's inverse), diagonal
/// inertia; attitude integrated as a quaternion.
struct Quad {
    q: Quat,
    w: [f32; 3],
    motors: [f32; MOTORS],
}

/// rad/s² per unit torque: roll/pitch, yaw (yaw from drag torque is weak).
const ACCEL_PER_TORQUE: [f32; 3] = [120.0, 120.0, 25.0];
/// Motor time constant, s.
const MOTOR_TAU_S: f32 = 0.025;
const DT_S: f32 = 0.001;

impl Quad {
    fn new() -> Self {
        Self {
            q: Quat::IDENTITY,
            w: [0.0; 3],
            motors: [0.5; MOTORS],
        }
    }

    fn step(&mut self, cmd: &[f32; MOTORS]) {
        let a = DT_S / (MOTOR_TAU_S + DT_S);
        for (m, c) in self.motors.iter_mut().zip(cmd) {
            *m += a * (c - *m);
        }
        let (_, t) = unmix(&self.motors);
        let tq = [t.roll, t.pitch, t.yaw];
        for k in 0..3 {
            self.w[k] += ACCEL_PER_TORQUE[k] * tq[k] * DT_S;
        }
        // q̇ = ½ q ⊗ (0, ω)
        let dq = self.q.mul(&Quat {
            w: 0.0,
            x: self.w[0],
            y: self.w[1],
            z: self.w[2],
        });
        let q = Quat {
            w: self.q.w + 0.5 * DT_S * dq.w,
            x: self.q.x + 0.5 * DT_S * dq.x,
            y: self.q.y + 0.5 * DT_S * dq.y,
            z: self.q.z + 0.5 * DT_S * dq.z,
        };
        let n = (q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z).sqrt();
        self.q = Quat {
            w: q.w / n,
            x: q.x / n,
            y: q.y / n,
            z: q.z / n,
        };
    }

    fn rates(&self) -> BodyRates {
        BodyRates {
            roll_rps: self.w[0],
            pitch_rps: self.w[1],
            yaw_rps: self.w[2],
        }
    }

    fn roll_rad(&self) -> f32 {
        let q = &self.q;
        (2.0 * (q.w * q.x + q.y * q.z)).atan2(1.0 - 2.0 * (q.x * q.x + q.y * q.y))
    }
}

/// Rise time 10→90 %, overshoot (fraction), final error (fraction).
struct Step {
    rise_s: f32,
    overshoot: f32,
    final_error: f32,
}

impl Step {
    /// Prints the response (shown with `--nocapture`) and checks it against
    /// the limits: rise time in s, overshoot and final error as fractions.
    fn check(&self, what: &str, max_rise_s: f32, max_overshoot: f32, max_final_error: f32) {
        println!(
            "{what}: rise {:.0} ms, overshoot {:.1} %, final error {:.2} %",
            self.rise_s * 1e3,
            self.overshoot * 100.0,
            self.final_error * 100.0
        );
        assert!(self.rise_s < max_rise_s, "{what}: rise {} s", self.rise_s);
        assert!(
            self.overshoot < max_overshoot,
            "{what}: overshoot {}",
            self.overshoot
        );
        assert!(
            self.final_error < max_final_error,
            "{what}: final error {}",
            self.final_error
        );
    }
}

fn analyse(trace: &[f32], target: f32) -> Step {
    let t10 = trace.iter().position(|v| *v >= 0.1 * target).unwrap();
    let t90 = trace.iter().position(|v| *v >= 0.9 * target).unwrap();
    let peak = trace.iter().cloned().fold(f32::MIN, f32::max);
    let last = *trace.last().unwrap();
    Step {
        rise_s: (t90 - t10) as f32 * DT_S,
        overshoot: (peak - target) / target,
        final_error: ((last - target) / target).abs(),
    }
}

fn rate_step(axis: usize, target_rps: f32, seconds: f32) -> Step {
    let mixer = Mixer::new(MixerConfig::default()).unwrap();
    let mut rate = RateController::new(RateConfig::default()).unwrap();
    let mut quad = Quad::new();
    let mut sp = BodyRates::default();
    match axis {
        0 => sp.roll_rps = target_rps,
        1 => sp.pitch_rps = target_rps,
        _ => sp.yaw_rps = target_rps,
    }
    let mut trace = Vec::new();
    for _ in 0..(seconds / DT_S) as usize {
        let tq = rate.update(&sp, &quad.rates(), DT_S).unwrap();
        let mix = mixer.mix(0.5, &tq).unwrap();
        quad.step(&mix.motors);
        trace.push(quad.w[axis]);
    }
    analyse(&trace, target_rps)
}

#[test]
fn roll_and_pitch_rate_steps() {
    for axis in [0, 1] {
        let s = rate_step(axis, 200f32.to_radians(), 1.0);
        s.check(&format!("rate step axis {axis}"), 0.08, 0.15, 0.02);
    }
}

#[test]
fn yaw_rate_step() {
    let s = rate_step(2, 90f32.to_radians(), 1.5);
    s.check("yaw rate step", 0.3, 0.2, 0.03);
}

#[test]
fn self_level_roll_step() {
    let mixer = Mixer::new(MixerConfig::default()).unwrap();
    let mut rate = RateController::new(RateConfig::default()).unwrap();
    let level = LevelController::new(LevelConfig::default()).unwrap();
    let mut quad = Quad::new();
    let target = 20f32.to_radians();
    let mut trace = Vec::new();
    let mut peak_rate = 0.0f32;
    for _ in 0..1500 {
        let sp = level.rate_setpoint(&quad.q, &tilt(20.0, 0.0), 0.0).unwrap();
        peak_rate = peak_rate.max(sp.roll_rps);
        let tq: TorqueCommand = rate.update(&sp, &quad.rates(), DT_S).unwrap();
        quad.step(&mixer.mix(0.5, &tq).unwrap().motors);
        trace.push(quad.roll_rad());
    }
    let s = analyse(&trace, target);
    s.check("angle step 20°", 0.45, 0.1, 0.01);
    // The demand is rate-limited.
    assert!(peak_rate <= level.config().max_rate_rps + 1e-6);
}

#[test]
fn recovers_from_upside_down() {
    let mixer = Mixer::new(MixerConfig::default()).unwrap();
    let mut rate = RateController::new(RateConfig::default()).unwrap();
    let level = LevelController::new(LevelConfig::default()).unwrap();
    let mut quad = Quad::new();
    quad.q = Quat::from_euler(3.0, 0.2, 0.5);
    for _ in 0..3000 {
        let sp = level.rate_setpoint(&quad.q, &tilt(0.0, 0.0), 0.0).unwrap();
        let tq = rate.update(&sp, &quad.rates(), DT_S).unwrap();
        quad.step(&mixer.mix(0.5, &tq).unwrap().motors);
    }
    assert!(
        quad.q.tilt_rad() < 1f32.to_radians(),
        "{}",
        quad.q.tilt_rad()
    );
}
