//! The fixed-point rate loop, mixer and ESC values against their `f32`
//! reference (`loops::RateController`, `mixer::Mixer`, `esc::EscTimer`):
//! property tests over the full input ranges, and a closed-loop step
//! response flown by both.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use control::controllers::{BodyRates, TorqueCommand};
use control::esc::{EscProtocol, EscTimer};
use control::fixed::{f32_to_q, q_to_f32, ONE_Q30};
use control::loops::{RateConfig, RateController};
use control::mixer::{unmix, Mixer, MixerConfig, MOTORS};
use control::rateq::{torque_from_q30, MixerQ, RateControllerQ};
use proptest::prelude::*;

/// The loop period, s (the IMU's 1 kHz).
const DT_S: f32 = 0.001;
/// The gyro's full scale, rad/s (±2000 °/s).
const FULL_SCALE_RPS: f32 = 2000.0 * core::f32::consts::PI / 180.0;

/// Torques: the fixed loop within this of the `f32` one (0.005 % of ±1;
/// the `f32` integrator's own rounding is 3e-8 a step at 0.3).
const TORQUE_TOL: f32 = 5e-5;
/// Motor commands: within this of the `f32` mixer's (2.4 ticks of the
/// Blue Pill's 24,000 between 0 and 1).
const MOTOR_TOL: f32 = 1e-4;

fn q16(x: f32) -> i32 {
    f32_to_q(x, 16)
}

/// `x` rounded to the nearest Q16 value, as an `f32`: both loops then see
/// the same input, and the comparison measures the arithmetic alone.
fn on_q16(x: f32) -> f32 {
    q_to_f32(q16(x), 16)
}

fn rates(v: [f32; 3]) -> BodyRates {
    BodyRates {
        roll_rps: v[0],
        pitch_rps: v[1],
        yaw_rps: v[2],
    }
}

fn torque_array(t: &TorqueCommand) -> [f32; 3] {
    [t.roll, t.pitch, t.yaw]
}

/// A sequence of (setpoint, gyro) triples: held values with small noise,
/// jumping anywhere in ±full scale every `hold` steps (so the integrators
/// wind into their bounds and the D term sees full-scale steps).
fn sequence() -> impl Strategy<Value = Vec<([f32; 3], [f32; 3])>> {
    let fs = FULL_SCALE_RPS;
    let point = (
        prop::array::uniform3(-fs..fs),
        prop::array::uniform3(-fs..fs),
        1usize..200,
    );
    prop::collection::vec(point, 1..12).prop_map(|segments| {
        let mut out = Vec::new();
        for (k, (sp, gyro, hold)) in segments.into_iter().enumerate() {
            for i in 0..hold {
                // A small deterministic wobble on the gyro.
                let w = 0.01 * ((i * 7 + k * 3) % 11) as f32 - 0.05;
                out.push((sp, gyro.map(|g| g + w)));
            }
        }
        out
    })
}

