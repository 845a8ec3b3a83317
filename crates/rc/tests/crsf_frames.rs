//! CRSF frames from published sources: CRC, channel values, link
//! statistics, and the counters for everything that is not a good frame.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::*;
use rc_input::crsf::{
    encode_rc_channels, ticks_to_us, unpack_channels, us_to_ticks, ADDRESS_FLIGHT_CONTROLLER,
};
use rc_input::{crc8_dvb_s2, CrsfParser, Event, LinkStatistics};

fn channels(event: &Event) -> [u16; 16] {
    match event {
        Event::Channels(f) => {
            assert_eq!(f.count, 16);
            f.channels_us
        }
        other => panic!("expected channels, got {other:?}"),
    }
}

#[test]
fn published_frames_carry_valid_crcs() {
    for f in BETAFLIGHT_CAPTURED {
        assert_eq!(crc8_dvb_s2(&f[2..25]), f[25]);
    }
    assert_eq!(crc8_dvb_s2(&BETAFLIGHT_BAUD_NEGOTIATION[2..13]), 0x72);
    assert_eq!(crc8_dvb_s2(&BETAFLIGHT_SUBSET[2..10]), 0xD1);
    assert_eq!(crc8_dvb_s2(&ELRS_EE_FRAME[2..25]), 0x36);
    assert_eq!(crc8_dvb_s2(&ADV_LINK_STATISTICS[2..13]), 0xEB);
    assert_eq!(crc8_dvb_s2(&ADV_RC_CENTRED[2..25]), 0xAD);
}

#[test]
fn betaflight_capture_channel_values() {
    // Betaflight's test expects ticks 189, 993, 978, 983 (second frame: 981)
    // on channels 1..4.
    let p: &[u8; 22] = BETAFLIGHT_CAPTURED[0][3..25].try_into().unwrap();
    let ticks = unpack_channels(p);
    assert_eq!(&ticks[..4], &[189, 993, 978, 983]);
    let p: &[u8; 22] = BETAFLIGHT_CAPTURED[1][3..25].try_into().unwrap();
    assert_eq!(&unpack_channels(p)[..4], &[189, 993, 978, 981]);

    let mut parser = CrsfParser::new();
    let (events, _) = feed(
        &mut parser,
        &[betaflight_as_fc(0), betaflight_as_fc(1)].concat(),
        0,
    );
    assert_eq!(events.len(), 2);
    let us = channels(&events[0]);
    // (x − 992) · 5/8 + 1500, rounded: 189 → 998.1 → 998 (Betaflight's own
    // linear fit 0.62477·x + 881 gives 999; the specification's formula is
    // used here), 993 → 1500.6 → 1501, 978 → 1491.25 → 1491, 983 → 1494.4 → 1494.
    assert_eq!(&us[..4], &[998, 1501, 1491, 1494]);
    assert_eq!(channels(&events[1])[3], 1493); // 981 → 1493.1
    assert_eq!(parser.stats().rc_frames, 2);
    assert_eq!(parser.stats().dropped(), 0);
}

#[test]
fn betaflight_capture_with_broadcast_address_is_not_for_a_flight_controller() {
    let mut parser = CrsfParser::new();
    let (events, _) = feed(&mut parser, &BETAFLIGHT_CAPTURED[0], 0);
    assert!(events.is_empty());
    assert_eq!(parser.stats().rc_frames, 0);
    // Every byte was searched for an address (0xC8 does not occur in it).
    assert_eq!(parser.stats().skipped_bytes, 26);
}

#[test]
fn elrs_frame_with_transmitter_address() {
    let mut parser = CrsfParser::new();
    let (events, _) = feed(&mut parser, &ELRS_EE_FRAME, 0);
    assert_eq!(events.len(), 1);
    let us = channels(&events[0]);
    let p: &[u8; 22] = ELRS_EE_FRAME[3..25].try_into().unwrap();
    let ticks = unpack_channels(p);
    assert_eq!(&ticks[..6], &[993, 988, 1063, 995, 173, 173]);
    assert_eq!(&ticks[6..], &[992; 10]);
    assert_eq!(&us[..6], &[1501, 1498, 1544, 1502, 988, 988]);
    assert_eq!(&us[6..], &[1500; 10]);
}

