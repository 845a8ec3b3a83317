//! Embedded flash and its program/erase controller (RM0008 §3.3.3; the
//! STM32F10xxx flash programming manual PM0075 §2.3–2.4, §3): ACR, the
//! KEYR unlock sequence, page erase, half-word programming, BSY/EOP/PGERR/
//! WRPRTERR and LOCK. The contents persist across MCU resets (the board
//! keeps this struct's `image`).

use crate::elf::FLASH_BASE;

/// Page size of medium-density devices (1 KiB).
pub const PAGE_SIZE: u32 = 1024;
/// Page erase time (DS5319 table 24, t_ERASE 20–40 ms): the CPU stalls.
pub const PAGE_ERASE_NS: u64 = 20_000_000;
/// Half-word program time (DS5319 table 24, t_prog 40–70 µs, 52.5 typical).
pub const PROGRAM_NS: u64 = 52_500;

const KEY1: u32 = 0x4567_0123;
const KEY2: u32 = 0xCDEF_89AB;
const SR_PGERR: u32 = 1 << 2;
const SR_WRPRTERR: u32 = 1 << 4;
const SR_EOP: u32 = 1 << 5;
const CR_PG: u32 = 1 << 0;
const CR_PER: u32 = 1 << 1;
const CR_MER: u32 = 1 << 2;
const CR_STRT: u32 = 1 << 6;
const CR_LOCK: u32 = 1 << 7;

/// What a flash access did, for the board to act on.
#[derive(Debug, PartialEq, Eq)]
pub enum FlashEffect {
    /// Nothing beyond the register change.
    None,
    /// The CPU stalls for this long (erase/program in progress); `changed`
    /// is the byte range whose contents changed.
    Stall {
        /// Stall time.
        ns: u64,
        /// Changed range (offsets into the image).
        changed: std::ops::Range<usize>,
    },
    /// A bus error (PM0075: wrong key sequence, a write that is not a
    /// half-word, or a write with PG clear): the access faults.
    BusError(&'static str),
}

/// Flash memory and its interface registers.
#[derive(Clone, Debug)]
pub struct Flash {
    /// Contents, offset 0 = 0x0800_0000.
    pub image: Vec<u8>,
    acr: u32,
    cr: u32,
    sr: u32,
    ar: u32,
    key_stage: u8,
    /// Locked by a wrong key until the next reset.
    locked_out: bool,
}

impl Flash {
    /// FLASH_ACR.LATENCY: the wait states of a flash read (RM0008 §3.3.3;
    /// values above 2 are reserved and read as given).
    pub fn wait_states(&self) -> u32 {
        self.acr & 7
    }

    /// Flash with `image` after a reset (locked, ACR at reset value).
    pub fn new(image: Vec<u8>) -> Self {
        Self {
            image,
            acr: 0x30,
            cr: CR_LOCK,
            sr: 0,
            ar: 0,
            key_stage: 0,
            locked_out: false,
        }
    }

    /// The same memory after an MCU reset (registers back to reset values).
    pub fn after_reset(self) -> Self {
        Self::new(self.image)
    }

    /// The chip's flash size in bytes (the image's length: 64 KiB on the
    /// C8, 128 KiB on the CB).
    pub fn size(&self) -> u32 {
        self.image.len() as u32
    }

    /// Memory read of `size` bytes at `offset` from FLASH_BASE.
    pub fn read_memory(&self, offset: u32, size: usize) -> u32 {
        (0..size).fold(0, |v, i| {
            let b = self.image.get(offset as usize + i).copied().unwrap_or(0xFF);
            v | (u32::from(b) << (8 * i))
        })
    }

    /// Memory write (a programming access) of `size` bytes at `offset`.
    pub fn write_memory(&mut self, offset: u32, size: usize, value: u32) -> FlashEffect {
        if self.cr & CR_PG == 0 {
            return FlashEffect::BusError("flash write with FLASH_CR.PG clear");
        }
        if size != 2 {
            return FlashEffect::BusError("flash programming access is not a half-word");
        }
        let at = (offset & !1) as usize;
        let Some(slot) = self.image.get_mut(at..at + 2) else {
            return FlashEffect::BusError("flash write outside the 64 KiB array");
        };
        let old = u16::from_le_bytes([slot[0], slot[1]]);
        let new = value as u16;
        // PM0075 §2.3.3: a location not erased is not programmed (PGERR),
        // except when 0x0000 is written.
        if old != 0xFFFF && new != 0 {
            self.sr |= SR_PGERR;
            return FlashEffect::None;
        }
        slot.copy_from_slice(&new.to_le_bytes());
        self.sr |= SR_EOP;
        FlashEffect::Stall {
            ns: PROGRAM_NS,
            changed: at..at + 2,
        }
    }

    /// Register read at `offset` from 0x4002_2000.
    pub fn read(&self, offset: u32) -> Option<u32> {
        Some(match offset {
            0x00 => (self.acr & !0x20) | ((self.acr & 0x10) << 1), // PRFTBS mirrors PRFTBE
            0x04 | 0x08 | 0x14 => 0,
            0x0C => self.sr,
            0x10 => self.cr,
            0x1C => 0x03FF_FFFC, // OBR: no read protection, option bytes erased
            0x20 => 0xFFFF_FFFF, // WRPR: no page write-protected
            _ => return None,
        })
    }

