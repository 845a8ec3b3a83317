//! The debug host stops reading RTT (a closed `cargo embed`): the firmware
//! must keep its 1 kHz loop running, with the channel mode `Embed.toml`
//! makes the probe set.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::BoardFault;

/// Host reads for 2 s, stops for 3 s, resumes: the IMU loop keeps ≥ 2900
/// updates over the 3 s without a reset, and lines arrive again after the
/// host resumes (6 s simulated).
#[test]
fn loop_keeps_running_while_the_host_does_not_read() {
    let Some(mut b) = board() else { return };
    boot_ok(&mut b);
    run_until(&mut b, 2 * S);
    b.apply(BoardFault::RttReaderStops);
    let n = imu_updates_during(&mut b, 3 * S);
    assert!(
        n >= 2900,
        "{n} IMU updates in 3 s without an RTT reader\n{}",
        tail(&b, 20)
    );
    assert_no_reset(&b);
    b.apply(BoardFault::RttReaderResumes);
    let resumed = b.now_ns();
    run_until(&mut b, 6 * S);
    assert!(
        !lines_after(&b, resumed, "att r=").is_empty(),
        "{}",
        tail(&b, 20)
    );
}
