//! The calibration flash page (`0x0800_FC00`, the last 1 KiB page) through
//! the HAL's flash writer.

use sensor_stack::storage::CalibrationStore;
use stm32f1xx_hal::flash::{Error, FlashSize, FlashWriter, Parts, SectorSize};

/// Offset of the calibration page from the start of flash.
pub const PAGE_OFFSET: u32 = sensor_stack::storage::PAGE_ADDRESS - 0x0800_0000;

/// The calibration page.
pub struct FlashPage<'a> {
    writer: FlashWriter<'a>,
}

impl<'a> FlashPage<'a> {
    /// A writer for the 64 KiB part with 1 KiB pages. The HAL's per-word
    /// verification is off: `sensor_stack::storage::save` reads the whole record
    /// back and compares it anyway.
    pub fn new(flash: &'a mut Parts) -> Self {
        let mut writer = flash.writer(SectorSize::Sz1K, FlashSize::Sz64K);
        writer.change_verification(false);
        Self { writer }
    }
}

impl CalibrationStore for FlashPage<'_> {
    type Error = Error;

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), Error> {
        let src = self.writer.read(PAGE_OFFSET + offset, buf.len())?;
        // Element copy, not `copy_from_slice`: the HAL returns exactly
        // `buf.len()` bytes, and the length-mismatch panic path would link
        // `core::fmt` (~0.7 KiB).
        for (d, s) in buf.iter_mut().zip(src) {
            *d = *s;
        }
        Ok(())
    }

    fn erase(&mut self) -> Result<(), Error> {
        self.writer.page_erase(PAGE_OFFSET)
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), Error> {
        self.writer.write(PAGE_OFFSET + offset, data)
    }
}
