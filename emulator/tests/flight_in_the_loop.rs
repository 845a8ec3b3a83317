//! Flight in the loop: the release ELF flies the quad model on the
//! emulated board (`emulator::rig`), with the simulator's datasheet sensor
//! errors and the scripted pilots of `cargo sim --scenario`. Every figure
//! is measured on the model's truth and on the ESC pins.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::rig::{FlightRig, RigOptions, RigSample};
use emulator::{calpage, Firmware};
use sim::scenario::{Scenario, ARM_AT_S, CLIMB_TO_S, LINK_LOSS_S};

/// A rig flying `scenario` with seed `seed`, calibrated as a user leaves
/// the board; `None` (skipped) without the ELF.
fn rig(scenario: Scenario, seed: u64) -> Option<FlightRig> {
    let path = elf()?;
    let fw = Firmware::load(&path).expect("ELF");
    let mut opts = RigOptions::new(scenario, seed);
    let errors = sim::SensorErrors::datasheet(opts.board_seed);
    opts.flash = Some(calpage::with_record(
        fw.flash.clone(),
        &calpage::record_for(&errors),
    ));
    Some(FlightRig::new(&path, &opts).unwrap_or_else(|e| panic!("rig: {e}")))
}

fn fly_until(r: &mut FlightRig, t_s: f64) {
    if let Err(e) = r.run_until_s(t_s) {
        panic!(
            "board stopped at {:.3} s: {e}\n{}",
            r.now_s(),
            tail(r.board(), 40)
        );
    }
}

fn window(r: &FlightRig, t0: f64, t1: f64) -> Vec<RigSample> {
    r.samples()
        .iter()
        .filter(|s| s.t_s >= t0 && s.t_s < t1)
        .copied()
        .collect()
}

/// Mean and RMS deviation from it of the true height over `w`.
fn height_stats(w: &[RigSample]) -> (f64, f64) {
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
fn pins_off(s: &RigSample) -> bool {
    s.pulse_us
        .iter()
        .all(|p| p.is_some_and(|us| (us - 1000.0).abs() < 5.0))
}

fn tilt_deg(s: &RigSample) -> f64 {
    let q = s.truth.q_ned_from_body;
    // The body z axis in NED: the angle from straight down.
    let z = q.rotate([0.0, 0.0, 1.0]);
    z[2].clamp(-1.0, 1.0).acos().to_degrees()
}

#[test]
fn the_firmware_takes_off_and_holds_its_height() {
    let Some(mut r) = rig(Scenario::Takeoff, 1) else {
        return;
    };
    fly_until(&mut r, Scenario::Takeoff.duration_s());
    let armed = lines_with(r.board(), "ARMED");
    assert!(!armed.is_empty(), "never armed\n{}", tail(r.board(), 60));
    // Disarmed on the ground until the arm switch.
    let before = window(&r, 0.5, ARM_AT_S);
    assert!(before.iter().all(|s| s.truth.height_m == 0.0));
    assert!(before.iter().all(pins_off), "pulses before arming");
    // Climbed, then holds (altitude hold, stick centred).
    let hover = window(&r, CLIMB_TO_S + 3.0, Scenario::Takeoff.duration_s());
    let (mean, rms) = height_stats(&hover);
    println!("fil takeoff seed 1: hover height {mean:.2} m, RMS about it {rms:.3} m");
    assert!(mean > 1.0, "hover at {mean} m\n{}", tail(r.board(), 60));
    assert!(rms < 0.15, "height RMS {rms} m");
    let max_tilt = hover.iter().map(tilt_deg).fold(0.0, f64::max);
    assert!(max_tilt < 10.0, "tilt {max_tilt}°");
    assert_no_reset(r.board());
}

#[test]
fn link_loss_in_flight_holds_descends_lands_and_turns_the_pins_off() {
    let Some(mut r) = rig(Scenario::LinkLoss, 1) else {
        return;
    };
    fly_until(&mut r, Scenario::LinkLoss.duration_s());
    let at_loss = window(&r, LINK_LOSS_S - 0.5, LINK_LOSS_S);
    let (h0, _) = height_stats(&at_loss);
    assert!(
        h0 > 1.0,
        "not flying at the loss: {h0} m\n{}",
        tail(r.board(), 60)
    );
    let after = window(&r, LINK_LOSS_S, Scenario::LinkLoss.duration_s());
    let since = |s: &RigSample| s.t_s - LINK_LOSS_S;
    let landed = after.iter().find(|s| s.truth.height_m < 0.02).map(since);
    let off = after.iter().find(|s| pins_off(s)).map(since);
    let max_tilt = after
        .iter()
        .filter(|s| !s.quad.on_ground)
        .map(tilt_deg)
        .fold(0.0, f64::max);
    println!(
        "fil linkloss seed 1: height at loss {h0:.2} m, touch-down +{landed:?} s, pins off +{off:?} s, max tilt {max_tilt:.1}°"
    );
    let (landed, off) = (landed.expect("never landed"), off.expect("pins never off"));
    assert!(off >= landed, "motors off in the air: {off} s < {landed} s");
    assert!(max_tilt < 10.0, "tilt {max_tilt}°");
    // Off for good once disarmed.
    assert!(after.iter().filter(|s| since(s) > off).all(pins_off));
}
