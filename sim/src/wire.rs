//! The bus as a master sees it on the wire: START + address, byte by byte
//! with the master's ACK/NACK, STOP, and -- for a master that has lost the
//! bus (reset mid-transfer) or drives the pins as GPIO -- the line levels
//! and what the slaves do on each SCL edge.
//!
//! [`SimBus`]'s `embedded_hal::i2c::I2c` transactions run over these same
//! steps, and so does a register-level master model (the emulator's I2C1).
//!
//! Line model (UM10204 §3.1): SCL and SDA are wired-AND (open drain with
//! pull-ups). A slave drives SDA only while it shifts out a read byte (a 0
//! bit pulls SDA low), and in the ACK slot of a byte it receives; it moves
//! to the next bit on each SCL falling edge. A STOP (SDA rising while SCL is
//! high) or START (SDA falling while SCL is high) resets every slave to
//! waiting for its address. The chips do not stretch SCL. Addresses sent
//! by bit-banging the pins are not decoded: a line-level master can release
//! a stuck slave and generate START/STOP, not run a transfer.

use crate::bus::{BusState, SimBus, SimBusError, AK8963_ADDRESS};
use crate::device::Device;
use crate::world::World;
use embedded_hal::i2c::NoAcknowledgeSource;

/// The chip a transaction is talking to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Target {
    Mpu,
    Ak,
    Ms,
}

/// What the addressed slave is doing on SDA between master actions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SlaveLine {
    /// Released; waiting for START/STOP.
    Idle,
    /// Shifting out `byte`; `bit` bits (MSB first) have been clocked out.
    Sending { byte: u8, bit: u8 },
    /// A read byte is fully clocked out; the slave has released SDA and
    /// samples the master's ACK on the next SCL high.
    AckSlot,
    /// The master ACKed: the next byte starts on the next SCL falling edge.
    Acked,
}

/// Wire-level state of the bus (inside [`BusState`]).
#[derive(Clone, Debug)]
pub(crate) struct WireState {
    /// The chip addressed in the transaction under way.
    pub(crate) selected: Option<Target>,
    /// Direction of the current address phase.
    pub(crate) reading: bool,
    pub(crate) slave: SlaveLine,
    pub(crate) in_transaction: bool,
    pub(crate) failed: bool,
    /// Data bytes left before the armed glitch, for this transaction.
    pub(crate) budget: Option<usize>,
    pub(crate) scl_stuck: bool,
    /// Bus levels at the last line-level update (SCL, SDA).
    pub(crate) last_levels: (bool, bool),
}

impl Default for WireState {
    fn default() -> Self {
        Self {
            selected: None,
            reading: false,
            slave: SlaveLine::Idle,
            in_transaction: false,
            failed: false,
            budget: None,
            scl_stuck: false,
            last_levels: (true, true),
        }
    }
}

fn device(s: &mut BusState, t: Target) -> (&mut dyn Device, &mut World) {
    let BusState {
        world, mpu, ak, ms, ..
    } = s;
    let d: &mut dyn Device = match t {
        Target::Mpu => mpu,
        Target::Ak => ak,
        Target::Ms => ms,
    };
    (d, world)
}

impl BusState {
    fn fail(&mut self, e: SimBusError) -> SimBusError {
        if !self.wire.failed {
            self.wire.failed = true;
            self.failed_transactions += 1;
        }
        e
    }

    fn sda_pulled_low(&self) -> bool {
        self.stuck || self.slave_drives_sda_low()
    }

    fn slave_drives_sda_low(&self) -> bool {
        match self.wire.slave {
            SlaveLine::Sending { byte, bit } => bit < 8 && (byte << bit) & 0x80 == 0,
            _ => false,
        }
    }

    /// The slave's transaction ends (STOP, START, or a glitch it saw).
    fn end_slave(&mut self, now: u64) {
        if let Some(t) = self.wire.selected.take() {
            let (d, w) = device(self, t);
            d.stop(now, w);
        }
        self.wire.slave = SlaveLine::Idle;
    }

    fn consume_budget(&mut self, now: u64) -> Result<(), SimBusError> {
        match self.wire.budget {
            Some(0) => {
                self.wire.budget = None;
                self.end_slave(now);
                Err(self.fail(SimBusError::Bus))
            }
            Some(n) => {
                self.wire.budget = Some(n - 1);
                Ok(())
            }
            None => Ok(()),
        }
    }

    /// Between bytes of a byte-level transfer SCL is low (held by the
    /// master) and SDA is whatever the chip drives.
    fn mid_transfer_levels(&mut self) {
        self.wire.last_levels = (false, !self.sda_pulled_low());
    }

