//! The calibration flash page (`CALIB_A`, the chip's last 1 KiB page:
//! `0x0800_FC00` on the C8, `0x0801_FC00` on the CB) through the HAL's
//! flash writer.

use sensor_stack::storage::CalibrationStore;
use stm32f1xx_hal::flash::{Error, FlashSize, FlashWriter, Parts, SectorSize};

/// Offset of `CALIB_A` from the start of flash, as the linker script
/// that is linked places it (`_calib_a_page` in `memory.x` /
/// `memory-cb.x`; a constant, not the symbol's address, which would cost
/// a literal load and a subtraction on the C8's last bytes of flash). The
/// emulated board writes the record where the ELF's symbol says and the
/// firmware must find it there, so a mismatch fails its calibration tests.
#[cfg(not(feature = "f103cb"))]
pub const PAGE_OFFSET: u32 = 0x0000_FC00;
#[cfg(feature = "f103cb")]
pub const PAGE_OFFSET: u32 = 0x0001_FC00;

/// The chip's flash size, as the HAL's writer bounds its accesses.
#[cfg(not(feature = "f103cb"))]
const CHIP_FLASH: FlashSize = FlashSize::Sz64K;
#[cfg(feature = "f103cb")]
const CHIP_FLASH: FlashSize = FlashSize::Sz128K;

/// The calibration page.
pub struct FlashPage<'a> {
    writer: FlashWriter<'a>,
}

impl<'a> FlashPage<'a> {
    /// A writer for the chip's flash (64 or 128 KiB) with 1 KiB pages. The HAL's per-word
    /// verification is off: `sensor_stack::storage::save` reads the whole record
    /// back and compares it anyway.
    pub fn new(flash: &'a mut Parts) -> Self {
        let mut writer = flash.writer(SectorSize::Sz1K, CHIP_FLASH);
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

/// The parameter pages (`PARAMS_A`, `PARAMS_B`: the STM32F103CB's flash
/// plan, `memory-cb.x`) through the HAL's flash writer, for
/// `params::store`. The F1 programs half-words; the HAL's `write` takes a
/// byte slice of whole half-words and programs them in order.
#[cfg(builder)]
pub struct ParamPages<'a> {
    writer: FlashWriter<'a>,
}

#[cfg(builder)]
impl<'a> ParamPages<'a> {
    /// Offset of `PARAMS_A` from the start of flash (`_params_a_page`).
    pub const A_OFFSET: u32 = 0x0001_F000;
    /// Offset of `PARAMS_B` (`_params_b_page`).
    pub const B_OFFSET: u32 = 0x0001_F400;

    /// A writer for the two pages (per-word verification off:
    /// `params::store::save` reads the whole record back).
    pub fn new(flash: &'a mut Parts) -> Self {
        let mut writer = flash.writer(SectorSize::Sz1K, CHIP_FLASH);
        writer.change_verification(false);
        Self { writer }
    }

    fn offset(page: params::store::Page) -> u32 {
        match page {
            params::store::Page::A => Self::A_OFFSET,
            params::store::Page::B => Self::B_OFFSET,
        }
    }
}

#[cfg(builder)]
impl params::store::ParamFlash for ParamPages<'_> {
    type Error = Error;

    fn erase_page(&mut self, page: params::store::Page) -> Result<(), Error> {
        self.writer.page_erase(Self::offset(page))
    }

    fn program_halfword(
        &mut self,
        page: params::store::Page,
        offset: usize,
        value: u16,
    ) -> Result<(), Error> {
        let at = Self::offset(page) + offset as u32;
        self.writer.write(at, &value.to_le_bytes())
    }

    fn read(
        &mut self,
        page: params::store::Page,
        offset: usize,
        buf: &mut [u8],
    ) -> Result<(), Error> {
        let src = self
            .writer
            .read(Self::offset(page) + offset as u32, buf.len())?;
        for (d, s) in buf.iter_mut().zip(src) {
            *d = *s;
        }
        Ok(())
    }
}
