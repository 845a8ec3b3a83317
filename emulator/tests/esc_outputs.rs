//! ESC outputs and the CRSF receiver on the real firmware: the off pulse on
//! TIM3 CH1–CH4 (PA6, PA7, PB0, PB1) from the first boot steps and again
//! after a watchdog reset; CRSF frames on USART1 RX reach the firmware and
//! signal loss is seen.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::{Board, BoardFault};

/// The protocol the firmware was built for, from its `outputs:` boot line:
/// (frame period, off pulse) in ns. Standard PWM: 2.5 ms and 1000 µs;
/// OneShot125 (`--features oneshot125`): 0.5 ms and 125 µs.
fn protocol(b: &Board) -> (u64, u64) {
    let line = lines_with(b, "outputs:")
        .last()
        .cloned()
        .unwrap_or_else(|| panic!("no outputs line\n{}", tail(b, 20)));
    if line.contains("OneShot125") {
        (500_000, 125_000)
    } else {
        assert!(
            line.contains("Pwm on TIM3") && line.contains("400 Hz"),
            "{line}"
        );
        (2_500_000, 1_000_000)
    }
}
const CRSF_BAUD: u32 = 420_000;

fn outputs(b: &mut Board) -> [Option<(u64, u64)>; 4] {
    [0, 1, 2, 3].map(|ch| b.esc_pwm_ns(ch))
}

fn assert_off(b: &mut Board, when: &str) {
    let want = protocol(b);
    let o = outputs(b);
    assert!(
        o.iter().all(|&x| x == Some(want)),
        "{when}: outputs {o:?}, want the off pulse {want:?}\n{}",
        tail(b, 30)
    );
}

/// The pin really toggles: high for the off pulse, low for the rest, over
/// one frame sampled every 10 µs.
fn measured_high_ns(b: &mut Board, port: usize, pin: u32) -> u64 {
    let step = 10_000;
    let mut high = 0;
    let end = b.now_ns() + protocol(b).0;
    while b.now_ns() < end {
        if b.pin_high(port, pin) {
            high += step;
        }
        let t = b.now_ns() + step;
        run_until(b, t);
    }
    high
}

#[test]
fn outputs_carry_the_off_pulse_from_boot() {
    let Some(mut b) = board() else { return };
    // Before any sensor is probed (the MPU-9250 needs 100 ms after power-up).
    let line = b.wait_for_line("outputs:", 50 * MS).unwrap();
    assert!(line.is_some(), "no outputs line\n{}", tail(&b, 20));
    assert_logged(&b, "on TIM3 CH1-4 (PA6 PA7 PB0 PB1)");
    let (_, off_ns) = protocol(&b);
    assert!(lines_with(&b, "probe ").is_empty(), "outputs after probing");
    assert_off(&mut b, "at the outputs step");
    boot_ok(&mut b);
    run_until(&mut b, 2 * S);
    assert_off(&mut b, "disarmed at 2 s");
    for (port, pin) in emulator::TIM3_PINS {
        let high = measured_high_ns(&mut b, port, pin);
        assert!(
            (off_ns - 10_000..=off_ns + 10_000).contains(&high),
            "pin {port}/{pin}: high {high} ns per frame"
        );
    }
    assert_no_reset(&b);
}

#[test]
fn outputs_return_to_the_off_pulse_after_a_watchdog_reset() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, S);
    assert_off(&mut b, "before the reset");
    b.apply(BoardFault::ImuIntStops);
    let mut t = b.now_ns();
    while resets_after_power_on(&b).is_empty() && t < 3 * S {
        t += MS;
        run_until(&mut b, t);
    }
    assert_eq!(
        resets_after_power_on(&b).first(),
        Some(&emulator::ResetCause::Watchdog)
    );
    // Reset state: the pins are inputs, no pulses.
    assert_eq!(outputs(&mut b), [None; 4], "right after the reset");
    let reset_at = b.resets()[1].0;
    run_until(&mut b, reset_at + 50 * MS);
    assert!(!lines_after(&b, reset_at, "outputs:").is_empty());
    assert_off(&mut b, "50 ms after the watchdog reset");
}

/// CRC-8/DVB-S2 (polynomial 0xD5), the CRSF frame check. Written again on
/// purpose (not `rc_input::crc8_dvb_s2`): the frames the board receives must
/// not come from the crate whose parser they test.
fn crc8_dvb_s2(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |mut crc, &b| {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ 0xD5
            } else {
                crc << 1
            };
        }
        crc
    })
}