    fn fetch_next(&mut self, now: u64) {
        if let Some(t) = self.wire.selected {
            let (d, w) = device(self, t);
            let byte = d.read_byte(now, w);
            self.wire.slave = SlaveLine::Sending { byte, bit: 0 };
        }
    }
}

impl SimBus {
    fn wire_now(&self) -> (u64, std::cell::RefMut<'_, BusState>) {
        let now = self.clock().now_ns();
        let mut s = self.state_cell().borrow_mut();
        s.update_all(now);
        (now, s)
    }

    /// A START (or repeated START) followed by `address_byte` (7-bit
    /// address << 1 | R/W). `Ok` when a chip acknowledged. In the read
    /// direction the chip starts shifting out its first byte at once.
    ///
    /// Errors: `Bus` when SDA is held low (no START possible), or a slave
    /// was left mid-byte; `ArbitrationLoss` (fault); `Nack(Address)` when no
    /// chip answers.
    pub fn wire_start(&self, address_byte: u8) -> Result<(), SimBusError> {
        let (now, mut guard) = self.wire_now();
        let s = &mut *guard;
        if !s.wire.in_transaction {
            s.wire.in_transaction = true;
            s.wire.failed = false;
            s.transactions += 1;
            s.wire.budget = s.bus_error_after.take();
        }
        if s.sda_pulled_low() || s.wire.scl_stuck {
            return Err(s.fail(SimBusError::Bus));
        }
        // A (repeated) START ends whatever the slaves were doing.
        s.end_slave(now);
        if s.arbitration_losses > 0 {
            s.arbitration_losses -= 1;
            return Err(s.fail(SimBusError::ArbitrationLoss));
        }
        let address = address_byte >> 1;
        let read = address_byte & 1 != 0;
        let nack = SimBusError::Nack(NoAcknowledgeSource::Address);
        if let Some(i) = s.nacks.iter().position(|(a, _)| *a == address) {
            let left = s.nacks.get_mut(i).map(|n| &mut n.1);
            match left {
                Some(None) => return Err(s.fail(nack)),
                Some(Some(0)) | None => {
                    s.nacks.remove(i);
                }
                Some(Some(n)) => {
                    *n -= 1;
                    if *n == 0 {
                        s.nacks.remove(i);
                    }
                    return Err(s.fail(nack));
                }
            }
        }
        let target = if address == s.mpu_address {
            Target::Mpu
        } else if address == s.ms5611_address {
            Target::Ms
        } else if address == AK8963_ADDRESS && s.mpu.bypass_active() {
            Target::Ak
        } else {
            return Err(s.fail(nack));
        };
        let (d, _) = device(s, target);
        if !d.acks_address(now) {
            return Err(s.fail(nack));
        }
        d.start(read);
        s.wire.selected = Some(target);
        s.wire.reading = read;
        if read {
            s.fetch_next(now);
        }
        s.mid_transfer_levels();
        Ok(())
    }

    /// The master writes one data byte. `Nack(Data)` when the chip does not
    /// acknowledge it (or no chip is addressed any more); `Bus` when a
    /// glitch hits this byte (the chip drops out of the transaction).
    pub fn wire_write(&self, byte: u8) -> Result<(), SimBusError> {
        let (now, mut guard) = self.wire_now();
        let s = &mut *guard;
        s.consume_budget(now)?;
        let Some(t) = s.wire.selected.filter(|_| !s.wire.reading) else {
            return Err(s.fail(SimBusError::Nack(NoAcknowledgeSource::Data)));
        };
        let (d, w) = device(s, t);
        let result = d.write_byte(byte, now, w);
        s.mid_transfer_levels();
        result.map_err(|e| s.fail(e))
    }

    /// The master clocks in one data byte and answers ACK (`ack`, the chip
    /// goes on to its next byte) or NACK (the chip releases SDA). With no
    /// chip sending, SDA floats high and the byte reads 0xFF. `Bus` when a
    /// glitch hits this byte.
    pub fn wire_read(&self, ack: bool) -> Result<u8, SimBusError> {
        let (now, mut guard) = self.wire_now();
        let s = &mut *guard;
        s.consume_budget(now)?;
        let byte = match s.wire.slave {
            SlaveLine::Sending { byte, bit: 0 } if s.wire.reading => byte,
            _ => 0xFF,
        };
        if ack && s.wire.selected.is_some() && s.wire.reading {
            s.fetch_next(now);
        } else {
            s.wire.slave = SlaveLine::Idle;
        }
        s.mid_transfer_levels();
        Ok(byte)
    }

