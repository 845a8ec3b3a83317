//! The calibration flash page: blank, corrupt, and written by the
//! six-position and magnetometer modes, then read back after a reset.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::{BoardFault, ResetCause};
use flight::storage::{self, CalibrationRecord, ValidParts};
use sim::Trajectory;

const PAGE: usize = (storage::PAGE_ADDRESS - 0x0800_0000) as usize;

/// Erased page: defaults, and the log says why (≤ 1 s simulated).
#[test]
fn blank_page_gives_defaults() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, S);
    assert_logged(&b, "calibration: using defaults (Blank)");
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
    image[PAGE..PAGE + bytes.len()].copy_from_slice(&bytes);
    image[PAGE + storage::HEADER_LEN + 6] ^= 0x10;
    let before = image[PAGE..PAGE + 1024].to_vec();
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
    assert_logged(&b, "calibration: using defaults (CrcMismatch");
    assert_eq!(&b.flash_image()[PAGE..PAGE + 1024], &before[..]);
}

fn assert_read_back_after_reset(mut b: emulator::Board, part: u16) {
    let page = b.flash_image()[PAGE..PAGE + storage::RECORD_LEN].to_vec();
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
    let Some(mut b) = board_with(|c| c.sim.trajectory = Trajectory::SixPosition) else {
        return;
    };
    b.apply(BoardFault::Button(true));
    run_until(&mut b, S);
    b.apply(BoardFault::Button(false));
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
    let Some(mut b) = board_with(|c| c.sim.trajectory = Trajectory::FigureEight) else {
        return;
    };
    boot_ok(&mut b);
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
