//! The I2C1 model under wire and peripheral faults: a chip holding SDA low
//! (power-up, or left mid-byte by a reset), stuck lines, NACK storms, bus
//! errors, arbitration loss, and the errata ES096 BUSY lock-up with its
//! documented workaround.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

// Each test spells out its fault's register and pin sequence as RM0008 and the
// errata give it, so neighbouring tests share runs of the same steps on purpose.

mod i2c1_support;

use emulator::i2c1::{cr1, reg, sr1, sr2, PeripheralFault, PinMode};
use i2c1_support::{Rig, BIT_NS, MPU, MS};
use sim::{Chip, Fault};

const AF_PINS: (PinMode, PinMode) = (PinMode::AlternateOpenDrain, PinMode::AlternateOpenDrain);

fn back_to_af(r: &mut Rig) {
    r.pins(AF_PINS.0, AF_PINS.1);
}

/// SWRST pulse and the register set-up again (the recovery's last steps).
fn swrst_and_configure(r: &mut Rig) {
    r.wr(reg::CR1, cr1::SWRST);
    r.wr(reg::CR1, 0);
    r.configure();
}

/// A START asked for on a busy bus gets no SB within `timeout_ns` and no
/// master mode; PE and START go off, ready for a recovery by GPIO.
fn start_held_then_pe_off(r: &mut Rig, timeout_ns: u64) {
    r.set_cr1(cr1::START);
    assert_eq!(
        r.poll_sr1(sr1::SB, timeout_ns),
        None,
        "START waits for a free bus"
    );
    assert_eq!(r.sr2() & sr2::MSL, 0, "no master mode");
    r.clear_cr1(cr1::PE | cr1::START);
}

/// Pins back to the peripheral, SWRST and set-up: the bus is free and the
/// MPU-9250 answers.
fn back_on_the_bus(r: &mut Rig) {
    back_to_af(r);
    swrst_and_configure(r);
    assert!(!r.busy(), "the recovery cleared BUSY");
    assert_eq!(r.who_am_i(), Some(0x71));
}
#[test]
fn chip_holding_sda_at_power_up_blocks_start_until_clocked_out() {
    let mut r = Rig::bare();
    r.i2c.bus().inject(Fault::SlaveHoldsSda(Chip::Mpu9250));
    r.pins(AF_PINS.0, AF_PINS.1);
    r.configure();
    assert!(!r.i2c.sda_high(r.t), "SDA held low by the chip");
    assert!(r.i2c.scl_high(r.t));
    assert!(r.busy(), "BUSY while SDA is low");
    // Recovery: PE off, GPIO, clock SCL, STOP by hand, SWRST, AF again.
    start_held_then_pe_off(&mut r, 1_000_000);
    let pulses = r.clock_out_stuck_slave().expect("SDA released");
    assert!((1..=9).contains(&pulses), "{pulses} pulses");
    assert!(!r.busy(), "the hand-made STOP cleared BUSY");
    back_on_the_bus(&mut r);
}

#[test]
fn reset_mid_read_leaves_the_chip_holding_sda() {
    // WHO_AM_I = 0x71 = 0b0111_0001: its MSB is 0, so a chip that has been
    // addressed for reading and not yet clocked holds SDA low.
    let mut r = Rig::new();
    r.write_bytes(MPU, &[0x75]).unwrap();
    r.set_cr1(cr1::ACK);
    let s = r.start_address((MPU << 1) | 1);
    assert_eq!(s, sr1::ADDR);
    // MCU reset now: the peripheral is reset, pins back to inputs.
    r.i2c.peripheral_reset();
    r.pins(PinMode::Input, PinMode::Input);
    r.wait(1_000_000);
    assert!(!r.i2c.sda_high(r.t), "SDA still held after 1 ms");
    assert!(r.busy(), "BUSY seen by the freshly reset peripheral");
    back_to_af(&mut r);
    r.configure();
    start_held_then_pe_off(&mut r, 200_000);
    // 0x71: bit 0 is low, bits 1..3 high; one pulse moves the chip to a 1.
    assert_eq!(r.clock_out_stuck_slave(), Some(1));
    back_on_the_bus(&mut r);
}

