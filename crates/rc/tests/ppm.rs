//! PPM decoding: sync detection, jitter, glitches, missed edges, channel
//! count changes, and arbitrary interval streams.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use proptest::prelude::*;
use rc_input::{ConfigError, PpmConfig, PpmDecoder, RcFrame};

/// A 22.5 ms frame: the channels, then the sync gap that fills the rest.
fn frame_intervals(channels: &[u32]) -> Vec<u32> {
    let used: u32 = channels.iter().sum();
    let mut v = channels.to_vec();
    v.push(22_500u32.saturating_sub(used).max(4_000));
    v
}

/// Feeds intervals; returns the frames delivered.
fn feed(d: &mut PpmDecoder, intervals: &[u32]) -> Vec<RcFrame> {
    intervals
        .iter()
        .filter_map(|&i| d.push_interval_us(i))
        .collect()
}

const EIGHT: [u32; 8] = [1500, 1500, 1000, 1500, 2000, 1200, 1800, 1500];

fn expect(channels: &[u32]) -> RcFrame {
    let mut us = [0u16; 16];
    for (slot, &c) in us.iter_mut().zip(channels) {
        *slot = c as u16;
    }
    RcFrame::new(us, channels.len() as u8)
}

#[test]
fn steady_stream_delivers_every_frame_after_the_first_two() {
    let mut d = PpmDecoder::new();
    // Start mid-frame: the decoder waits for a sync before counting.
    let mut stream = vec![1500, 1700];
    for _ in 0..10 {
        stream.extend(frame_intervals(&EIGHT));
    }
    let frames = feed(&mut d, &stream);
    // Frame 1's channels come before any sync and are ignored; frame 2 is
    // unconfirmed; frames 3..=10 are delivered.
    assert_eq!(frames.len(), 8);
    assert!(frames.iter().all(|f| *f == expect(&EIGHT)));
    assert_eq!(d.stats().frames, 8);
    assert_eq!(d.stats().unconfirmed, 1);
}

#[test]
fn timing_jitter_is_passed_through_not_rejected() {
    let mut d = PpmDecoder::new();
    let mut frames = Vec::new();
    for k in 0..20u32 {
        // ±7 µs of capture jitter on every channel and on the gap.
        let jittered: Vec<u32> = EIGHT
            .iter()
            .enumerate()
            .map(|(i, &c)| c + (i as u32 * 3 + k) % 15 - 7)
            .collect();
        frames.extend(feed(&mut d, &frame_intervals(&jittered)));
    }
    assert_eq!(frames.len(), 18);
    for f in frames {
        for (got, want) in f.channels().iter().zip(EIGHT) {
            assert!(got.abs_diff(want as u16) <= 7);
        }
    }
    assert_eq!(d.stats().dropped(), 1, "only the unconfirmed first frame");
}

#[test]
fn a_glitch_drops_its_frame_and_the_next_is_unconfirmed() {
    let mut d = PpmDecoder::new();
    for _ in 0..3 {
        feed(&mut d, &frame_intervals(&EIGHT));
    }
    // A 300 µs spike splits channel 3.
    let glitched = [1500, 1500, 300, 700, 1500, 2000, 1200, 1800, 1500];
    assert!(feed(&mut d, &frame_intervals(&glitched)).is_empty());
    assert_eq!(d.stats().bad_pulse, 1);
    // The frame after a dropped one is held back; the one after that flows.
    assert!(feed(&mut d, &frame_intervals(&EIGHT)).is_empty());
    assert_eq!(feed(&mut d, &frame_intervals(&EIGHT)), vec![expect(&EIGHT)]);
}

#[test]
fn pulses_just_inside_and_outside_the_plausible_range() {
    let edge = [750, 2250, 1500, 1500];
    let mut d = PpmDecoder::new();
    feed(&mut d, &frame_intervals(&edge));
    feed(&mut d, &frame_intervals(&edge));
    assert_eq!(feed(&mut d, &frame_intervals(&edge)), vec![expect(&edge)]);
    for bad in [749, 2251, 2700] {
        let mut d = PpmDecoder::new();
        let f = [1500, bad, 1500, 1500];
        for _ in 0..4 {
            assert!(feed(&mut d, &frame_intervals(&f)).is_empty(), "pulse {bad}");
        }
        assert_eq!(d.stats().bad_pulse, 3, "pulse {bad}");
    }
}

#[test]
fn a_missed_edge_that_looks_like_a_sync_delivers_nothing_wrong() {
    let mut d = PpmDecoder::new();
    for _ in 0..3 {
        feed(&mut d, &frame_intervals(&EIGHT));
    }
    // Channels 5 and 6 (2000 + 1200 µs) merge into one 3200 µs interval:
    // longer than the sync threshold, so it splits the frame in two.
    let merged = [1500, 1500, 1000, 1500, 3200, 1800, 1500];
    let frames = feed(&mut d, &frame_intervals(&merged));
    assert!(
        frames.is_empty(),
        "neither fragment has 8 channels: {frames:?}"
    );
    assert!(feed(&mut d, &frame_intervals(&EIGHT)).is_empty());
    assert_eq!(feed(&mut d, &frame_intervals(&EIGHT)).len(), 1);
}

