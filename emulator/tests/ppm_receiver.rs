//! The PPM receiver on the real firmware of the `ppm` build
//! (`cargo build -p firmware --target thumbv7m-none-eabi --release
//! --features ppm`, its ELF given in `FIL_ELF`; `scripts/check` does both):
//! an 8-channel PPM train (22.5 ms frames, 0.3 ms separator pulses) driven
//! on PB8 reaches the log (positive and negative PPM), arming and failsafe
//! behave as with CRSF, frames with a wrong channel count or an
//! out-of-range pulse are dropped and counted, and spikes shorter than the
//! capture filter never reach the decoder.
//!
//! Without `FIL_ELF` the default release ELF is the CRSF build: the tests
//! say "skipped". An ELF given in `FIL_ELF` that is not the `ppm` build
//! fails them.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::Board;

/// PB8 (TIM4_CH3).
const PPM_PORT: usize = 1;
const PPM_PIN: u32 = 8;
const US: u64 = 1_000;
/// Standard PPM frame period and separator pulse.
const FRAME_NS: u64 = 22_500 * US;
const SEPARATOR_NS: u64 = 300 * US;

/// The board running the `ppm` build, booted to its receiver line; `None`
/// (skipped) when the firmware under test is the default CRSF build and
/// no `FIL_ELF` was given.
fn ppm_board(ideal: bool) -> Option<Board> {
    let mut b = board_with(|c| {
        if ideal {
            // With the simulator's default noise the start-up gyro bias
            // restarts until it gives up on the emulated board (see
            // esc_outputs.rs), and arming is refused for it.
            c.sim.errors = sim::SensorErrors::ideal();
        }
    })?;
    let rx = b
        .wait_for_line("receiver:", 2 * S)
        .unwrap()
        .unwrap_or_else(|| panic!("no receiver line\n{}", tail(&b, 20)));
    if !rx.text.contains("PPM") {
        if std::env::var_os("FIL_ELF").is_some() {
            panic!("FIL_ELF is not the ppm build: {}", rx.text);
        }
        println!(
            "skipped: the firmware under test is the CRSF build (set FIL_ELF to the ppm build)"
        );
        return None;
    }
    assert!(
        rx.text
            .contains("PPM on PB8 (TIM4_CH3 input capture, 5 V tolerant), rising edges"),
        "{}",
        rx.text
    );
    Some(b)
}

/// A PPM transmitter on PB8: positive PPM (idle low, each channel opened
/// by a 0.3 ms high pulse, one more pulse closing the last channel, the
/// sync gap filling the frame), or negative PPM (the same inverted).
struct Ppm {
    next_frame_ns: u64,
    /// Idle high, low pulses.
    negative: bool,
    /// A spike of this width (ns) 200 µs after each separator pulse: ringing
    /// coupled into the receiver lead.
    spike_ns: Option<u64>,
}

impl Ppm {
    fn new(b: &Board) -> Self {
        Self {
            next_frame_ns: b.now_ns() + 100 * US,
            negative: false,
            spike_ns: None,
        }
    }

    /// Queues one frame of `channels_us` and runs the board through it.
    fn frame(&mut self, b: &mut Board, channels_us: &[u64]) {
        let mut t = self.next_frame_ns;
        let mut edges = Vec::new();
        let pulse = !self.negative;
        for &ch in channels_us {
            edges.push((t, pulse));
            edges.push((t + SEPARATOR_NS, !pulse));
            if let Some(w) = self.spike_ns {
                let at = t + SEPARATOR_NS + 200 * US;
                edges.push((at, pulse));
                edges.push((at + w, !pulse));
            }
            t += ch * US;
        }
        edges.push((t, pulse));
        edges.push((t + SEPARATOR_NS, !pulse));
        b.drive_pin(PPM_PORT, PPM_PIN, &edges)
            .unwrap_or_else(|e| panic!("{e}"));
        self.next_frame_ns += FRAME_NS;
        // Up to just before the next frame: the board stops at a block
        // boundary a little after the time asked for, and the next frame's
        // first edge must not be in the past.
        run_until(b, self.next_frame_ns - 1_000 * US);
    }

