//! The I2C1 model against errata ES096 §2.13's master-receiver races, with
//! the manual's register sequences (RM0008 §26.3.3 "Closing the
//! communication") done in time and late by a stated time:
//! * "Wrong data read into data register": with byte N−1 in DR and byte N
//!   in the shift register, reading N−1 after the STOP condition is on the
//!   bus leaves byte N shifted one bit to the left.
//! * The late EV7 (ES096 §2.13.2, "Some software events must be managed
//!   before the current byte is being transferred": "reading the same data
//!   twice or missing data"): byte k read from DR in the last SCL period
//!   of byte k+1 races that byte's move out of the shift register; the
//!   model's window and its halves are an assumption (see `emulator::i2c1`).
//! * A late STOP for N = 1 clocks one byte more (`i2c1_sequences.rs`,
//!   `single_byte_reception_with_late_stop_clocks_an_extra_byte`); a late
//!   RxNE without STOP only stretches SCL (BTF), nothing is lost
//!   (`n_byte_reception_stalls_on_btf_until_dr_is_read`).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod i2c1_support;

use emulator::i2c1::{cr1, reg, sr1};
use i2c1_support::{Rig, BIT_NS, MPU, MS};

/// The gyro offset registers XG_OFFSET_H..ZG_OFFSET_L (0x13..0x18): six
/// bytes of known, non-zero value (each with bit 7 set, so that a byte
/// shifted one bit left differs), written now.
const OFFSETS: [u8; 6] = [0xA1, 0xB2, 0xC3, 0xD4, 0xE5, 0x96];

fn load_offsets(r: &mut Rig) {
    let mut w = vec![0x13];
    w.extend_from_slice(&OFFSETS);
    r.write_bytes(MPU, &w).unwrap();
}

/// Reads `n` ≥ 3 bytes the way the firmware's interrupt handler does
/// (RM0008's BTF ending): on BTF with N−2 in DR clear ACK and read N−2;
/// on BTF again (N−1 in DR, N in the shift register, SCL held low) set
/// STOP, read N−1 `late_ns` later, then read N.
fn read_n_btf_ending(r: &mut Rig, n: usize, late_ns: u64) -> Vec<u8> {
    load_offsets(r);
    r.write_bytes(MPU, &[0x13]).unwrap();
    r.set_cr1(cr1::ACK);
    r.start_address((MPU << 1) | 1);
    r.clear_addr();
    let mut out = Vec::new();
    while out.len() < n - 3 {
        r.poll_sr1(sr1::RXNE, 100_000).expect("RXNE");
        out.push(r.rd(reg::DR) as u8);
    }
    r.poll_sr1(sr1::BTF, 100_000).expect("BTF, N-2 in DR");
    r.clear_cr1(cr1::ACK);
    out.push(r.rd(reg::DR) as u8);
    r.poll_sr1(sr1::BTF, 100_000).expect("BTF, N-1 in DR");
    r.set_cr1(cr1::STOP);
    r.wait(late_ns);
    out.push(r.rd(reg::DR) as u8);
    assert_eq!(r.rd(reg::SR1) & sr1::RXNE, sr1::RXNE, "byte N in DR");
    out.push(r.rd(reg::DR) as u8);
    r.wait_stop_cleared(100_000).expect("STOP clears");
    out
}

#[test]
fn btf_ending_read_before_the_stop_is_on_the_bus_is_correct() {
    for late_ns in [0, 1_000, BIT_NS - 1] {
        let mut r = Rig::new();
        let got = read_n_btf_ending(&mut r, 6, late_ns);
        assert_eq!(got, OFFSETS.to_vec(), "N-1 read {late_ns} ns after STOP");
    }
}

#[test]
fn btf_ending_read_after_the_stop_is_on_the_bus_shifts_byte_n() {
    // STOP set with SCL held low goes out in one SCL period (2.5 µs, 180
    // cycles at 72 MHz): an interrupt that long inside the window is late.
    for late_ns in [BIT_NS, 3 * BIT_NS, 100_000] {
        let mut r = Rig::new();
        let got = read_n_btf_ending(&mut r, 6, late_ns);
        let want = OFFSETS.to_vec();
        assert_eq!(got[..5], want[..5], "N-1 and before are right");
        assert_eq!(got[5], want[5] << 1, "byte N shifted one bit left");
        assert_ne!(got[5], want[5]);
    }
}

/// RM0008's N > 2 ending without waiting for BTF a second time: read N−2
/// (byte N starts, NACKed), set STOP, read N−1 `late_ns` later, read N.
fn read_n_rm0008_ending(r: &mut Rig, n: usize, late_ns: u64) -> Vec<u8> {
    load_offsets(r);
    r.write_bytes(MPU, &[0x13]).unwrap();
    r.set_cr1(cr1::ACK);
    r.start_address((MPU << 1) | 1);
    r.clear_addr();
    let mut out = Vec::new();
    while out.len() < n - 3 {
        r.poll_sr1(sr1::RXNE, 100_000).expect("RXNE");
        out.push(r.rd(reg::DR) as u8);
    }
    r.poll_sr1(sr1::BTF, 100_000).expect("BTF, N-2 in DR");
    r.clear_cr1(cr1::ACK);
    out.push(r.rd(reg::DR) as u8);
    r.set_cr1(cr1::STOP);
    r.wait(late_ns);
    out.push(r.rd(reg::DR) as u8);
    r.poll_sr1(sr1::RXNE, 100_000).expect("RXNE of byte N");
    out.push(r.rd(reg::DR) as u8);
    r.wait_stop_cleared(100_000).expect("STOP clears");
    out
}

