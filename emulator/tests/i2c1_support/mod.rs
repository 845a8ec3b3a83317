//! Shared rig for the I2C1 model's tests: the peripheral configured as the
//! manual's example (PCLK1 = 36 MHz, fast mode 400 kHz duty 2:1), and the
//! RM0008 §26.3.3 master steps written out register by register.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use emulator::i2c1::{cr1, reg, sr1, sr2, I2c1, PinMode};
use sim::{SimBus, SimClock, SimConfig};

/// One SCL period at 400 kHz.
pub const BIT_NS: u64 = 2_500;
/// MPU-9250 (AD0 low).
pub const MPU: u8 = 0x68;
/// MS5611 (CSB low).
pub const MS: u8 = 0x77;

/// The peripheral, its bus, and the current time.
pub struct Rig {
    pub i2c: I2c1,
    pub t: u64,
}

impl Rig {
    /// Reset state, pins still inputs.
    pub fn bare() -> Self {
        let clock = SimClock::new();
        let bus = SimBus::new(
            &clock,
            SimConfig {
                bus_hz: None,
                ..SimConfig::default()
            },
        );
        Self {
            i2c: I2c1::new(bus),
            t: 0,
        }
    }

    /// Pins AF open drain, FREQ = 36, CCR = 0x801E, TRISE = 11, PE = 1.
    pub fn new() -> Self {
        let mut r = Self::bare();
        r.pins(PinMode::AlternateOpenDrain, PinMode::AlternateOpenDrain);
        r.configure();
        r
    }

    pub fn configure(&mut self) {
        self.wr(reg::CR2, 36);
        self.wr(reg::CCR, 0x801E);
        self.wr(reg::TRISE, 11);
        self.wr(reg::CR1, cr1::PE);
    }

    pub fn pins(&mut self, scl: PinMode, sda: PinMode) {
        self.i2c.set_pins(scl, sda, self.t);
    }

    /// GPIO open drain on both lines with these ODR levels.
    pub fn gpio(&mut self, scl_high: bool, sda_high: bool) {
        self.pins(
            PinMode::GpioOutputOpenDrain { high: scl_high },
            PinMode::GpioOutputOpenDrain { high: sda_high },
        );
    }

    pub fn rd(&mut self, offset: u32) -> u16 {
        self.i2c.read(offset, self.t)
    }

    pub fn wr(&mut self, offset: u32, v: u16) {
        self.i2c.write(offset, v, self.t);
    }

    pub fn set_cr1(&mut self, bits: u16) {
        let v = self.rd(reg::CR1);
        self.wr(reg::CR1, v | bits);
    }

    pub fn clear_cr1(&mut self, bits: u16) {
        let v = self.rd(reg::CR1);
        self.wr(reg::CR1, v & !bits);
    }

    pub fn wait(&mut self, ns: u64) {
        self.t += ns;
        self.i2c.advance(self.t);
    }

    /// Polls SR1 every 100 ns (as firmware would) until any of `mask` is
    /// set; `Some(ns waited)` or `None` after `limit_ns`.
    pub fn poll_sr1(&mut self, mask: u16, limit_ns: u64) -> Option<u64> {
        let t0 = self.t;
        loop {
            if self.rd(reg::SR1) & mask != 0 {
                return Some(self.t - t0);
            }
            if self.t - t0 >= limit_ns {
                return None;
            }
            self.wait(100);
        }
    }

    /// Polls CR1 until STOP has cleared; ns waited.
    pub fn wait_stop_cleared(&mut self, limit_ns: u64) -> Option<u64> {
        let t0 = self.t;
        while self.rd(reg::CR1) & cr1::STOP != 0 {
            if self.t - t0 >= limit_ns {
                return None;
            }
            self.wait(100);
        }
        Some(self.t - t0)
    }

    /// START, EV5 (SB, SR1 read then address to DR), then waits for ADDR
    /// or AF. Returns SR1 at that moment.
    pub fn start_address(&mut self, addr_byte: u8) -> u16 {
        self.set_cr1(cr1::START);
        self.poll_sr1(sr1::SB, 100_000).expect("SB");
        self.wr(reg::DR, u16::from(addr_byte));
        self.poll_sr1(sr1::ADDR | sr1::AF, 100_000)
            .expect("ADDR or AF");
        self.rd(reg::SR1)
    }

    /// EV6: ADDR cleared by reading SR1 then SR2; returns (SR1, SR2).
    pub fn clear_addr(&mut self) -> (u16, u16) {
        let s1 = self.rd(reg::SR1);
        let s2 = self.rd(reg::SR2);
        (s1, s2)
    }

