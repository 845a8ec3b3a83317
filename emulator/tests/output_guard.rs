//! The ESC outputs when the IMU stops in flight, on the real firmware
//! (`flight::outputguard`): armed over CRSF with the throttle up, the
//! MPU-9250's INT line dies; the four outputs reach the off pulse within
//! the guard's bound and the log says why, the pilot's arm switch off
//! reaches the off pulse within 5 ms of its frame whatever the IMU does,
//! and the watchdog is not fed while the outputs run without samples.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::crsf;
use emulator::{Board, BoardFault, ResetCause};

const CRSF_BAUD: u32 = 420_000;
/// A 26-byte RC_CHANNELS frame on the line (10 bits a byte).
const FRAME_NS: u64 = 26 * 10 * 1_000_000_000 / CRSF_BAUD as u64;
/// The off pulse and frame of the standard PWM build, ns.
const OFF_NS: u64 = 1_000_000;
const PERIOD_NS: u64 = 2_500_000;
/// `flight::outputguard::NO_SAMPLE_TIMEOUT_US` and `NO_SAMPLE_BOUND_US`.
const NO_SAMPLE_TIMEOUT_NS: u64 = 50 * MS;
const NO_SAMPLE_BOUND_NS: u64 = 60 * MS;
/// `flight::outputguard::ARM_SWITCH_OFF_BOUND_US`.
const ARM_SWITCH_OFF_BOUND_NS: u64 = 5 * MS;

/// CRSF ticks for a pulse width in µs (`emulator::crsf`, written from the
/// TBS specification, not from the parser under test).
fn ticks(us: i32) -> u16 {
    crsf::ticks(u16::try_from(us).unwrap_or(0))
}

/// An RC_CHANNELS_PACKED frame: sticks centred, throttle (channel 3) at
/// `throttle_us`, arm switch (channel 5) on or off, mode switch (channel
/// 6) high: acro, where the throttle stick drives the motors directly.
fn frame(throttle_us: i32, arm: bool) -> Vec<u8> {
    let mut ch = [ticks(1500); 16];
    ch[2] = ticks(throttle_us);
    ch[4] = ticks(if arm { 2000 } else { 1000 });
    ch[5] = ticks(2000);
    crsf::rc_frame(ch)
}

fn send(b: &mut Board, f: &[u8]) {
    b.apply(BoardFault::UsartRx {
        bytes: f.to_vec(),
        baud: CRSF_BAUD,
    });
}

/// Sends `f` every 4 ms (250 Hz) for `ns`.
fn stream(b: &mut Board, f: &[u8], ns: u64) {
    let end = b.now_ns() + ns;
    while b.now_ns() < end {
        send(b, f);
        run_for(b, 4 * MS);
    }
}

fn all_off(b: &mut Board) -> bool {
    (0..4).all(|ch| b.esc_pwm_ns(ch) == Some((PERIOD_NS, OFF_NS)))
}

/// High times of the four outputs now (0 for a silent pin).
fn highs(b: &mut Board) -> [u64; 4] {
    [0, 1, 2, 3].map(|ch| b.esc_pwm_ns(ch).map_or(0, |o| o.1))
}

/// Boots (ideal sensors: the start-up gyro bias completes), brings the
/// link up, arms in acro and raises the throttle to 1500 µs: all four
/// outputs well above idle. Skipped (`None`) without the ELF.
fn armed_with_throttle_up() -> Option<Board> {
    let mut b = board_with(|c| c.sim.errors = sim::SensorErrors::ideal())?;
    assert!(wait_for_gyro_bias(&mut b), "{}", tail(&b, 30));
    // The link counts as up after 0.5 s of steady frames.
    stream(&mut b, &frame(1000, false), 700 * MS);
    assert_link_up_after(&b, 0);
    let t = b.now_ns();
    stream(&mut b, &frame(1000, true), 100 * MS);
    assert!(
        !lines_after(&b, t, "flight: ARMED").is_empty(),
        "{}",
        tail(&b, 30)
    );
    stream(&mut b, &frame(1500, true), 200 * MS);
    let h = highs(&mut b);
    assert!(
        h.iter().all(|&x| x > OFF_NS + OFF_NS / 4),
        "throttle up: {h:?}\n{}",
        tail(&b, 20)
    );
    Some(b)
}

/// Runs in 0.25 ms steps, sending `f` every 4 ms, until all four outputs
/// carry the off pulse or `max_ns` passes; when they did.
fn until_all_off(b: &mut Board, f: &[u8], max_ns: u64) -> Option<u64> {
    let start = b.now_ns();
    let mut next_frame = start;
    while b.now_ns() < start + max_ns {
        if b.now_ns() >= next_frame {
            send(b, f);
            next_frame += 4 * MS;
        }
        run_for(b, 250_000);
        if all_off(b) {
            return Some(b.now_ns());
        }
    }
    None
}

