//! Property tests of the CRSF parser: arbitrary byte streams, frames hidden
//! in garbage, chunked delivery, and the channel bit packing.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::BYTE_US;
use proptest::prelude::*;
use rc_input::crsf::{
    encode_link_statistics, encode_rc_channels, is_address, pack_channels, ticks_to_us,
    unpack_channels, us_to_ticks, DEFAULT_MAX_FRAME_TIME_US,
};
use rc_input::{CrsfParser, Event, LinkStatistics, RcFrame};

/// A frame's bytes and the event it must produce.
type Framed = (Vec<u8>, Event);

/// A valid frame and the event it must produce.
fn frame() -> impl Strategy<Value = Framed> {
    let address = prop::sample::select(vec![0xC8u8, 0xEE, 0xEA]);
    let rc = (address.clone(), prop::array::uniform16(0u16..2048)).prop_map(|(a, ticks)| {
        let bytes = encode_rc_channels(a, &ticks).to_vec();
        (
            bytes,
            Event::Channels(RcFrame::new(ticks.map(ticks_to_us), 16)),
        )
    });
    let link = (address, prop::array::uniform10(any::<u8>())).prop_map(|(a, p)| {
        let stats = LinkStatistics::from_payload(&p);
        (
            encode_link_statistics(a, &stats).to_vec(),
            Event::LinkStatistics(stats),
        )
    });
    prop_oneof![3 => rc, 1 => link]
}

/// Bytes that can never start a frame.
fn non_address_garbage(max: usize) -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(
        any::<u8>().prop_filter("not an address", |b| !is_address(*b)),
        0..max,
    )
}

/// Garbage rich in address bytes and plausible lengths.
fn nasty_garbage(max: usize) -> impl Strategy<Value = Vec<u8>> {
    let byte = prop_oneof![
        2 => any::<u8>(),
        1 => prop::sample::select(vec![0xC8u8, 0xEE, 0xEA]),
        1 => 2u8..=62,
    ];
    prop::collection::vec(byte, 0..max)
}

/// Feeds timed bytes, then polls until the parser has nothing more.
fn run(parser: &mut CrsfParser, timed: &[(u8, u32)]) -> Vec<Event> {
    let mut events: Vec<Event> = timed
        .iter()
        .filter_map(|&(b, t)| parser.push(b, t))
        .collect();
    let end = timed.last().map_or(0, |&(_, t)| t) + 2 * DEFAULT_MAX_FRAME_TIME_US;
    while let Some(e) = parser.poll(end) {
        events.push(e);
    }
    events
}

/// Garbage and frames back to back, and the events the frames must give.
fn interleave(parts: Vec<(Vec<u8>, Framed)>) -> (Vec<u8>, Vec<Event>) {
    let mut bytes = Vec::new();
    let mut expected = Vec::new();
    for (garbage, (f, e)) in parts {
        bytes.extend(garbage);
        bytes.extend(f);
        expected.push(e);
    }
    (bytes, expected)
}