    /// STOP condition: the transaction ends for the master and the chips.
    /// A chip that is driving a 0 bit (it was ACKed and is shifting out the
    /// next byte) keeps SDA low, so no STOP reaches it: it stays where it
    /// is, holding the bus.
    pub fn wire_stop(&self) {
        let (now, mut guard) = self.wire_now();
        let s = &mut *guard;
        if !s.slave_drives_sda_low() {
            s.end_slave(now);
        }
        s.wire.last_levels = (!s.wire.scl_stuck, !s.sda_pulled_low());
        s.wire.in_transaction = false;
        if !s.wire.failed {
            // A glitch armed for later than this (short) transaction stays armed.
            s.bus_error_after = s.wire.budget.take();
        }
        s.wire.budget = None;
    }

    /// The master stops driving in the middle of a byte (reset, or its pins
    /// switched to GPIO) after `bits_clocked` SCL pulses of it (0..=8; 8 =
    /// the ACK slot). A chip shifting out a read byte keeps its place and
    /// holds SDA at its current bit until SCL is clocked again; a chip
    /// receiving releases SDA. The chip does not see a STOP.
    pub fn wire_abandon(&self, bits_clocked: u8) {
        let (_, mut guard) = self.wire_now();
        let s = &mut *guard;
        s.wire.in_transaction = false;
        s.wire.budget = None;
        s.wire.slave = match s.wire.slave {
            SlaveLine::Sending { byte, .. } if bits_clocked < 8 => SlaveLine::Sending {
                byte,
                bit: bits_clocked,
            },
            SlaveLine::Sending { .. } => SlaveLine::AckSlot,
            other => other,
        };
        s.wire.last_levels = (false, !s.sda_pulled_low());
    }

    /// SDA is pulled low by something other than the master: a chip
    /// shifting out a 0 bit, or a stuck-line fault.
    pub fn wire_sda_pulled_low(&self) -> bool {
        let (_, s) = self.wire_now();
        s.sda_pulled_low()
    }

    /// SCL is pulled low by something other than the master (stuck-line fault).
    pub fn wire_scl_pulled_low(&self) -> bool {
        let (_, s) = self.wire_now();
        s.wire.scl_stuck
    }

    /// Line-level step: the master now drives SCL/SDA to these levels
    /// (`true` = released, pulled up). The chips react to the resulting bus
    /// edges: the next bit on SCL falling, the master's ACK/NACK sampled on
    /// SCL rising in the ACK slot, STOP/START on SDA edges while SCL is high.
    /// Returns the bus levels (SCL, SDA) afterwards.
    pub fn wire_lines(&self, master_scl_high: bool, master_sda_high: bool) -> (bool, bool) {
        let (now, mut guard) = self.wire_now();
        let s = &mut *guard;
        let (old_scl, old_sda) = s.wire.last_levels;
        let scl = master_scl_high && !s.wire.scl_stuck;
        // The chip changes SDA only while SCL is low, so SCL edges are
        // handled with the SDA level from before them.
        if old_scl && !scl {
            s.wire.slave = match s.wire.slave {
                SlaveLine::Sending { byte, bit } if bit + 1 < 8 => {
                    SlaveLine::Sending { byte, bit: bit + 1 }
                }
                SlaveLine::Sending { .. } => SlaveLine::AckSlot,
                SlaveLine::Acked => {
                    s.fetch_next(now);
                    s.wire.slave
                }
                other => other,
            };
        }
        if !old_scl && scl && s.wire.slave == SlaveLine::AckSlot {
            let sda_now = master_sda_high && !s.sda_pulled_low();
            if sda_now {
                // NACK: the chip stops sending and waits for STOP/START.
                s.wire.slave = SlaveLine::Idle;
            } else {
                s.wire.slave = SlaveLine::Acked;
            }
        }
        let sda = master_sda_high && !s.sda_pulled_low();
        if old_scl && scl && old_sda != sda {
            // STOP (rising) or START (falling): every chip starts over.
            s.end_slave(now);
            s.wire.in_transaction = false;
        }
        s.wire.last_levels = (scl, sda);
        (scl, sda)
    }

    /// Puts `target`'s chip in the middle of a read, shifting out 0x00 from
    /// its MSB, so it holds SDA low for the next 8 SCL pulses (a chip left
    /// behind by a master reset, or by power-up noise).
    pub(crate) fn wire_hold_sda(&self, target: Target) {
        let (_, mut guard) = self.wire_now();
        let s = &mut *guard;
        s.wire.selected = Some(target);
        s.wire.reading = true;
        s.wire.in_transaction = false;
        s.wire.slave = SlaveLine::Sending { byte: 0, bit: 0 };
        s.wire.last_levels = (!s.wire.scl_stuck, false);
    }
}
