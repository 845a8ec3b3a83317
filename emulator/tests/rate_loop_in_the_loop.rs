//! The rate loop measured on the emulated board: the release ELF flies
//! the chirp scenario (acro sweeps of roll, pitch and yaw, the pilot's
//! hand holding height and level), and `sim::rate_loop` measures each
//! axis from the setpoint and gyro the controller saw
//! (`emulator::rate_view`), as `cargo sim --scenario chirp` measures the
//! host build. One seed: the flight is 77 s simulated.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::rigs::*;
use common::*;
use control::pid::PidConfig;
use emulator::rate_view;
use sim::rate_loop::freq::C;
use sim::rate_loop::{chirp_window_s, AXES};
use sim::scenario::Scenario;
use sim::QuadParams;
use std::f64::consts::PI;
use std::ops::{Add, Div, Mul, Sub};

/// Longest delay around the loop (s) the bounds allow: the chip's DLPF
/// (DLPF_CFG 1: 2.9 ms per the register map), the gyro filter (≈ 1 ms
/// at these frequencies), the sample and the control step (≤ 1 ms), and
/// the ESC's frame and the rig's step (≤ 3 ms).
const MAX_LOOP_DELAY_S: f64 = 8e-3;

/// The rigid-body model of one axis: angular acceleration per unit torque
/// command (rad/s² per unit) at hover and `battery_v`, from the airframe
/// alone. The mixer gives each motor ±½ of the command (control::mixer's
/// table); a motor's steady speed is linear in its command (ω_max at
/// the nominal voltage, scaled by the voltage), thrust k_f ω² and drag
/// torque k_m ω², linearised at the hover's ω_h = √(m g / 4 k_f).
fn torque_authority(q: &QuadParams, axis: usize, battery_v: f64) -> f64 {
    let p = &q.propulsion;
    let w_hover = (q.weight_n() / 4.0 / p.k_f_n_per_rps2).sqrt();
    let dw_dc = p.omega_max_rps * battery_v / p.v_nominal_v;
    let per_motor_nm = match axis {
        // Roll about x: the motors' y offset; pitch about y: their x offset.
        0 => 2.0 * p.k_f_n_per_rps2 * w_hover * dw_dc * q.motors[0].position_body_m[1].abs(),
        1 => 2.0 * p.k_f_n_per_rps2 * w_hover * dw_dc * q.motors[0].position_body_m[0].abs(),
        _ => 2.0 * p.k_m_nm_per_rps2 * w_hover * dw_dc,
    };
    4.0 * 0.5 * per_motor_nm / q.inertia_kgm2[axis]
}

/// The crossover (Hz) of `T / (1 − T)` for the model: the PID of `pid`
/// (derivative on the measurement, low-passed) on `b / (s (1 + s τ))`
/// with a delay `delay_s`; the same quantity the analysis measures.
fn model_crossover_hz(pid: &PidConfig, b: f64, tau_s: f64, delay_s: f64) -> f64 {
    let one = C::new(1.0, 0.0);
    let l_at = |f: f64| {
        let s = C::new(0.0, 2.0 * PI * f);
        let g = C::from_phase(-2.0 * PI * f * delay_s)
            .scale(b)
            .div(s.mul(one.add(s.scale(tau_s))));
        let pi = C::new(f64::from(pid.kp), 0.0).add(C::new(f64::from(pid.ki), 0.0).div(s));
        // `d_cutoff_hz` 0: no low-pass (τ 0).
        let d_tau_s = if pid.d_cutoff_hz > 0.0 {
            1.0 / (2.0 * PI * f64::from(pid.d_cutoff_hz))
        } else {
            0.0
        };
        let d = s.scale(f64::from(pid.kd)).div(one.add(s.scale(d_tau_s)));
        let t = pi.mul(g).div(one.add(pi.add(d).mul(g)));
        t.div(one.sub(t))
    };
    (0..4000)
        .map(|i| 0.3 * 10f64.powf(i as f64 / 1000.0))
        .find(|&f| l_at(f).abs() < 1.0)
        .expect("the model crosses over below 3 kHz")
}

#[test]
fn the_rate_loop_on_the_board_has_its_margins_and_the_airframe_s_crossover() {
    let Some(mut r) = rig(Scenario::Chirp, 1) else {
        return;
    };
    fly_until(&mut r, Scenario::Chirp.duration_s());
    assert_no_reset(r.board());
    let reports = rate_view::analyse_chirp(&r).unwrap_or_else(|e| panic!("{e}"));
    for l in sim::rate_loop::table(&reports) {
        println!("fil chirp seed 1: {l}");
    }
    let airframe = Scenario::Chirp.airframe();
    let rate = settings::flight_config().rate;
    for (axis, rep) in reports.iter().enumerate() {
        assert_eq!(rep.axis, AXES[axis]);
        let m = &rep.margins;
        // The line for a loop that is not fragile (Betaflight's
        // configurator calls Ms = 2 the fragility line).
        assert!(m.phase_margin_deg.unwrap() >= 45.0, "{}: {m:?}", rep.axis);
        assert!(m.ms <= 2.0, "{}: {m:?}", rep.axis);
        // The crossover the airframe and the gains give, between no delay
        // and the longest the path has, at the battery's voltage during
        // the sweep; the measured one within 25 % of that range.
        let (t0, t1) = chirp_window_s(axis);
        let sweep = window(&r, t0, t1);
        let v = sweep.iter().map(|s| s.quad.battery_voltage_v).sum::<f64>() / sweep.len() as f64;
        let b = torque_authority(&airframe, axis, v);
        let pid = [rate.roll, rate.pitch, rate.yaw][axis];
        let tau = airframe.propulsion.tau_s;
        let lo = model_crossover_hz(&pid, b, tau, 0.0);
        let hi = model_crossover_hz(&pid, b, tau, MAX_LOOP_DELAY_S);
        let fc = m.crossover_hz.unwrap();
        println!(
            "fil chirp seed 1: {} crossover {fc:.2} Hz; rigid-body model {lo:.2}–{hi:.2} Hz ({v:.2} V)",
            rep.axis
        );
        assert!(
            fc >= 0.75 * lo.min(hi) && fc <= 1.25 * lo.max(hi),
            "{}: {fc} Hz outside 25 % of {lo}–{hi} Hz",
            rep.axis
        );
        // The deconvolved step settles on the setpoint (the loop has an
        // integrator).
        let s = rep.step.as_ref().unwrap();
        assert!((s.final_value - 1.0).abs() < 0.1, "{}: {s:?}", rep.axis);
    }
}
