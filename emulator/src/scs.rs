//! The Cortex-M3 system control space the firmware touches: NVIC, SCB,
//! SysTick, DWT's cycle counter and DCB.DEMCR (ARMv7-M ARM B3; PM0056, the
//! STM32F10xxx Cortex-M3 programming manual, §4). Registers only: taking
//! and returning from exceptions is in `exceptions`.

/// Number of exception numbers modelled: 16 system + 68 IRQ lines of the
/// connectivity-line vector table (the C8 uses 0..=59).
pub const EXCEPTIONS: usize = 16 + 68;
/// First external interrupt's exception number.
pub const IRQ0: usize = 16;
/// HardFault's exception number.
pub const HARDFAULT: usize = 3;
/// PendSV's exception number.
pub const PENDSV: usize = 14;
/// SysTick's exception number.
pub const SYSTICK: usize = 15;
/// Priority bits implemented by the STM32F1 (PM0056 §4.3.7: bits 7:4).
const PRIO_MASK: u8 = 0xF0;

/// Exception state: enables, pendings, priorities, the active stack, and
/// the SCB registers that configure them.
#[derive(Clone, Debug)]
pub struct Nvic {
    /// Enabled (IRQs via ISER/ICER; system handlers are always enabled).
    pub enabled: [bool; EXCEPTIONS],
    /// Pending.
    pub pending: [bool; EXCEPTIONS],
    /// Active exceptions, outermost first.
    pub active: Vec<usize>,
    /// Priority byte per exception (IPR for IRQs, SHPR for system handlers).
    pub priority: [u8; EXCEPTIONS],
    /// AIRCR.PRIGROUP.
    pub prigroup: u8,
    /// SCB.VTOR.
    pub vtor: u32,
    /// SCB.CCR (reset: STKALIGN set, PM0056 §4.4.8).
    pub ccr: u32,
    /// SCB.SCR.
    pub scr: u32,
    /// SCB.SHCSR.
    pub shcsr: u32,
    /// SCB.CFSR and HFSR (written by the harness on a fault).
    pub cfsr: u32,
    /// SCB.HFSR.
    pub hfsr: u32,
    /// Set when a write asks for a system reset (AIRCR.SYSRESETREQ).
    pub reset_requested: bool,
}

impl Default for Nvic {
    fn default() -> Self {
        let mut enabled = [false; EXCEPTIONS];
        enabled[..IRQ0].fill(true);
        Self {
            enabled,
            pending: [false; EXCEPTIONS],
            active: Vec::new(),
            priority: [0; EXCEPTIONS],
            prigroup: 0,
            vtor: 0,
            ccr: 0x200,
            scr: 0,
            shcsr: 0,
            cfsr: 0,
            hfsr: 0,
            reset_requested: false,
        }
    }
}

impl Nvic {
    /// Priority of exception `n` (Reset −3, NMI −2, HardFault −1 are fixed).
    pub fn priority_of(&self, n: usize) -> i16 {
        match n {
            1 => -3,
            2 => -2,
            3 => -1,
            _ => i16::from(self.priority.get(n).copied().unwrap_or(0)),
        }
    }

    /// Group (pre-emption) priority of a configurable priority byte
    /// (AIRCR.PRIGROUP splits group and sub-priority, PM0056 §4.4.5).
    pub fn group(&self, prio: i16) -> i16 {
        if prio < 0 {
            return prio;
        }
        let sub_bits = u32::from(self.prigroup) + 1;
        let mask = (0xFFu32 << sub_bits) as u8;
        i16::from(prio as u8 & mask)
    }

    /// Execution priority: the highest-priority active exception, lowered
    /// further by BASEPRI, PRIMASK and FAULTMASK. 256 = thread mode, no boost.
    pub fn execution_priority(&self, basepri: u8, primask: bool, faultmask: bool) -> i16 {
        let mut p: i16 = 256;
        for &n in &self.active {
            p = p.min(self.group(self.priority_of(n)));
        }
        if basepri & PRIO_MASK != 0 {
            p = p.min(self.group(i16::from(basepri & PRIO_MASK)));
        }
        if primask {
            p = p.min(0);
        }
        if faultmask {
            p = p.min(-1);
        }
        p
    }

    /// The pending, enabled exception that would be taken next, with its
    /// priority: lowest group priority first, then lowest sub-priority,
    /// then lowest number.
    pub fn highest_pending(&self) -> Option<(usize, i16)> {
        let mut best: Option<(usize, i16)> = None;
        for n in 1..EXCEPTIONS {
            if !(self.pending[n] && self.enabled[n]) || self.active.contains(&n) {
                continue;
            }
            let p = self.priority_of(n);
            if best.is_none_or(|(_, bp)| p < bp) {
                best = Some((n, p));
            }
        }
        best
    }