#[test]
fn rm0008_ending_window_is_byte_n_plus_the_stop() {
    // Byte N takes nine SCL periods, the STOP after it one more: N−1 read
    // before then is in time, after it byte N is shifted.
    for late_ns in [0, 9 * BIT_NS, 10 * BIT_NS - 1] {
        let mut r = Rig::new();
        let got = read_n_rm0008_ending(&mut r, 6, late_ns);
        assert_eq!(got, OFFSETS.to_vec(), "N-1 read {late_ns} ns after STOP");
    }
    let mut r = Rig::new();
    let got = read_n_rm0008_ending(&mut r, 6, 10 * BIT_NS);
    let want = OFFSETS.to_vec();
    assert_eq!(got[..5], want[..5]);
    assert_eq!(got[5], want[5] << 1, "byte N shifted one bit left");
}

/// RM0008's N = 2 ending (POS = 1): on BTF set STOP, read Data1
/// `late_ns` later, then Data2.
fn read_two_with_pos(r: &mut Rig, late_ns: u64) -> [u8; 2] {
    r.write_bytes(MS, &[0xA4]).unwrap(); // PROM C2
    r.set_cr1(cr1::ACK | cr1::POS);
    r.start_address((MS << 1) | 1);
    r.clear_addr();
    r.clear_cr1(cr1::ACK);
    r.poll_sr1(sr1::BTF, 100_000).expect("BTF");
    r.set_cr1(cr1::STOP);
    r.wait(late_ns);
    let d1 = r.rd(reg::DR) as u8;
    let d2 = r.rd(reg::DR) as u8;
    r.wait_stop_cleared(100_000).expect("STOP clears");
    r.clear_cr1(cr1::POS);
    [d1, d2]
}

#[test]
fn two_byte_ending_data2_is_shifted_when_data1_is_read_late() {
    let mut r = Rig::new();
    let want = r.i2c.bus().state().ms.prom()[2].to_be_bytes();
    assert_eq!(read_two_with_pos(&mut r, BIT_NS - 1), want);
    let got = read_two_with_pos(&mut r, BIT_NS);
    assert_eq!(got, [want[0], want[1] << 1]);
    assert_ne!(want[1], want[1] << 1, "the test can tell");
}

/// RM0008's N = 1 ending (EV6_3): ACK cleared before the ADDR clear, STOP
/// set `late_ns` after it; returns (SR1 after the first byte, the byte,
/// SR1 after that read).
fn read_one(r: &mut Rig, late_ns: u64) -> (u16, u8, u16) {
    r.write_bytes(MPU, &[0x75]).unwrap();
    r.start_address((MPU << 1) | 1);
    r.clear_cr1(cr1::ACK);
    r.clear_addr();
    r.wait(late_ns);
    r.set_cr1(cr1::STOP);
    let at = r.poll_sr1(sr1::RXNE, 100_000).expect("RXNE");
    r.wait(20 * BIT_NS - at.min(20 * BIT_NS));
    let s = r.rd(reg::SR1);
    let b = r.rd(reg::DR) as u8;
    let after = r.rd(reg::SR1);
    r.rd(reg::DR);
    r.wait_stop_cleared(100_000).expect("STOP clears");
    (s, b, after)
}

#[test]
fn single_byte_stop_must_be_set_before_the_byte_ends() {
    // ES096 §2.13.2 (EV6_3) and RM0008: STOP set during the byte's
    // reception goes out after it; once the byte has ended (nine SCL
    // periods after the ADDR clear) the master clocks one more byte.
    let (s, b, after) = read_one(&mut Rig::new(), 9 * BIT_NS - 100);
    assert_eq!((s, b, after), (sr1::RXNE, 0x71, 0), "one byte, then STOP");
    let (s, b, after) = read_one(&mut Rig::new(), 9 * BIT_NS);
    assert_eq!(
        s,
        sr1::RXNE | sr1::BTF,
        "an extra byte in the shift register"
    );
    assert_eq!(b, 0x71);
    assert_eq!(after, sr1::RXNE, "the extra byte moved to DR");
}

/// RM0008's N = 2 ending (POS = 1): ACK cleared `late_ns` after the ADDR
/// clear, STOP on BTF, Data1 and Data2 read at once. Whether SDA is
/// released after the STOP.
fn two_bytes_sda_released(r: &mut Rig, late_ns: u64) -> bool {
    r.write_bytes(MS, &[0xA4]).unwrap();
    r.set_cr1(cr1::ACK | cr1::POS);
    r.start_address((MS << 1) | 1);
    r.clear_addr();
    r.wait(late_ns);
    r.clear_cr1(cr1::ACK);
    r.poll_sr1(sr1::BTF, 100_000).expect("BTF");
    r.set_cr1(cr1::STOP);
    r.rd(reg::DR);
    r.rd(reg::DR);
    r.wait_stop_cleared(100_000).expect("STOP bit clears");
    r.clear_cr1(cr1::POS);
    r.i2c.sda_high(r.t)
}

