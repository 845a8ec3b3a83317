//! The boot watchdog's budget on the real firmware: the longest boot the
//! probes can make, at the LSI's fastest 60 kHz (the shortest timeout,
//! 2.0 s), with the waits measured on the DWT cycle counter.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::*;
use emulator::Board;
use sim::{Chip, Fault};

/// PWR_MGMT_1 and its H_RESET bit.
const PWR_MGMT_1: u8 = 0x6B;
const H_RESET: u8 = 0x80;
const MPU_ADDRESS: u8 = 0x68;

/// Where the driven MPU-9250 is in its probe attempt.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Attempt {
    /// Before the reset of the next attempt.
    Idle,
    /// Reset written: the chip NACKs 19 of the 20 polls ("still
    /// rebooting"), the last finds H_RESET clear.
    Resetting,
    /// Configured and in bypass: the post-reset check after the 100 ms
    /// settle will read a wrong WHO_AM_I (set at this time, ns).
    Settling(u64),
    /// The check read it (at this time, ns): the id is restored 2 ms
    /// later, before the retry's WHO_AM_I.
    Failed(u64),
}

/// One step of the fault driver: an MPU-9250 that answers but makes each
/// probe attempt take its longest path (every reset poll but the last,
/// then the 100 ms settle, then a failed check). `tx` the bus's
/// transaction count at the last step.
fn drive(b: &mut Board, at: Attempt, tx: &mut u64, attempts: &mut u32) -> Attempt {
    let now = b.now_ns();
    let (reg, bypass) = {
        let s = b.sim().state();
        (s.mpu.register(PWR_MGMT_1), s.mpu.bypass_active())
    };
    let (count, _) = b.sim().transaction_counts();
    let new_tx = count > *tx;
    *tx = count;
    match at {
        Attempt::Idle if reg & H_RESET != 0 => {
            *attempts += 1;
            b.sim().inject(Fault::Nack {
                address: MPU_ADDRESS,
                transactions: Some(19),
            });
            Attempt::Resetting
        }
        Attempt::Resetting if bypass => {
            b.sim().inject(Fault::WrongChipId {
                chip: Chip::Mpu9250,
                id: 0x12,
            });
            Attempt::Settling(now)
        }
        Attempt::Settling(t) if now > t + 50 * MS && new_tx => Attempt::Failed(now),
        Attempt::Failed(t) if now > t + 2 * MS => {
            b.sim().state_mut().mpu.who_am_i_override = None;
            Attempt::Idle
        }
        other => other,
    }
}

/// The worst boot: the MPU-9250 answers but fails its post-reset check
/// three times, each attempt on its longest path (≈ 200 ms of reset polls,
/// the 100 ms settle), after its 100 ms power-up wait: ≈ 1.03 s of waits
/// before the barometer's probe. With the waits on CYCCNT the boot ends
/// within the 1.15 s `watchdog.rs` budgets (a wait counted in loop
/// iterations ran 2× long here, 3× on silicon: past the 2.0 s timeout),
/// and at LSI 60 kHz the board is never reset (3 s simulated).
#[test]
fn the_worst_boot_fits_the_boot_watchdog_at_the_fastest_lsi() {
    let Some(mut b) = board_with(|c| c.lsi_hz = 60_000) else {
        return;
    };
    let (mut at, mut tx, mut attempts) = (Attempt::Idle, 0, 0);
    while lines_with(&b, "capabilities:").is_empty() && b.now_ns() < 3 * S {
        run_for(&mut b, 100_000);
        at = drive(&mut b, at, &mut tx, &mut attempts);
    }
    let caps = b
        .log_lines()
        .iter()
        .find(|l| l.text.contains("capabilities:"))
        .map(|l| l.host_time_ns);
    let Some(booted_at) = caps else {
        panic!("no capabilities line\n{}", tail(&b, 40));
    };
    assert_eq!(attempts, 3, "{}", tail(&b, 40));
    assert_logged(&b, "probe MPU-9250: FAILED");
    println!("worst boot: capabilities at {} ms", booted_at / MS);
    // The attempts took their longest path (the waits alone are 1.03 s).
    assert!(
        (1_000 * MS..=1_150 * MS).contains(&booted_at),
        "boot ended at {booted_at} ns"
    );
    run_until(&mut b, 3 * S);
    assert_no_reset(&b);
}
