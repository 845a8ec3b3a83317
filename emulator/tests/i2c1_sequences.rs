//! The I2C1 model against RM0008 §26.3.3's master event sequences
//! (Figures 273 and 274, the 1-, 2- and N-byte reception endings): what SR1
//! and SR2 read at each event, and when in bus time each flag appears.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod i2c1_support;

use emulator::i2c1::{cr1, reg, sr1, sr2};
use i2c1_support::{Rig, BIT_NS, MPU, MS};

#[test]
fn bit_time_follows_freq_and_ccr() {
    let mut r = Rig::new();
    assert_eq!(
        r.i2c.bit_ns(),
        2_500,
        "fast mode, duty 2:1, CCR 30 at 36 MHz"
    );
    r.clear_cr1(cr1::PE);
    r.wr(reg::CCR, 180);
    assert_eq!(r.i2c.bit_ns(), 10_000, "standard mode: 2·CCR·T_PCLK1");
    r.wr(reg::CCR, 0xC000 | 4);
    assert_eq!(r.i2c.bit_ns(), 2_777, "fast mode duty 16:9: 25·CCR·T_PCLK1");
    // CCR is read-only while PE = 1.
    r.set_cr1(cr1::PE);
    r.wr(reg::CCR, 180);
    assert_eq!(r.rd(reg::CCR), 0xC000 | 4);
    // The START condition takes one period at the programmed clock.
    r.set_cr1(cr1::START);
    assert_eq!(r.poll_sr1(sr1::SB, 100_000), Some(2_800));
}

#[test]
fn master_transmitter_event_sequence() {
    let mut r = Rig::new();
    assert_eq!(r.sr2(), 0, "idle bus");
    r.set_cr1(cr1::START);
    assert_eq!(r.rd(reg::SR1), 0, "SB only once the START is on the wire");
    // EV5
    assert_eq!(r.poll_sr1(sr1::SB, 100_000), Some(BIT_NS));
    assert_eq!(r.rd(reg::SR1), sr1::SB);
    assert_eq!(r.sr2(), sr2::MSL | sr2::BUSY);
    assert_eq!(r.rd(reg::CR1) & cr1::START, 0, "START cleared when sent");
    r.wr(reg::DR, u16::from(MPU << 1));
    assert_eq!(r.rd(reg::SR1), 0, "SB cleared by SR1 read then DR write");
    // EV6: nine bit times later.
    r.wait(9 * BIT_NS - 100);
    assert_eq!(r.rd(reg::SR1) & sr1::ADDR, 0, "not before the ACK bit");
    r.wait(100);
    assert_eq!(r.rd(reg::SR1), sr1::ADDR | sr1::TXE);
    assert_eq!(r.sr2(), sr2::MSL | sr2::BUSY | sr2::TRA);
    // EV8_1: ADDR cleared, shift register and DR empty.
    assert_eq!(r.rd(reg::SR1), sr1::TXE);
    r.wr(reg::DR, 0x19); // SMPLRT_DIV
    assert_eq!(
        r.rd(reg::SR1),
        sr1::TXE,
        "Data1 went straight to the shift register"
    );
    // EV8: Data2 waits in DR.
    r.wr(reg::DR, 0x04);
    assert_eq!(r.rd(reg::SR1), 0);
    r.wait(9 * BIT_NS);
    assert_eq!(
        r.rd(reg::SR1),
        sr1::TXE,
        "Data2 moved to the shift register"
    );
    // EV8_2: both sent, DR empty: BTF, SCL held low.
    r.wait(9 * BIT_NS);
    assert_eq!(r.rd(reg::SR1), sr1::TXE | sr1::BTF);
    assert!(!r.i2c.scl_high(r.t), "SCL stretched by the master");
    r.set_cr1(cr1::STOP);
    r.wait(BIT_NS - 100);
    assert_ne!(r.rd(reg::CR1) & cr1::STOP, 0, "STOP still on the wire");
    r.wait(100);
    assert_eq!(
        r.rd(reg::CR1) & cr1::STOP,
        0,
        "cleared when the STOP was sent"
    );
    assert_eq!(r.sr2(), 0, "MSL, BUSY, TRA cleared");
    assert_eq!(r.rd(reg::SR1), 0);
    assert_eq!(r.i2c.bus().state().mpu.register(0x19), 0x04);
}