    /// Frames until `until_ns`.
    fn stream(&mut self, b: &mut Board, channels_us: &[u64], until_ns: u64) {
        while b.now_ns() < until_ns {
            self.frame(b, channels_us);
        }
    }

    /// Frames until `until_ns`, then asserts one TIM4 capture interrupt per
    /// rising edge: nine a frame (more: spikes or noise were captured).
    fn stream_counting_irqs(&mut self, b: &mut Board, channels_us: &[u64], until_ns: u64) {
        let start = b.now_ns();
        let irqs_before = b.exception_entries(emulator::TIM4_IRQ);
        self.stream(b, channels_us, until_ns);
        let sent_frames = (self.next_frame_ns - start) / FRAME_NS;
        let irqs = b.exception_entries(emulator::TIM4_IRQ) - irqs_before;
        assert!(
            (9 * (sent_frames - 1)..=9 * sent_frames).contains(&irqs),
            "{irqs} TIM4 interrupts for {sent_frames} frames"
        );
    }

    /// Frames until a line containing `pattern` appears after the start
    /// (returned) or `timeout_ns` passes.
    fn stream_until(
        &mut self,
        b: &mut Board,
        channels_us: &[u64],
        pattern: &str,
        timeout_ns: u64,
    ) -> Option<String> {
        let start = b.now_ns();
        while b.now_ns() < start + timeout_ns {
            self.frame(b, channels_us);
            if let Some(l) = lines_after(b, start, pattern).first() {
                return Some(l.clone());
            }
        }
        None
    }
}

const EIGHT: [u64; 8] = [1_500, 1_500, 1_000, 1_500, 2_000, 1_200, 1_800, 1_500];