/// Stamps bytes one byte time apart from `t0`.
fn stamp(bytes: &[u8], t0: u32) -> Vec<(u8, u32)> {
    (0u32..)
        .zip(bytes)
        .map(|(i, &b)| (b, t0.wrapping_add(i * BYTE_US)))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn arbitrary_bytes_and_times_never_panic(
        input in prop::collection::vec((any::<u8>(), any::<u32>()), 0..600),
        gap in any::<u32>(),
    ) {
        let mut parser = CrsfParser::with_max_frame_time_us(gap);
        let mut t = 0u32;
        let mut events = 0u32;
        for (b, dt) in input {
            t = t.wrapping_add(dt % 3_000);
            events += u32::from(parser.push(b, t).is_some());
            events += u32::from(parser.poll(t).is_some());
        }
        let s = parser.stats();
        prop_assert_eq!(s.rc_frames + s.link_statistics_frames, events);
    }

    #[test]
    fn frames_between_non_address_garbage_are_all_found(
        parts in prop::collection::vec((non_address_garbage(40), frame()), 1..12),
        t0 in any::<u32>(),
    ) {
        let (bytes, expected) = interleave(parts);
        let mut parser = CrsfParser::new();
        let events = run(&mut parser, &stamp(&bytes, t0));
        prop_assert_eq!(events, expected);
        prop_assert_eq!(parser.stats().crc_errors, 0);
    }

    #[test]
    fn frames_after_a_pause_longer_than_the_frame_time_are_found_whatever_came_before(
        parts in prop::collection::vec((nasty_garbage(80), frame()), 1..10),
        t0 in any::<u32>(),
        gap_us in (DEFAULT_MAX_FRAME_TIME_US + 1)..20_000,
    ) {
        let mut timed = Vec::new();
        let mut expected = Vec::new();
        let mut t = t0;
        for (garbage, (f, e)) in parts {
            timed.extend(stamp(&garbage, t));
            t = t.wrapping_add(garbage.len() as u32 * BYTE_US + gap_us);
            timed.extend(stamp(&f, t));
            t = t.wrapping_add(f.len() as u32 * BYTE_US);
            expected.push(e);
        }
        let mut parser = CrsfParser::new();
        let events = run(&mut parser, &timed);
        // Garbage may itself hold a frame whose CRC matches by chance
        // (1 in 256 per false start); such an extra event is allowed, a
        // missing real frame is not.
        let mut want = expected.iter().peekable();
        for e in &events {
            if want.peek() == Some(&e) {
                want.next();
            }
        }
        prop_assert!(want.next().is_none(), "missing frames; got {:?}", events);
    }

    #[test]
    fn frames_in_garbage_without_gaps_are_lost_only_to_a_chance_crc_match(
        parts in prop::collection::vec((nasty_garbage(30), frame()), 1..12),
    ) {
        let (mut bytes, expected) = interleave(parts);
        // 64 idle-line bytes complete any false start still pending.
        bytes.extend([0u8; 64]);
        let mut parser = CrsfParser::with_max_frame_time_us(u32::MAX);
        let events: Vec<Event> = bytes.iter().filter_map(|&b| parser.push(b, 0)).collect();
        let mut matched = 0;
        for e in &events {
            if expected.get(matched) == Some(e) {
                matched += 1;
            }
        }
        let missing = expected.len() - matched;
        // A loss needs a garbage candidate that passed its CRC and swallowed
        // real frames: such a candidate is counted as an unknown type or a
        // bad payload length, or is an extra event, and hides at most 4
        // frames (62 bytes).
        let s = parser.stats();
        let chance = s.unknown_type + s.bad_payload_length + (events.len() - matched) as u32;
        prop_assert!(missing as u32 <= 4 * chance, "missing {} chance {}", missing, chance);
    }

    #[test]
    fn chunked_delivery_gives_the_same_events_as_byte_timed(
        parts in prop::collection::vec((nasty_garbage(20), frame()), 1..8),
        cuts in prop::collection::vec(1usize..40, 1..60),
    ) {
        // Frames with pauses between them, as a receiver sends them.
        let mut bursts: Vec<Vec<u8>> = Vec::new();
        for (garbage, (f, _)) in parts {
            bursts.push([garbage, f].concat());
        }
        let mut per_byte = CrsfParser::new();
        let mut chunked = CrsfParser::new();
        let mut a = Vec::new();
        let mut b = Vec::new();
        let mut t = 0u32;
        let mut cut = cuts.iter().cycle();
        for burst in &bursts {
            for (i, &byte) in burst.iter().enumerate() {
                a.extend(per_byte.push(byte, t + i as u32 * BYTE_US));
            }
            // The same burst drained in chunks (e.g. from DMA), every byte
            // of a chunk stamped with the chunk's arrival time (later than
            // the byte's own: a candidate's span can only look shorter, and
            // no candidate of at most 64 bytes in one burst is too slow).
            let mut rest = &burst[..];
            let mut tc = t;
            while !rest.is_empty() {
                let n = (*cut.next().unwrap()).min(rest.len());
                let (chunk, tail) = rest.split_at(n);
                tc += n as u32 * BYTE_US;
                for &byte in chunk {
                    b.extend(chunked.push(byte, tc));
                }
                rest = tail;
            }
            t += burst.len() as u32 * BYTE_US + 2 * DEFAULT_MAX_FRAME_TIME_US;
        }
        while let Some(e) = per_byte.poll(t) { a.push(e); }
        while let Some(e) = chunked.poll(t) { b.push(e); }
        prop_assert_eq!(a, b);
    }

    #[test]
    fn a_frame_is_parsed_with_any_pauses_while_it_lasts_at_most_the_frame_time(
        (f, e) in frame(),
        pauses in prop::collection::vec(0u32..90, 64),
        t0 in any::<u32>(),
    ) {
        let mut timed = Vec::new();
        let mut span = 0u32;
        for (i, (&b, &p)) in f.iter().zip(&pauses).enumerate() {
            if i > 0 {
                span += BYTE_US + p;
            }
            timed.push((b, t0.wrapping_add(span)));
        }
        let mut parser = CrsfParser::new();
        let events = run(&mut parser, &timed);
        if span <= DEFAULT_MAX_FRAME_TIME_US {
            prop_assert_eq!(events, vec![e]);
            prop_assert_eq!(parser.stats().dropped(), 0);
        } else {
            prop_assert!(!events.contains(&e), "span {} µs: {:?}", span, events);
            prop_assert!(parser.stats().frame_timeouts >= 1);
        }
    }

    #[test]
    fn parser_recovers_after_any_input(
        garbage in prop::collection::vec(any::<u8>(), 0..300),
        (f, e) in frame(),
    ) {
        let mut parser = CrsfParser::new();
        let mut timed = stamp(&garbage, 7);
        let t = garbage.len() as u32 * BYTE_US + 5_000;
        timed.extend(stamp(&f, t));
        let events = run(&mut parser, &timed);
        prop_assert_eq!(events.last(), Some(&e));
    }

    #[test]
    fn channel_packing_round_trips(ticks in prop::array::uniform16(0u16..2048)) {
        prop_assert_eq!(unpack_channels(&pack_channels(&ticks)), ticks);
    }

    #[test]
    fn every_payload_is_some_channel_set(payload in prop::array::uniform22(any::<u8>())) {
        // 16 × 11 bits is exactly 22 bytes: packing is a bijection.
        prop_assert_eq!(pack_channels(&unpack_channels(&payload)), payload);
    }

    #[test]
    fn channel_packing_matches_a_bit_by_bit_reference(ticks in prop::array::uniform16(0u16..2048)) {
        let packed = pack_channels(&ticks);
        for (ch, &t) in ticks.iter().enumerate() {
            for bit in 0..11 {
                let pos = ch * 11 + bit;
                let wire = (packed[pos / 8] >> (pos % 8)) & 1;
                prop_assert_eq!(u16::from(wire), (t >> bit) & 1);
            }
        }
    }

    #[test]
    fn microseconds_survive_the_round_trip_through_ticks(us in 988u16..=2012) {
        prop_assert_eq!(ticks_to_us(us_to_ticks(us)), us);
    }

    #[test]
    fn ticks_survive_the_round_trip_within_one_tick(t in 0u16..2048) {
        let back = us_to_ticks(ticks_to_us(t));
        prop_assert!(back.abs_diff(t) <= 1, "{} -> {} -> {}", t, ticks_to_us(t), back);
    }
}