#[test]
fn centred_test_vector_decodes_to_1500_us_and_encodes_back() {
    let mut parser = CrsfParser::new();
    let (events, _) = feed(&mut parser, &ADV_RC_CENTRED, 0);
    assert_eq!(channels(&events[0]), [1500; 16]);
    assert_eq!(
        encode_rc_channels(ADDRESS_FLIGHT_CONTROLLER, &[992; 16]),
        ADV_RC_CENTRED
    );
}

#[test]
fn link_statistics_test_vector() {
    let mut parser = CrsfParser::new();
    let (events, _) = feed(&mut parser, &ADV_LINK_STATISTICS, 0);
    let expected = LinkStatistics {
        uplink_rssi_ant1_dbm: -65,
        uplink_rssi_ant2_dbm: -66,
        uplink_link_quality_pct: 98,
        uplink_snr_db: -7,
        active_antenna: 1,
        rf_mode: 3,
        uplink_tx_power_index: 5,
        downlink_rssi_dbm: -70,
        downlink_link_quality_pct: 99,
        downlink_snr_db: -9,
    };
    assert_eq!(events, vec![Event::LinkStatistics(expected)]);
    assert_eq!(expected.uplink_tx_power_mw(), Some(1000));
    assert_eq!(expected.uplink_rssi_dbm(), -66); // antenna 2 active
    assert_eq!(
        rc_input::crsf::encode_link_statistics(0xC8, &expected),
        ADV_LINK_STATISTICS
    );
    assert_eq!(parser.stats().link_statistics_frames, 1);
}

#[test]
fn undefined_power_index_has_no_milliwatts() {
    let s = LinkStatistics {
        uplink_tx_power_index: 9,
        ..Default::default()
    };
    assert_eq!(s.uplink_tx_power_mw(), None);
}

#[test]
fn unknown_types_are_skipped_and_counted() {
    let mut parser = CrsfParser::new();
    let stream = [
        &BETAFLIGHT_BAUD_NEGOTIATION[..],
        &BETAFLIGHT_SUBSET,
        &ADV_RC_CENTRED,
    ]
    .concat();
    let (events, _) = feed(&mut parser, &stream, 0);
    assert_eq!(events.len(), 1);
    assert_eq!(parser.stats().unknown_type, 2);
    assert_eq!(parser.stats().crc_errors, 0);
}

#[test]
fn crc_failure_drops_the_frame_and_counts_it() {
    for byte in 2..26 {
        let mut bad = ADV_RC_CENTRED;
        bad[byte] ^= 0x01;
        let mut parser = CrsfParser::new();
        let (events, t) = feed(&mut parser, &bad, 0);
        // A corrupted length byte (index 1 is not flipped here) cannot
        // apply; every other flip must be caught by the CRC.
        assert!(events.is_empty(), "flip at {byte}");
        assert!(parser.stats().crc_errors >= 1, "flip at {byte}");
        // The next good frame is found.
        let (events, _) = feed(&mut parser, &ADV_RC_CENTRED, t);
        assert_eq!(events.len(), 1, "flip at {byte}");
    }
}

#[test]
fn out_of_range_lengths_are_rejected_and_counted() {
    for len in [0u8, 1, 63, 64, 0xFF] {
        let mut parser = CrsfParser::new();
        let stream = [&[0xC8, len][..], &ADV_RC_CENTRED].concat();
        let (events, _) = feed(&mut parser, &stream, 0);
        assert_eq!(events.len(), 1, "length {len}");
        assert_eq!(parser.stats().bad_length, 1, "length {len}");
    }
}