    /// A complete write (RM0008 Figure 273: EV5, EV6, EV8_1, EV8..., EV8_2, STOP).
    pub fn write_bytes(&mut self, address: u8, bytes: &[u8]) -> Result<(), u16> {
        let s = self.start_address(address << 1);
        if s & sr1::AF != 0 {
            self.set_cr1(cr1::STOP);
            self.wait_stop_cleared(100_000);
            return Err(s);
        }
        self.clear_addr();
        for &b in bytes {
            self.poll_sr1(sr1::TXE | sr1::AF, 100_000).expect("TXE");
            if self.rd(reg::SR1) & sr1::AF != 0 {
                break;
            }
            self.wr(reg::DR, u16::from(b));
        }
        let s = self
            .poll_sr1(sr1::BTF | sr1::AF, 100_000)
            .map(|_| self.rd(reg::SR1));
        self.set_cr1(cr1::STOP);
        self.wait_stop_cleared(100_000).expect("STOP clears");
        match s {
            Some(v) if v & sr1::AF == 0 => Ok(()),
            Some(v) => Err(v),
            None => Err(0),
        }
    }

    /// N ≥ 3 bytes read the manual's way (RM0008 §26.3.3 "N > 2").
    pub fn read_n(&mut self, address: u8, n: usize) -> Vec<u8> {
        assert!(n > 2);
        self.set_cr1(cr1::ACK);
        let s = self.start_address((address << 1) | 1);
        assert_eq!(s & sr1::ADDR, sr1::ADDR, "address acknowledged");
        self.clear_addr();
        let mut out = Vec::new();
        while out.len() < n - 3 {
            self.poll_sr1(sr1::RXNE, 100_000).expect("RXNE");
            out.push(self.rd(reg::DR) as u8);
        }
        // EV7_2: BTF with N-2 in DR and N-1 in the shift register.
        self.poll_sr1(sr1::BTF, 100_000).expect("BTF");
        self.clear_cr1(cr1::ACK);
        out.push(self.rd(reg::DR) as u8);
        self.set_cr1(cr1::STOP);
        out.push(self.rd(reg::DR) as u8);
        self.poll_sr1(sr1::RXNE, 100_000)
            .expect("RXNE of the last byte");
        out.push(self.rd(reg::DR) as u8);
        self.wait_stop_cleared(100_000).expect("STOP clears");
        out
    }

    pub fn sr2(&mut self) -> u16 {
        self.rd(reg::SR2)
    }

    pub fn busy(&mut self) -> bool {
        self.sr2() & sr2::BUSY != 0
    }

    /// Recovery by hand: pins GPIO open drain, SCL pulsed until SDA reads
    /// high (at most 9 pulses), then a STOP (SDA low → high with SCL high).
    /// Returns the pulses needed, or `None` if SDA never came up.
    pub fn clock_out_stuck_slave(&mut self) -> Option<u32> {
        self.gpio(true, true);
        self.wait(BIT_NS);
        let mut pulses = 0;
        while !self.i2c.sda_high(self.t) {
            if pulses == 9 {
                return None;
            }
            self.gpio(false, true);
            self.wait(BIT_NS / 2);
            self.gpio(true, true);
            self.wait(BIT_NS / 2);
            pulses += 1;
        }
        self.stop_by_hand();
        Some(pulses)
    }

    /// A STOP driven on the pins (GPIO open drain): SCL low, SDA low, SCL
    /// high, then SDA rising while SCL is high, half a bit time each.
    pub fn stop_by_hand(&mut self) {
        self.gpio(false, true);
        self.wait(BIT_NS / 2);
        self.gpio(false, false);
        self.wait(BIT_NS / 2);
        self.gpio(true, false);
        self.wait(BIT_NS / 2);
        self.gpio(true, true);
        self.wait(BIT_NS / 2);
    }

    /// Recovery that always gives nine SCL pulses with SDA released (so a
    /// chip mid-read reaches its ACK slot, sees NACK and lets go), then a
    /// STOP by hand. Returns whether SDA is high afterwards.
    pub fn nine_clocks_and_stop(&mut self) -> bool {
        self.gpio(true, true);
        self.wait(BIT_NS);
        for _ in 0..9 {
            self.gpio(false, true);
            self.wait(BIT_NS / 2);
            self.gpio(true, true);
            self.wait(BIT_NS / 2);
        }
        self.stop_by_hand();
        self.i2c.sda_high(self.t)
    }

    /// WHO_AM_I over a write + repeated START + 1-byte read (the manual's
    /// single-byte ending). `None` on NACK.
    pub fn who_am_i(&mut self) -> Option<u8> {
        let s = self.start_address(MPU << 1);
        if s & sr1::AF != 0 {
            self.set_cr1(cr1::STOP);
            self.wait_stop_cleared(100_000);
            return None;
        }
        self.clear_addr();
        self.poll_sr1(sr1::TXE, 100_000)?;
        self.wr(reg::DR, 0x75);
        self.poll_sr1(sr1::BTF, 100_000)?;
        let s = self.start_address((MPU << 1) | 1);
        assert_eq!(s & sr1::ADDR, sr1::ADDR);
        self.clear_cr1(cr1::ACK);
        self.clear_addr();
        self.set_cr1(cr1::STOP);
        self.poll_sr1(sr1::RXNE, 100_000)?;
        let v = self.rd(reg::DR) as u8;
        self.wait_stop_cleared(100_000)?;
        Some(v)
    }
}