/// An RC_CHANNELS_PACKED frame (type 0x16) to the flight controller
/// (0xC8): 16 channels of 11 bits, little-endian, LSB first.
fn rc_frame(ticks: [u16; 16]) -> Vec<u8> {
    let mut payload = vec![0u8; 22];
    for (i, &t) in ticks.iter().enumerate() {
        for bit in 0..11 {
            if t & (1 << bit) != 0 {
                let at = i * 11 + bit;
                payload[at / 8] |= 1 << (at % 8);
            }
        }
    }
    let mut body = vec![0x16];
    body.extend_from_slice(&payload);
    let crc = crc8_dvb_s2(&body);
    let mut f = vec![0xC8, (body.len() + 1) as u8];
    f.extend_from_slice(&body);
    f.push(crc);
    f
}

/// CRSF ticks for a pulse in µs (the specification's
/// `us = (ticks − 992) · 5/8 + 1500`, inverted; exact for these values).
fn ticks(us: i32) -> u16 {
    ((us - 1500) * 8 / 5 + 992) as u16
}

/// Sends `frame` every `period_ns` until `until_ns`.
fn stream(b: &mut Board, frame: &[u8], period_ns: u64, until_ns: u64) {
    while b.now_ns() < until_ns {
        b.apply(BoardFault::UsartRx {
            bytes: frame.to_vec(),
            baud: CRSF_BAUD,
        });
        let t = b.now_ns() + period_ns;
        run_until(b, t);
    }
}

#[test]
fn crsf_frames_reach_the_firmware_and_loss_is_detected() {
    let Some(mut b) = board() else { return };
    let rx = b.wait_for_line("receiver:", 2 * S).unwrap();
    assert!(
        rx.is_some_and(|l| l.text.contains("CRSF on USART1 RX (PA10), 420000 baud")),
        "{}",
        tail(&b, 20)
    );
    let mut ch = [ticks(1500); 16];
    ch[2] = ticks(1000); // throttle low (AETR)
    ch[4] = ticks(2000); // a switch high
    let frame = rc_frame(ch);
    // 250 Hz, as ExpressLRS sends by default.
    let start = b.now_ns();
    stream(&mut b, &frame, 4 * MS, start + 1_500 * MS);
    assert!(
        !lines_after(&b, start, "rc: link up").is_empty(),
        "{}",
        tail(&b, 40)
    );
    let rc = lines_after(&b, start, "rc: ch1-8");
    let last = rc
        .last()
        .unwrap_or_else(|| panic!("no channel line\n{}", tail(&b, 40)));
    assert!(
        last.contains("[1500, 1500, 1000, 1500, 2000, 1500, 1500, 1500]"),
        "{last}"
    );
    assert!(last.contains("crc_err 0"), "{last}");
    assert!(last.contains("fe 0"), "{last}");
    // defmt-rtt encodes each log message with interrupts disabled; a long
    // line outlasts a byte time (24 µs) and the USART overruns. A lost
    // byte costs its frame (dropped, never misparsed): allow 5 %.
    let (received, overruns) = b.usart1_counts();
    let sent = 1_500 / 4;
    assert!(received + overruns >= 26 * (sent - 2), "{received} bytes");
    let (frames, dropped) = (field(last, "frames "), field(last, "dropped "));
    assert!(frames >= 200 && dropped * 20 <= frames, "{last}");
    // Stop sending: lost within the 100 ms timeout plus one 50 ms log tick.
    let stop = b.now_ns();
    run_until(&mut b, stop + 200 * MS);
    let lost = lines_after(&b, stop, "rc: link lost");
    assert!(
        lost.first().is_some_and(|l| l.contains("TimedOut")),
        "{lost:?}\n{}",
        tail(&b, 20)
    );
    assert_no_reset(&b);
}

#[test]
fn corrupted_crsf_frames_are_dropped_and_counted() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    let mut bad = rc_frame([ticks(1500); 16]);
    bad[10] ^= 0x40;
    let start = b.now_ns();
    stream(&mut b, &bad, 4 * MS, start + 500 * MS);
    assert!(
        lines_after(&b, start, "rc: link up").is_empty(),
        "a frame with a bad CRC counted as a link\n{}",
        tail(&b, 20)
    );
    // Then good frames: the counters show the earlier CRC errors.
    let good = rc_frame([ticks(1500); 16]);
    stream(&mut b, &good, 4 * MS, start + 1_600 * MS);
    let rc = lines_after(&b, start, "rc: ch1-8");
    let last = rc.last().unwrap_or_else(|| panic!("{}", tail(&b, 30)));
    assert!(field(last, "crc_err ") >= 100, "{last}");
}

/// The number after `key` in a log line (0 if absent).
fn field(line: &str, key: &str) -> u64 {
    line.split(key)
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or(0)
}