#[test]
fn known_type_with_wrong_payload_size_is_counted() {
    // RC channels with 21 payload bytes and a correct CRC.
    let mut f = vec![0xC8, 23, 0x16];
    f.extend_from_slice(&ADV_RC_CENTRED[3..24]);
    f.push(crc8_dvb_s2(&f[2..]));
    let mut parser = CrsfParser::new();
    let (events, _) = feed(&mut parser, &f, 0);
    assert!(events.is_empty());
    assert_eq!(parser.stats().bad_payload_length, 1);
}

#[test]
fn shortest_legal_frame_is_accepted() {
    // Length 2: type + CRC, no payload; an unknown type 0x0B (heartbeat).
    let f = [0xC8, 0x02, 0x0B, crc8_dvb_s2(&[0x0B])];
    let mut parser = CrsfParser::new();
    feed(&mut parser, &f, 0);
    assert_eq!(parser.stats().unknown_type, 1);
}

#[test]
fn a_torn_frame_is_abandoned_when_the_next_frame_starts_after_the_frame_time() {
    let mut parser = CrsfParser::new();
    let (events, t) = feed(&mut parser, &ADV_RC_CENTRED[..13], 0);
    assert!(events.is_empty());
    // 1.5 ms of silence, then a whole frame beginning 1.81 ms after the torn
    // one: the first half is discarded instead of being completed by the
    // new frame's bytes.
    let (events, _) = feed(&mut parser, &ADV_LINK_STATISTICS, t + 1_500);
    assert_eq!(events.len(), 1);
    assert!(matches!(events[0], Event::LinkStatistics(_)));
    assert_eq!(parser.stats().frame_timeouts, 1);
    assert_eq!(parser.stats().crc_errors, 0);
}

#[test]
fn frame_time_resync_works_across_timer_wrap() {
    let mut parser = CrsfParser::new();
    let t0 = u32::MAX - 100;
    let (_, t) = feed(&mut parser, &ADV_RC_CENTRED[..10], t0);
    let (events, _) = feed(&mut parser, &ADV_RC_CENTRED, t.wrapping_add(5_000));
    assert_eq!(events.len(), 1);
    assert_eq!(parser.stats().frame_timeouts, 1);
}

#[test]
fn a_pause_inside_the_frame_time_does_not_split_a_frame() {
    let mut parser = CrsfParser::new();
    let (_, t) = feed(&mut parser, &ADV_RC_CENTRED[..13], u32::MAX - 200);
    // Interrupt latency of 900 µs mid-frame, across the timer wrap.
    let (events, _) = feed(&mut parser, &ADV_RC_CENTRED[13..], t.wrapping_add(900));
    assert_eq!(events.len(), 1);
    assert_eq!(parser.stats().frame_timeouts, 0);
}

/// Feeds `frame` one byte time apart, with the pauses `(i, µs)` before
/// byte `i`; returns the events and the last byte's time.
fn feed_with_pauses(
    parser: &mut CrsfParser,
    frame: &[u8],
    t0_us: u32,
    pauses: &[(usize, u32)],
) -> (Vec<Event>, u32) {
    let mut t = t0_us;
    let mut events = Vec::new();
    for (i, &b) in frame.iter().enumerate() {
        if i > 0 {
            t += BYTE_US;
        }
        t += pauses
            .iter()
            .filter(|&&(at, _)| at == i)
            .map(|&(_, p)| p)
            .sum::<u32>();
        events.extend(parser.push(b, t));
    }
    (events, t)
}

#[test]
fn frames_with_pauses_inside_them_are_parsed() {
    // One character time (23.8 µs at 420 kbaud: the USART's IDLE fires),
    // 100 µs and 500 µs, alone and all in one frame.
    let cases: [&[(usize, u32)]; 4] = [
        &[(13, 24)],
        &[(5, 100)],
        &[(20, 500)],
        &[(2, 24), (9, 100), (17, 500), (25, 24)],
    ];
    for pauses in cases {
        let mut parser = CrsfParser::new();
        let (events, _) = feed_with_pauses(&mut parser, &ADV_RC_CENTRED, 10_000, pauses);
        assert_eq!(events.len(), 1, "pauses {pauses:?}");
        assert_eq!(channels(&events[0]), [1500; 16]);
        assert_eq!(parser.stats().dropped(), 0, "pauses {pauses:?}");
    }
}