/// Armed at half throttle, the INT line dies: no sample reaches the flight
/// controller, yet the outputs reach the off pulse within the guard's
/// bound (50 ms without a sample step, checked every 5–6 ms, plus the PWM
/// frame in flight), and not before the timeout; the log says why. The
/// pilot keeps the switch on and the throttle up throughout.
#[test]
fn outputs_go_off_when_the_imu_stops_while_armed() {
    let Some(mut b) = armed_with_throttle_up() else {
        return;
    };
    let dead_at = b.now_ns();
    b.apply(BoardFault::ImuIntStops);
    let off_at = until_all_off(&mut b, &frame(1500, true), 300 * MS);
    let Some(off_at) = off_at else {
        panic!(
            "outputs still {:?} 300 ms after the IMU stopped\n{}",
            highs(&mut b),
            tail(&b, 30)
        );
    };
    let took = off_at - dead_at;
    println!(
        "off pulse on all four {} µs after the last sample",
        took / 1_000
    );
    assert!(
        (NO_SAMPLE_TIMEOUT_NS..=NO_SAMPLE_BOUND_NS).contains(&took),
        "off after {took} ns"
    );
    run_for(&mut b, 5 * MS);
    assert!(
        !lines_after(&b, dead_at, "outputs: forced off: no IMU sample for 50 ms").is_empty(),
        "{}",
        tail(&b, 30)
    );
    // Held off while the pilot still asks for throttle.
    stream(&mut b, &frame(1500, true), 100 * MS);
    assert!(all_off(&mut b), "{:?}", highs(&mut b));
}

/// Armed at half throttle with the IMU dead for 10 ms (the no-sample
/// timeout has not run out): the arm switch off reaches the off pulse on
/// all four pins within 5 ms of the end of its frame, from the receiver's
/// task alone.
#[test]
fn arm_switch_off_reaches_the_off_pulse_with_the_imu_dead() {
    let Some(mut b) = armed_with_throttle_up() else {
        return;
    };
    let dead_at = b.now_ns();
    b.apply(BoardFault::ImuIntStops);
    // Frames keep coming with the switch on until 10 ms after.
    stream(&mut b, &frame(1500, true), 8 * MS);
    run_until(&mut b, dead_at + 10 * MS);
    assert!(
        !all_off(&mut b),
        "off before the switch: {:?}",
        highs(&mut b)
    );
    let sent_at = b.now_ns();
    let off_at = until_all_off(&mut b, &frame(1500, false), 30 * MS);
    let Some(off_at) = off_at else {
        panic!("outputs {:?}\n{}", highs(&mut b), tail(&b, 30));
    };
    let took = off_at - (sent_at + FRAME_NS);
    println!("off pulse on all four {} µs after the frame", took / 1_000);
    assert!(took <= ARM_SWITCH_OFF_BOUND_NS, "off after {took} ns");
    assert!(
        off_at < dead_at + NO_SAMPLE_TIMEOUT_NS,
        "the switch, not the timeout"
    );
    run_for(&mut b, 5 * MS);
    assert!(
        !lines_after(&b, sent_at, "outputs: forced off: the arm switch went off").is_empty(),
        "{}",
        tail(&b, 30)
    );
}

/// The watchdog with the IMU dead while armed: not fed once the last
/// sample step is more than 50 ms old (the outputs ran without samples,
/// then were forced off with the MPU still reporting healthy: a dead INT
/// line), so it resets the MCU one watchdog timeout (750 ms at the
/// default 40 kHz LSI) after the last feed, within 50 ms + one 50 ms log
/// period of the INT stopping; the board boots into the off pulse.
#[test]
fn the_watchdog_is_not_fed_while_armed_without_samples() {
    let Some(mut b) = armed_with_throttle_up() else {
        return;
    };
    let dead_at = b.now_ns();
    b.apply(BoardFault::ImuIntStops);
    let f = frame(1500, true);
    while resets_after_power_on(&b).is_empty() && b.now_ns() < dead_at + 2 * S {
        send(&mut b, &f);
        run_for(&mut b, 4 * MS);
    }
    assert_eq!(
        resets_after_power_on(&b).first(),
        Some(&ResetCause::Watchdog),
        "{}",
        tail(&b, 30)
    );
    let reset_at = b.resets()[1].0;
    let after = reset_at - dead_at;
    println!("watchdog reset {} ms after the IMU stopped", after / MS);
    let timeout = 750 * MS;
    assert!(
        (timeout..=timeout + 100 * MS).contains(&after),
        "reset {after} ns after the IMU stopped"
    );
    run_until(&mut b, reset_at + 50 * MS);
    assert!(all_off(&mut b), "after the reset: {:?}", highs(&mut b));
}