#[test]
fn single_byte_reception() {
    let mut r = Rig::new();
    r.write_bytes(MPU, &[0x75]).unwrap();
    let s = r.start_address((MPU << 1) | 1);
    assert_eq!(s, sr1::ADDR, "receiver: no TXE");
    // EV6_3: ACK cleared before ADDR, STOP right after.
    r.clear_cr1(cr1::ACK);
    let (_, s2) = r.clear_addr();
    assert_eq!(s2, sr2::MSL | sr2::BUSY, "TRA = 0");
    r.set_cr1(cr1::STOP);
    assert_eq!(r.poll_sr1(sr1::RXNE, 100_000), Some(9 * BIT_NS));
    assert_eq!(r.rd(reg::SR1), sr1::RXNE, "no BTF for the single byte");
    assert_eq!(r.rd(reg::DR), 0x71, "WHO_AM_I");
    assert_eq!(r.rd(reg::SR1), 0, "RXNE cleared by the DR read");
    assert_eq!(r.wait_stop_cleared(10_000), Some(BIT_NS));
    assert_eq!(r.sr2(), 0);
}

#[test]
fn single_byte_reception_with_late_stop_clocks_an_extra_byte() {
    // The byte was NACKed (ACK = 0), so the chip released SDA: when STOP
    // comes too late the master clocks in one more byte, 0xFF, and stalls
    // on BTF (RM0008: events must be handled before the current byte ends).
    let mut r = Rig::new();
    r.write_bytes(MPU, &[0x75]).unwrap();
    r.start_address((MPU << 1) | 1);
    r.clear_cr1(cr1::ACK);
    r.clear_addr();
    r.wait(30 * BIT_NS);
    assert_eq!(r.rd(reg::SR1), sr1::RXNE | sr1::BTF);
    r.set_cr1(cr1::STOP);
    assert_eq!(r.rd(reg::DR), 0x71);
    assert_eq!(r.rd(reg::DR), 0xFF, "nobody drove SDA");
    assert_eq!(r.wait_stop_cleared(10_000), Some(BIT_NS));
}

fn prom_word(r: &Rig, i: usize) -> [u8; 2] {
    r.i2c.bus().state().ms.prom()[i].to_be_bytes()
}

#[test]
fn two_byte_reception_with_pos() {
    let mut r = Rig::new();
    r.write_bytes(MS, &[0xA2]).unwrap(); // PROM C1
    r.set_cr1(cr1::ACK | cr1::POS);
    r.start_address((MS << 1) | 1);
    r.clear_addr();
    r.clear_cr1(cr1::ACK);
    // Data1 in DR after 9 bits; Data2 in the shift register after 18: BTF.
    assert_eq!(r.poll_sr1(sr1::RXNE, 100_000), Some(9 * BIT_NS));
    assert_eq!(r.rd(reg::SR1), sr1::RXNE);
    assert_eq!(r.poll_sr1(sr1::BTF, 100_000), Some(9 * BIT_NS));
    assert_eq!(r.rd(reg::SR1), sr1::RXNE | sr1::BTF);
    r.wait(20 * BIT_NS);
    assert_eq!(
        r.rd(reg::SR1),
        sr1::RXNE | sr1::BTF,
        "SCL held low: nothing more"
    );
    r.set_cr1(cr1::STOP);
    let d1 = r.rd(reg::DR) as u8;
    assert_eq!(r.rd(reg::SR1), sr1::RXNE, "Data2 moved to DR");
    let d2 = r.rd(reg::DR) as u8;
    assert_eq!([d1, d2], prom_word(&r, 1));
    assert_eq!(r.wait_stop_cleared(10_000).map(|t| t <= BIT_NS), Some(true));
    r.clear_cr1(cr1::POS);
    assert_eq!(r.sr2(), 0);
}

#[test]
fn two_byte_sequence_without_pos_nacks_the_first_byte() {
    // Same register steps with POS = 0: clearing ACK after ADDR NACKs Data1
    // itself, the chip releases SDA, and Data2 reads 0xFF. This is why the
    // manual's two-byte ending needs POS.
    let mut r = Rig::new();
    r.write_bytes(MS, &[0xA2]).unwrap();
    r.set_cr1(cr1::ACK);
    r.start_address((MS << 1) | 1);
    r.clear_addr();
    r.clear_cr1(cr1::ACK);
    r.poll_sr1(sr1::BTF, 100_000).expect("BTF");
    r.set_cr1(cr1::STOP);
    let d1 = r.rd(reg::DR) as u8;
    let d2 = r.rd(reg::DR) as u8;
    assert_eq!(d1, prom_word(&r, 1)[0]);
    assert_eq!(d2, 0xFF);
}