    /// Register write at `offset`.
    pub fn write(&mut self, offset: u32, v: u32) -> Option<FlashEffect> {
        Some(match offset {
            0x00 => {
                self.acr = v & 0x1F;
                FlashEffect::None
            }
            0x04 => self.key(v),
            0x08 => FlashEffect::None, // OPTKEYR: option bytes not modelled beyond reads
            0x0C => {
                self.sr &= !(v & (SR_PGERR | SR_WRPRTERR | SR_EOP));
                FlashEffect::None
            }
            0x10 => self.control(v),
            0x14 => {
                if self.cr & CR_LOCK == 0 {
                    self.ar = v;
                }
                FlashEffect::None
            }
            _ => return None,
        })
    }

    fn key(&mut self, v: u32) -> FlashEffect {
        if self.locked_out {
            return FlashEffect::BusError(
                "FLASH_KEYR written after a wrong key (locked until reset)",
            );
        }
        match (self.key_stage, v) {
            (0, KEY1) => {
                self.key_stage = 1;
                FlashEffect::None
            }
            (1, KEY2) => {
                self.key_stage = 0;
                self.cr &= !CR_LOCK;
                FlashEffect::None
            }
            _ => {
                // PM0075 §2.3.1: a wrong sequence locks the FPEC until the
                // next reset and answers with a bus error.
                self.locked_out = true;
                self.cr |= CR_LOCK;
                FlashEffect::BusError("wrong FLASH_KEYR sequence")
            }
        }
    }

    fn control(&mut self, v: u32) -> FlashEffect {
        if self.cr & CR_LOCK != 0 {
            return FlashEffect::None; // CR is write-protected while locked
        }
        self.cr = v & 0x1677;
        if v & CR_LOCK != 0 {
            self.cr |= CR_LOCK;
        }
        if v & CR_STRT == 0 {
            return FlashEffect::None;
        }
        self.cr &= !CR_STRT;
        if v & CR_MER != 0 {
            self.image.fill(0xFF);
            self.sr |= SR_EOP;
            return FlashEffect::Stall {
                ns: PAGE_ERASE_NS,
                changed: 0..self.image.len(),
            };
        }
        if v & CR_PER != 0 {
            let off = self.ar.wrapping_sub(FLASH_BASE) & !(PAGE_SIZE - 1);
            if off >= self.size() {
                return FlashEffect::BusError("page erase address outside flash");
            }
            let r = off as usize..(off + PAGE_SIZE) as usize;
            self.image[r.clone()].fill(0xFF);
            self.sr |= SR_EOP;
            return FlashEffect::Stall {
                ns: PAGE_ERASE_NS,
                changed: r,
            };
        }
        FlashEffect::None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elf::FLASH_SIZE;

    fn unlocked() -> Flash {
        let mut f = Flash::new(vec![0xFF; FLASH_SIZE as usize]);
        f.write(0x04, KEY1);
        f.write(0x04, KEY2);
        f
    }

    #[test]
    fn unlock_needs_both_keys_in_order_and_a_wrong_key_locks_until_reset() {
        let mut f = unlocked();
        assert_eq!(f.read(0x10).map(|cr| cr & CR_LOCK), Some(0));
        let mut g = Flash::new(vec![0xFF; 16]);
        assert!(matches!(
            g.write(0x04, KEY2),
            Some(FlashEffect::BusError(_))
        ));
        g.write(0x04, KEY1);
        assert!(matches!(
            g.write(0x04, KEY2),
            Some(FlashEffect::BusError(_))
        ));
        assert_eq!(g.read(0x10).map(|cr| cr & CR_LOCK), Some(CR_LOCK));
        f.write(0x10, CR_LOCK);
        assert_eq!(f.read(0x10).map(|cr| cr & CR_LOCK), Some(CR_LOCK));
    }

    #[test]
    fn program_only_erased_half_words_and_erase_pages() {
        let mut f = unlocked();
        assert!(matches!(
            f.write_memory(0xFC00, 2, 0x1234),
            FlashEffect::BusError(_)
        ));
        f.write(0x10, CR_PG);
        assert!(matches!(
            f.write_memory(0xFC00, 4, 0x1234),
            FlashEffect::BusError(_)
        ));
        assert!(matches!(
            f.write_memory(0xFC00, 2, 0x1234),
            FlashEffect::Stall { .. }
        ));
        assert_eq!(f.read_memory(0xFC00, 2), 0x1234);
        assert_eq!(f.write_memory(0xFC00, 2, 0x5678), FlashEffect::None);
        assert_eq!(f.read(0x0C).map(|sr| sr & SR_PGERR), Some(SR_PGERR));
        assert_eq!(f.read_memory(0xFC00, 2), 0x1234);
        f.write(0x10, CR_PER);
        f.write(0x14, 0x0800_FC10);
        f.write(0x10, CR_PER | CR_STRT);
        assert_eq!(f.read_memory(0xFC00, 4), 0xFFFF_FFFF);
        assert_eq!(f.read(0x0C).map(|sr| sr & SR_EOP), Some(SR_EOP));
    }
}