#[test]
fn reset_mid_byte_counts_the_bits_already_clocked() {
    // Reset 5.5 bit times into the second byte of a read of 0x75.. : the
    // chip is shifting out register 0x76 at its bit 5.
    let mut r = Rig::new();
    r.i2c.bus().inject(Fault::SlaveHoldsSda(Chip::Ms5611));
    r.clear_cr1(cr1::PE);
    // The MS5611 was left sending 0x00 from its MSB: all 8 bits low, then
    // the ACK slot: 8 pulses.
    assert_eq!(r.clock_out_stuck_slave(), Some(8));
    back_to_af(&mut r);
    swrst_and_configure(&mut r);
    r.write_bytes(MPU, &[0x75]).unwrap();
    r.set_cr1(cr1::ACK);
    r.start_address((MPU << 1) | 1);
    r.clear_addr();
    r.poll_sr1(sr1::RXNE, 100_000).unwrap();
    let second = r.i2c.bus().state().mpu.register(0x76);
    r.wait(BIT_NS * 11 / 2);
    r.wr(reg::CR1, cr1::SWRST);
    let sda_low = !r.i2c.sda_high(r.t);
    let bit5_low = (second << 5) & 0x80 == 0;
    assert_eq!(sda_low, bit5_low, "SDA shows bit 5 of 0x{second:02X}");
    r.wr(reg::CR1, 0);
    r.clear_cr1(cr1::PE);
    let pulses = r.clock_out_stuck_slave().expect("released");
    assert!(pulses <= 3, "at most the 3 bits left: {pulses}");
    back_to_af(&mut r);
    r.configure();
    assert_eq!(r.who_am_i(), Some(0x71));
}

#[test]
fn sda_stuck_low_is_not_released_by_clocking() {
    let mut r = Rig::new();
    r.i2c.bus().inject(Fault::StuckBus);
    r.wait(BIT_NS);
    assert!(r.busy());
    start_held_then_pe_off(&mut r, 1_000_000);
    assert_eq!(r.clock_out_stuck_slave(), None, "9 pulses, SDA still low");
    r.i2c.bus().clear_faults();
    r.gpio(true, true);
    r.wait(BIT_NS);
    assert!(!r.busy(), "SDA rising with SCL high is a STOP");
    back_on_the_bus(&mut r);
}

#[test]
fn scl_stuck_low_keeps_busy() {
    let mut r = Rig::new();
    r.i2c.bus().inject(Fault::SclStuckLow);
    r.wait(BIT_NS);
    assert!(!r.i2c.scl_high(r.t));
    assert!(r.busy());
    r.set_cr1(cr1::START);
    assert_eq!(r.poll_sr1(sr1::SB, 500_000), None);
    r.i2c.bus().clear_faults();
    r.clear_cr1(cr1::PE | cr1::START);
    swrst_and_configure(&mut r);
    assert!(!r.busy(), "SWRST with the lines high clears BUSY");
    assert_eq!(r.who_am_i(), Some(0x71));
}

#[test]
fn nack_storm_then_recovery() {
    let mut r = Rig::new();
    r.i2c.bus().inject(Fault::Nack {
        address: MPU,
        transactions: Some(5),
    });
    for _ in 0..5 {
        assert_eq!(r.who_am_i(), None);
        assert_ne!(r.rd(reg::SR1) & sr1::AF, 0);
        r.wr(reg::SR1, !sr1::AF);
        assert_eq!(r.sr2(), 0, "STOP after the NACK freed the bus");
    }
    assert_eq!(r.who_am_i(), Some(0x71));
    assert_eq!(r.i2c.bus().transaction_counts(), (6, 5));
}