#[test]
fn a_frame_may_last_exactly_the_frame_time_and_no_longer() {
    // 26 bytes: 25 byte times from the first to the last, plus one pause.
    let limit = rc_input::crsf::DEFAULT_MAX_FRAME_TIME_US;
    let pause = limit - 25 * BYTE_US;
    let mut parser = CrsfParser::new();
    let (events, last) = feed_with_pauses(&mut parser, &ADV_RC_CENTRED, 0, &[(13, pause)]);
    assert_eq!(last, limit);
    assert_eq!(events.len(), 1);
    let mut parser = CrsfParser::new();
    let (events, last) = feed_with_pauses(&mut parser, &ADV_RC_CENTRED, 0, &[(13, pause + 1)]);
    assert_eq!(last, limit + 1);
    assert!(events.is_empty());
    assert_eq!(parser.stats().frame_timeouts, 1);
}

#[test]
fn a_frame_spanning_more_than_the_frame_time_is_dropped_and_the_next_parsed() {
    let mut parser = CrsfParser::new();
    // 1.2 ms in the middle: 1 800 µs from the first byte to the last.
    let (events, last) = feed_with_pauses(&mut parser, &ADV_RC_CENTRED, 0, &[(13, 1_200)]);
    assert_eq!(last, 1_800);
    assert!(events.is_empty());
    assert!(parser.stats().frame_timeouts >= 1);
    assert_eq!(parser.stats().rc_frames, 0);
    // The next frame 4 ms later (250 Hz) is parsed.
    let (events, _) = feed(&mut parser, &ADV_LINK_STATISTICS, 4_000);
    assert_eq!(events.len(), 1);
    assert!(matches!(events[0], Event::LinkStatistics(_)));
}

#[test]
fn garbage_then_a_frame_resynchronises() {
    // Noise with a false start announcing 62 bytes, then a frame at once
    // (as at 1000 Hz: no pause) and one 2 ms later.
    let noise = [0x13, 0xC8, 0x3E, 0x77, 0xEE, 0x05, 0x00, 0xEA];
    let mut parser = CrsfParser::new();
    let (mut events, t) = feed(&mut parser, &[&noise[..], &ADV_RC_CENTRED].concat(), 0);
    let (more, _) = feed(&mut parser, &ADV_LINK_STATISTICS, t + 2_000);
    events.extend(more);
    while let Some(e) = parser.poll(t + 10_000) {
        events.push(e);
    }
    assert_eq!(events.len(), 2, "{events:?}");
    assert_eq!(channels(&events[0]), [1500; 16]);
    assert!(matches!(events[1], Event::LinkStatistics(_)));
}

#[test]
fn without_the_frame_time_rule_a_torn_frame_is_caught_by_the_crc() {
    let mut parser = CrsfParser::with_max_frame_time_us(u32::MAX);
    let stream = [&ADV_RC_CENTRED[..13], &ADV_RC_CENTRED[..]].concat();
    let (events, _) = feed(&mut parser, &stream, 0);
    // The torn frame swallows the start of the next one, fails its CRC,
    // and the buffered bytes are searched again: the whole frame is found.
    assert_eq!(events.len(), 1);
    assert_eq!(parser.stats().crc_errors, 1);
}

