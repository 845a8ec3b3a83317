//! The bus's byte- and line-level steps (what a register-level master and
//! a GPIO bus recovery see), and that `SimBus`'s transactions are the same
//! steps.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use embedded_hal::i2c::{Error as _, ErrorKind, I2c, NoAcknowledgeSource};
use sim::{Chip, Fault, SimBus, SimBusError, SimClock, SimConfig};

const MPU: u8 = 0x68;

fn bus() -> SimBus {
    SimBus::new(
        &SimClock::new(),
        SimConfig {
            bus_hz: None,
            ..SimConfig::default()
        },
    )
}

/// One SCL pulse with SDA released by the master; returns SDA while SCL was high.
fn pulse(bus: &SimBus) -> bool {
    bus.wire_lines(false, true);
    bus.wire_lines(true, true).1
}

/// STOP by hand: SDA low with SCL low, SCL high, then SDA high.
fn stop_by_hand(bus: &SimBus) {
    bus.wire_lines(false, false);
    bus.wire_lines(true, false);
    bus.wire_lines(true, true);
}

#[test]
fn byte_steps_match_a_transaction() {
    let b = bus();
    b.wire_start(MPU << 1).unwrap();
    b.wire_write(0x75).unwrap();
    b.wire_start((MPU << 1) | 1).unwrap();
    assert_eq!(b.wire_read(false), Ok(0x71));
    b.wire_stop();
    let mut id = [0u8];
    b.clone().write_read(MPU, &[0x75], &mut id).unwrap();
    assert_eq!(id[0], 0x71);
    assert_eq!(b.transaction_counts(), (2, 0));
}

#[test]
fn byte_step_errors() {
    let b = bus();
    assert_eq!(
        b.wire_start(0x50 << 1),
        Err(SimBusError::Nack(NoAcknowledgeSource::Address))
    );
    b.wire_stop();
    b.wire_start(0x77 << 1).unwrap();
    b.wire_write(0x1E).unwrap();
    assert_eq!(
        b.wire_write(0x00),
        Err(SimBusError::Nack(NoAcknowledgeSource::Data)),
        "the MS5611 takes one command byte"
    );
    b.wire_stop();
    assert_eq!(b.transaction_counts(), (2, 2));
}

#[test]
fn a_nacked_read_releases_sda_and_an_acked_one_does_not_always() {
    let b = bus();
    b.wire_start(MPU << 1).unwrap();
    b.wire_write(0x75).unwrap();
    b.wire_start((MPU << 1) | 1).unwrap();
    // The chip drives the MSB of 0x71 (0) as soon as it is addressed.
    assert!(b.wire_sda_pulled_low());
    assert_eq!(b.wire_read(false), Ok(0x71));
    assert!(!b.wire_sda_pulled_low(), "NACK: the chip let go");
    b.wire_stop();
}

#[test]
fn chip_left_mid_read_is_released_by_clocking() {
    let b = bus();
    b.inject(Fault::SlaveHoldsSda(Chip::Mpu9250));
    assert!(b.wire_sda_pulled_low());
    let mut id = [0u8];
    assert_eq!(
        b.clone()
            .write_read(MPU, &[0x75], &mut id)
            .unwrap_err()
            .kind(),
        ErrorKind::Bus,
        "no START while SDA is low"
    );
    // Bits 1..7 of the 0x00 byte, then the ACK slot.
    let mut pulses = 0;
    while b.wire_sda_pulled_low() {
        pulse(&b);
        pulses += 1;
        assert!(pulses <= 9);
    }
    assert_eq!(pulses, 8);
    // SCL high in the ACK slot with SDA released: NACK, the chip stops.
    pulse(&b);
    assert!(!b.wire_sda_pulled_low());
    stop_by_hand(&b);
    b.clone().write_read(MPU, &[0x75], &mut id).unwrap();
    assert_eq!(id[0], 0x71);
}

#[test]
fn master_ack_in_the_slot_makes_the_chip_send_the_next_byte() {
    let b = bus();
    b.wire_start(MPU << 1).unwrap();
    b.wire_write(0x75).unwrap();
    b.wire_start((MPU << 1) | 1).unwrap();
    // The master vanishes before clocking WHO_AM_I (0x71) ...
    b.wire_abandon(0);
    // ... and a GPIO master clocks it out by hand, reading each bit.
    let mut byte = 0u8;
    for i in 0..8 {
        if i > 0 {
            b.wire_lines(false, true);
        }
        let sda = b.wire_lines(true, true).1;
        byte = (byte << 1) | u8::from(sda);
    }
    assert_eq!(byte, 0x71);
    // ACK: SDA low through the 9th clock.
    b.wire_lines(false, true);
    b.wire_lines(false, false);
    b.wire_lines(true, false);
    b.wire_lines(false, false);
    b.wire_lines(false, true);
    // The chip is now shifting out register 0x76.
    let want = b.state().mpu.register(0x76);
    let mut next = 0u8;
    for i in 0..8 {
        if i > 0 {
            b.wire_lines(false, true);
        }
        next = (next << 1) | u8::from(b.wire_lines(true, true).1);
    }
    assert_eq!(next, want);
    b.wire_lines(false, true);
    b.wire_lines(true, true); // NACK
    stop_by_hand(&b);
    assert!(!b.wire_sda_pulled_low());
}

#[test]
fn stuck_lines() {
    let mut b = bus();
    b.inject(Fault::SclStuckLow);
    assert!(b.wire_scl_pulled_low());
    assert_eq!(b.wire_lines(true, true), (false, true));
    assert_eq!(b.write(MPU, &[0x75]).unwrap_err().kind(), ErrorKind::Bus);
    b.clear_faults();
    b.inject(Fault::StuckBus);
    assert_eq!(b.wire_lines(true, true), (true, false));
    for _ in 0..9 {
        pulse(&b);
    }
    assert!(
        b.wire_sda_pulled_low(),
        "a stuck line does not answer clocks"
    );
    b.clear_faults();
    assert_eq!(b.wire_lines(true, true), (true, true));
    assert!(b.write(MPU, &[0x75]).is_ok());
}

/// The MPU-9250's 14 sensor bytes (ACCEL_XOUT_H ..= GYRO_ZOUT_L) as the
/// chip holds them internally now.
fn mpu_sensor_registers(b: &SimBus) -> Vec<u8> {
    let s = b.state();
    (0x3Bu8..=0x48).map(|r| s.mpu.register(r)).collect()
}

#[test]
fn a_burst_read_straddling_a_sample_reads_one_sampling_instant() {
    let b = bus();
    b.advance_to_next_mpu_sample();
    let before = mpu_sensor_registers(&b);
    b.wire_start(MPU << 1).unwrap();
    b.wire_write(0x3B).unwrap();
    b.wire_start((MPU << 1) | 1).unwrap();
    let mut got = Vec::new();
    for k in 0..14 {
        if k == 9 {
            // The next sample lands mid-burst, among the gyro bytes.
            b.advance_to_next_mpu_sample();
        }
        got.push(b.wire_read(k < 13).unwrap());
    }
    b.wire_stop();
    let after = mpu_sensor_registers(&b);
    assert_ne!(after, before, "datasheet noise: a new sample differs");
    assert_eq!(got, before, "the whole burst is the sample it started on");
    // The bus idle again, the next read sees the new sample.
    let mut next = [0u8; 14];
    b.clone().write_read(MPU, &[0x3B], &mut next).unwrap();
    assert_eq!(next.to_vec(), after);
}
