//! ESC outputs and the CRSF receiver on the real firmware: the off pulse on
//! TIM3 CH1–CH4 (PA6, PA7, PB0, PB1) from the first boot steps and again
//! after a watchdog reset; CRSF frames on USART1 RX reach the firmware (by
//! DMA1 channel 5), every one of them while the firmware logs, and signal
//! loss is seen.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::crsf::{self, crc8_dvb_s2, rc_frame};
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
            line.contains("standard PWM (1000-2000 us) on TIM3") && line.contains("400 Hz"),
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
        run_for(b, step);
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

/// CRSF ticks for a pulse width in µs. The frames come from
/// `emulator::crsf`, written from the TBS specification on purpose, not
/// from `rc_input`: the frames the board receives must not come from the
/// crate whose parser they test.
fn ticks(us: i32) -> u16 {
    crsf::ticks(u16::try_from(us).unwrap_or(0))
}

/// Sends `frame` every `period_ns` until `until_ns`; when each was sent.
fn stream(b: &mut Board, frame: &[u8], period_ns: u64, until_ns: u64) -> Vec<u64> {
    let mut sent_at = Vec::new();
    while b.now_ns() < until_ns {
        sent_at.push(b.now_ns());
        b.apply(BoardFault::UsartRx {
            bytes: frame.to_vec(),
            baud: CRSF_BAUD,
        });
        run_for(b, period_ns);
    }
    sent_at
}

#[test]
fn crsf_frames_reach_the_firmware_and_loss_is_detected() {
    let Some(mut b) = board() else { return };
    let rx = b.wait_for_line("receiver:", 2 * S).unwrap();
    assert!(
        rx.is_some_and(|l| l
            .text
            .contains("CRSF on USART1 RX (PA10), 420000 baud, DMA1 channel 5")),
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
    assert_link_up_after(&b, start);
    let last = last_channel_line(&b, start);
    assert!(
        last.contains("[1500, 1500, 1000, 1500, 2000, 1500, 1500, 1500]"),
        "{last}"
    );
    assert!(last.contains("crc_err 0"), "{last}");
    assert!(last.contains("fe 0"), "{last}");
    // The DMA empties DR as each byte lands, whatever the CPU does.
    let (received, overruns) = b.usart1_counts();
    let sent = 1_500 / 4;
    assert!(received >= 26 * (sent - 2), "{received} bytes");
    assert_eq!(overruns, 0);
    assert_eq!(b.dma1_served()[4], received, "every byte by DMA1 channel 5");
    let (frames, dropped) = (field(&last, "frames "), field(&last, "dropped "));
    assert!(frames >= 200 && dropped == 0, "{last}");
    assert_link_times_out(&mut b);
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
    // Then good frames: the counters show the earlier CRC errors (the link
    // is up 0.5 s after the first good frame, the channel line comes once a
    // second while it is up).
    let good = rc_frame([ticks(1500); 16]);
    stream(&mut b, &good, 4 * MS, start + 2_100 * MS);
    let last = last_channel_line(&b, start);
    assert!(field(&last, "crc_err ") >= 100, "{last}");
}

/// Frames every 4 ms for 4 s while the firmware logs as much as it ever
/// does: the 20 Hz live log for 2 s, then the raw log at 100 Hz (a short
/// button press switches to it), and throughout the flight log (the arm
/// switch flipped every 100 ms with the throttle high: an arming refusal
/// on every flip to high). defmt-rtt encodes each line with interrupts
/// disabled, longer than a byte time for a long line: a receiver taking
/// each byte in its own interrupt overruns then (on about 1 frame in 60
/// here). With the DMA ring no byte is lost, every frame is parsed and the
/// link never drops.
#[test]
fn every_crsf_frame_is_parsed_while_the_firmware_logs() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, 1_500 * MS);
    let start = b.now_ns();
    let mut sent_at = Vec::new();
    let (high, low) = (sticks(1800, true), sticks(1800, false));
    while b.now_ns() < start + 4 * S {
        let flip = (b.now_ns() - start) / (100 * MS);
        if flip == 20 || flip == 21 {
            b.apply(BoardFault::Button(flip == 20));
        }
        let frame = if flip % 2 == 1 { &high } else { &low };
        sent_at.push(b.now_ns());
        b.apply(BoardFault::UsartRx {
            bytes: frame.clone(),
            baud: CRSF_BAUD,
        });
        let t = b.now_ns() + 4 * MS;
        run_until(&mut b, t);
    }
    let sent = sent_at.len() as u64;
    // The logging this test is about happened.
    let raw_rows = lines_after(&b, start, ",nan,nan,nan,nan,0").len();
    let refusals = lines_after(&b, start, "flight: arm refused").len();
    let live = lines_after(&b, start, "att r=").len();
    // The raw log opens with the header the replay tool reads.
    let header = sensor_stack::calmode::RAW_LOG_HEADER;
    assert!(
        b.log_lines().iter().any(|l| l.text.ends_with(header)),
        "no raw-log header\n{}",
        tail(&b, 30)
    );
    assert!(
        raw_rows >= 150 && refusals >= 15 && live >= 35,
        "raw {raw_rows}, refusals {refusals}, live {live}\n{}",
        tail(&b, 30)
    );
    let (received, overruns) = b.usart1_counts();
    assert_eq!((received, overruns), (26 * sent, 0), "bytes, overruns");
    assert_eq!(b.dma1_served()[4], received);
    // Half and complete marks of the 128 B ring: one per 64 bytes.
    let marks = b.exception_entries(emulator::DMA1_CHANNEL5_IRQ);
    assert!(marks + 2 >= received / 64, "{marks} DMA interrupts");
    assert!(
        lines_after(&b, start, "rc: link lost").is_empty(),
        "{}",
        tail(&b, 40)
    );
    // Each once-a-second counter line: nothing dropped, no CRC error, no
    // UART error, and every frame sent 3.5 ms (a frame, the handover and
    // the 1 ms RTT poll) before the line was read was parsed.
    let rc: Vec<_> = b
        .log_lines()
        .iter()
        .filter(|l| l.host_time_ns >= start && l.text.contains("rc: ch1-8"))
        .cloned()
        .collect();
    assert!(rc.len() >= 3, "{}", tail(&b, 30));
    let mut last_frames = 0;
    for l in &rc {
        for key in ["crc_err ", "dropped ", "ore ", "fe "] {
            assert_eq!(field(&l.text, key), 0, "{key}in {}", l.text);
        }
        let frames = field(&l.text, "frames ");
        let done = sent_at
            .iter()
            .filter(|&&t| t + 3_500_000 <= l.host_time_ns)
            .count() as u64;
        let begun = sent_at.iter().filter(|&&t| t <= l.host_time_ns).count() as u64;
        assert!(
            (done..=begun).contains(&frames),
            "{frames} frames parsed, {done}..={begun} sent: {}",
            l.text
        );
        last_frames = frames;
    }
    println!(
        "{sent} frames sent, {last_frames} parsed by the last counter line; \
         {raw_rows} raw rows, {refusals} arming refusals, {live} live lines"
    );
    assert_no_reset(&b);
}