/// Sends `frame` every 4 ms (250 Hz) until a log line containing
/// `pattern` appears (returned) or `timeout_ns` passes.
fn stream_until(b: &mut Board, frame: &[u8], pattern: &str, timeout_ns: u64) -> Option<String> {
    let start = b.now_ns();
    while b.now_ns() < start + timeout_ns {
        b.apply(BoardFault::UsartRx {
            bytes: frame.to_vec(),
            baud: CRSF_BAUD,
        });
        let t = b.now_ns() + 4 * MS;
        run_until(b, t);
        if let Some(l) = lines_after(b, start, pattern).first() {
            return Some(l.clone());
        }
    }
    None
}

/// Sticks centred, throttle at `throttle_us`, arm switch (channel 5) on or
/// off, mode switch (channel 6) low: angle mode.
fn sticks(throttle_us: i32, arm: bool) -> Vec<u8> {
    let mut ch = [ticks(1500); 16];
    ch[2] = ticks(throttle_us);
    ch[4] = ticks(if arm { 2000 } else { 1000 });
    ch[5] = ticks(1000);
    rc_frame(ch)
}

/// Arming on the real firmware: refused with the throttle high (reason in
/// the log), armed with the throttle low and the switch, idle pulses while
/// armed, and on signal loss failsafe, disarm and the off pulse. The
/// firmware must report a ready flight controller at boot.
#[test]
fn arming_refusal_arming_idle_and_failsafe_on_signal_loss() {
    // Ideal sensors: with the simulator's default noise the start-up gyro
    // bias restarts until it gives up on the emulated board, and arming is
    // then refused for it (checked below when it happens).
    let Some(mut b) = board_with(|c| c.sim.errors = sim::SensorErrors::ideal()) else {
        return;
    };
    let fc = b.wait_for_line("flight controller:", 2 * S).unwrap();
    assert!(
        fc.as_ref().is_some_and(|l| l.text.contains("ready")),
        "flight controller not ready at boot: {:?}",
        fc.map(|l| l.text)
    );
    // The start-up gyro bias needs 1 s of stillness after the probe.
    let mut t = b.now_ns();
    let bias_ended = |b: &Board| {
        !lines_with(b, "gyro bias: Done").is_empty()
            || !lines_with(b, "gyro bias: GaveUp").is_empty()
    };
    while !bias_ended(&b) && t < 8 * S {
        t += 100 * MS;
        run_until(&mut b, t);
    }
    let bias_done = !lines_with(&b, "gyro bias: Done").is_empty();

    let up = stream_until(&mut b, &sticks(1500, false), "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    let refused = stream_until(&mut b, &sticks(1500, true), "flight: arm refused", S);
    // The first reason in the controller's order of checks.
    let reason = if bias_done {
        "ThrottleNotLow"
    } else {
        "GyroBiasPending"
    };
    assert!(
        refused.as_ref().is_some_and(|l| l.contains(reason)),
        "{refused:?}\n{}",
        tail(&b, 30)
    );
    assert_off(&mut b, "after the refusal");
    if !bias_done {
        println!("skipped the rest: the start-up gyro bias gave up on the emulated board");
        return;
    }

    stream_until(&mut b, &sticks(1000, false), "never", 300 * MS);
    let armed = stream_until(&mut b, &sticks(1000, true), "flight: ARMED", S);
    assert!(armed.is_some(), "{}", tail(&b, 30));
    stream_until(&mut b, &sticks(1000, true), "never", 100 * MS);
    for (ch, o) in outputs(&mut b).into_iter().enumerate() {
        let (period, high) = o.unwrap_or_else(|| panic!("channel {ch} silent"));
        let (period_ns, off_ns) = protocol(&b);
        assert_eq!(period, period_ns);
        // Idle: a few % of the command range (off to twice off) above off.
        assert!(
            (off_ns + off_ns / 100..off_ns + off_ns / 5).contains(&high),
            "armed, throttle low: channel {ch} at {high} ns, want idle above the off pulse"
        );
    }

    // Signal loss: stop sending.
    let lost_at = b.now_ns();
    let disarmed = b.wait_for_line("flight: disarmed", 7 * S).unwrap();
    assert!(
        !lines_after(&b, lost_at, "flight: FailsafeHold").is_empty(),
        "no failsafe\n{}",
        tail(&b, 40)
    );
    assert!(disarmed.is_some(), "{}", tail(&b, 40));
    let t = b.now_ns() + 10 * MS;
    run_until(&mut b, t);
    assert_off(&mut b, "after the failsafe disarm");
    for l in lines_with(&b, "flight") {
        println!("{l}");
    }
    assert_no_reset(&b);
}

/// Sticks centred, throttle at `throttle_us`, arm switch off, mode switch
/// low, motor-test switch (channel 7) on or off.
fn motor_test_frame(throttle_us: i32, test_switch: bool) -> Vec<u8> {
    let mut ch = [ticks(1500); 16];
    ch[2] = ticks(throttle_us);
    ch[4] = ticks(1000);
    ch[5] = ticks(1000);
    ch[6] = ticks(if test_switch { 2000 } else { 1000 });
    rc_frame(ch)
}

/// Which channels carry more than the off pulse, and at what high time.
fn spinning(b: &mut Board) -> Vec<(usize, u64)> {
    let (_, off_ns) = protocol(b);
    outputs(b)
        .into_iter()
        .enumerate()
        .filter_map(|(ch, o)| {
            let (_, high) = o.unwrap_or_else(|| panic!("channel {ch} silent"));
            (high != off_ns).then_some((ch, high))
        })
        .collect()
}

/// The props-off motor test from the transmitter on the real firmware:
/// the switch on at boot spins nothing; each off → on flip puts exactly
/// one output at the test pulse (8 % of the range above the off pulse:
/// 1080 µs in standard PWM, 135 µs in OneShot125) and the others at the
/// off pulse, motor 1 then motor 2; the switch off or a throttle movement
/// ends it.
#[test]
fn motor_test_switch_spins_one_motor_per_flip() {
    let Some(mut b) = board() else { return };
    let fc = b.wait_for_line("flight controller:", 2 * S).unwrap();
    assert!(
        fc.as_ref()
            .is_some_and(|l| l.text.contains("motor-test channel 7")),
        "{:?}\n{}",
        fc.map(|l| l.text),
        tail(&b, 20)
    );
    let (_, off_ns) = protocol(&b);
    // A command of 0.08 spans 8 % of the off pulse (the range is off..2·off).
    let test_ns = off_ns + off_ns * 8 / 100;
    let on = motor_test_frame(1000, true);
    let off = motor_test_frame(1000, false);

    // Switch on from the first frame: an edge is needed, nothing spins.
    let up = stream_until(&mut b, &on, "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    let start = b.now_ns();
    stream(&mut b, &on, 4 * MS, start + 1_000 * MS);
    assert!(
        lines_after(&b, start, "motor test").is_empty(),
        "switch on at boot started a motor\n{}",
        tail(&b, 20)
    );
    assert_off(&mut b, "motor-test switch on since the link came up");

    for (motor, position) in [(1, "RearRight"), (2, "FrontRight")] {
        let t = b.now_ns();
        stream(&mut b, &off, 4 * MS, t + 100 * MS);
        assert_off(&mut b, "switch off");
        let started = stream_until(&mut b, &on, "motor test:", S);
        let want = format!("motor test: motor {motor} ({position}) at 8 %");
        assert!(
            started.as_ref().is_some_and(|l| l.contains(&want)),
            "{started:?}, want {want}\n{}",
            tail(&b, 20)
        );
        // The preloaded compare takes effect with the next timer frame.
        let t = b.now_ns();
        stream(&mut b, &on, 4 * MS, t + 20 * MS);
        let s = spinning(&mut b);
        assert_eq!(s.len(), 1, "motor {motor}: spinning {s:?}");
        let (ch, high) = s[0];
        assert_eq!(ch, motor - 1, "motor {motor} is TIM3 CH{motor}");
        assert!(
            high.abs_diff(test_ns) <= off_ns / 200,
            "motor {motor}: {high} ns, want {test_ns} ns"
        );
        // Held on: still spinning 1 s later.
        let t = b.now_ns();
        stream(&mut b, &on, 4 * MS, t + 1_000 * MS);
        assert_eq!(spinning(&mut b), s, "motor {motor} after 1 s");
        if motor == 1 {
            let t = b.now_ns();
            let ended = stream_until(&mut b, &off, "MotorTestEnded", S);
            assert!(
                ended.as_ref().is_some_and(|l| l.contains("SwitchOff")),
                "{ended:?}"
            );
            stream(&mut b, &off, 4 * MS, t + 200 * MS);
            assert_off(&mut b, "after the switch went off");
        }
    }
    // Throttle moved with motor 2 running: back to off.
    let ended = stream_until(&mut b, &motor_test_frame(1300, true), "MotorTestEnded", S);
    assert!(
        ended.as_ref().is_some_and(|l| l.contains("StickMoved")),
        "{ended:?}\n{}",
        tail(&b, 20)
    );
    let t = b.now_ns();
    stream(&mut b, &motor_test_frame(1300, true), 4 * MS, t + 20 * MS);
    assert_off(&mut b, "after the throttle moved");
    for l in lines_with(&b, "motor test") {
        println!("{l}");
    }
    assert_no_reset(&b);
}