fn rate_configs() -> [RateConfig; 2] {
    let mut hard = RateConfig::default();
    hard.roll = hard.roll.with_integral_limits(-0.5, 0.5);
    hard.pitch.kp = 0.6;
    hard.pitch.kd = 0.008;
    hard.yaw.ki = 3.0;
    [RateConfig::default(), hard]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// The three PIDs: torques and integrals within `TORQUE_TOL` of the
    /// `f32` loop at every step, across the gyro's full range; beyond it
    /// only by the integrator steps that one loop took and the other
    /// skipped (conditional integration decides on `unclamped ≥ limit`,
    /// and an unclamped output within rounding of a limit can go either
    /// way: one step of `ki·dt·e`, up to 0.056 at 70 rad/s, which then
    /// persists until the integrators reach a bound).
    #[test]
    fn rate_loop_tracks_the_f32_loop(seq in sequence(), which in 0usize..2) {
        let cfg = rate_configs()[which];
        let pids = [cfg.roll, cfg.pitch, cfg.yaw];
        let mut f = RateController::new(cfg).unwrap();
        let mut q = RateControllerQ::new(&cfg, DT_S).unwrap();
        let mut slack = [0.0f32; 3];
        let mut flips = 0;
        let steps = seq.len();
        for (sp, gyro) in seq {
            let (sp, gyro) = (sp.map(on_q16), gyro.map(on_q16));
            let (fi0, qi0) = (torque_array(&f.integrals()), q.integrals_q30().map(|t| q_to_f32(t, 30)));
            let tf = torque_array(&f.update(&rates(sp), &rates(gyro), DT_S).unwrap());
            let tq = q.update(sp.map(q16), gyro.map(q16)).map(|t| q_to_f32(t, 30));
            let fi = torque_array(&f.integrals());
            let qi = q.integrals_q30().map(|t| q_to_f32(t, 30));
            for k in 0..3 {
                let c = &pids[k];
                let di = c.ki * DT_S * (sp[k] - gyro[k]);
                let stepped = |i0: f32, i1: f32| {
                    let full = (i0 + di).max(c.integral_min).min(c.integral_max);
                    if (full - i0).abs() < 1e-6 {
                        None // nothing to tell apart
                    } else {
                        Some((i1 - full).abs() < (i1 - i0).abs())
                    }
                };
                if let (Some(a), Some(b)) = (stepped(fi0[k], fi[k]), stepped(qi0[k], qi[k])) {
                    if a != b {
                        slack[k] += di.abs();
                        flips += 1;
                    }
                }
                let tol = TORQUE_TOL + slack[k];
                prop_assert!((tf[k] - tq[k]).abs() <= tol, "axis {k}: {tf:?} vs {tq:?}, slack {slack:?}");
                prop_assert!((fi[k] - qi[k]).abs() <= tol, "integral {k}: {fi:?} vs {qi:?}, slack {slack:?}");
            }
        }
        // Rare: a flip needs an unclamped output within rounding of a limit.
        prop_assert!(flips * 100 <= steps.max(100), "{flips} flips in {steps} steps");
    }

    /// The mixer over the whole input box (throttle beyond 0..1, torques
    /// beyond ±1, so saturated on every side): motors within `MOTOR_TOL`,
    /// the same saturation verdict, and the fixed motors in `[idle, 1]`.
    #[test]
    fn mixer_tracks_the_f32_mixer(
        t in -0.2f32..1.2,
        r in -1.5f32..1.5,
        p in -1.5f32..1.5,
        y in -1.5f32..1.5,
        idle in 0.0f32..0.3,
    ) {
        let cfg = MixerConfig { idle };
        let mf = Mixer::new(cfg).unwrap();
        let mq = MixerQ::new(&cfg).unwrap();
        let [t, r, p, y] = [t, r, p, y].map(|v| q_to_f32(f32_to_q(v, 30), 30));
        let of = mf.mix(t, &TorqueCommand { roll: r, pitch: p, yaw: y }).unwrap();
        let oq = mq.mix(f32_to_q(t, 30), [r, p, y].map(|v| f32_to_q(v, 30)));
        let idle_q30 = f32_to_q(idle, 30);
        for k in 0..MOTORS {
            let m = q_to_f32(oq.motors_q30[k], 30);
            prop_assert!((m - of.motors[k]).abs() <= MOTOR_TOL, "{of:?} vs {oq:?}");
            prop_assert!((idle_q30 - 1..=ONE_Q30).contains(&oq.motors_q30[k]), "{oq:?}");
        }
        let g = oq.to_f32();
        prop_assert!((g.roll_pitch_gain - of.roll_pitch_gain).abs() <= 1e-4, "{of:?} vs {oq:?}");
        // The yaw gain is ill-conditioned for a tiny yaw (the room left
        // over divided by the yaw's span): compare the yaw it lets through.
        prop_assert!(((g.yaw_gain - of.yaw_gain) * y).abs() <= MOTOR_TOL, "{of:?} vs {oq:?}");
    }

    /// Unsaturated mixes reproduce the commanded collective and torques.
    #[test]
    fn unsaturated_mix_reproduces_the_command(
        t in 0.35f32..0.65, r in -0.2f32..0.2, p in -0.2f32..0.2, y in -0.2f32..0.2,
    ) {
        let mq = MixerQ::new(&MixerConfig::default()).unwrap();
        let oq = mq.mix(f32_to_q(t, 30), [r, p, y].map(|v| f32_to_q(v, 30)));
        prop_assert!(!oq.saturated());
        let (thr, tq) = unmix(&oq.motor_commands());
        prop_assert!((thr - t).abs() < 1e-6 && (tq.roll - r).abs() < 1e-6);
        prop_assert!((tq.pitch - p).abs() < 1e-6 && (tq.yaw - y).abs() < 1e-6);
    }

    /// The Q30 compare value equals the `f32` one within one tick, for
    /// both protocols at the Blue Pill's timer clock.
    #[test]
    fn esc_compare_q30_matches_the_f32_compare(c in -0.5f32..1.5, oneshot in any::<bool>()) {
        let proto = if oneshot { EscProtocol::OneShot125 } else { EscProtocol::Pwm };
        let esc = EscTimer::for_clock(proto, proto.default_rate_hz(), 72_000_000).unwrap();
        let c_q30 = f32_to_q(c, 30);
        let a = i32::from(esc.compare_q30(c_q30));
        let b = i32::from(esc.compare(q_to_f32(c_q30, 30)));
        prop_assert!((a - b).abs() <= 1, "{c}: {a} vs {b}");
    }

    /// The bit-level conversions against the f64 arithmetic they replace.
    #[test]
    fn conversions_match_the_arithmetic(x in any::<f32>(), frac in 0u32..31) {
        let exact = (f64::from(x) * f64::from(2f32.powi(frac as i32))).round();
        let want = if x.is_nan() { 0 } else { exact.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32 };
        prop_assert_eq!(f32_to_q(x, frac), want, "{} at Q{}", x, frac);
        let back = q_to_f32(want, frac);
        let v = f64::from(want) / f64::from(2f32.powi(frac as i32));
        prop_assert!((f64::from(back) - v).abs() <= v.abs() * 1.2e-7, "{} {}", back, v);
    }
}