    /// The exception to take now at this execution priority, if any.
    pub fn deliverable(&self, exec_prio: i16) -> Option<usize> {
        self.highest_pending()
            .filter(|&(_, p)| self.group(p) < exec_prio)
            .map(|(n, _)| n)
    }

    /// ICSR as read (PM0056 §4.4.3).
    fn icsr(&self) -> u32 {
        let mut v = 0;
        if let Some(&n) = self.active.last() {
            v |= n as u32 & 0x1FF;
        }
        if self.active.len() <= 1 {
            v |= 1 << 11; // RETTOBASE
        }
        if let Some((n, _)) = self.highest_pending() {
            v |= (n as u32 & 0x3FF) << 12;
        }
        if self.pending[IRQ0..].iter().any(|&p| p) {
            v |= 1 << 22;
        }
        if self.pending[SYSTICK] {
            v |= 1 << 26;
        }
        if self.pending[PENDSV] {
            v |= 1 << 28;
        }
        v
    }

    fn icsr_write(&mut self, v: u32) {
        if v & (1 << 31) != 0 {
            self.pending[2] = true;
        }
        if v & (1 << 28) != 0 {
            self.pending[PENDSV] = true;
        }
        if v & (1 << 27) != 0 {
            self.pending[PENDSV] = false;
        }
        if v & (1 << 26) != 0 {
            self.pending[SYSTICK] = true;
        }
        if v & (1 << 25) != 0 {
            self.pending[SYSTICK] = false;
        }
    }

    fn bits32(flags: &[bool]) -> u32 {
        flags
            .iter()
            .take(32)
            .enumerate()
            .fold(0, |v, (i, &b)| v | (u32::from(b) << i))
    }

    /// Word read of NVIC/SCB at `offset` from 0xE000_E000; `None` if not modelled.
    pub fn read(&self, offset: u32) -> Option<u32> {
        let irq_word = |base: u32| ((offset - base) / 4) as usize * 32 + IRQ0;
        Some(match offset {
            0x004 => 1, // ICTR: 64 lines
            0x100..=0x108 => Self::bits32(&self.enabled[irq_word(0x100)..]),
            0x180..=0x188 => Self::bits32(&self.enabled[irq_word(0x180)..]),
            0x200..=0x208 => Self::bits32(&self.pending[irq_word(0x200)..]),
            0x280..=0x288 => Self::bits32(&self.pending[irq_word(0x280)..]),
            0x300..=0x308 => {
                let base = irq_word(0x300);
                (0..32).fold(0, |v, i| {
                    v | (u32::from(self.active.contains(&(base + i))) << i)
                })
            }
            0x400..=0x440 => {
                let n = (offset - 0x400) as usize + IRQ0;
                u32::from_le_bytes(std::array::from_fn(|i| {
                    self.priority.get(n + i).copied().unwrap_or(0)
                }))
            }
            0xD00 => 0x411F_C231, // CPUID: Cortex-M3 r1p1
            0xD04 => self.icsr(),
            0xD08 => self.vtor,
            0xD0C => 0xFA05_0000 | (u32::from(self.prigroup) << 8),
            0xD10 => self.scr,
            0xD14 => self.ccr,
            0xD18..=0xD20 => {
                let n = (offset - 0xD18) as usize + 4;
                u32::from_le_bytes(std::array::from_fn(|i| self.priority[n + i]))
            }
            0xD24 => self.shcsr,
            0xD28 => self.cfsr,
            0xD2C => self.hfsr,
            _ => return None,
        })
    }

