//! Flight in the loop at the corners the board may run at: the cycle
//! model's pessimistic end (take-off, link loss, the sensor board losing
//! power in the hover, a NACK burst), the LSI at both ends of its datasheet range (30 and 60 kHz: the
//! watchdog bites later or earlier) and the HSI fallback (no crystal:
//! SYSCLK 64 MHz, APB1 32 MHz). The subset `scripts/check` flies on every
//! run (README, "Flight in the loop"); each test flies only the seconds
//! its judgement needs, and the tests run in parallel.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::rigs::*;
use common::*;
use emulator::rig::{FlightRig, RigOptions, RigSample};
use emulator::CycleModel;
use sim::scenario::{Scenario, ARM_AT_S, CLIMB_TO_S, LINK_LOSS_S};

/// Take-off, climb to 6 s, then judged hovering over 8–10 s.
const HOVER_FROM_S: f64 = CLIMB_TO_S + 2.0;
const HOVER_TO_S: f64 = CLIMB_TO_S + 4.0;

fn corner(scenario: Scenario, seed: u64, set: impl FnOnce(&mut RigOptions)) -> Option<FlightRig> {
    let mut opts = RigOptions::new(scenario, seed);
    set(&mut opts);
    rig_with(opts)
}

fn pessimistic(opts: &mut RigOptions) {
    opts.cycle_model = CycleModel::Pessimistic;
}

/// Flies the take-off to the end of the hover window and asserts the
/// hover: above 1 m, height RMS under 0.15 m, tilt under 10°, no reset.
fn assert_takes_off_and_hovers(r: &mut FlightRig, what: &str) {
    fly_until(r, HOVER_TO_S);
    let hover = window(r, HOVER_FROM_S, HOVER_TO_S);
    let (mean, rms) = height_stats(&hover);
    let max_tilt = hover.iter().map(tilt_deg).fold(0.0, f64::max);
    println!("fil {what}: hover {mean:.2} m, RMS {rms:.3} m, max tilt {max_tilt:.1}°");
    assert!(
        mean > 1.0 && rms < 0.15,
        "{what}: {mean} m, RMS {rms} m\n{}",
        tail(r.board(), 30)
    );
    assert!(max_tilt < 10.0, "{what}: tilt {max_tilt}°");
    assert_no_reset(r.board());
}

#[test]
fn pessimistic_corner_takes_off_and_holds_its_height() {
    let Some(mut r) = corner(Scenario::Takeoff, 1, pessimistic) else {
        return;
    };
    assert_takes_off_and_hovers(&mut r, "pessimistic takeoff");
}

/// The link lost at 10 s at the pessimistic corner: the failsafe holds,
/// descends and lands; the pins go to the off pulse only on the ground.
#[test]
fn pessimistic_corner_link_loss_lands_and_turns_the_pins_off() {
    let Some(mut r) = corner(Scenario::LinkLoss, 1, pessimistic) else {
        return;
    };
    let end = LINK_LOSS_S + 8.5;
    fly_until(&mut r, end);
    let (h0, _) = height_stats(&window(&r, LINK_LOSS_S - 0.5, LINK_LOSS_S));
    let after = window(&r, LINK_LOSS_S, end);
    let since = |s: &RigSample| s.t_s - LINK_LOSS_S;
    let landed = after.iter().find(|s| s.truth.height_m < 0.02).map(since);
    let off = after.iter().find(|s| pins_off(s)).map(since);
    println!("fil pessimistic linkloss: {h0:.2} m at the loss, touch-down +{landed:?} s, pins off +{off:?} s");
    assert!(h0 > 1.0, "not flying at the loss\n{}", tail(r.board(), 40));
    let (landed, off) = (landed.expect("never landed"), off.expect("pins never off"));
    assert!(off >= landed, "motors off in the air: {off} s < {landed} s");
    assert!(after.iter().filter(|s| since(s) > off).all(pins_off));
}

/// The sensor board loses power in the hover at the pessimistic corner:
/// all four pins at the off pulse within 0.1 s (the output guard's 50 ms
/// and the ESC outputs' timing hold at the slow end of the cycle model).
#[test]
fn pessimistic_corner_imu_power_lost_turns_the_motors_off() {
    let Some(mut r) = corner(Scenario::Takeoff, 1, pessimistic) else {
        return;
    };
    fly_until(&mut r, FAULT_AT_S);
    r.board_mut().apply(emulator::BoardFault::ImuIntStops);
    r.board_mut().sim().inject(sim::Fault::Nack {
        address: 0x68,
        transactions: None,
    });
    fly_until(&mut r, FAULT_AT_S + 0.5);
    let off = pins_off_at(&r, FAULT_AT_S).map(|t| t - FAULT_AT_S);
    println!("fil pessimistic imu lost: pins off after {off:?} s");
    assert!(
        off.is_some_and(|d| d <= 0.1),
        "pins off after {off:?} s\n{}",
        tail(r.board(), 30)
    );
}