#[test]
fn a_channel_count_change_needs_two_frames() {
    let mut d = PpmDecoder::new();
    for _ in 0..3 {
        feed(&mut d, &frame_intervals(&EIGHT));
    }
    let six = &EIGHT[..6];
    assert!(feed(&mut d, &frame_intervals(six)).is_empty());
    assert_eq!(feed(&mut d, &frame_intervals(six)), vec![expect(six)]);
}

#[test]
fn channel_counts_outside_4_to_16_are_rejected() {
    for n in [1usize, 2, 3, 17, 18] {
        let chans = vec![1500u32; n];
        let mut d = PpmDecoder::new();
        for _ in 0..4 {
            assert!(
                feed(&mut d, &frame_intervals(&chans)).is_empty(),
                "{n} channels"
            );
        }
        assert_eq!(d.stats().bad_count, 3, "{n} channels");
    }
    for n in [4usize, 16] {
        let chans = vec![1500u32; n];
        let mut d = PpmDecoder::new();
        let mut frames = Vec::new();
        for _ in 0..4 {
            frames.extend(feed(&mut d, &frame_intervals(&chans)));
        }
        assert_eq!(frames.len(), 2, "{n} channels");
        assert_eq!(frames[0].count as usize, n);
    }
}

#[test]
fn clear_forgets_the_frame_in_progress() {
    let mut d = PpmDecoder::new();
    for _ in 0..3 {
        feed(&mut d, &frame_intervals(&EIGHT));
    }
    feed(&mut d, &EIGHT[..3]);
    d.clear(); // e.g. a capture overflow: an edge was lost
               // Waits for a sync, then needs two matching frames again.
    assert!(feed(&mut d, &EIGHT[3..]).is_empty());
    assert!(feed(&mut d, &[10_000]).is_empty());
    assert!(feed(&mut d, &frame_intervals(&EIGHT)).is_empty());
    assert_eq!(feed(&mut d, &frame_intervals(&EIGHT)).len(), 1);
}

#[test]
fn thresholds_are_validated() {
    assert!(PpmDecoder::with_config(PpmConfig::DEFAULT).is_ok());
    let bad = PpmConfig {
        pulse_min_us: 900,
        pulse_max_us: 2300,
        sync_min_us: 2200,
    };
    assert_eq!(
        PpmDecoder::with_config(bad).err(),
        Some(ConfigError::PpmThresholds {
            pulse_min_us: 900,
            pulse_max_us: 2300,
            sync_min_us: 2200
        })
    );
    let zero = PpmConfig {
        pulse_min_us: 0,
        ..PpmConfig::DEFAULT
    };
    assert!(zero.validate().is_err());
}

#[test]
fn a_wider_sync_threshold_is_honoured() {
    let cfg = PpmConfig {
        sync_min_us: 3_500,
        ..PpmConfig::DEFAULT
    };
    let mut d = PpmDecoder::with_config(cfg).unwrap();
    // A 3000 µs interval is neither a channel nor a sync under this config.
    for _ in 0..3 {
        assert!(feed(&mut d, &[1500, 1500, 3000, 1500, 1500, 10_000][..]).is_empty());
    }
    // The first frame came before any sync and was not judged.
    assert_eq!(d.stats().bad_pulse, 2);
}

proptest! {
    #[test]
    fn arbitrary_intervals_never_panic_and_frames_are_plausible(
        intervals in prop::collection::vec(
            prop_oneof![any::<u32>(), 0u32..3_000, 700u32..2_300, 2_600u32..30_000],
            0..500,
        )
    ) {
        let mut d = PpmDecoder::new();
        for i in intervals {
            if let Some(f) = d.push_interval_us(i) {
                prop_assert!((4..=16).contains(&f.count));
                prop_assert!(f.channels().iter().all(|&c| (750..=2250).contains(&c)));
            }
        }
    }

    #[test]
    fn clean_frames_of_any_count_are_decoded(
        channels in prop::collection::vec(750u32..=2250, 4..=16),
        gap in 2_701u32..40_000,
    ) {
        let mut d = PpmDecoder::new();
        let mut stream = Vec::new();
        for _ in 0..3 {
            stream.extend(&channels);
            stream.push(gap);
        }
        let frames = feed(&mut d, &stream);
        // Frame 1 starts before any sync; frame 2 is unconfirmed.
        prop_assert_eq!(frames, vec![expect(&channels)]);
    }
}