/// A receiver that never links up is diagnosable from the log: with
/// nothing on PA10 the board says so every second; with a receiver on the
/// wrong baud rate (CRSF frames at 115,200 baud) it counts the bytes and
/// their framing errors and parses no frame; with the right one the
/// diagnosis stops and the link comes up.
#[test]
fn a_receiver_that_never_links_is_diagnosed_in_the_log() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, 3 * S);
    let silent = lines_with(&b, "rc: no link: no bytes at all on PA10");
    assert!(silent.len() >= 2, "once a second\n{}", tail(&b, 30));
    let t0 = b.now_ns();
    let frame = sticks(1000, false);
    let mut next = t0;
    while b.now_ns() < t0 + 3 * S {
        while next < b.now_ns() + 50 * MS {
            b.usart1_send_at(&frame, 115_200, next);
            next += 4 * MS;
        }
        run_for(&mut b, 2 * MS);
    }
    let wrong = lines_after(&b, t0 + 1_100 * MS, "rc: no link: PA10");
    let last = wrong.last().unwrap_or_else(|| panic!("{}", tail(&b, 30)));
    assert!(field(last, "bytes ") > 100, "{last}");
    assert_eq!(field(last, "frames "), 0, "{last}");
    assert!(field(last, "fe ") > 10, "{last}");
    assert!(lines_after(&b, t0 + 1_100 * MS, "no bytes at all").is_empty());
    let t1 = b.now_ns();
    let up = stream_until(&mut b, &frame, "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    stream_until(&mut b, &frame, "never logged", 1_500 * MS);
    let since = lines_after(&b, t1 + 600 * MS, "rc: no link");
    assert!(since.is_empty(), "{since:?}");
}