/// 30 ms of NACKs from the MPU-9250 in the hover at the pessimistic
/// corner: flown through (before the armed reset policy the failed
/// samples ended in MPU re-initialisations and the motors off).
#[test]
fn pessimistic_corner_flies_through_a_nack_burst() {
    let Some(mut r) = corner(Scenario::Takeoff, 1, pessimistic) else {
        return;
    };
    fly_until(&mut r, FAULT_AT_S);
    r.board_mut().sim().inject(sim::Fault::Nack {
        address: 0x68,
        transactions: Some(30),
    });
    assert_flown_through(&mut r, "pessimistic nack burst", 0.3);
}

/// The LSI at the low end of its range (30 kHz): the watchdog's timeouts
/// last twice the nominal; the take-off and hover as usual, no reset.
#[test]
fn lsi_at_30_khz_takes_off_and_hovers() {
    let Some(mut r) = corner(Scenario::Takeoff, 4, |o| o.lsi_hz = Some(30_000)) else {
        return;
    };
    assert_takes_off_and_hovers(&mut r, "lsi 30 kHz");
}

/// The LSI at the high end (60 kHz): the watchdog bites 1.5 times sooner
/// than at 40 kHz; the firmware still feeds it in time.
#[test]
fn lsi_at_60_khz_takes_off_and_hovers() {
    let Some(mut r) = corner(Scenario::Takeoff, 4, |o| o.lsi_hz = Some(60_000)) else {
        return;
    };
    assert_takes_off_and_hovers(&mut r, "lsi 60 kHz");
}

/// `runs` of the last `loop:` line the host read before `t_s`.
fn loop_runs_before(r: &FlightRig, t_s: f64) -> (u64, String) {
    let line = r
        .board()
        .log_lines()
        .iter()
        .rfind(|l| (l.host_time_ns as f64) < t_s * 1e9 && l.text.starts_with("loop:"))
        .map(|l| l.text.clone())
        .unwrap_or_else(|| panic!("no loop: line before {t_s} s\n{}", tail(r.board(), 30)));
    (field(&line, "loop:"), line)
}

/// No crystal: the firmware falls back to HSI/2 × 16 = 64 MHz (APB1
/// 32 MHz) and flies as on the crystal: the ESC pulses are 1000 µs every
/// 2.5 ms before arming (TIM3's prescaler computed for 64 MHz), the CRSF
/// link at 420 kbaud is up without a framing error (USART1's BRR for
/// 64 MHz), the sample loop runs at 1 kHz on the ground, and it takes
/// off and holds its height.
#[test]
fn the_hsi_fallback_takes_off_and_holds_its_height() {
    let Some(mut r) = corner(Scenario::Takeoff, 1, |o| o.hse_works = false) else {
        return;
    };
    fly_until(&mut r, ARM_AT_S);
    assert_logged(r.board(), "running on HSI at 64 MHz");
    // TIM3 at 64 MHz with PSC 2 ticks every 46.875 ns: 1000 µs and 2.5 ms
    // to within that tick.
    for ch in 0..4 {
        let (period, high) = r.board_mut().esc_pwm_ns(ch).expect("pulses");
        println!("fil hsi: ESC {ch} before arming: {high} ns every {period} ns");
        assert!(
            period.abs_diff(2_500_000) < 47,
            "ESC {ch}: period {period} ns"
        );
        assert!(high.abs_diff(1_000_000) < 47, "ESC {ch}: high {high} ns");
    }
    assert!(window(&r, 0.5, ARM_AT_S).iter().all(pins_off));
    let (runs, line) = loop_runs_before(&r, ARM_AT_S);
    println!("fil hsi: on the ground: {line}");
    assert!((990..=1_030).contains(&runs), "{line}");
    assert_takes_off_and_hovers(&mut r, "hsi 64 MHz");
    assert_logged(r.board(), "ARMED");
    assert_logged(r.board(), "rc: link up");
    let rc = last_channel_line(r.board(), 0);
    println!("fil hsi: {rc}");
    assert_eq!(field(&rc, "crc_err"), 0, "{rc}");
    assert_eq!(field(&rc, "fe"), 0, "{rc}");
    // Flying, with the rate loop and mixer in fixed point the loop keeps
    // its rate at 64 MHz too (with them in f32 it fell to 857 a second).
    let (runs, line) = loop_runs_before(&r, HOVER_TO_S);
    println!("fil hsi: flying: {line}");
    assert!((990..=1_030).contains(&runs), "{line}");
}