#[test]
fn bus_error_glitch_mid_transfer() {
    // A real misplaced START/STOP on byte 2: BERR, and the chip drops out
    // of the transfer, so the byte is not acknowledged either.
    let mut r = Rig::new();
    r.i2c
        .bus()
        .inject(Fault::BusErrorMidTransfer { after_bytes: 1 });
    let e = r.write_bytes(MPU, &[0x19, 0x09]).unwrap_err();
    assert_eq!(e & (sr1::BERR | sr1::AF), sr1::BERR | sr1::AF);
    assert_ne!(r.i2c.bus().state().mpu.register(0x19), 0x09);
    r.wr(reg::SR1, 0);
    assert_eq!(r.who_am_i(), Some(0x71), "one-shot");
}

#[test]
fn spurious_berr_changes_nothing_else() {
    // Errata: spurious BERR in master mode; clear it and carry on.
    let mut r = Rig::new();
    r.i2c.inject(PeripheralFault::SpuriousBerr, r.t);
    r.write_bytes(MPU, &[0x19, 0x09]).unwrap();
    assert_eq!(r.rd(reg::SR1), sr1::BERR);
    assert_eq!(r.i2c.bus().state().mpu.register(0x19), 0x09);
    r.wr(reg::SR1, !sr1::BERR);
    assert_eq!(r.rd(reg::SR1), 0);
    assert_eq!(
        r.i2c.bus().transaction_counts().1,
        0,
        "nothing failed on the wire"
    );
}

/// Another master starts with the next transfer and wins arbitration:
/// START, then `address`'s write byte on the wire against it.
fn address_against_another_master(r: &mut Rig, address: u8) {
    r.i2c
        .bus()
        .inject(Fault::ArbitrationLoss { transactions: 1 });
    r.set_cr1(cr1::START);
    r.poll_sr1(sr1::SB, 100_000).unwrap();
    r.wr(reg::DR, u16::from(address << 1));
}

#[test]
fn arbitration_loss() {
    let mut r = Rig::new();
    address_against_another_master(&mut r, MPU);
    assert_eq!(r.poll_sr1(sr1::ARLO, 100_000), Some(9 * BIT_NS));
    assert_eq!(r.rd(reg::SR1) & (sr1::ADDR | sr1::AF), 0);
    assert_eq!(
        r.sr2(),
        sr2::BUSY,
        "slave mode; the other master owns the bus"
    );
    r.wr(reg::SR1, !sr1::ARLO);
    r.wait(40 * BIT_NS);
    assert_eq!(r.sr2(), 0, "its STOP frees the bus");
    assert_eq!(r.who_am_i(), Some(0x71));
}

#[test]
fn start_waits_for_the_other_master() {
    let mut r = Rig::new();
    address_against_another_master(&mut r, MS);
    r.poll_sr1(sr1::ARLO, 100_000).unwrap();
    let t_lost = r.t;
    r.set_cr1(cr1::START);
    let waited = r.poll_sr1(sr1::SB, 1_000_000).expect("SB once free");
    assert!(waited > 20 * BIT_NS, "START held while BUSY ({waited} ns)");
    assert!(r.t - t_lost < 40 * BIT_NS);
}

/// Errata ES096 §2.13.7 workaround, steps 1-15.
fn errata_busy_workaround(r: &mut Rig) {
    r.clear_cr1(cr1::PE); // 1
    r.gpio(true, true); // 2
    assert!(r.i2c.scl_high(r.t) && r.i2c.sda_high(r.t)); // 3
    r.gpio(true, false); // 4
    assert!(!r.i2c.sda_high(r.t)); // 5
    r.gpio(false, false); // 6
    assert!(!r.i2c.scl_high(r.t)); // 7
    r.gpio(true, false); // 8
    assert!(r.i2c.scl_high(r.t)); // 9
    r.gpio(true, true); // 10
    assert!(r.i2c.sda_high(r.t)); // 11
    back_to_af(r); // 12
    r.wr(reg::CR1, cr1::SWRST); // 13
    r.wr(reg::CR1, 0); // 14
    r.configure(); // 15 (PE = 1)
}

