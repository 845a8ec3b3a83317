//! The calibration flash page: blank and corrupt (either build); written
//! by the calibration build's six-position and magnetometer sessions, then
//! read back after a reset; the flight build refuses both sessions and
//! leaves the page alone.
//!
//! The session tests need the calibration build (`cargo build -p firmware
//! --target thumbv7m-none-eabi --release --features calibrate`, its ELF in
//! `FIL_ELF`; `scripts/check` does both); on the flight build they say
//! "skipped", and the flight build's refusal test runs instead (it skips
//! on the calibration build). A flight ELF given in `FIL_ELF` fails the
//! session tests.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::crsf::{rc_frame, ticks};
use emulator::{Board, BoardConfig, BoardFault, ResetCause};
use sensor_stack::storage::{self, CalibrationRecord, ValidParts};
use sim::Trajectory;

/// The calibration page's offset in a flash image: the chip's last 1 KiB
/// page (the C8's `0x0800_FC00`, the CB's `0x0801_FC00`), so these
/// scenarios run on the calibration build of either chip.
fn page_of(image: &[u8]) -> usize {
    emulator::calpage::page_offset(image.len())
}
const CRSF_BAUD: u32 = 420_000;

/// Which firmware build a board runs, from its flight-controller boot line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Build {
    Flight,
    Calibration,
}

fn build_of(b: &mut Board) -> Build {
    let line = b
        .wait_for_line("flight controller:", 2 * S)
        .unwrap()
        .unwrap_or_else(|| panic!("no flight controller line\n{}", tail(b, 20)));
    if line.text.contains("not built (calibration build)") {
        Build::Calibration
    } else {
        Build::Flight
    }
}

/// A board with `config` adjusted by `f`, running the `want` build, booted
/// to its flight-controller line with the button held from power-up if
/// `held`; `None` (skipped) when the firmware under test is the other
/// build and no `FIL_ELF` was given.
fn board_of(want: Build, held: bool, f: impl FnOnce(&mut BoardConfig)) -> Option<Board> {
    let mut b = board_with(f)?;
    if held {
        b.apply(BoardFault::Button(true));
    }
    let got = build_of(&mut b);
    if got != want {
        // A calibration build asked for by FIL_ELF and not given is a
        // mistake; the flight build's test just skips on the calibration
        // build (scripts/check runs this file on both).
        if want == Build::Calibration && std::env::var_os("FIL_ELF").is_some() {
            panic!("FIL_ELF is the {got:?} build; this test needs the {want:?} build");
        }
        println!(
            "skipped: the firmware under test is the {got:?} build (set FIL_ELF to the {want:?} build)"
        );
        return None;
    }
    Some(b)
}

/// The calibration build with the button held at power-up and released
/// after 1 s: the six-position session running, the builder about to
/// present the faces (`Trajectory::SixPosition`). `None`: skipped.
fn six_position_started() -> Option<Board> {
    let mut b = board_of(Build::Calibration, true, |c| {
        c.sim.trajectory = Trajectory::SixPosition;
    })?;
    run_until(&mut b, S);
    b.apply(BoardFault::Button(false));
    Some(b)
}

/// Erased page: defaults, and the log says why (≤ 1 s simulated).
#[test]
fn blank_page_gives_defaults() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, S);
    assert_logged(
        &b,
        "calibration: using defaults (the page is blank: never calibrated)",
    );
}

/// A valid record with one flipped payload byte: defaults and a CRC
/// reason (≤ 1 s simulated); the page itself is left as it was.
#[test]
fn corrupt_page_gives_defaults_with_the_reason() {
    let Some(path) = elf() else { return };
    let fw = emulator::Firmware::load(&path).expect("ELF");
    let mut image = fw.flash.clone();
    let mut rec = CalibrationRecord {
        gyro_bias_dps: [0.5, -0.25, 0.125],
        ..Default::default()
    };
    rec.valid.0 |= ValidParts::GYRO;
    let bytes = storage::encode(&rec);
    let at = page_of(&image);
    image[at..at + bytes.len()].copy_from_slice(&bytes);
    image[at + storage::HEADER_LEN + 6] ^= 0x10;
    let before = image[at..at + 1024].to_vec();
    let mut b = emulator::Board::new(
        &fw,
        emulator::BoardConfig {
            flash: Some(image),
            ..Default::default()
        },
    )
    .expect("board");
    boot_ok(&mut b);
    run_until(&mut b, S);
    assert_logged(
        &b,
        "calibration: using defaults (the record is corrupt (CRC stored",
    );
    assert_eq!(&b.flash_image()[at..at + 1024], &before[..]);
}

fn assert_read_back_after_reset(mut b: emulator::Board, part: u16) {
    let at = page_of(b.flash_image());
    let page = b.flash_image()[at..at + storage::RECORD_LEN].to_vec();
    let rec = storage::decode(&page).expect("a valid record in flash");
    assert!(rec.valid.has(part), "parts {:#x}", rec.valid.0);
    let t = b.now_ns();
    b.reset(ResetCause::Watchdog).expect("reset");
    run_until(&mut b, t + S);
    let loaded = lines_after(&b, t, "calibration loaded from flash");
    assert!(!loaded.is_empty(), "{}", tail(&b, 30));
    assert!(
        loaded[0].contains(&format!("{:#x}", rec.valid.0)),
        "{loaded:?}"
    );
}