/// A byte with a framing error early in a burst long enough to cross a
/// half-ring mark: the handover at the mark reads SR (FE set), the DMA's
/// next DR read completes FE's clear sequence before the burst's IDLE, and
/// the error must still be counted, once per burst.
#[test]
fn a_framing_error_before_a_half_ring_mark_is_counted() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    let good = rc_frame([ticks(1500); 16]);
    let up = stream_until(&mut b, &good, "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    for _ in 0..3 {
        // One byte sent 30 % slow (outside the receiver's 3.75 %
        // tolerance: FE), then four frames back to back: 105 bytes.
        let now = b.now_ns();
        b.usart1_send_at(&[0x00], 300_000, now);
        b.usart1_send_at(&good.repeat(4), CRSF_BAUD, now);
        let t = b.now_ns() + 10 * MS;
        run_until(&mut b, t);
        stream(&mut b, &good, 4 * MS, t + 100 * MS);
    }
    let t = b.now_ns();
    stream(&mut b, &good, 4 * MS, t + 1_100 * MS);
    let last = last_channel_line(&b, t);
    assert_eq!(field(&last, "fe "), 3, "{last}");
    assert_eq!(field(&last, "ore "), 0, "{last}");
}

/// A LINK_STATISTICS frame (type 0x14) with uplink link quality `lq`.
fn link_stats_frame(lq: u8) -> Vec<u8> {
    let mut body = vec![0x14, 60, 60, lq, 10, 0, 4, 2, 70, 100, 8];
    let crc = crc8_dvb_s2(&body);
    let mut f = vec![0xC8, (body.len() + 1) as u8];
    f.append(&mut body);
    f.push(crc);
    f
}

/// The IDLE line is the parser's frame boundary: the head of a frame cut
/// off by a receiver glitch is abandoned when the line goes idle (one
/// frame dropped, counted as such, and no CRC error: without the boundary
/// its length byte would swallow the next frame's first bytes and fail the
/// CRC), and frames back to back in one burst, with no idle between them,
/// are all parsed, also a burst of 11 frames (300 B) longer than the ring,
/// handed over at its half and complete marks.
#[test]
fn a_torn_frame_ends_at_the_idle_line_and_back_to_back_frames_parse() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    let good = sticks(1000, false);
    let start = b.now_ns();
    let mut sent_at = stream(&mut b, &good, 4 * MS, start + 200 * MS);
    b.apply(BoardFault::UsartRx {
        bytes: good[..10].to_vec(),
        baud: CRSF_BAUD,
    });
    run_for(&mut b, 3 * MS);
    let mut burst = good.repeat(10);
    burst.extend(link_stats_frame(87));
    sent_at.extend([b.now_ns(); 10]);
    b.apply(BoardFault::UsartRx {
        bytes: burst,
        baud: CRSF_BAUD,
    });
    let t = b.now_ns() + 10 * MS;
    run_until(&mut b, t);
    sent_at.extend(stream(&mut b, &good, 4 * MS, t + 1_200 * MS));
    let last = last_channel_line(&b, start);
    assert!(last.contains("lq 87 %"), "{last}");
    // Every good frame sent 10 ms before the line was read was parsed
    // (the burst's take 7 ms), none of the torn one.
    let line = b
        .log_lines()
        .iter()
        .rev()
        .find(|l| l.text.contains("rc: ch1-8"))
        .map_or(0, |l| l.host_time_ns);
    let done = sent_at.iter().filter(|&&t| t + 10 * MS <= line).count() as u64;
    let begun = sent_at.iter().filter(|&&t| t <= line).count() as u64;
    let frames = field(&last, "frames ");
    assert!((done..=begun).contains(&frames), "{done}..={begun}: {last}");
    assert_eq!(field(&last, "dropped "), 1, "{last}");
    assert_eq!(field(&last, "crc_err "), 0, "{last}");
    assert_eq!(b.usart1_counts().1, 0);
    assert!(lines_after(&b, start, "rc: link lost").is_empty());
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
        run_for(b, 4 * MS);
        if let Some(l) = lines_after(b, start, pattern).first() {
            return Some(l.clone());
        }
    }
    None
}

/// Sticks centred, throttle at `throttle_us`, arm switch (channel 5) on or
/// off, mode switch (channel 6) low: angle mode.
fn sticks(throttle_us: i32, arm: bool) -> Vec<u8> {
    sticks_in_mode(throttle_us, arm, 1000)
}