#[test]
fn busy_lockup_survives_swrst_and_pe_alone() {
    let mut r = Rig::new();
    r.i2c.inject(PeripheralFault::BusyLockup, r.t);
    assert!(
        r.i2c.scl_high(r.t) && r.i2c.sda_high(r.t),
        "the lines are high"
    );
    assert!(r.busy(), "but BUSY is set");
    start_held_then_pe_off(&mut r, 500_000);
    swrst_and_configure(&mut r);
    assert!(r.busy(), "SWRST alone does not clear it");
    // Clocking SCL alone does not toggle SDA: still locked.
    r.clear_cr1(cr1::PE);
    for _ in 0..9 {
        r.gpio(false, true);
        r.wait(BIT_NS / 2);
        r.gpio(true, true);
        r.wait(BIT_NS / 2);
    }
    back_to_af(&mut r);
    swrst_and_configure(&mut r);
    assert!(r.busy(), "SDA was never driven low");
    // Nor does an RCC reset of the peripheral (the filter is in the I/O).
    r.i2c.peripheral_reset();
    r.configure();
    assert!(r.busy());
    // SDA toggled as well: unlocked, and SWRST clears BUSY.
    r.clear_cr1(cr1::PE);
    r.gpio(true, false);
    r.gpio(true, true);
    back_to_af(&mut r);
    assert!(r.busy(), "until SWRST");
    swrst_and_configure(&mut r);
    assert!(!r.busy());
    assert_eq!(r.who_am_i(), Some(0x71));
}

#[test]
fn errata_sequence_clears_busy_lockup() {
    let mut r = Rig::new();
    r.i2c.inject(PeripheralFault::BusyLockup, r.t);
    assert!(r.busy());
    errata_busy_workaround(&mut r);
    assert!(!r.busy());
    assert_eq!(r.who_am_i(), Some(0x71));
}

#[test]
fn errata_sequence_without_swrst_leaves_busy() {
    let mut r = Rig::new();
    r.i2c.inject(PeripheralFault::BusyLockup, r.t);
    r.clear_cr1(cr1::PE);
    r.gpio(true, false);
    r.gpio(false, false);
    r.gpio(true, false);
    r.gpio(true, true);
    back_to_af(&mut r);
    r.set_cr1(cr1::PE);
    assert!(r.busy(), "BUSY latched until SWRST");
    r.wr(reg::CR1, cr1::SWRST);
    r.wr(reg::CR1, 0);
    r.configure();
    assert!(!r.busy());
}

#[test]
fn pins_taken_mid_write_release_the_bus() {
    let mut r = Rig::new();
    r.start_address(MPU << 1);
    r.clear_addr();
    r.wr(reg::DR, 0x19);
    r.wait(4 * BIT_NS);
    r.gpio(true, true);
    assert!(r.i2c.sda_high(r.t), "a chip receiving does not hold SDA");
    assert_ne!(
        r.sr2() & sr2::MSL,
        0,
        "the peripheral still thinks it is master"
    );
    r.wait(100 * BIT_NS);
    assert_eq!(
        r.rd(reg::SR1) & sr1::BTF,
        0,
        "and waits for an SCL it cannot drive"
    );
    r.wr(reg::CR1, cr1::SWRST);
    r.wr(reg::CR1, 0);
    back_to_af(&mut r);
    r.configure();
    assert_eq!(r.who_am_i(), Some(0x71));
    // The same with PE = 0 instead of SWRST: the stranded transfer is
    // dropped, but no STOP was seen, so BUSY stays until one is made.
    r.start_address(MPU << 1);
    r.clear_addr();
    r.gpio(true, true);
    r.clear_cr1(cr1::PE);
    assert_eq!(r.sr2(), sr2::BUSY);
    r.gpio(true, false);
    r.gpio(true, true);
    assert_eq!(r.sr2(), 0, "a STOP by hand");
    back_to_af(&mut r);
    r.set_cr1(cr1::PE);
    assert_eq!(r.who_am_i(), Some(0x71));
}