#[test]
fn ppm_frames_reach_the_firmware_and_loss_is_detected() {
    let Some(mut b) = ppm_board(false) else {
        return;
    };
    let mut ppm = Ppm::new(&b);
    let start = b.now_ns();
    ppm.stream_counting_irqs(&mut b, &EIGHT, start + 1_500 * MS);
    assert_link_up_after(&b, start);
    let last = last_channel_line(&b, start);
    assert!(
        last.contains("[1500, 1500, 1000, 1500, 2000, 1200, 1800, 1500]"),
        "{last}"
    );
    // 1.5 s of 22.5 ms frames, less the last second's log period: the
    // first frame after the first sync is held back (unconfirmed).
    let frames = field(&last, "ppm frames ");
    assert!(frames >= 40, "{last}");
    assert!(field(&last, "dropped ") <= 1, "{last}");
    assert_eq!(field(&last, "overcapture "), 0, "{last}");
    assert_link_times_out(&mut b);
    // The receiver comes back after a pause of many counter wraps: up
    // after the 0.5 s recovery window.
    let back = b.now_ns() + 500 * MS;
    run_until(&mut b, back);
    let mut ppm = Ppm::new(&b);
    let up = ppm.stream_until(&mut b, &EIGHT, "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    assert_no_reset(&b);
}

/// A PPM receiver that never sends is diagnosable from the log: with no
/// pulse on PB8 the board says so every second; once a frame has been
/// decoded it counts the frames instead, and the link comes up.
#[test]
fn a_silent_ppm_receiver_is_diagnosed_in_the_log() {
    let Some(mut b) = ppm_board(false) else {
        return;
    };
    let start = b.now_ns();
    run_until(&mut b, start + 2_100 * MS);
    let silent = lines_after(&b, start, "rc: no link: no PPM pulses at all on PB8");
    assert!(silent.len() >= 2, "once a second\n{}", tail(&b, 30));
    let mut ppm = Ppm::new(&b);
    let up = ppm.stream_until(&mut b, &EIGHT, "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    let t = b.now_ns();
    ppm.stream(&mut b, &EIGHT, t + 1_200 * MS);
    let since = lines_after(&b, t + 100 * MS, "rc: no link");
    assert!(since.is_empty(), "{since:?}");
}

/// Negative PPM (idle high, low separator pulses): the firmware captures
/// rising edges, which end the pulses instead of starting them; the
/// pulses' constant width makes every interval the same.
#[test]
fn negative_ppm_decodes_the_same() {
    let Some(mut b) = ppm_board(false) else {
        return;
    };
    let mut ppm = Ppm::new(&b);
    ppm.negative = true;
    b.drive_pin(PPM_PORT, PPM_PIN, &[(ppm.next_frame_ns - 50 * US, true)])
        .unwrap();
    let start = b.now_ns();
    ppm.stream(&mut b, &EIGHT, start + 1_100 * MS);
    let last = last_channel_line(&b, start);
    assert!(
        last.contains("[1500, 1500, 1000, 1500, 2000, 1200, 1800, 1500]"),
        "{last}"
    );
    assert_eq!(field(&last, "bad_pulse "), 0, "{last}");
}

#[test]
fn ppm_frames_with_a_wrong_count_or_pulse_are_dropped_and_counted() {
    let Some(mut b) = ppm_board(false) else {
        return;
    };
    let mut ppm = Ppm::new(&b);
    let start = b.now_ns();
    // Three channels: fewer than any PPM receiver sends.
    ppm.stream(&mut b, &[1_500, 1_500, 1_000], start + 300 * MS);
    // A 2.5 ms interval: longer than any channel, shorter than a sync gap.
    let mut bad_pulse = EIGHT;
    bad_pulse[3] = 2_500;
    ppm.stream(&mut b, &bad_pulse, start + 600 * MS);
    assert!(
        lines_after(&b, start, "rc: link up").is_empty(),
        "a bad frame counted as a link\n{}",
        tail(&b, 20)
    );
    // Then good frames: the counters show the earlier drops (the link is
    // up 0.5 s after the first good frame, the channel line comes once a
    // second while it is up).
    ppm.stream(&mut b, &EIGHT, start + 2_200 * MS);
    let last = last_channel_line(&b, start);
    assert!(field(&last, "bad_count ") >= 10, "{last}");
    assert!(field(&last, "bad_pulse ") >= 10, "{last}");
    assert!(
        last.contains("[1500, 1500, 1000, 1500, 2000, 1200, 1800, 1500]"),
        "{last}"
    );
}

/// Spikes shorter than the capture filter's 8 samples at 72 MHz (111 ns)
/// never reach the decoder: every frame of a train with a 60 ns spike in
/// each channel decodes. Without the filter each spike is a capture and
/// every frame is dropped (bad_pulse).
#[test]
fn short_spikes_on_the_ppm_line_are_filtered_out() {
    let Some(mut b) = ppm_board(false) else {
        return;
    };
    let mut ppm = Ppm::new(&b);
    ppm.spike_ns = Some(60);
    let start = b.now_ns();
    ppm.stream_counting_irqs(&mut b, &EIGHT, start + 1_100 * MS);
    let last = last_channel_line(&b, start);
    assert!(
        last.contains("[1500, 1500, 1000, 1500, 2000, 1200, 1800, 1500]"),
        "{last}"
    );
    assert_eq!(field(&last, "bad_pulse "), 0, "{last}");
    assert!(field(&last, "dropped ") <= 1, "{last}");
    // A 300 ns pulse is longer than the filter: it is an edge, and its
    // frame is dropped and counted.
    ppm.spike_ns = Some(300);
    let mid = b.now_ns();
    ppm.stream(&mut b, &EIGHT, mid + 300 * MS);
    ppm.spike_ns = None;
    ppm.stream(&mut b, &EIGHT, mid + 1_300 * MS);
    let last = last_channel_line(&b, mid);
    assert!(field(&last, "bad_pulse ") >= 10, "{last}");
}

/// Sticks centred, throttle at `throttle_us`, arm switch (channel 5) on or
/// off, mode switch (channel 6) high: acro (the emulated flash page holds
/// no accelerometer calibration, and only acro arms without one; the
/// failsafe flies level whatever the mode); motor-test switch (channel 7)
/// off.
fn sticks(throttle_us: u64, arm: bool) -> [u64; 8] {
    let mut ch = [1_500; 8];
    ch[2] = throttle_us;
    ch[4] = if arm { 2_000 } else { 1_000 };
    ch[5] = 2_000;
    ch[6] = 1_000;
    ch
}

/// ESC period and off pulse from the `outputs:` boot line (ns).
fn protocol(b: &Board) -> (u64, u64) {
    let line = lines_with(b, "outputs:")
        .last()
        .cloned()
        .unwrap_or_default();
    if line.contains("OneShot125") {
        (500_000, 125_000)
    } else {
        (2_500_000, 1_000_000)
    }
}

/// Arming with PPM: throttle low and the switch arm it, the outputs idle;
/// the train stops: failsafe, disarm and the off pulse.
#[test]
fn ppm_arming_idle_and_failsafe_when_the_train_stops() {
    let Some(mut b) = ppm_board(true) else {
        return;
    };
    if !wait_for_gyro_bias(&mut b) {
        println!("skipped: the start-up gyro bias gave up on the emulated board");
        return;
    }
    let mut ppm = Ppm::new(&b);
    let up = ppm.stream_until(&mut b, &sticks(1_000, false), "rc: link up", S);
    assert!(up.is_some(), "{}", tail(&b, 20));
    let until = b.now_ns() + 300 * MS;
    ppm.stream(&mut b, &sticks(1_000, false), until);
    let armed = ppm.stream_until(&mut b, &sticks(1_000, true), "flight: ARMED", S);
    assert!(armed.is_some(), "{}", tail(&b, 30));
    let until = b.now_ns() + 100 * MS;
    ppm.stream(&mut b, &sticks(1_000, true), until);
    let (period_ns, off_ns) = protocol(&b);
    for ch in 0..4 {
        let (period, high) = b
            .esc_pwm_ns(ch)
            .unwrap_or_else(|| panic!("channel {ch} silent"));
        assert_eq!(period, period_ns);
        assert!(
            (off_ns + off_ns / 100..off_ns + off_ns / 5).contains(&high),
            "armed, throttle low: channel {ch} at {high} ns, want idle above the off pulse"
        );
    }

    // The train stops (receiver unplugged). The last frame delivered is
    // the one the last queued frame's first edge (its sync gap's end)
    // completed. The link is lost 100 ms later (the log sees it within one
    // 50 ms tick); the flight controller holds level for 1 s, then
    // descends (the barometer gives an altitude) until the landing
    // detector's 2 s on the ground disarm it: 3.1 s after the last frame,
    // with up to 0.2 s allowed for the log tick and the detector's steps.
    let stopped_at = ppm.next_frame_ns - FRAME_NS;
    let lost = b
        .wait_for_line("rc: link lost", 200 * MS)
        .unwrap()
        .unwrap_or_else(|| panic!("{}", tail(&b, 20)));
    assert!(
        lost.text.contains("no good frame within the timeout"),
        "{}",
        lost.text
    );
    let lost_ms = (lost.host_time_ns - stopped_at) / MS;
    assert!(
        (100..=100 + 50 + 23).contains(&lost_ms),
        "lost after {lost_ms} ms"
    );
    let disarmed = b
        .wait_for_line("flight: disarmed", 7 * S)
        .unwrap()
        .unwrap_or_else(|| panic!("{}", tail(&b, 40)));
    assert!(
        !lines_after(&b, stopped_at, "flight: failsafe: no link: holding level").is_empty(),
        "no failsafe\n{}",
        tail(&b, 40)
    );
    assert!(
        disarmed.text.contains("failsafe: landed"),
        "{}",
        disarmed.text
    );
    let disarm_ms = (disarmed.host_time_ns - stopped_at) / MS;
    println!("link lost after {lost_ms} ms, disarmed after {disarm_ms} ms");
    assert!(
        (3_100..=3_300).contains(&disarm_ms),
        "disarmed after {disarm_ms} ms"
    );
    run_for(&mut b, 10 * MS);
    for ch in 0..4 {
        assert_eq!(
            b.esc_pwm_ns(ch),
            Some((period_ns, off_ns)),
            "channel {ch} after the failsafe disarm"
        );
    }
    for l in lines_with(&b, "flight") {
        println!("{l}");
    }
    assert_no_reset(&b);
}