#[test]
fn conversions_at_the_edges() {
    assert_eq!(f32_to_q(f32::INFINITY, 16), i32::MAX);
    assert_eq!(f32_to_q(f32::NEG_INFINITY, 16), i32::MIN);
    assert_eq!(f32_to_q(f32::NAN, 16), 0);
    assert_eq!(f32_to_q(-0.0, 30), 0);
    assert_eq!(f32_to_q(1.0, 30), ONE_Q30);
    assert_eq!(f32_to_q(-2.0, 30), i32::MIN);
    assert_eq!(f32_to_q(2.0, 30), i32::MAX);
    assert_eq!(f32_to_q(1.5e-45, 30), 0);
    assert_eq!(q_to_f32(i32::MIN, 31), -1.0);
    assert_eq!(q_to_f32(ONE_Q30, 30), 1.0);
    assert_eq!(q_to_f32(-3, 0), -3.0);
    let t = torque_from_q30([ONE_Q30, -ONE_Q30 / 2, 0]);
    assert_eq!((t.roll, t.pitch, t.yaw), (1.0, -0.5, 0.0));
}

/// Every input the flight controller can hand the fixed loop, however
/// extreme, gives torques within the output limits.
#[test]
fn extreme_rates_stay_within_the_limits() {
    let mut q = RateControllerQ::new(&RateConfig::default(), DT_S).unwrap();
    for (sp, g) in [
        (i32::MAX, i32::MIN),
        (i32::MIN, i32::MAX),
        (0, i32::MAX),
        (q16(FULL_SCALE_RPS), q16(-FULL_SCALE_RPS)),
    ] {
        let t = q.update([sp; 3], [g; 3]);
        assert!(t.iter().all(|v| (-ONE_Q30..=ONE_Q30).contains(v)), "{t:?}");
    }
}

/// Rigid-body roll/pitch/yaw rates driven by the motors through a
/// first-order lag (20 ms), with aerodynamic damping: enough to show a
/// closed loop's rise, overshoot and settling.
struct Plant {
    motors: [f32; MOTORS],
    w: [f32; 3],
}

impl Plant {
    fn new() -> Self {
        Self {
            motors: [0.5; MOTORS],
            w: [0.0; 3],
        }
    }

    fn step(&mut self, cmd: &[f32; MOTORS]) {
        for (m, c) in self.motors.iter_mut().zip(cmd) {
            *m += (c - *m) * DT_S / 0.02;
        }
        let (_, tq) = unmix(&self.motors);
        // rad/s² per unit torque (roll, pitch, yaw), damping 1/s.
        let gain = [120.0, 120.0, 25.0];
        for (k, t) in torque_array(&tq).iter().enumerate() {
            self.w[k] += (gain[k] * t - 0.5 * self.w[k]) * DT_S;
        }
    }
}

/// A 400 °/s roll, −300 °/s pitch and 150 °/s yaw step flown by the `f32`
/// loop and mixer and by the fixed ones from the same start: the rate
/// traces stay within 0.02 °/s of each other, and both settle on the target.
#[test]
fn closed_loop_step_response_matches() {
    let cfg = RateConfig::default();
    let mut f = RateController::new(cfg).unwrap();
    let mut q = RateControllerQ::new(&cfg, DT_S).unwrap();
    let mf = Mixer::new(MixerConfig::default()).unwrap();
    let mq = MixerQ::new(&MixerConfig::default()).unwrap();
    let (mut pf, mut pq) = (Plant::new(), Plant::new());
    let target = [400.0f32, -300.0, 150.0].map(f32::to_radians);
    let mut worst = 0.0f32;
    let mut saturated = 0;
    for _ in 0..1500 {
        let tf = f.update(&rates(target), &rates(pf.w), DT_S).unwrap();
        pf.step(&mf.mix(0.5, &tf).unwrap().motors);
        let tq = q.update(target.map(q16), pq.w.map(q16));
        let out = mq.mix(ONE_Q30 / 2, tq);
        saturated += usize::from(out.saturated());
        pq.step(&out.motor_commands());
        for k in 0..3 {
            worst = worst.max((pf.w[k] - pq.w[k]).abs());
        }
    }
    assert!(saturated > 10, "the step must saturate the mixer");
    assert!(
        worst < 0.02f32.to_radians(),
        "worst {} °/s",
        worst.to_degrees()
    );
    for (k, goal) in target.iter().enumerate() {
        for w in [pf.w[k], pq.w[k]] {
            assert!(
                (w - goal).abs() < 0.02 * goal.abs(),
                "axis {k}: {w} vs {goal}"
            );
        }
    }
}