#[test]
fn two_byte_ack_must_be_cleared_before_data1_ends() {
    // ES096 §2.13.2 (EV6_1): with POS = 1 the ACK bit when Data1 ends
    // decides Data2's. Cleared in time, Data2 is NACKed and the chip lets
    // SDA go; cleared after Data1 ended, Data2 is ACKed: the chip starts
    // its next byte, holds SDA low and the STOP never reaches the wire.
    assert!(two_bytes_sda_released(&mut Rig::new(), 9 * BIT_NS - 100));
    let mut r = Rig::new();
    assert!(!two_bytes_sda_released(&mut r, 9 * BIT_NS));
    assert!(r.busy(), "NACK not sent: the bus stays busy");
}

/// Reads the six offset bytes and two more the simple way (each byte on
/// RXNE, or on BTF with RXNE clear, as an event-driven reader would see
/// them), with byte index 1 read `into_ns` into the last SCL period of
/// byte index 2 (negative: before it); ends with NACK and STOP. Returns
/// the first six values read and how many late-EV7 races the model saw.
fn read_with_late_ev7(into_ns: i64) -> (Vec<u8>, u64) {
    let mut r = Rig::new();
    load_offsets(&mut r);
    r.write_bytes(MPU, &[0x13]).unwrap();
    r.set_cr1(cr1::ACK);
    r.start_address((MPU << 1) | 1);
    r.clear_addr();
    let mut out = Vec::new();
    r.poll_sr1(sr1::RXNE, 100_000).expect("RXNE of byte 0");
    out.push(r.rd(reg::DR) as u8);
    r.poll_sr1(sr1::RXNE, 100_000).expect("RXNE of byte 1");
    // Byte 2 is on the wire; it ends (ACK pulse included) at `done`.
    let done = r.i2c.next_event_ns().expect("byte 2 on the wire");
    let at = (done - BIT_NS).checked_add_signed(into_ns).unwrap();
    r.wait(at - r.t);
    out.push(r.rd(reg::DR) as u8);
    while out.len() < 6 {
        r.poll_sr1(sr1::RXNE | sr1::BTF, 100_000)
            .expect("RXNE or BTF");
        out.push(r.rd(reg::DR) as u8);
    }
    r.clear_cr1(cr1::ACK);
    r.set_cr1(cr1::STOP);
    r.rd(reg::DR);
    r.rd(reg::DR);
    r.wait_stop_cleared(100_000).expect("STOP clears");
    (out, r.i2c.late_ev7_reads())
}

#[test]
fn ev7_served_before_the_next_byte_ends_reads_every_byte_once() {
    // In time: anywhere before the last SCL period of the byte after it.
    for into_ns in [-(8 * BIT_NS as i64), -1_000, -1] {
        let (got, races) = read_with_late_ev7(into_ns);
        assert_eq!(got, OFFSETS.to_vec(), "read {into_ns} ns into the window");
        assert_eq!(races, 0);
    }
}

#[test]
fn ev7_late_into_the_next_bytes_ack_pulse_reads_a_byte_twice() {
    // First half of byte 2's last SCL period: byte 2 held in the shift
    // register (BTF), DR still byte 1 with RXNE clear; the next read (on
    // BTF) returns byte 1 again, and everything after comes one late.
    for into_ns in [0, 600, BIT_NS as i64 / 2 - 1] {
        let (got, races) = read_with_late_ev7(into_ns);
        let o = OFFSETS;
        assert_eq!(
            got,
            vec![o[0], o[1], o[1], o[2], o[3], o[4]],
            "{into_ns} ns"
        );
        assert_eq!(races, 1);
    }
}

#[test]
fn ev7_late_to_the_end_of_the_next_byte_misses_it() {
    // Second half: byte 2 is loaded into DR but RXNE stays clear; byte 3
    // overwrites it, and the reader never sees byte 2.
    for into_ns in [BIT_NS as i64 / 2, BIT_NS as i64 - 1] {
        let (got, races) = read_with_late_ev7(into_ns);
        let o = OFFSETS;
        assert_eq!(got[..5], [o[0], o[1], o[3], o[4], o[5]], "{into_ns} ns");
        assert_eq!(races, 1);
    }
}

#[test]
fn ev7_after_the_next_byte_ended_waits_on_btf_and_loses_nothing() {
    // RM0008: byte 2 ended with byte 1 unread: BTF, SCL held low; a read
    // then (however late) is in time.
    for into_ns in [BIT_NS as i64, 10 * BIT_NS as i64, 400_000] {
        let (got, races) = read_with_late_ev7(into_ns);
        assert_eq!(
            got,
            OFFSETS.to_vec(),
            "read {into_ns} ns after the window opened"
        );
        assert_eq!(races, 0);
    }
}
