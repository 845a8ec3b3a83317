//! External interrupt controller (RM0008 §10.3): edge detection on the
//! lines selected by AFIO, pending register (write 1 to clear), software
//! interrupts, and the NVIC lines the pending bits drive.

/// EXTI registers and the last sampled level of each GPIO line.
#[derive(Clone, Debug, Default)]
pub struct Exti {
    imr: u32,
    emr: u32,
    rtsr: u32,
    ftsr: u32,
    /// Pending register.
    pub pr: u32,
    levels: u32,
}

/// NVIC IRQ number for EXTI line `line` (RM0008 §10.1.2 table 63).
pub fn irq_of_line(line: u32) -> Option<usize> {
    Some(match line {
        0..=4 => 6 + line as usize,
        5..=9 => 23,
        10..=15 => 40,
        16 => 1,  // PVD
        17 => 41, // RTC alarm
        18 => 42, // USB wakeup
        _ => return None,
    })
}

impl Exti {
    /// New level of GPIO line `line` (0..16); latches a pending bit on a
    /// selected edge.
    pub fn input(&mut self, line: u32, high: bool) {
        let bit = 1 << line;
        let was = self.levels & bit != 0;
        if high && !was && self.rtsr & bit != 0 || !high && was && self.ftsr & bit != 0 {
            self.pr |= bit;
        }
        if high {
            self.levels |= bit;
        } else {
            self.levels &= !bit;
        }
    }

    /// Whether the NVIC line `irq` is asserted (a pending, unmasked line).
    pub fn irq_asserted(&self, irq: usize) -> bool {
        (0..19).any(|l| self.pr & self.imr & (1 << l) != 0 && irq_of_line(l) == Some(irq))
    }

    /// Read at `offset` from 0x4001_0400.
    pub fn read(&self, offset: u32) -> Option<u32> {
        Some(match offset {
            0x00 => self.imr,
            0x04 => self.emr,
            0x08 => self.rtsr,
            0x0C => self.ftsr,
            0x10 => 0,
            0x14 => self.pr,
            _ => return None,
        })
    }

    /// Write at `offset` with byte-lane `mask`.
    pub fn write(&mut self, offset: u32, v: u32, mask: u32) -> bool {
        let merge = |old: u32| ((old & !mask) | (v & mask)) & 0x7_FFFF;
        match offset {
            0x00 => self.imr = merge(self.imr),
            0x04 => self.emr = merge(self.emr),
            0x08 => self.rtsr = merge(self.rtsr),
            0x0C => self.ftsr = merge(self.ftsr),
            0x10 => self.pr |= v & mask & self.imr & 0x7_FFFF,
            0x14 => self.pr &= !(v & mask),
            _ => return false,
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rising_edge_pends_until_written_one() {
        let mut e = Exti::default();
        e.write(0x08, 1 << 5, !0);
        e.write(0x00, 1 << 5, !0);
        e.input(5, false);
        e.input(5, true);
        assert!(e.irq_asserted(23));
        e.input(5, true);
        e.write(0x14, 1 << 5, !0);
        assert!(!e.irq_asserted(23));
        e.input(5, false);
        assert!(!e.irq_asserted(23));
    }
}
