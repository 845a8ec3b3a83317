//! SPI transport for the MPU-9250 and MS5611 models: the same chips as on
//! the I2C [`SimBus`] (shared state, shared clock), reached through an
//! `embedded_hal::spi::SpiDevice` with the chip's SPI framing, so a driver on
//! SPI and one on I2C read the same registers and the same samples.
//!
//! Framing (MPU-9250 datasheet §7.5; MS5611 datasheet "SPI interface"):
//! * MPU-9250: the first byte of a transaction is the register address, bit 7
//!   set for a read; the following bytes are written to, or read from,
//!   consecutive registers.
//! * MS5611: the first byte is a command; bytes clocked after it return the
//!   PROM word or the ADC result of that command under the same chip select.
//!
//! The chip models' byte interface ([`Device`]) is reused as is: an SPI frame
//! is played to the model as the I2C transfer with the same meaning.

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};

use crate::bus::SimBus;
use crate::device::Device;

/// Which model the chip-select line selects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpiChip {
    /// The MPU-9250.
    Mpu9250,
    /// The MS5611 (PS pin low).
    Ms5611,
}

/// An SPI error; the models never produce one (SPI has no acknowledge).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimSpiError;

impl embedded_hal::spi::Error for SimSpiError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

/// One chip on SPI, sharing the chips and the clock of a [`SimBus`].
#[derive(Clone, Debug)]
pub struct SimSpi {
    bus: SimBus,
    chip: SpiChip,
    clock_hz: u32,
}

impl SimSpi {
    /// `chip` of `bus` on SPI at `clock_hz` (transfer time advances the clock).
    pub fn new(bus: &SimBus, chip: SpiChip, clock_hz: u32) -> Self {
        Self {
            bus: bus.clone(),
            chip,
            clock_hz,
        }
    }

    fn run(&self, operations: &mut [Operation<'_, u8>]) {
        let now = self.bus.clock().now_ns();
        let mut bytes = 0usize;
        {
            let mut guard = self.bus.state_mut();
            let s = &mut *guard;
            s.update_all(now);
            let world = &mut s.world;
            let dev: &mut dyn Device = match self.chip {
                SpiChip::Mpu9250 => &mut s.mpu,
                SpiChip::Ms5611 => &mut s.ms,
            };
            let mut frame = Frame::new(self.chip);
            for op in operations.iter_mut() {
                match op {
                    Operation::Write(out) => {
                        for &b in out.iter() {
                            frame.byte(dev, Some(b), now, world);
                        }
                        bytes += out.len();
                    }
                    Operation::Read(inp) => {
                        for slot in inp.iter_mut() {
                            *slot = frame.byte(dev, None, now, world);
                        }
                        bytes += inp.len();
                    }
                    Operation::Transfer(inp, out) => {
                        let n = inp.len().max(out.len());
                        for i in 0..n {
                            let v = frame.byte(dev, out.get(i).copied(), now, world);
                            if let Some(slot) = inp.get_mut(i) {
                                *slot = v;
                            }
                        }
                        bytes += n;
                    }
                    Operation::TransferInPlace(buf) => {
                        for slot in buf.iter_mut() {
                            *slot = frame.byte(dev, Some(*slot), now, world);
                        }
                        bytes += buf.len();
                    }
                    Operation::DelayNs(ns) => self.bus.clock().advance_ns(u64::from(*ns)),
                }
            }
            frame.end(dev, now, world);
        }
        if self.clock_hz > 0 {
            let ns = bytes as u64 * 8 * 1_000_000_000 / u64::from(self.clock_hz);
            self.bus.clock().advance_ns(ns);
        }
    }
}

/// Where a chip-select frame is: the first byte picks the register or
/// command, the rest move data.
struct Frame {
    chip: SpiChip,
    first: bool,
    read: bool,
}

impl Frame {
    fn new(chip: SpiChip) -> Self {
        Self {
            chip,
            first: true,
            read: false,
        }
    }

    /// Clock one byte: `mosi` is what the host sends (`None` for a read).
    fn byte(
        &mut self,
        dev: &mut dyn Device,
        mosi: Option<u8>,
        now: u64,
        world: &mut crate::world::World,
    ) -> u8 {
        let out = mosi.unwrap_or(0);
        if self.first {
            self.first = false;
            dev.start(false);
            // SPI has no acknowledge: a byte the model refuses is simply lost.
            match self.chip {
                SpiChip::Mpu9250 => {
                    self.read = out & 0x80 != 0;
                    let _ = dev.write_byte(out & 0x7F, now, world);
                    if self.read {
                        dev.start(true);
                    }
                }
                SpiChip::Ms5611 => {
                    let _ = dev.write_byte(out, now, world);
                    dev.stop(now, world);
                    dev.start(true);
                    self.read = true;
                }
            }
            return 0;
        }
        if self.read {
            dev.read_byte(now, world)
        } else {
            let _ = dev.write_byte(out, now, world);
            0
        }
    }

    fn end(self, dev: &mut dyn Device, now: u64, world: &mut crate::world::World) {
        if !self.first {
            dev.stop(now, world);
        }
    }
}

impl ErrorType for SimSpi {
    type Error = SimSpiError;
}

impl SpiDevice for SimSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        self.run(operations);
        Ok(())
    }
}