    /// Write of NVIC/SCB at `offset` (word-aligned) with byte-lane `mask`;
    /// returns false if the register is not modelled.
    pub fn write(&mut self, offset: u32, value: u32, mask: u32) -> bool {
        let irq_base = |base: u32| ((offset - base) / 4) as usize * 32 + IRQ0;
        let v = value & mask;
        let set_bits = |flags: &mut [bool; EXCEPTIONS], base: usize, to: bool| {
            for i in 0..32 {
                if v & (1 << i) != 0 {
                    if let Some(f) = flags.get_mut(base + i) {
                        *f = to;
                    }
                }
            }
        };
        match offset {
            0x100..=0x108 => set_bits(&mut self.enabled, irq_base(0x100), true),
            0x180..=0x188 => set_bits(&mut self.enabled, irq_base(0x180), false),
            0x200..=0x208 => set_bits(&mut self.pending, irq_base(0x200), true),
            0x280..=0x288 => set_bits(&mut self.pending, irq_base(0x280), false),
            0x400..=0x440 | 0xD18..=0xD20 => {
                let n = if offset >= 0xD18 {
                    (offset - 0xD18) as usize + 4
                } else {
                    (offset - 0x400) as usize + IRQ0
                };
                for i in 0..4 {
                    if mask & (0xFF << (8 * i)) != 0 {
                        if let Some(p) = self.priority.get_mut(n + i) {
                            *p = (value >> (8 * i)) as u8 & PRIO_MASK;
                        }
                    }
                }
            }
            0xD04 => self.icsr_write(v),
            0xD08 => self.vtor = v & 0x3FFF_FF80,
            0xD0C => {
                // Writes without VECTKEY are ignored (PM0056 §4.4.5).
                if v >> 16 == 0x05FA {
                    self.prigroup = ((v >> 8) & 7) as u8;
                    if v & (1 << 2) != 0 {
                        self.reset_requested = true;
                    }
                }
            }
            0xD10 => self.scr = v & 0x16,
            0xD14 => self.ccr = v & 0x31B,
            0xD24 => self.shcsr = v,
            0xD28 => self.cfsr &= !v,
            0xD2C => self.hfsr &= !v,
            0xF00 => {
                // STIR: pends IRQ n.
                if let Some(p) = self.pending.get_mut((v & 0x1FF) as usize + IRQ0) {
                    *p = true;
                }
            }
            _ => return false,
        }
        true
    }
}

/// SysTick (PM0056 §4.5): a 24-bit down-counter on HCLK or HCLK/8.
#[derive(Clone, Debug, Default)]
pub struct SysTick {
    ctrl: u32,
    load: u32,
    /// Cycle at which the counter was 0 (after a VAL write or enable).
    origin: u64,
    /// Wraps already reported (count of reloads since `origin`).
    reported: u64,
}

impl SysTick {
    fn div(&self) -> u64 {
        if self.ctrl & 4 != 0 {
            1
        } else {
            8
        }
    }
    fn enabled(&self) -> bool {
        self.ctrl & 1 != 0
    }
    fn ticks(&self, cycles: u64) -> u64 {
        cycles.saturating_sub(self.origin) / self.div()
    }
    /// Counter reaches 0 events (exclusive of the origin) up to `cycles`.
    fn wraps(&self, cycles: u64) -> u64 {
        let period = u64::from(self.load) + 1;
        if !self.enabled() || self.load == 0 {
            return 0;
        }
        self.ticks(cycles) / period
    }

    /// Brings the counter to `cycles`; true if it reached zero since the
    /// last call with TICKINT set (the exception is to be pended).
    pub fn advance(&mut self, cycles: u64) -> bool {
        let w = self.wraps(cycles);
        if w > self.reported {
            self.reported = w;
            self.ctrl |= 1 << 16;
            return self.ctrl & 2 != 0;
        }
        false
    }

    /// Cycle of the next zero crossing, if counting.
    pub fn next_event(&self) -> Option<u64> {
        if !self.enabled() || self.load == 0 {
            return None;
        }
        let period = u64::from(self.load) + 1;
        Some(self.origin + (self.reported + 1) * period * self.div())
    }

    /// Word read at `offset` from 0xE000_E010.
    pub fn read(&mut self, offset: u32, cycles: u64) -> Option<u32> {
        self.advance(cycles);
        Some(match offset {
            0x0 => {
                let v = self.ctrl;
                self.ctrl &= !(1 << 16); // COUNTFLAG clears on read
                v
            }
            0x4 => self.load,
            0x8 => {
                let t = self.ticks(cycles);
                if !self.enabled() || t == 0 {
                    0
                } else {
                    let period = u64::from(self.load) + 1;
                    (u64::from(self.load) - (t - 1) % period) as u32
                }
            }
            0xC => 0x0000_2328, // CALIB: 9000 at HCLK/8 = 1 ms (STM32F1)
            _ => return None,
        })
    }

    /// Word write.
    pub fn write(&mut self, offset: u32, value: u32, cycles: u64) -> bool {
        self.advance(cycles);
        match offset {
            0x0 => {
                let was = self.enabled();
                self.ctrl = (self.ctrl & (1 << 16)) | (value & 7);
                if !was && self.enabled() {
                    self.origin = cycles;
                    self.reported = 0;
                }
            }
            0x4 => self.load = value & 0x00FF_FFFF,
            0x8 => {
                self.origin = cycles;
                self.reported = 0;
                self.ctrl &= !(1 << 16);
            }
            _ => return false,
        }
        true
    }
}