/// Button held at power-up, the six faces held in turn (≈ 40 s simulated):
/// the offsets are saved, and read back after a watchdog-style reset.
#[test]
fn six_position_calibration_is_saved_and_read_back() {
    let Some(mut b) = six_position_started() else {
        return;
    };
    assert_logged(&b, "accelerometer six-position calibration");
    let end = (Trajectory::six_position_duration_s() + 5.0) as u64 * S;
    let saved = b
        .wait_for_line("calibration saved to flash", end)
        .expect("board");
    assert!(saved.is_some(), "{}", tail(&b, 40));
    // The log names each next face in words, in the order the simulated
    // builder presents them (level, upside down, nose up, ...), and no
    // Rust debug text.
    assert_logged(&b, "0 of 6 faces done; next: lay it flat, the right way up");
    assert_logged(&b, "1 of 6 faces done; next: lay it upside down");
    assert_logged(&b, "2 of 6 faces done; next: stand it on its tail, nose up");
    assert!(lines_with(&b, "accel cal")
        .iter()
        .all(|l| !l.contains("Some(")));
    assert_read_back_after_reset(b, ValidParts::ACCEL);
}

/// Long press (2 s) then the figure-eight dance: the magnetometer
/// calibration is saved, and read back after a reset (≤ 60 s simulated).
#[test]
fn magnetometer_calibration_is_saved_and_read_back() {
    let Some(mut b) = board_of(Build::Calibration, false, |c| {
        c.sim.trajectory = Trajectory::FigureEight;
    }) else {
        return;
    };
    assert_logged(&b, "capabilities:");
    run_until(&mut b, S);
    b.apply(BoardFault::Button(true));
    run_until(&mut b, 3 * S);
    b.apply(BoardFault::Button(false));
    let saved = b
        .wait_for_line("calibration saved to flash", 60 * S)
        .expect("board");
    assert!(saved.is_some(), "{}", tail(&b, 40));
    assert_logged(&b, "mag cal done");
    assert_read_back_after_reset(b, ValidParts::MAG);
}

/// The flight build runs no calibration session: the button held at power
/// up and a long press each log where the sessions are, the mode stays
/// normal (the live log goes on), and the calibration page is not touched.
#[test]
fn the_flight_build_refuses_calibration_sessions_and_leaves_the_page() {
    let Some(mut b) = board_of(Build::Flight, true, |c| {
        c.sim.trajectory = Trajectory::SixPosition;
    }) else {
        return;
    };
    let at = page_of(b.flash_image());
    let before = b.flash_image()[at..at + 1024].to_vec();
    run_until(&mut b, S);
    b.apply(BoardFault::Button(false));
    run_until(&mut b, 2 * S);
    b.apply(BoardFault::Button(true));
    run_until(&mut b, 4 * S);
    b.apply(BoardFault::Button(false));
    run_until(&mut b, 8 * S);
    let refusals = lines_with(&b, "calibration: not in the flight build");
    assert_eq!(refusals.len(), 2, "boot and long press\n{}", tail(&b, 30));
    assert!(refusals[0].contains("--features calibrate"), "{refusals:?}");
    assert!(lines_with(&b, "accel cal").is_empty() && lines_with(&b, "mag cal").is_empty());
    assert!(
        lines_with(&b, "mode Normal ->").is_empty(),
        "{}",
        tail(&b, 30)
    );
    assert!(
        !lines_after(&b, 7 * S, "att r=").is_empty(),
        "{}",
        tail(&b, 30)
    );
    assert_eq!(&b.flash_image()[at..at + 1024], &before[..]);
}

/// A CRSF frame: sticks centred, throttle at `throttle_us`, the arm
/// switch (channel 5) on if `arm`, angle mode.
fn sticks(throttle_us: u16, arm: bool) -> Vec<u8> {
    let mut ch = [ticks(1500); 16];
    ch[2] = ticks(throttle_us);
    ch[4] = ticks(if arm { 2000 } else { 1000 });
    ch[5] = ticks(1000);
    rc_frame(ch)
}

/// A flash page erase stalls the CPU for 20 ms (the calibration save after
/// the six-position calibration, ≈ 40 s simulated) while frames keep
/// coming at 500 Hz: the DMA goes on receiving and laps the 128 B ring,
/// the handover after the stall counts itself late (bytes overwritten, the
/// frames they belonged to never delivered), the link holds (100 ms
/// timeout) and the frames after it parse.
#[test]
fn a_flash_erase_during_reception_is_counted_late_and_the_link_holds() {
    let Some(mut b) = six_position_started() else {
        return;
    };
    let frame = sticks(1000, false);
    let end = (Trajectory::six_position_duration_s() + 5.0) as u64 * S;
    let mut saved_at = None;
    // The sender keeps its schedule through the stall: frames are queued
    // on the line 50 ms ahead.
    let mut next = b.now_ns();
    while b.now_ns() < saved_at.map_or(end, |t| t + 1_200 * MS) {
        while next < b.now_ns() + 50 * MS {
            b.usart1_send_at(&frame, CRSF_BAUD, next);
            next += 2 * MS;
        }
        run_for(&mut b, 2 * MS);
        if saved_at.is_none() && !lines_with(&b, "calibration saved to flash").is_empty() {
            saved_at = Some(b.now_ns());
        }
    }
    let saved_at = saved_at.unwrap_or_else(|| panic!("no save\n{}", tail(&b, 30)));
    let up = lines_with(&b, "rc: link up").len();
    assert_eq!(up, 1, "the link came up once and held\n{}", tail(&b, 30));
    assert!(lines_with(&b, "rc: link lost").is_empty());
    let last = last_channel_line(&b, saved_at);
    assert!(field(&last, "late ") >= 1, "{last}");
    let before = lines_with(&b, "rc: ch1-8");
    let first = before.first().map_or(0, |l| field(l, "frames "));
    assert!(field(&last, "frames ") > first + 1_000, "{last}");
    assert_eq!(b.usart1_counts().1, 0, "still no overrun");
    println!("{last}");
}