#[test]
fn false_start_in_garbage_does_not_hide_the_frames_behind_it() {
    // 0xC8 0x3E in the noise announces a 62-byte frame, which swallows the
    // two real frames after it.
    let stream = [
        &[0x55, 0xC8, 0x3E, 0x01][..],
        &ADV_LINK_STATISTICS,
        &ADV_RC_CENTRED,
    ]
    .concat();
    let mut parser = CrsfParser::new();
    let (events, t) = feed(&mut parser, &stream, 0);
    assert!(
        events.is_empty(),
        "the false start is still waiting for bytes"
    );
    // Once the false start's frame time (from its first byte, 24 µs) has
    // passed, it is abandoned and both frames come out, one per call.
    assert!(
        parser.poll(t + 500).is_none(),
        "its frame time is not over yet"
    );
    assert!(matches!(
        parser.poll(t + 1_500),
        Some(Event::LinkStatistics(_))
    ));
    assert!(matches!(parser.poll(t + 1_600), Some(Event::Channels(_))));
    assert_eq!(parser.poll(t + 1_700), None);
    assert_eq!(parser.stats().frame_timeouts, 1);
}

#[test]
fn frames_behind_a_false_start_come_out_when_the_next_burst_starts() {
    let stream = [&[0xC8, 0x3E][..], &ADV_LINK_STATISTICS].concat();
    let mut parser = CrsfParser::new();
    let (events, t) = feed(&mut parser, &stream, 0);
    assert!(events.is_empty());
    // The next frame after the false start's frame time: the first push delivers the
    // buffered link statistics, the frame itself still completes.
    let (events, _) = feed(&mut parser, &ADV_RC_CENTRED, t + 2_000);
    assert_eq!(events.len(), 2);
    assert!(matches!(events[0], Event::LinkStatistics(_)));
    assert!(matches!(events[1], Event::Channels(_)));
}

#[test]
fn a_false_start_completed_by_later_bytes_is_searched_again() {
    // No frame-time rule at all: the false start is resolved by its CRC after 64
    // bytes, and the frames inside it are found by searching again.
    let stream = [
        &[0xC8, 0x3E][..],
        &ADV_LINK_STATISTICS,
        &ADV_RC_CENTRED,
        &ADV_RC_CENTRED,
    ]
    .concat();
    let mut parser = CrsfParser::with_max_frame_time_us(u32::MAX);
    let (mut events, t) = feed(&mut parser, &stream, 0);
    while let Some(e) = parser.poll(t) {
        events.push(e);
    }
    assert_eq!(events.len(), 3);
    assert_eq!(parser.stats().crc_errors, 1);
}

#[test]
fn ticks_conversion_matches_the_specification_range() {
    assert_eq!(ticks_to_us(172), 988);
    assert_eq!(ticks_to_us(992), 1500);
    assert_eq!(ticks_to_us(1811), 2012);
    assert_eq!(ticks_to_us(0), 880);
    assert_eq!(ticks_to_us(2047), 2159);
    assert_eq!(us_to_ticks(988), 173);
    assert_eq!(us_to_ticks(1500), 992);
    assert_eq!(us_to_ticks(2012), 1811);
    assert_eq!(us_to_ticks(0), 0);
    assert_eq!(us_to_ticks(u16::MAX), 2047);
}

#[test]
fn two_pauses_before_the_held_frames_are_out() {
    // A false start holds two link-statistics frames; the line pauses for
    // longer than the frame time twice before they are all delivered.
    let stream = [
        &[0xC8, 0x3E][..],
        &ADV_LINK_STATISTICS,
        &ADV_LINK_STATISTICS,
    ]
    .concat();
    let mut parser = CrsfParser::new();
    let (events, t) = feed(&mut parser, &stream, 0);
    assert!(events.is_empty());
    let (first, t) = feed(&mut parser, &ADV_RC_CENTRED[..1], t + 2_000);
    assert!(matches!(first[..], [Event::LinkStatistics(_)]));
    let (rest, _) = feed(&mut parser, &ADV_RC_CENTRED, t + 2_000);
    assert_eq!(rest.len(), 2, "{rest:?}");
    assert!(matches!(rest[0], Event::LinkStatistics(_)));
    assert!(matches!(rest[1], Event::Channels(_)));
}