/// DWT cycle counter and DCB.DEMCR.TRCENA (ARMv7-M ARM C1.8, C1.6.5).
///
/// CYCCNT counts the board's core cycles (`Hw::cycles`), the cycle model
/// of `crate::cycles`: instruction costs from the Cortex-M3 TRM, taken
/// branch refills, flash wait states, exception entry and return, APB
/// bridge cycles.
#[derive(Clone, Debug, Default)]
pub struct Dwt {
    ctrl: u32,
    /// CYCCNT value at `base_cycle`.
    value: u32,
    base_cycle: u64,
    demcr: u32,
}

impl Dwt {
    fn counting(&self) -> bool {
        self.ctrl & 1 != 0 && self.demcr & (1 << 24) != 0
    }
    fn cyccnt(&self, cycles: u64) -> u32 {
        if self.counting() {
            self.value
                .wrapping_add(cycles.wrapping_sub(self.base_cycle) as u32)
        } else {
            self.value
        }
    }
    fn rebase(&mut self, cycles: u64) {
        self.value = self.cyccnt(cycles);
        self.base_cycle = cycles;
    }

    /// Read of DWT at `offset` from 0xE000_1000.
    pub fn read(&self, offset: u32, cycles: u64) -> Option<u32> {
        Some(match offset {
            0x000 => self.ctrl | (4 << 28), // NUMCOMP = 4
            0x004 => self.cyccnt(cycles),
            0xFB4 => 0, // LSR: no lock on the M3
            _ => return None,
        })
    }

    /// Write of DWT at `offset`.
    pub fn write(&mut self, offset: u32, value: u32, cycles: u64) -> bool {
        match offset {
            0x000 => {
                self.rebase(cycles);
                self.ctrl = value & 0x0FFF_FFFF;
            }
            0x004 => {
                self.value = value;
                self.base_cycle = cycles;
            }
            0xFB0 => {} // LAR: ignored on the M3
            _ => return false,
        }
        true
    }

    /// DCB.DEMCR read.
    pub fn demcr(&self) -> u32 {
        self.demcr
    }

    /// DCB.DEMCR write.
    pub fn set_demcr(&mut self, value: u32, cycles: u64) {
        self.rebase(cycles);
        self.demcr = value & 0x010F_07F1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn systick_counts_down_and_wraps_at_load_plus_one() {
        let mut st = SysTick::default();
        st.write(0x4, 71_999, 0);
        st.write(0x8, 0, 0);
        st.write(0x0, 0b111, 100);
        assert_eq!(st.read(0x8, 100), Some(0));
        assert_eq!(st.read(0x8, 101), Some(71_999));
        assert_eq!(st.next_event(), Some(100 + 72_000));
        assert!(!st.advance(100 + 71_999));
        assert!(st.advance(100 + 72_000));
        assert_eq!(st.read(0x0, 100 + 72_000).map(|v| v >> 16 & 1), Some(1));
        assert_eq!(st.read(0x0, 100 + 72_000).map(|v| v >> 16 & 1), Some(0));
    }

    #[test]
    fn basepri_masks_equal_and_lower_priorities_only() {
        let mut n = Nvic::default();
        n.priority[IRQ0 + 23] = 0x10;
        n.priority[IRQ0 + 37] = 0x30;
        n.enabled[IRQ0 + 23] = true;
        n.enabled[IRQ0 + 37] = true;
        n.pending[IRQ0 + 37] = true;
        n.pending[IRQ0 + 23] = true;
        assert_eq!(
            n.deliverable(n.execution_priority(0x20, false, false)),
            Some(IRQ0 + 23)
        );
        assert_eq!(
            n.deliverable(n.execution_priority(0x10, false, false)),
            None
        );
        assert_eq!(n.deliverable(n.execution_priority(0, true, false)), None);
        n.pending[IRQ0 + 23] = false;
        assert_eq!(
            n.deliverable(n.execution_priority(0x30, false, false)),
            None
        );
        assert_eq!(n.deliverable(256), Some(IRQ0 + 37));
    }

    #[test]
    fn cyccnt_runs_only_with_trcena_and_cyccntena() {
        let mut d = Dwt::default();
        d.write(0x0, 1, 0);
        assert_eq!(d.read(0x4, 1000), Some(0));
        d.set_demcr(1 << 24, 1000);
        assert_eq!(d.read(0x4, 1500), Some(500));
    }
}