#[test]
fn n_byte_reception() {
    let mut r = Rig::new();
    for n in [3usize, 4, 6, 11] {
        r.write_bytes(MPU, &[0x75]).unwrap();
        let got = r.read_n(MPU, n);
        let want: Vec<u8> = (0..n)
            .map(|i| r.i2c.bus().state().mpu.register(0x75 + i as u8))
            .collect();
        assert_eq!(got, want, "n = {n}");
        assert_eq!(r.sr2(), 0, "idle after n = {n}");
        assert!(
            r.i2c.sda_high(r.t),
            "the last byte was NACKed: SDA released"
        );
    }
}

#[test]
fn n_byte_reception_stalls_on_btf_until_dr_is_read() {
    let mut r = Rig::new();
    r.write_bytes(MPU, &[0x75]).unwrap();
    r.set_cr1(cr1::ACK);
    r.start_address((MPU << 1) | 1);
    r.clear_addr();
    r.wait(100 * BIT_NS);
    assert_eq!(
        r.rd(reg::SR1),
        sr1::RXNE | sr1::BTF,
        "two bytes in, SCL held"
    );
    assert!(!r.i2c.scl_high(r.t));
    assert_eq!(r.rd(reg::DR), 0x71);
    // Reading DR frees the shift register: byte 3 is clocked in.
    assert_eq!(r.rd(reg::SR1), sr1::RXNE);
    assert_eq!(r.poll_sr1(sr1::BTF, 100_000), Some(9 * BIT_NS));
}

#[test]
fn repeated_start_after_btf() {
    let mut r = Rig::new();
    assert_eq!(r.who_am_i(), Some(0x71));
    let (all, failed) = r.i2c.bus().transaction_counts();
    assert_eq!(
        (all, failed),
        (1, 0),
        "write + read under one START ... STOP"
    );
}

#[test]
fn address_nack_sets_af_and_holds_until_stop() {
    let mut r = Rig::new();
    r.set_cr1(cr1::START);
    r.poll_sr1(sr1::SB, 100_000).unwrap();
    r.wr(reg::DR, 0x50 << 1);
    assert_eq!(r.poll_sr1(sr1::AF | sr1::ADDR, 100_000), Some(9 * BIT_NS));
    assert_eq!(r.rd(reg::SR1), sr1::AF);
    assert_eq!(
        r.sr2(),
        sr2::MSL | sr2::BUSY | sr2::TRA,
        "still master; TRA from the R/W bit"
    );
    r.wait(50 * BIT_NS);
    assert_eq!(
        r.sr2(),
        sr2::MSL | sr2::BUSY | sr2::TRA,
        "waits for software"
    );
    r.set_cr1(cr1::STOP);
    assert_eq!(r.wait_stop_cleared(10_000), Some(BIT_NS));
    assert_eq!(r.sr2(), 0);
    assert_eq!(r.rd(reg::SR1), sr1::AF, "AF stays until software clears it");
    r.wr(reg::SR1, !sr1::AF);
    assert_eq!(r.rd(reg::SR1), 0);
    assert_eq!(r.who_am_i(), Some(0x71), "bus usable again");
}

#[test]
fn data_nack_sets_af_without_btf() {
    let mut r = Rig::new();
    // The MS5611 takes one command byte and NACKs a second.
    let e = r.write_bytes(MS, &[0x1E, 0x00]).unwrap_err();
    assert_eq!(e & (sr1::AF | sr1::BTF), sr1::AF);
    assert_eq!(r.sr2(), 0, "STOP sent after the NACK");
}

/// A WHO_AM_I read left with its STOP on the wire; returns the CR1 value
/// read back while STOP was still set.
fn read_with_stop_pending(r: &mut Rig) -> u16 {
    r.write_bytes(MPU, &[0x75]).unwrap();
    r.start_address((MPU << 1) | 1);
    r.clear_cr1(cr1::ACK);
    r.clear_addr();
    r.set_cr1(cr1::STOP);
    r.poll_sr1(sr1::RXNE, 100_000).unwrap();
    assert_eq!(r.rd(reg::DR), 0x71);
    let cr1_now = r.rd(reg::CR1);
    assert_ne!(cr1_now & cr1::STOP, 0, "STOP still pending");
    cr1_now
}

