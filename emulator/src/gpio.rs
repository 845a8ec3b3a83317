//! GPIO ports A–C and AFIO (RM0008 §9): CRL/CRH pin configuration,
//! IDR/ODR/BSRR/BRR/LCKR, AFIO's EXTI line selection and remap register.
//! Pin levels from outside the chip (button, MPU INT, the I2C lines) are
//! supplied by the board.

/// Configuration of one pin (CNF/MODE nibble, RM0008 §9.2.1 table 20).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PinConfig {
    /// Analog input (IDR reads 0).
    Analog,
    /// Floating input.
    Floating,
    /// Input with pull-up (`true`) or pull-down (`false`), chosen by ODR.
    Pull(bool),
    /// General-purpose output.
    Output {
        /// Open drain (else push-pull).
        open_drain: bool,
    },
    /// Alternate-function output (the peripheral drives the pin).
    Alternate {
        /// Open drain (else push-pull).
        open_drain: bool,
    },
}

/// One GPIO port.
#[derive(Clone, Debug)]
pub struct Port {
    crl: u32,
    crh: u32,
    /// Output data register.
    pub odr: u32,
    lckr: u32,
}

impl Default for Port {
    fn default() -> Self {
        // Reset: every pin floating input (CNF = 01, MODE = 00).
        Self {
            crl: 0x4444_4444,
            crh: 0x4444_4444,
            odr: 0,
            lckr: 0,
        }
    }
}

impl Port {
    /// Configuration of pin `n` (0..16).
    pub fn config(&self, n: u32) -> PinConfig {
        let reg = if n < 8 { self.crl } else { self.crh };
        let nib = (reg >> ((n % 8) * 4)) & 0xF;
        let (cnf, mode) = (nib >> 2, nib & 3);
        match (mode, cnf) {
            (0, 0) => PinConfig::Analog,
            (0, 1) | (0, 3) => PinConfig::Floating,
            (0, _) => PinConfig::Pull(self.odr & (1 << n) != 0),
            (_, 0) => PinConfig::Output { open_drain: false },
            (_, 1) => PinConfig::Output { open_drain: true },
            (_, 2) => PinConfig::Alternate { open_drain: false },
            _ => PinConfig::Alternate { open_drain: true },
        }
    }

    /// Level of pin `n` given what the outside drives (`None`: nothing).
    pub fn level(&self, n: u32, external: Option<bool>) -> bool {
        let out = self.odr & (1 << n) != 0;
        match self.config(n) {
            PinConfig::Analog => false,
            PinConfig::Floating => external.unwrap_or(false),
            PinConfig::Pull(up) => external.unwrap_or(up),
            PinConfig::Output { open_drain: false } => out,
            PinConfig::Output { open_drain: true } => out && external.unwrap_or(true),
            PinConfig::Alternate { .. } => external.unwrap_or(true),
        }
    }

    /// Register read at `offset` (IDR computed by the caller from `level`).
    pub fn read(&self, offset: u32, idr: impl Fn() -> u32) -> Option<u32> {
        Some(match offset {
            0x00 => self.crl,
            0x04 => self.crh,
            0x08 => idr(),
            0x0C => self.odr,
            0x10 | 0x14 => 0,
            0x18 => self.lckr,
            _ => return None,
        })
    }

    /// Register write at `offset` with byte-lane `mask`.
    pub fn write(&mut self, offset: u32, v: u32, mask: u32) -> bool {
        let merge = |old: u32| (old & !mask) | (v & mask);
        let v = v & mask;
        let locked = if self.lckr & (1 << 16) != 0 {
            self.lckr & 0xFFFF
        } else {
            0
        };
        let lock_nibbles = |old: u32, new: u32, half: u32| {
            (0..8).fold(new, |acc, i| {
                if locked & (1 << (i + half)) != 0 {
                    let m = 0xF << (i * 4);
                    (acc & !m) | (old & m)
                } else {
                    acc
                }
            })
        };
        match offset {
            0x00 => self.crl = lock_nibbles(self.crl, merge(self.crl), 0),
            0x04 => self.crh = lock_nibbles(self.crh, merge(self.crh), 8),
            0x08 => {}
            0x0C => self.odr = merge(self.odr) & 0xFFFF,
            0x10 => self.odr = (self.odr & !(v >> 16)) | (v & 0xFFFF),
            0x14 => self.odr &= !(v & 0xFFFF),
            // LCKR: the key sequence is not modelled; the value is kept.
            0x18 => self.lckr = v & 0x1_FFFF,
            _ => return false,
        }
        true
    }
}

/// AFIO: event control, remap, EXTI source selection (RM0008 §9.4).
#[derive(Clone, Debug, Default)]
pub struct Afio {
    evcr: u32,
    /// MAPR (bit 1: I2C1 remapped to PB8/PB9).
    pub mapr: u32,
    exticr: [u32; 4],
}

impl Afio {
    /// Port (0 = A, 1 = B, …) selected for EXTI line `line`.
    pub fn exti_port(&self, line: u32) -> u32 {
        (self.exticr[(line / 4) as usize % 4] >> ((line % 4) * 4)) & 0xF
    }

    /// Read at `offset` from 0x4001_0000.
    pub fn read(&self, offset: u32) -> Option<u32> {
        Some(match offset {
            0x00 => self.evcr,
            0x04 => self.mapr & 0x001F_FFFF,
            0x08..=0x14 => self.exticr[((offset - 8) / 4) as usize],
            0x1C => 0,
            _ => return None,
        })
    }

    /// Write at `offset` with byte-lane `mask`.
    pub fn write(&mut self, offset: u32, v: u32, mask: u32) -> bool {
        let merge = |old: u32| (old & !mask) | (v & mask);
        match offset {
            0x00 => self.evcr = merge(self.evcr) & 0xFF,
            0x04 => self.mapr = merge(self.mapr),
            0x08..=0x14 => {
                let i = ((offset - 8) / 4) as usize;
                self.exticr[i] = merge(self.exticr[i]) & 0xFFFF;
            }
            0x1C => {}
            _ => return false,
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bsrr_set_wins_over_reset_and_brr_clears() {
        let mut p = Port::default();
        p.write(0x10, (1 << 13) | (1 << (13 + 16)), !0);
        assert_eq!(p.odr, 1 << 13);
        p.write(0x14, 1 << 13, !0);
        assert_eq!(p.odr, 0);
    }

    #[test]
    fn pull_up_input_reads_high_until_driven_low() {
        let mut p = Port::default();
        p.write(0x00, 0x8, 0xF);
        p.write(0x0C, 1, !0);
        assert_eq!(p.config(0), PinConfig::Pull(true));
        assert!(p.level(0, None));
        assert!(!p.level(0, Some(false)));
    }
}
