//! CRSF telemetry frames against bytes worked out by hand from the TBS
//! specification and the crsf-wg description's examples, the unit
//! conversions against floating-point references, and the scheduler's
//! order and rates.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use proptest::prelude::*;
use rc_input::telemetry::*;
use rc_input::CrsfParser;

/// CRC-8/DVB-S2 bit by bit (poly 0xD5, MSB first, init 0), independent of
/// the crate's nibble tables.
fn crc_bitwise(data: &[u8]) -> u8 {
    let mut crc = 0u8;
    for &b in data {
        crc ^= b;
        for _ in 0..8 {
            crc = if crc & 0x80 != 0 {
                (crc << 1) ^ 0xD5
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// `head` (sync byte to last payload byte, written by hand) with its CRC
/// over type and payload appended.
fn with_crc(head: &[u8]) -> Vec<u8> {
    let mut v = head.to_vec();
    v.push(crc_bitwise(&head[2..]));
    v
}

fn encoded(f: impl FnOnce(&mut [u8; 64]) -> usize) -> Vec<u8> {
    let mut out = [0xAAu8; 64];
    let n = f(&mut out);
    out[..n].to_vec()
}

/// π/4 in Q16 rad, rounded (0.785 398 · 65 536 = 51 471.85).
const QUARTER_PI_Q16: i32 = 51_472;

#[test]
fn battery_frame_by_hand() {
    // crsf-wg examples: 25.2 V → 252 = 0x00FC, 18.9 A → 189 = 0x00BD,
    // 2199 mAh → 0x000897, 20 % → 0x14. Length: type + 8 + CRC = 10.
    let b = Battery {
        voltage_mv: 25_200,
        current_ma: 18_900,
        used_mah: 2_199,
        remaining_pct: 20,
    };
    let want = with_crc(&[
        0xC8, 0x0A, 0x08, 0x00, 0xFC, 0x00, 0xBD, 0x00, 0x08, 0x97, 0x14,
    ]);
    assert_eq!(encoded(|o| encode_battery(&b, o)), want);
    // 3.7 V → 37; a charging −0.25 A rounds away from zero to −3 (0xFFFD);
    // 100 % full and more is 100.
    let b = Battery {
        voltage_mv: 3_700,
        current_ma: -250,
        used_mah: 0,
        remaining_pct: 180,
    };
    let want = with_crc(&[
        0xC8, 0x0A, 0x08, 0x00, 0x25, 0xFF, 0xFD, 0x00, 0x00, 0x00, 0x64,
    ]);
    assert_eq!(encoded(|o| encode_battery(&b, o)), want);
}

#[test]
fn attitude_frame_by_hand_in_pitch_roll_yaw_order() {
    // Pitch 45° → 7854 = 0x1EAE, roll −45° → −7854 = 0xE152, yaw 180° →
    // clamped to 31 415 = 0x7AB7. (The crsf-wg examples 0x1EAD / 0xE153
    // truncate 7853.98; rounding sends the nearer 7854.)
    let a = Attitude {
        roll_rad_q16: -QUARTER_PI_Q16,
        pitch_rad_q16: QUARTER_PI_Q16,
        yaw_rad_q16: PI_RAD_Q16,
    };
    let want = with_crc(&[0xC8, 0x08, 0x1E, 0x1E, 0xAE, 0xE1, 0x52, 0x7A, 0xB7]);
    assert_eq!(encoded(|o| encode_attitude(&a, o)), want);
}

#[test]
fn flight_mode_frames_by_hand() {
    let cases: [(ModeName, Arming, &[u8]); 5] = [
        (ModeName::Angle, Arming::Ready, b"ANGL*\0"),
        (ModeName::Acro, Arming::Armed, b"ACRO\0"),
        (ModeName::AltitudeHold, Arming::Blocked, b"ALTH!\0"),
        (ModeName::Failsafe, Arming::Ready, b"!FS!\0"),
        (ModeName::Failsafe, Arming::Armed, b"!FS!\0"),
    ];
    for (mode, arming, text) in cases {
        let mut head = vec![0xC8, text.len() as u8 + 2, 0x21];
        head.extend_from_slice(text);
        let fm = FlightMode { mode, arming };
        assert_eq!(encoded(|o| encode_flight_mode(&fm, o)), with_crc(&head));
    }
    // "ANGL*": 0x41 0x4E 0x47 0x4C 0x2A 0x00, length 8.
    let fm = FlightMode::default();
    let want = with_crc(&[0xC8, 0x08, 0x21, 0x41, 0x4E, 0x47, 0x4C, 0x2A, 0x00]);
    assert_eq!(encoded(|o| encode_flight_mode(&fm, o)), want);
}

#[test]
fn baro_altitude_frames_by_hand() {
    // crsf-wg examples: 10 m → 0x2774, −10 m → 0x26AC; 1.5 m/s → 150.
    let up = BaroAltitude {
        altitude_cm: 1_000,
        vertical_speed_cmps: 150,
    };
    let want = with_crc(&[0xC8, 0x06, 0x09, 0x27, 0x74, 0x00, 0x96]);
    assert_eq!(encoded(|o| encode_baro_altitude(&up, o)), want);
    let down = BaroAltitude {
        altitude_cm: -1_000,
        vertical_speed_cmps: -150,
    };
    let want = with_crc(&[0xC8, 0x06, 0x09, 0x26, 0xAC, 0xFF, 0x6A]);
    assert_eq!(encoded(|o| encode_baro_altitude(&down, o)), want);
}

#[test]
fn the_bitwise_crc_gives_the_catalogue_check_value() {
    // CRC-8/DVB-S2's check value (the CRC RevEng catalogue): what anchors
    // the test's own CRC, independent of the crate.
    assert_eq!(crc_bitwise(b"123456789"), 0xBC);
}

fn all_frames(s: &TelemetrySnapshot) -> Vec<Vec<u8>> {
    FrameKind::ALL
        .iter()
        .filter_map(|&k| {
            let mut out = [0u8; 64];
            s.encode(k, &mut out).map(|n| out[..n].to_vec())
        })
        .collect()
}

fn snapshot_full() -> TelemetrySnapshot {
    TelemetrySnapshot {
        attitude: Attitude {
            roll_rad_q16: 12_345,
            pitch_rad_q16: -54_321,
            yaw_rad_q16: 200_000,
        },
        baro: Some(BaroAltitude {
            altitude_cm: 12_345,
            vertical_speed_cmps: -321,
        }),
        battery: Some(Battery {
            voltage_mv: 16_049,
            current_ma: 45_678,
            used_mah: 1_234,
            remaining_pct: 57,
        }),
        flight_mode: FlightMode {
            mode: ModeName::AltitudeHold,
            arming: Arming::Armed,
        },
    }
}

#[test]
fn the_receiver_parser_accepts_every_frame_as_a_valid_frame_of_another_type() {
    let frames = all_frames(&snapshot_full());
    assert_eq!(frames.len(), 4);
    let mut parser = CrsfParser::new();
    for (i, b) in frames.concat().iter().enumerate() {
        assert_eq!(parser.push(*b, 24 * i as u32), None);
    }
    let st = parser.stats();
    assert_eq!(st.unknown_type, 4, "{st:?}");
    assert_eq!(st.dropped(), 0, "{st:?}");
    assert_eq!(st.skipped_bytes, 0, "{st:?}");
}

#[test]
fn decoded_frames_carry_the_inputs_in_wire_units() {
    let s = snapshot_full();
    let frames = all_frames(&s);
    let decoded: Vec<_> = frames
        .iter()
        .map(|f| decode_telemetry(f).unwrap())
        .collect();
    // 200 000 Q16 rad = 3.051 76 rad → 30 518; −54 321 → −0.828 87 → −8289;
    // 12 345 → 0.188 37 → 1884.
    assert_eq!(
        decoded[0],
        TelemetryFrame::Attitude {
            pitch_e4_rad: -8_289,
            roll_e4_rad: 1_884,
            yaw_e4_rad: 30_518
        }
    );
    // 123.45 m → 1234.5 dm → 1235 dm (halves away from zero).
    assert_eq!(
        decoded[1],
        TelemetryFrame::BaroAltitude {
            altitude_dm: 1_235,
            vertical_speed_cmps: Some(-321)
        }
    );
    assert_eq!(
        decoded[2],
        TelemetryFrame::Battery {
            voltage_dv: 160,
            current_da: 457,
            used_mah: 1_234,
            remaining_pct: 57
        }
    );
    let TelemetryFrame::FlightMode { text, len } = decoded[3] else {
        panic!("{:?}", decoded[3]);
    };
    assert_eq!(&text[..len], b"ALTH");
}

#[test]
fn decoder_rejects_what_a_receiver_would() {
    let mut f = all_frames(&snapshot_full()).remove(0);
    let last = f.len() - 1;
    f[last] ^= 1;
    assert_eq!(decode_telemetry(&f), Err(TelemetryDecodeError::Crc));
    assert_eq!(
        decode_telemetry(&f[..last]),
        Err(TelemetryDecodeError::Length)
    );
    let link = rc_input::crsf::encode_link_statistics(0xC8, &Default::default());
    assert_eq!(
        decode_telemetry(&link),
        Err(TelemetryDecodeError::UnknownType(0x14))
    );
    // A 2-byte baro payload (the crsf-wg form without speed) decodes.
    let short = with_crc(&[0xC8, 0x04, 0x09, 0x80, 0x0A]);
    assert_eq!(
        decode_telemetry(&short),
        Ok(TelemetryFrame::BaroAltitude {
            altitude_dm: 100,
            vertical_speed_cmps: None
        })
    );
}

#[test]
fn every_frame_fits_the_stated_maximum() {
    let mut s = snapshot_full();
    for mode in [
        ModeName::Acro,
        ModeName::Angle,
        ModeName::AltitudeHold,
        ModeName::Failsafe,
    ] {
        for arming in [Arming::Armed, Arming::Ready, Arming::Blocked] {
            s.flight_mode = FlightMode { mode, arming };
            let mut out = [0u8; 64];
            let n = encode_flight_mode(&s.flight_mode, &mut out);
            assert!(n - 4 <= FLIGHT_MODE_MAX_PAYLOAD_BYTES);
            for f in all_frames(&s) {
                assert!(f.len() <= MAX_TELEMETRY_FRAME_BYTES, "{f:02X?}");
            }
        }
    }
    assert_eq!(MAX_TELEMETRY_FRAME_BYTES, 12);
}

/// f32 reference of [`attitude_e4_rad`]: wrap, round, clamp.
fn attitude_ref_f32(q16: i32) -> i16 {
    let rad = q16 as f32 / 65_536.0;
    let pi = core::f32::consts::PI;
    // Wrapped only when outside: adding and taking π again would move
    // exact halves.
    let w = if (-pi..pi).contains(&rad) {
        rad
    } else {
        (rad + pi).rem_euclid(2.0 * pi) - pi
    };
    (w * 10_000.0).round().clamp(-31_415.0, 31_415.0) as i16
}

/// Exact (f64) reference.
fn attitude_ref_f64(q16: i32) -> i16 {
    let rad = f64::from(q16) / 65_536.0;
    let pi = core::f64::consts::PI;
    // Wrapped only when outside: adding and taking π again would move
    // exact halves.
    let w = if (-pi..pi).contains(&rad) {
        rad
    } else {
        (rad + pi).rem_euclid(2.0 * pi) - pi
    };
    (w * 10_000.0).round().clamp(-31_415.0, 31_415.0) as i16
}

#[test]
fn attitude_conversion_matches_the_float_references_over_a_turn() {
    let mut worst_f32 = 0i32;
    for q16 in -PI_RAD_Q16..=PI_RAD_Q16 {
        let got = attitude_e4_rad(q16);
        assert_eq!(got, attitude_ref_f64(q16), "q16 {q16}");
        worst_f32 = worst_f32.max((i32::from(got) - i32::from(attitude_ref_f32(q16))).abs());
    }
    // f32 has 24 bits: the reference itself is off by one near halves.
    assert!(worst_f32 <= 1, "{worst_f32}");
}

#[test]
fn attitude_wraps_and_saturates() {
    // 2π + 1 rad wraps to 1 rad; −(2π + 1) to −1 rad.
    let two_pi_plus_one = ((2.0 * core::f64::consts::PI + 1.0) * 65_536.0).round() as i32;
    assert_eq!(attitude_e4_rad(two_pi_plus_one), 10_000);
    assert_eq!(attitude_e4_rad(-two_pi_plus_one), -10_000);
    // Just past ±π: the other side; exactly at the ends: the clamp.
    assert_eq!(attitude_e4_rad(PI_RAD_Q16 + 1), -31_415);
    assert_eq!(attitude_e4_rad(PI_RAD_Q16), 31_415);
    assert_eq!(attitude_e4_rad(-PI_RAD_Q16), -31_415);
    for q16 in [
        i32::MIN,
        i32::MIN + 1,
        i32::MAX,
        i32::MAX - 7,
        1 << 30,
        -(1 << 30),
    ] {
        assert_eq!(attitude_e4_rad(q16), attitude_ref_f64(q16), "{q16}");
    }
}

#[test]
fn battery_conversions_round_and_saturate() {
    // Halves: 25 250 mV → 252.5 dV → 253; 25 249 → 252.
    assert_eq!(voltage_dv(25_250), 253);
    assert_eq!(voltage_dv(25_249), 252);
    assert_eq!(voltage_dv(3_276_700), 32_767);
    assert_eq!(voltage_dv(u32::MAX), 32_767);
    assert_eq!(current_da(-150), -2);
    assert_eq!(current_da(-149), -1);
    assert_eq!(current_da(150), 2);
    assert_eq!(current_da(i32::MAX), i16::MAX);
    assert_eq!(current_da(i32::MIN), i16::MIN);
    assert_eq!(used_mah_u24(0x80_0000), USED_MAH_LIMIT);
    assert_eq!(used_mah_u24(2_199), 2_199);
    for mv in (0..=3_276_749u32).step_by(7) {
        assert_eq!(
            u32::from(voltage_dv(mv)),
            (f64::from(mv) / 100.0).round() as u32
        );
    }
}

#[test]
fn altitude_packing_at_its_boundaries() {
    // 2276.7 m is the dm form's top (0x7FFF); 2276.8 m goes to metres:
    // 22 768 dm → 2277 m → 0x8000 | 2277 = 0x88E5.
    assert_eq!(altitude_packed(227_670), 0x7FFF);
    assert_eq!(altitude_packed(227_680), 0x88E5);
    // −1000.0 m is 0; below stays 0.
    assert_eq!(altitude_packed(-100_000), 0);
    assert_eq!(altitude_packed(-100_006), 0);
    assert_eq!(altitude_packed(i32::MIN), 0);
    // 0 m is 10 000; 5 mm rounds to 1 dm (10 001), 4 mm to 0.
    assert_eq!(altitude_packed(0), 10_000);
    assert_eq!(altitude_packed(5), 10_001);
    assert_eq!(altitude_packed(4), 10_000);
    // The top: 32 766 m (0xFFFE), never 0xFFFF.
    assert_eq!(altitude_packed(3_276_600), 0xFFFE);
    assert_eq!(altitude_packed(i32::MAX), 0xFFFE);
    // 6407.45 m → 6407 m: rounded once from cm (via 64 075 dm it would
    // be 6408).
    assert_eq!(altitude_packed(640_745), 0x8000 | 6_407);
    assert_eq!(altitude_unpacked_dm(0x800A), 100);
    assert_eq!(altitude_unpacked_dm(0x26AC), -100);
    assert_eq!(vertical_speed_cmps_i16(40_000), i16::MAX);
    assert_eq!(vertical_speed_cmps_i16(-40_000), i16::MIN);
}

proptest! {
    /// The packed altitude reads back within its resolution (0.05 m in
    /// the dm form, 0.5 m in metres) and never decreases with height.
    #[test]
    fn altitude_round_trips_within_resolution(cm in -100_000i32..3_276_000, d in 0i32..2_000) {
        let back_dm = altitude_unpacked_dm(altitude_packed(cm));
        let err_cm = (back_dm * 10 - cm).abs();
        let limit = if cm < 227_675 { 5 } else { 50 };
        prop_assert!(err_cm <= limit, "{cm} cm → {back_dm} dm");
        prop_assert!(altitude_unpacked_dm(altitude_packed(cm + d)) >= back_dm);
    }

    /// Any snapshot's frames are valid CRSF frames that decode to the
    /// converted inputs.
    #[test]
    fn any_snapshot_round_trips(
        mv in any::<u32>(), ma in any::<i32>(), mah in any::<u32>(), pct in any::<u8>(),
        roll in any::<i32>(), pitch in any::<i32>(), yaw in any::<i32>(),
        alt in any::<i32>(), vs in any::<i32>(),
    ) {
        let s = TelemetrySnapshot {
            attitude: Attitude { roll_rad_q16: roll, pitch_rad_q16: pitch, yaw_rad_q16: yaw },
            baro: Some(BaroAltitude { altitude_cm: alt, vertical_speed_cmps: vs }),
            battery: Some(Battery { voltage_mv: mv, current_ma: ma, used_mah: mah, remaining_pct: pct }),
            flight_mode: FlightMode::default(),
        };
        let frames = all_frames(&s);
        prop_assert_eq!(frames.len(), 4);
        for f in &frames {
            prop_assert_eq!(f[0], 0xC8);
            prop_assert_eq!(usize::from(f[1]) + 2, f.len());
            prop_assert_eq!(*f.last().unwrap(), crc_bitwise(&f[2..f.len() - 1]));
        }
        prop_assert_eq!(decode_telemetry(&frames[0]).unwrap(), TelemetryFrame::Attitude {
            pitch_e4_rad: attitude_e4_rad(pitch),
            roll_e4_rad: attitude_e4_rad(roll),
            yaw_e4_rad: attitude_e4_rad(yaw),
        });
        prop_assert_eq!(decode_telemetry(&frames[2]).unwrap(), TelemetryFrame::Battery {
            voltage_dv: voltage_dv(mv),
            current_da: current_da(ma),
            used_mah: used_mah_u24(mah),
            remaining_pct: pct.min(100),
        });
    }
}

/// Runs the scheduler for `duration_us` of RC frames every `period_us`;
/// returns how many frames of each type went out and the least gap.
fn run(
    sched: &mut TelemetryScheduler,
    s: &TelemetrySnapshot,
    period_us: u32,
    duration_us: u32,
) -> ([u32; 4], u32) {
    let mut counts = [0u32; 4];
    let mut out = [0u8; 64];
    let mut last: Option<u32> = None;
    let mut min_gap = u32::MAX;
    let mut t = 0u32;
    while t < duration_us {
        if let Some(n) = sched.on_rc_frame(t, s, &mut out) {
            assert!(n <= MAX_TELEMETRY_FRAME_BYTES);
            let k = FrameKind::ALL
                .iter()
                .position(|k| k.frame_type() == out[2])
                .unwrap();
            counts[k] += 1;
            if let Some(l) = last {
                min_gap = min_gap.min(t - l);
            }
            last = Some(t);
        }
        t += period_us;
    }
    (counts, min_gap)
}

#[test]
fn round_robin_in_betaflight_order() {
    let s = snapshot_full();
    let mut sched = TelemetryScheduler::with_min_interval_us(FrameSet::ALL, 0);
    let mut out = [0u8; 64];
    let types: Vec<u8> = (0..9)
        .map(|i| {
            sched.on_rc_frame(i * 1_000, &s, &mut out).unwrap();
            out[2]
        })
        .collect();
    assert_eq!(
        types,
        [0x1E, 0x09, 0x08, 0x21, 0x1E, 0x09, 0x08, 0x21, 0x1E]
    );
}

#[test]
fn rates_per_rc_rate_are_as_stated_and_at_least_5_hz() {
    let s = snapshot_full();
    // 25, 50, 150, 250, 500 and 1000 Hz RC frames, 20 s each.
    for period_us in [40_000u32, 20_000, 6_667, 4_000, 2_000, 1_000] {
        let mut sched = TelemetryScheduler::new(FrameSet::ALL);
        assert_eq!(sched.min_interval_us(), 25_000);
        let (counts, min_gap) = run(&mut sched, &s, period_us, 20_000_000);
        assert!(min_gap >= 25_000, "{period_us}: {min_gap}");
        let want_mhz = per_frame_rate_mhz(period_us, 4, 25_000);
        for c in counts {
            // Frames in 20 s against the stated rate, ±1 frame.
            let want = u64::from(want_mhz) * 20 / 1_000;
            assert!(
                u64::from(c).abs_diff(want) <= 1,
                "{period_us} µs: {c} vs {want}"
            );
            assert!(c >= 5 * 20, "{period_us} µs: {c} frames in 20 s");
        }
    }
    // The figures the documentation states.
    assert_eq!(per_frame_rate_mhz(20_000, 4, 25_000), 6_250);
    assert_eq!(per_frame_rate_mhz(40_000, 4, 25_000), 6_250);
    assert_eq!(per_frame_rate_mhz(4_000, 4, 25_000), 8_928);
    assert_eq!(per_frame_rate_mhz(2_000, 4, 25_000), 9_615);
    assert_eq!(per_frame_rate_mhz(1_000, 4, 25_000), 10_000);
}

#[test]
fn missing_or_disabled_frames_give_their_turn_away() {
    let mut s = snapshot_full();
    s.battery = None;
    let mut sched = TelemetryScheduler::new(FrameSet::ALL.without(FrameKind::Attitude));
    assert_eq!(sched.min_interval_us(), 33_333);
    let (counts, _) = run(&mut sched, &s, 20_000, 2_000_000);
    assert_eq!(counts[0], 0); // disabled
    assert_eq!(counts[2], 0); // no data
                              // 50 Hz, every 2nd frame (40 ms): 50 frames in 2 s, shared by two.
    assert_eq!(counts[1] + counts[3], 50);
    assert!(counts[1].abs_diff(counts[3]) <= 1);
    let mut none = TelemetryScheduler::new(FrameSet::NONE);
    assert_eq!(run(&mut none, &s, 20_000, 1_000_000).0, [0; 4]);
}

#[test]
fn the_interval_holds_across_the_counter_wrap() {
    let s = snapshot_full();
    let mut sched = TelemetryScheduler::new(FrameSet::ALL);
    let mut out = [0u8; 64];
    let t0 = u32::MAX - 10_000;
    assert!(sched.on_rc_frame(t0, &s, &mut out).is_some());
    assert!(sched
        .on_rc_frame(t0.wrapping_add(20_000), &s, &mut out)
        .is_none());
    assert!(sched
        .on_rc_frame(t0.wrapping_add(25_000), &s, &mut out)
        .is_some());
}

#[test]
fn a_frame_fits_between_rc_frames_at_1000_hz() {
    // 26 bytes · 10 bits / 420 000 baud = 619.05 µs → 620; 12 bytes →
    // 285.71 → 286; 1000 − 620 − 286 = 94.
    assert_eq!(wire_time_us(RC_FRAME_BYTES), 620);
    assert_eq!(wire_time_us(MAX_TELEMETRY_FRAME_BYTES), 286);
    assert_eq!(SLOT_MARGIN_US, 94);
}