/// As [`sticks`], mode switch (channel 6) high: acro, the one mode that
/// arms without an accelerometer calibration (the emulated flash page is
/// blank).
fn acro_sticks(throttle_us: i32, arm: bool) -> Vec<u8> {
    sticks_in_mode(throttle_us, arm, 2000)
}

fn sticks_in_mode(throttle_us: i32, arm: bool, mode_us: i32) -> Vec<u8> {
    let mut ch = [ticks(1500); 16];
    ch[2] = ticks(throttle_us);
    ch[4] = ticks(if arm { 2000 } else { 1000 });
    ch[5] = ticks(mode_us);
    rc_frame(ch)
}

/// Arming on the real firmware with a board's datasheet sensor errors
/// (noise, gyro bias, scale errors): the start-up gyro bias completes,
/// arming is refused with the throttle high (reason in the log), refused in
/// angle mode without an accelerometer calibration, armed in acro with the
/// throttle low and the switch, idle pulses while armed, and on signal loss
/// failsafe, disarm and the off pulse. The firmware must report a ready
/// flight controller at boot.
#[test]
fn arming_refusal_arming_idle_and_failsafe_on_signal_loss() {
    let Some(mut b) = board_with(|c| c.sim.errors = sim::SensorErrors::datasheet(1)) else {
        return;
    };
    let fc = b.wait_for_line("flight controller:", 2 * S).unwrap();
    assert!(
        fc.as_ref().is_some_and(|l| l.text.contains("ready")),
        "flight controller not ready at boot: {:?}",
        fc.map(|l| l.text)
    );
    assert!(wait_for_gyro_bias(&mut b), "{}", tail(&b, 30));

    let up = stream_until(&mut b, &sticks(1500, false), "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    let refused = stream_until(&mut b, &sticks(1500, true), "flight: arm refused", S);
    assert!(
        refused
            .as_ref()
            .is_some_and(|l| l.contains("throttle not low")),
        "{refused:?}\n{}",
        tail(&b, 30)
    );
    assert_off(&mut b, "after the refusal");

    // Throttle low in angle mode: refused, the flash page holds no
    // accelerometer calibration. Acro arms.
    stream_until(&mut b, &sticks(1000, false), "never", 300 * MS);
    let refused = stream_until(&mut b, &sticks(1000, true), "flight: arm refused", S);
    assert!(
        refused
            .as_ref()
            .is_some_and(|l| l.contains("accelerometer not calibrated")),
        "{refused:?}\n{}",
        tail(&b, 30)
    );
    stream_until(&mut b, &acro_sticks(1000, false), "never", 300 * MS);
    let armed = stream_until(&mut b, &acro_sticks(1000, true), "flight: ARMED", S);
    assert!(armed.is_some(), "{}", tail(&b, 30));
    stream_until(&mut b, &acro_sticks(1000, true), "never", 100 * MS);
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
        !lines_after(&b, lost_at, "flight: failsafe: no link: holding level").is_empty(),
        "no failsafe\n{}",
        tail(&b, 40)
    );
    assert!(disarmed.is_some(), "{}", tail(&b, 40));
    run_for(&mut b, 10 * MS);
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

    for (motor, position) in [
        (1, "rear right, clockwise"),
        (2, "front right, counter-clockwise"),
    ] {
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
            let ended = stream_until(&mut b, &off, "motor test ended", S);
            assert!(
                ended
                    .as_ref()
                    .is_some_and(|l| l.contains("motor-test switch off")),
                "{ended:?}"
            );
            stream(&mut b, &off, 4 * MS, t + 200 * MS);
            assert_off(&mut b, "after the switch went off");
        }
    }
    // Throttle moved with motor 2 running: back to off.
    let ended = stream_until(&mut b, &motor_test_frame(1300, true), "motor test ended", S);
    assert!(
        ended.as_ref().is_some_and(|l| l.contains("a stick moved")),
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

/// One character (start, 8 data, stop bit) at 420 kbaud, ns.
const CHAR_NS: u64 = 10 * S / CRSF_BAUD as u64;

/// Channel frames every 4 ms, each sent in two pieces (13 + 13 bytes) with
/// a pause between them: one character time and a bit (25 µs, the USART
/// sees a whole idle character and raises IDLE inside the frame), 100 µs
/// and 500 µs in turn. The parser accepts a frame that lasts at most
/// 1 750 µs from its first byte to its last (this one: 619 µs + the
/// pause), so every frame is parsed and none is dropped.
#[test]
fn crsf_frames_with_pauses_inside_them_are_parsed() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    let frame = sticks(1000, false);
    let (head, rest) = frame.split_at(13);
    let pauses_ns = [25_000, 100_000, 500_000];
    let start = b.now_ns();
    let mut next = start;
    let mut sent_at = Vec::new();
    while b.now_ns() < start + 1_300 * MS {
        while next < b.now_ns() + 20 * MS {
            let pause = pauses_ns[sent_at.len() % pauses_ns.len()];
            b.usart1_send_at(head, CRSF_BAUD, next);
            b.usart1_send_at(rest, CRSF_BAUD, next + 13 * CHAR_NS + pause);
            sent_at.push(next);
            next += 4 * MS;
        }
        run_for(&mut b, 4 * MS);
    }
    assert_link_up_after(&b, start);
    let line = b
        .log_lines()
        .iter()
        .rev()
        .find(|l| l.text.contains("rc: ch1-8"))
        .cloned()
        .unwrap_or_else(|| panic!("no channel line\n{}", tail(&b, 20)));
    // Every frame sent 10 ms before the line was read was parsed (the
    // line's counters are read before it is encoded and reaches the host).
    let done = sent_at
        .iter()
        .filter(|&&t| t + 10 * MS <= line.host_time_ns);
    let begun = sent_at.iter().filter(|&&t| t <= line.host_time_ns);
    let (done, begun) = (done.count() as u64, begun.count() as u64);
    let frames = field(&line.text, "frames ");
    assert!(
        (done..=begun).contains(&frames),
        "{done}..={begun}: {} (sent from {start} ns, line at {} ns)",
        line.text,
        line.host_time_ns
    );
    assert_eq!(field(&line.text, "dropped "), 0, "{}", line.text);
    assert_eq!(field(&line.text, "crc_err "), 0, "{}", line.text);
    assert!(lines_after(&b, start, "rc: link lost").is_empty());
}