#[test]
fn stale_cr1_write_after_stop_cleared_is_a_second_stop() {
    // RM0008 CR1 note: no write to CR1 until STOP is cleared, or a second
    // STOP may be requested: a read-modify-write whose read saw STOP = 1
    // and whose write lands after the hardware cleared it.
    let mut r = Rig::new();
    let stale = read_with_stop_pending(&mut r);
    r.wait(2 * BIT_NS);
    assert_eq!(r.rd(reg::CR1) & cr1::STOP, 0, "the first STOP is done");
    r.wr(reg::CR1, stale | cr1::ACK);
    assert_ne!(r.rd(reg::CR1) & cr1::STOP, 0, "a second STOP is pending");
    // It kills the next transfer right after its START.
    r.set_cr1(cr1::START);
    r.wait(3 * BIT_NS);
    assert_eq!(r.sr2() & sr2::MSL, 0, "START then STOP at once");
    assert_eq!(r.rd(reg::CR1) & (cr1::STOP | cr1::START), 0);
    r.wr(reg::DR, u16::from(MPU << 1));
    assert_eq!(
        r.poll_sr1(sr1::ADDR | sr1::AF, 30 * BIT_NS),
        None,
        "no address phase"
    );
}

#[test]
fn cr1_write_while_stop_is_still_pending_is_the_same_request() {
    let mut r = Rig::new();
    let pending = read_with_stop_pending(&mut r);
    r.wr(reg::CR1, pending | cr1::ACK);
    assert_eq!(
        r.wait_stop_cleared(10 * BIT_NS).map(|t| t <= BIT_NS),
        Some(true)
    );
    assert_eq!(r.rd(reg::CR1), cr1::PE | cr1::ACK);
    r.clear_cr1(cr1::ACK);
    assert_eq!(r.who_am_i(), Some(0x71));
}

#[test]
fn pe_cleared_mid_transfer_takes_effect_at_the_end() {
    // RM0008 CR1.PE: reset during a communication, the peripheral is
    // disabled when back to idle.
    let mut r = Rig::new();
    r.start_address(MPU << 1);
    r.clear_addr();
    r.wr(reg::DR, 0x19);
    r.wr(reg::DR, 0x07);
    r.poll_sr1(sr1::BTF, 100_000).unwrap();
    r.set_cr1(cr1::STOP);
    r.clear_cr1(cr1::PE);
    assert_ne!(r.rd(reg::CR1) & cr1::PE, 0, "still enabled mid-transfer");
    r.wait(30 * BIT_NS);
    assert_eq!(r.rd(reg::CR1) & cr1::PE, 0);
    // A byte left in DR is dropped with PE = 0 (RxNE cleared by hardware).
    r.set_cr1(cr1::PE);
    r.write_bytes(MPU, &[0x75]).unwrap();
    r.start_address((MPU << 1) | 1);
    r.clear_cr1(cr1::ACK);
    r.clear_addr();
    r.set_cr1(cr1::STOP);
    r.wait(20 * BIT_NS);
    assert_eq!(r.rd(reg::SR1), sr1::RXNE);
    r.clear_cr1(cr1::PE);
    assert_eq!(r.rd(reg::SR1), 0);
    assert_eq!(r.i2c.bus().state().mpu.register(0x19), 0x07);
}

#[test]
fn interrupt_requests_follow_the_enable_bits() {
    use emulator::i2c1::cr2;
    let mut r = Rig::new();
    r.wr(reg::CR2, 36 | cr2::ITEVTEN | cr2::ITERREN);
    r.set_cr1(cr1::START);
    assert!(!r.i2c.event_irq());
    r.wait(BIT_NS);
    assert!(r.i2c.event_irq(), "SB is an event");
    r.rd(reg::SR1);
    r.wr(reg::DR, u16::from(MPU << 1));
    r.wait(9 * BIT_NS);
    r.clear_addr();
    assert!(!r.i2c.event_irq(), "TXE needs ITBUFEN");
    r.wr(reg::CR2, 36 | cr2::ITEVTEN | cr2::ITBUFEN | cr2::ITERREN);
    assert!(r.i2c.event_irq());
    r.set_cr1(cr1::STOP);
    r.wait(BIT_NS);
    assert!(!r.i2c.event_irq() && !r.i2c.error_irq());
    r.set_cr1(cr1::START);
    r.poll_sr1(sr1::SB, 100_000).unwrap();
    r.wr(reg::DR, 0x50 << 1);
    r.wait(9 * BIT_NS);
    assert!(r.i2c.error_irq(), "AF");
}

