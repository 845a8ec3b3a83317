//! Shared by the flight scenarios (`flight_in_the_loop`, `flight_corners`):
//! rigs calibrated as a user leaves the board, flying to a time, and the
//! figures read off the model's truth and the ESC pins.

use super::*;
use emulator::rig::{FlightRig, RigOptions, RigSample};
use emulator::{calpage, Firmware};
use sim::scenario::Scenario;

/// The rig's options for `scenario`, at the cycle model's pessimistic
/// corner with `FIL_CYCLE_MODEL=pessimistic`.
pub fn options(scenario: Scenario, seed: u64) -> RigOptions {
    let mut opts = RigOptions::new(scenario, seed);
    if std::env::var("FIL_CYCLE_MODEL").is_ok_and(|m| m == "pessimistic") {
        opts.cycle_model = emulator::CycleModel::Pessimistic;
    }
    opts
}

/// A rig flying `scenario` with seed `seed`, calibrated as a user leaves
/// the board; `None` (skipped) without the ELF.
pub fn rig(scenario: Scenario, seed: u64) -> Option<FlightRig> {
    rig_with(options(scenario, seed))
}

/// Flies until `t_s`; a board error fails the test with the log's end.
pub fn fly_until(r: &mut FlightRig, t_s: f64) {
    if let Err(e) = r.run_until_s(t_s) {
        panic!(
            "board stopped at {:.3} s: {e}\n{}",
            r.now_s(),
            tail(r.board(), 40)
        );
    }
}

/// The rig's steps that end within `t0..t1` (s).
pub fn window(r: &FlightRig, t0: f64, t1: f64) -> Vec<RigSample> {
    r.samples()
        .iter()
        .filter(|s| s.t_s >= t0 && s.t_s < t1)
        .copied()
        .collect()
}

/// Mean and RMS deviation from it of the true height over `w`.
pub fn height_stats(w: &[RigSample]) -> (f64, f64) {
    let n = w.len() as f64;
    let mean = w.iter().map(|s| s.truth.height_m).sum::<f64>() / n;
    let var = w
        .iter()
        .map(|s| (s.truth.height_m - mean).powi(2))
        .sum::<f64>()
        / n;
    (mean, var.sqrt())
}

/// All four pins at the off pulse (PWM 1000 µs ± 5 µs).
pub fn pins_off(s: &RigSample) -> bool {
    s.pulse_us
        .iter()
        .all(|p| p.is_some_and(|us| (us - 1000.0).abs() < 5.0))
}

pub fn tilt_deg(s: &RigSample) -> f64 {
    let q = s.truth.q_ned_from_body;
    // The body z axis in NED: the angle from straight down.
    let z = q.rotate([0.0, 0.0, 1.0]);
    z[2].clamp(-1.0, 1.0).acos().to_degrees()
}

/// A rig for `opts` (its flash replaced by the calibration page a user's
/// calibrations leave for its board seed); `None` (skipped) without the
/// ELF.
pub fn rig_with(mut opts: RigOptions) -> Option<FlightRig> {
    let path = elf()?;
    let fw = Firmware::load(&path).expect("ELF");
    let errors = sim::SensorErrors::datasheet(opts.board_seed);
    opts.flash = Some(calpage::with_record(
        fw.flash.clone(),
        &calpage::record_for(&errors),
    ));
    Some(FlightRig::new(&path, &opts).unwrap_or_else(|e| panic!("rig: {e}")))
}

/// When the faults strike: hovering, 2 s after the climb.
pub const FAULT_AT_S: f64 = 8.0;

/// First time at or after `t0` when all four pins carry the off pulse.
pub fn pins_off_at(r: &FlightRig, t0: f64) -> Option<f64> {
    r.samples()
        .iter()
        .find(|s| s.t_s >= t0 && pins_off(s))
        .map(|s| s.t_s)
}

/// A rig hovering at FAULT_AT_S.
pub fn hovering(seed: u64) -> Option<FlightRig> {
    let mut r = rig(Scenario::Takeoff, seed)?;
    fly_until(&mut r, FAULT_AT_S);
    let h = r.samples().last().unwrap().truth.height_m;
    assert!(
        h > 1.0,
        "not hovering before the fault: {h} m\n{}",
        tail(r.board(), 40)
    );
    Some(r)
}

/// Flies 3 s on from the fault just injected at FAULT_AT_S: the motors
/// never stop and the true height stays within `max_dh_m` of the hover's.
pub fn assert_flown_through(r: &mut FlightRig, what: &str, max_dh_m: f64) {
    let h0 = window(r, FAULT_AT_S - 0.1, FAULT_AT_S)
        .last()
        .unwrap()
        .truth
        .height_m;
    fly_until(r, FAULT_AT_S + 3.0);
    let after = window(r, FAULT_AT_S, FAULT_AT_S + 3.0);
    let off = after.iter().any(pins_off);
    let dh = after
        .iter()
        .map(|s| (s.truth.height_m - h0).abs())
        .fold(0.0, f64::max);
    println!("fil {what}: motors off {off}, height deviation {dh:.2} m");
    assert!(!off, "the motors stopped\n{}", tail(r.board(), 40));
    assert!(dh < max_dh_m, "height deviation {dh} m");
}