#[test]
fn stop_with_ack_still_set_leaves_the_chip_holding_sda() {
    // The last byte ACKed instead of NACKed: the chip goes on to its next
    // byte (the MS5611 sends 0x00 past the PROM word), keeps SDA low, and
    // the STOP cannot happen on the wire: BUSY right after the "STOP".
    let mut r = Rig::new();
    r.write_bytes(MS, &[0xA4]).unwrap();
    r.set_cr1(cr1::ACK);
    r.start_address((MS << 1) | 1);
    r.clear_addr();
    r.poll_sr1(sr1::RXNE, 100_000).unwrap();
    r.rd(reg::DR);
    r.set_cr1(cr1::STOP);
    r.poll_sr1(sr1::RXNE, 100_000).unwrap();
    r.rd(reg::DR);
    assert_eq!(
        r.wait_stop_cleared(10 * BIT_NS),
        Some(BIT_NS),
        "STOP bit clears"
    );
    assert!(!r.i2c.sda_high(r.t), "but the chip holds SDA");
    assert!(r.busy());
    r.clear_cr1(cr1::PE | cr1::ACK);
    assert_eq!(r.clock_out_stuck_slave(), Some(8));
    back_on_the_bus(&mut r);
}

/// An MCU reset `after_ns` into a 14-byte burst read from ACCEL_XOUT_H
/// (the IMU task's read), pins back to inputs, peripheral set up again.
fn reset_into_burst(after_ns: u64) -> Rig {
    let mut r = Rig::new();
    r.write_bytes(MPU, &[0x6B, 0x00]).unwrap(); // wake: samples are non-zero
    r.wait(5_000_000);
    r.write_bytes(MPU, &[0x3B]).unwrap();
    r.set_cr1(cr1::ACK);
    r.start_address((MPU << 1) | 1);
    r.clear_addr();
    let t0 = r.t;
    while r.t - t0 < after_ns {
        if r.rd(reg::SR1) & sr1::RXNE != 0 {
            r.rd(reg::DR);
        }
        r.wait(200);
    }
    r.i2c.peripheral_reset();
    r.pins(PinMode::Input, PinMode::Input);
    r.wait(100_000);
    r
}

#[test]
fn resets_during_a_burst_read_and_the_two_recoveries() {
    // Sweep the reset instant over the 14 bytes. Physical truths: the chip
    // holds SDA exactly when it was cut off on a 0 bit (sometimes, not
    // always); nine clocks with SDA released and a STOP always free the
    // bus; stopping the clocks as soon as SDA reads high can leave the chip
    // mid-byte, because its next bit may be a 0 when SCL falls for the STOP.
    let (mut held, mut free, mut early_exit_failures) = (0, 0, 0);
    for k in 0..140u64 {
        let after = k * 14 * 9 * BIT_NS / 140 + 37;
        let mut r = reset_into_burst(after);
        if r.i2c.sda_high(r.t) {
            free += 1;
        } else {
            held += 1;
        }
        let mut early = reset_into_burst(after);
        if early.clock_out_stuck_slave().is_none() || !early.i2c.sda_high(early.t) {
            early_exit_failures += 1;
        }
        assert!(
            r.nine_clocks_and_stop(),
            "reset at {after} ns: SDA still low"
        );
        back_to_af(&mut r);
        swrst_and_configure(&mut r);
        assert!(!r.busy(), "reset at {after} ns");
        assert_eq!(r.who_am_i(), Some(0x71), "reset at {after} ns");
    }
    assert!(held > 10 && free > 10, "held {held}, free {free}");
    assert!(
        early_exit_failures > 0,
        "the early-exit recovery never failed"
    );
}