/// The link comes back after a loss: for the recovery window (0.5 s of
/// frames without a break) it does not count as up, so an arm-switch flip
/// inside the window does not arm; "rc: link up" comes 0.5 s after the
/// first frame, and a flip after it arms. The first link-up after boot
/// waits the same 0.5 s.
#[test]
fn arming_waits_for_the_recovery_window_after_the_link_comes_back() {
    let Some(mut b) = board_with(|c| c.sim.errors = sim::SensorErrors::ideal()) else {
        return;
    };
    if !wait_for_gyro_bias(&mut b) {
        println!("skipped: the start-up gyro bias gave up on the emulated board");
        return;
    }
    let first = b.now_ns();
    let up = stream_until(&mut b, &sticks(1000, false), "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    let up_at = lines_after(&b, first, "rc: link up");
    assert_eq!(up_at.len(), 1);
    let up_ns = up_time(&b, first);
    assert!(
        up_ns >= first + 500 * MS,
        "up {} ms after the first frame",
        (up_ns - first) / MS
    );
    assert_link_times_out(&mut b);

    let back = b.now_ns();
    stream_until(&mut b, &acro_sticks(1000, false), "never", 250 * MS);
    // An off -> on flip 250 ms into the window: refused (no arming).
    stream_until(&mut b, &acro_sticks(1000, true), "never", 150 * MS);
    assert!(
        lines_after(&b, back, "flight: ARMED").is_empty(),
        "armed inside the recovery window\n{}",
        tail(&b, 30)
    );
    assert!(lines_after(&b, back, "rc: link up").is_empty());
    stream_until(&mut b, &acro_sticks(1000, false), "never", 250 * MS);
    let up_ns = up_time(&b, back);
    assert!(
        (back + 500 * MS..back + 600 * MS).contains(&up_ns),
        "link up {} ms after the first frame",
        (up_ns - back) / MS
    );
    let armed = stream_until(&mut b, &acro_sticks(1000, true), "flight: ARMED", S);
    assert!(armed.is_some(), "{}", tail(&b, 30));
    assert_no_reset(&b);
}

/// When the first "rc: link up" after `t_ns` was logged.
fn up_time(b: &Board, t_ns: u64) -> u64 {
    b.log_lines()
        .iter()
        .find(|l| l.host_time_ns >= t_ns && l.text.contains("rc: link up"))
        .map(|l| l.host_time_ns)
        .unwrap_or_else(|| panic!("no link up\n{}", tail(b, 30)))
}