/// The event interrupt through a register read as the firmware's
/// interrupt-driven engine runs it (RM0008 §26.3.3 with §26.4's interrupt
/// table: SB, ADDR, BTF with ITEVTEN; RxNE with ITBUFEN too): write the
/// register, repeated START on BTF, then N = 3 with the BTF ending, and a
/// single byte with NACK and STOP programmed around the ADDR clear. The
/// request drops as each event is handled and rises at the next.
#[test]
fn event_interrupt_through_an_interrupt_driven_register_read() {
    use emulator::i2c1::cr2;
    let mut r = Rig::new();
    let irqs = cr2::ITEVTEN | cr2::ITERREN;
    r.wr(reg::CR2, 36 | irqs);
    let reg_at = |r: &Rig, a: u8| r.i2c.bus().state().mpu.register(a);

    // Write phase: SB, ADDR, then BTF once the register byte is out.
    r.set_cr1(cr1::ACK | cr1::START);
    r.wait(BIT_NS);
    assert!(r.i2c.event_irq(), "SB");
    r.rd(reg::SR1);
    r.wr(reg::DR, u16::from(MPU << 1));
    assert!(!r.i2c.event_irq(), "SB cleared by the address write");
    r.wait(9 * BIT_NS);
    assert!(r.i2c.event_irq(), "ADDR");
    r.clear_addr();
    r.wr(reg::DR, 0x19);
    assert!(!r.i2c.event_irq(), "TXE alone needs ITBUFEN");
    r.wait(9 * BIT_NS);
    assert_eq!(r.rd(reg::SR1) & sr1::BTF, sr1::BTF);
    assert!(r.i2c.event_irq(), "BTF");
    // BTF is cleared by the START (RM0008: "by hardware after a start");
    // a handler entered again before that must find nothing to do.
    r.set_cr1(cr1::START);
    r.wait(BIT_NS);
    assert_eq!(r.rd(reg::SR1), sr1::SB, "repeated START: BTF cleared");

    // N = 3: ADDR, then BTF with bytes 1 and 2 in; NACK, read 1; BTF
    // again; STOP, read 2 and 3.
    r.wr(reg::DR, u16::from((MPU << 1) | 1));
    r.wait(9 * BIT_NS);
    assert!(r.i2c.event_irq(), "ADDR (read)");
    r.clear_addr();
    r.wait(9 * BIT_NS);
    assert!(!r.i2c.event_irq(), "RxNE alone needs ITBUFEN");
    r.wait(9 * BIT_NS);
    assert!(r.i2c.event_irq(), "BTF: two bytes in, SCL held");
    r.clear_cr1(cr1::ACK);
    let b1 = r.rd(reg::DR) as u8;
    r.wait(9 * BIT_NS);
    assert!(r.i2c.event_irq(), "BTF: the NACKed third byte in");
    r.set_cr1(cr1::STOP);
    let b2 = r.rd(reg::DR) as u8;
    let b3 = r.rd(reg::DR) as u8;
    assert!(!r.i2c.event_irq());
    assert_eq!(
        [b1, b2, b3],
        [reg_at(&r, 0x19), reg_at(&r, 0x1A), reg_at(&r, 0x1B)]
    );
    assert!(r.wait_stop_cleared(2 * BIT_NS).is_some());
    assert_eq!(r.sr2(), 0, "STOP sent, bus free");

    // N = 1 (WHO_AM_I), RxNE with ITBUFEN.
    r.write_bytes(MPU, &[0x75]).unwrap();
    r.wr(reg::CR2, 36 | irqs | cr2::ITBUFEN);
    r.set_cr1(cr1::ACK | cr1::START);
    r.wait(BIT_NS);
    r.rd(reg::SR1);
    r.wr(reg::DR, u16::from((MPU << 1) | 1));
    r.wait(9 * BIT_NS);
    assert!(r.i2c.event_irq(), "ADDR (read, one byte)");
    r.clear_cr1(cr1::ACK);
    r.clear_addr();
    r.set_cr1(cr1::STOP);
    assert!(!r.i2c.event_irq());
    r.wait(9 * BIT_NS);
    assert!(r.i2c.event_irq(), "RxNE");
    assert_eq!(r.rd(reg::DR), 0x71);
    assert!(!r.i2c.event_irq(), "RxNE cleared by the DR read");
    assert!(r.wait_stop_cleared(2 * BIT_NS).is_some());
    assert!(r.i2c.sda_high(r.t), "the byte was NACKed: SDA released");
}
