//! The byte-level interface between the virtual bus and a chip model.

use crate::bus::SimBusError;
use crate::world::World;

/// What a chip model sees of an I2C transaction, byte by byte.
///
/// The bus calls [`Device::update`] with the current time before every
/// transaction (and before every `data_ready` query), then `start` for each
/// (re)start condition addressed to the chip, `write_byte` / `read_byte` for
/// each data byte, and `stop` at the end.
pub trait Device {
    /// Brings the model up to `now_ns` (samples, conversions, resets).
    fn update(&mut self, now_ns: u64, world: &mut World);
    /// Whether the chip acknowledges its address at `now_ns`.
    fn acks_address(&self, now_ns: u64) -> bool {
        let _ = now_ns;
        true
    }
    /// A (repeated) start in the given direction.
    fn start(&mut self, read: bool);
    /// The master writes one byte; an error is a data NACK.
    fn write_byte(&mut self, byte: u8, now_ns: u64, world: &mut World) -> Result<(), SimBusError>;
    /// The master reads one byte.
    fn read_byte(&mut self, now_ns: u64, world: &mut World) -> u8;
    /// Stop condition.
    fn stop(&mut self, now_ns: u64, world: &mut World) {
        let _ = (now_ns, world);
    }
    /// Power-on reset: every register back to its reset value.
    fn power_on_reset(&mut self, now_ns: u64);
}
