//! 16-bit 1 MHz input captures to PPM intervals: exact across one counter
//! wrap, a pause of several wraps seen as a sync gap, and a PPM edge train
//! through the captures and the decoder.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use proptest::prelude::*;
use rc_input::ppm::CAPTURE_WRAP_GUARD_US;
use rc_input::{CaptureIntervals, PpmDecoder};

/// What the timer latches for an edge at `t_us`: the free-running 16-bit
/// counter at 1 MHz.
fn capture(t_us: u64) -> u16 {
    (t_us % 65_536) as u16
}

proptest! {
    /// An interval comes out exact while it and the difference of the two
    /// interrupt latencies (up to 5 ms here) stay below half a wrap.
    #[test]
    fn intervals_within_a_wrap_are_exact(
        start in 0u64..1_000_000,
        steps in prop::collection::vec((1u64..CAPTURE_WRAP_GUARD_US as u64 - 5_000, 0u64..5_000), 1..50),
    ) {
        let mut c = CaptureIntervals::new();
        let mut t = start;
        let mut now = t;
        prop_assert_eq!(c.push(capture(t), now as u32), None);
        for (dt, latency) in steps {
            t += dt;
            // The interrupts run in order: the coarse clock never goes back.
            now = (t + latency).max(now);
            let got = c.push(capture(t), now as u32);
            prop_assert_eq!(got, Some(dt as u32));
        }
    }

    /// A pause of one or more whole wraps (which the 16-bit difference
    /// alone would read as a short interval) is a sync gap, never a channel.
    #[test]
    fn pauses_longer_than_a_wrap_are_sync_gaps(
        start in 0u64..1_000_000,
        pause in 65_536u64..10_000_000,
        latency in 0u64..5_000,
    ) {
        let mut c = CaptureIntervals::new();
        c.push(capture(start), start as u32);
        let t = start + pause;
        let got = c.push(capture(t), (t + latency) as u32).unwrap();
        prop_assert!(got >= CAPTURE_WRAP_GUARD_US, "{got}");
        prop_assert!(got > PpmDecoder::new().config().sync_min_us);
    }
}

#[test]
fn restart_forgets_the_previous_capture() {
    let mut c = CaptureIntervals::new();
    c.push(100, 100);
    c.restart();
    assert_eq!(c.push(1_600, 1_600), None, "the edge in between was lost");
    assert_eq!(c.push(3_100, 3_100), Some(1_500));
}

/// Rising-edge times of positive PPM: each channel starts with a 300 µs
/// separator pulse, the sync gap fills the 22.5 ms frame.
fn ppm_rising_edges(frames: usize, channels: &[u64], start_us: u64) -> Vec<u64> {
    let mut t = start_us;
    let mut edges = Vec::new();
    for _ in 0..frames {
        let frame_start = t;
        for &ch in channels {
            edges.push(t);
            t += ch;
        }
        // The edge that starts the sync gap's closing pulse.
        edges.push(t);
        t = frame_start + 22_500;
    }
    edges
}

#[test]
fn ppm_frames_decode_through_captures_across_counter_wraps() {
    let channels = [1_500, 1_500, 1_000, 1_500, 2_000, 1_200, 1_800, 1_500];
    // 20 frames = 450 ms: the counter wraps seven times.
    let edges = ppm_rising_edges(20, &channels, 61_000);
    let mut c = CaptureIntervals::new();
    let mut d = PpmDecoder::new();
    let mut frames = Vec::new();
    for t in edges {
        if let Some(i) = c.push(capture(t), (t + 7) as u32) {
            frames.extend(d.push_interval_us(i));
        }
    }
    assert!(frames.len() >= 17, "{} frames", frames.len());
    for f in frames {
        let got: Vec<u64> = f.channels().iter().map(|&c| u64::from(c)).collect();
        assert_eq!(got, channels);
    }
    assert_eq!(d.stats().bad_pulse + d.stats().bad_count, 0);
}
