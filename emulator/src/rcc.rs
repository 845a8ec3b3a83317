//! Reset and clock control (RM0008 §7.3): oscillator ready bits with
//! start-up times, the system clock switch, peripheral clock enables and
//! resets, and the reset flags in CSR; the clock tree those registers
//! program (§7.2, figure 8: SYSCLK from HSI, HSE or the PLL, the AHB and
//! APB prescalers, the APB1 timers' ×2) and the core's time base that
//! follows HCLK ([`CoreClock`]).

/// HSE start-up time (DS5319 table 22, t_SU(HSE) typical 2 ms).
pub const HSE_STARTUP_NS: u64 = 2_000_000;
/// PLL lock time (DS5319 table 30, t_LOCK max 200 µs).
pub const PLL_LOCK_NS: u64 = 200_000;
/// LSI start-up (DS5319 table 28, t_SU(LSI) max 85 µs).
pub const LSI_STARTUP_NS: u64 = 85_000;
/// HSI (RM0008 §7.2.2; factory-trimmed, taken as exact).
pub const HSI_HZ: u32 = 8_000_000;
/// The board's crystal (the Blue Pill's 8 MHz HSE).
pub const HSE_HZ: u32 = 8_000_000;
/// Highest SYSCLK, AHB and APB2 clock (RM0008 §7.2: 72 MHz).
pub const MAX_SYSCLK_HZ: u32 = 72_000_000;
/// Highest APB1 clock (RM0008 §7.2: 36 MHz).
pub const MAX_PCLK1_HZ: u32 = 36_000_000;

/// The core's time base: core (HCLK) cycles since power-on mapped to
/// simulated ns. HCLK changes when the firmware switches SYSCLK or the AHB
/// prescaler (and at a reset, back to HSI); each change starts a new
/// segment at the cycle it happens, so SysTick and DWT CYCCNT, which count
/// core cycles (PM0056 §4.5, ARMv7-M ARM C1.8.8), and the CPU's work run
/// at the programmed clock. Cycles before the current segment map to its
/// start (only the present and future are asked).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CoreClock {
    hz: u64,
    from_cycle: u64,
    from_ns: u64,
}

impl CoreClock {
    /// A clock at `hz` from cycle 0 at 0 ns.
    pub fn new(hz: u32) -> Self {
        Self {
            hz: u64::from(hz.max(1)),
            from_cycle: 0,
            from_ns: 0,
        }
    }

    /// HCLK now (Hz).
    pub fn hz(&self) -> u32 {
        self.hz as u32
    }

    /// Simulated ns at core cycle `cycle` (rounded down).
    pub fn ns_at(&self, cycle: u64) -> u64 {
        let d = u128::from(cycle.saturating_sub(self.from_cycle));
        self.from_ns + (d * 1_000_000_000 / u128::from(self.hz)) as u64
    }

    /// The first core cycle at or after `ns` (rounded up: `ns_at` of it is
    /// not before `ns`).
    pub fn cycle_at(&self, ns: u64) -> u64 {
        self.from_cycle + self.cycles_for(ns.saturating_sub(self.from_ns))
    }

    /// Core cycles that last at least `ns` at the current HCLK.
    pub fn cycles_for(&self, ns: u64) -> u64 {
        (u128::from(ns) * u128::from(self.hz)).div_ceil(1_000_000_000) as u64
    }

    /// HCLK becomes `hz` at core cycle `cycle`.
    pub fn retune(&mut self, hz: u32, cycle: u64) {
        let hz = u64::from(hz.max(1));
        if hz != self.hz {
            self.from_ns = self.ns_at(cycle);
            self.from_cycle = cycle;
            self.hz = hz;
        }
    }
}

/// Why the MCU last came out of reset (RCC_CSR flags, RM0008 §7.3.10).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// Power-on reset.
    PowerOn,
    /// Independent watchdog.
    Watchdog,
    /// Software (AIRCR.SYSRESETREQ).
    Software,
}

/// RCC registers.
#[derive(Clone, Debug)]
pub struct Rcc {
    cr: u32,
    cfgr: u32,
    /// APB2RSTR, APB1RSTR, AHBENR, APB2ENR, APB1ENR.
    pub apb2rstr: u32,
    /// APB1RSTR.
    pub apb1rstr: u32,
    ahbenr: u32,
    /// APB2ENR (GPIO, AFIO, USART1 clocks).
    pub apb2enr: u32,
    /// APB1ENR (I2C1 clock).
    pub apb1enr: u32,
    bdcr: u32,
    csr: u32,
    hse_on_at: Option<u64>,
    pll_on_at: Option<u64>,
    lsi_on_at: Option<u64>,
    /// The HSE crystal oscillates (false: a board fault, HSERDY never sets).
    pub hse_works: bool,
}

impl Rcc {
    /// RCC after a reset of the given cause (CSR keeps the flags of
    /// earlier resets until RMVF).
    pub fn new(cause: ResetCause, previous_csr: u32) -> Self {
        let flag = match cause {
            ResetCause::PowerOn => (1 << 27) | (1 << 26),
            ResetCause::Watchdog => 1 << 29,
            ResetCause::Software => 1 << 28,
        };
        let kept = if cause == ResetCause::PowerOn {
            0
        } else {
            previous_csr & 0xFC00_0000
        };
        Self {
            cr: 0x0000_0083,
            cfgr: 0,
            apb2rstr: 0,
            apb1rstr: 0,
            ahbenr: 0x14,
            apb2enr: 0,
            apb1enr: 0,
            bdcr: 0,
            csr: kept | flag,
            hse_on_at: None,
            pll_on_at: None,
            lsi_on_at: None,
            hse_works: true,
        }
    }

    /// CSR (for the next reset's flags).
    pub fn csr(&self) -> u32 {
        self.csr
    }

    fn update(&mut self, now_ns: u64) {
        if let Some(t) = self.hse_on_at {
            if self.hse_works && now_ns >= t + HSE_STARTUP_NS {
                self.cr |= 1 << 17;
            }
        }
        if let Some(t) = self.pll_on_at {
            let src_ready = self.cfgr & (1 << 16) == 0 || self.cr & (1 << 17) != 0;
            if src_ready && now_ns >= t + PLL_LOCK_NS {
                self.cr |= 1 << 25;
            }
        }
        if let Some(t) = self.lsi_on_at {
            if now_ns >= t + LSI_STARTUP_NS {
                self.csr |= 1 << 1;
            }
        }
    }

    /// When a ready bit will next set by itself.
    pub fn next_event_ns(&self) -> Option<u64> {
        let mut next = None::<u64>;
        let mut consider = |t: u64, pending: bool| {
            if pending {
                next = Some(next.map_or(t, |n| n.min(t)));
            }
        };
        if let Some(t) = self.hse_on_at {
            consider(
                t + HSE_STARTUP_NS,
                self.hse_works && self.cr & (1 << 17) == 0,
            );
        }
        if let Some(t) = self.pll_on_at {
            consider(t + PLL_LOCK_NS, self.cr & (1 << 25) == 0);
        }
        next
    }

    /// SYSCLK in Hz for the current CFGR.SWS (RM0008 §7.2, figure 8): HSI,
    /// HSE, or the PLL from HSI/2 or HSE (÷2 with PLLXTPRE) times PLLMUL
    /// (field + 2, 0b1111 also ×16; §7.3.2).
    pub fn sysclk_hz(&self) -> u32 {
        match (self.cfgr >> 2) & 3 {
            1 => HSE_HZ,
            2 => {
                let mul = (((self.cfgr >> 18) & 0xF) + 2).min(16);
                let src = if self.cfgr & (1 << 16) == 0 {
                    HSI_HZ / 2
                } else if self.cfgr & (1 << 17) != 0 {
                    HSE_HZ / 2
                } else {
                    HSE_HZ
                };
                src * mul
            }
            _ => HSI_HZ,
        }
    }

    /// The clock tree against the manual's limits (RM0008 §7.2: SYSCLK
    /// and AHB ≤ 72 MHz, APB1 ≤ 36 MHz); the first one broken.
    pub fn out_of_spec(&self) -> Option<String> {
        if self.sysclk_hz() > MAX_SYSCLK_HZ {
            Some(format!(
                "SYSCLK {} Hz above the {MAX_SYSCLK_HZ} Hz maximum (RM0008 §7.2)",
                self.sysclk_hz()
            ))
        } else if self.pclk1_hz() > MAX_PCLK1_HZ {
            Some(format!(
                "PCLK1 {} Hz above the {MAX_PCLK1_HZ} Hz maximum of APB1 (RM0008 §7.2)",
                self.pclk1_hz()
            ))
        } else {
            None
        }
    }

    /// HCLK: SYSCLK through the AHB prescaler (CFGR.HPRE).
    pub fn hclk_hz(&self) -> u32 {
        let hpre = (self.cfgr >> 4) & 0xF;
        let shift = match hpre {
            0..=7 => 0,
            8..=11 => hpre - 7,
            _ => hpre - 6,
        };
        self.sysclk_hz() >> shift
    }

    fn apb_shift(ppre: u32) -> u32 {
        if ppre < 4 {
            0
        } else {
            ppre - 3
        }
    }

    /// The kernel clock of TIM2–TIM7: PCLK1, doubled when the APB1
    /// prescaler is not 1 (RM0008 §7.2, figure 8).
    pub fn apb1_timer_hz(&self) -> u32 {
        let shift = Self::apb_shift((self.cfgr >> 8) & 7);
        let pclk1 = self.hclk_hz() >> shift;
        if shift == 0 {
            pclk1
        } else {
            pclk1 * 2
        }
    }

    /// PCLK1: HCLK through the APB1 prescaler (PPRE1).
    pub fn pclk1_hz(&self) -> u32 {
        self.hclk_hz() >> Self::apb_shift((self.cfgr >> 8) & 7)
    }

    /// PCLK2 (USART1's clock): HCLK through CFGR.PPRE2.
    pub fn pclk2_hz(&self) -> u32 {
        self.hclk_hz() >> Self::apb_shift((self.cfgr >> 11) & 7)
    }

    /// ADCCLK: PCLK2 through CFGR.ADCPRE (÷2, ÷4, ÷6, ÷8; RM0008 §7.3.2).
    pub fn adc_hz(&self) -> u32 {
        self.pclk2_hz() / (2 * (((self.cfgr >> 14) & 3) + 1))
    }

    /// AHBENR (DMA1, SRAM, FLITF clocks).
    pub fn ahbenr(&self) -> u32 {
        self.ahbenr
    }

    /// The LSI was started by the watchdog (KR 0xCCCC forces it on).
    pub fn force_lsi(&mut self, now_ns: u64) {
        if self.lsi_on_at.is_none() {
            self.lsi_on_at = Some(now_ns);
        }
    }

    /// Read at `offset` from 0x4002_1000.
    pub fn read(&mut self, offset: u32, now_ns: u64) -> Option<u32> {
        self.update(now_ns);
        Some(match offset {
            0x00 => self.cr,
            0x04 => self.cfgr,
            0x08 => 0,
            0x0C => self.apb2rstr,
            0x10 => self.apb1rstr,
            0x14 => self.ahbenr,
            0x18 => self.apb2enr,
            0x1C => self.apb1enr,
            0x20 => self.bdcr,
            0x24 => self.csr,
            _ => return None,
        })
    }

    /// Write at `offset`; returns `Err` text when the firmware programs a
    /// clock tree outside the manual's limits ([`Rcc::out_of_spec`]).
    pub fn write(&mut self, offset: u32, v: u32, now_ns: u64) -> Option<Result<(), String>> {
        self.update(now_ns);
        match offset {
            0x00 => {
                let ro = (1 << 1) | (1 << 17) | (1 << 25);
                let old = self.cr;
                self.cr = (self.cr & ro) | (v & !ro & 0x010D_00F9);
                if v & (1 << 16) != 0 && old & (1 << 16) == 0 {
                    self.hse_on_at = Some(now_ns);
                }
                if v & (1 << 16) == 0 {
                    self.hse_on_at = None;
                    self.cr &= !(1 << 17);
                }
                if v & (1 << 24) != 0 && old & (1 << 24) == 0 {
                    self.pll_on_at = Some(now_ns);
                }
                if v & (1 << 24) == 0 {
                    self.pll_on_at = None;
                    self.cr &= !(1 << 25);
                }
            }
            0x04 => {
                // SWS follows SW when the selected source is ready.
                let sw = v & 3;
                let ready = match sw {
                    0 => true,
                    1 => self.cr & (1 << 17) != 0,
                    2 => self.cr & (1 << 25) != 0,
                    _ => false,
                };
                let sws = if ready { sw } else { (self.cfgr >> 2) & 3 };
                self.cfgr = (v & !0xC) | (sws << 2);
                if let Some(e) = self.out_of_spec() {
                    return Some(Err(e));
                }
            }
            0x08 => {}
            0x0C => self.apb2rstr = v,
            0x10 => self.apb1rstr = v,
            0x14 => self.ahbenr = v,
            0x18 => self.apb2enr = v,
            0x1C => self.apb1enr = v,
            0x20 => self.bdcr = v,
            0x24 => {
                if v & (1 << 24) != 0 {
                    self.csr &= 0x00FF_FFFF;
                }
                if v & 1 != 0 {
                    self.force_lsi(now_ns);
                }
                self.csr = (self.csr & !1) | (v & 1);
            }
            _ => return None,
        }
        Some(Ok(()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_core_clock_maps_cycles_to_time_per_segment() {
        let mut c = CoreClock::new(72_000_000);
        assert_eq!(c.ns_at(72_000_000), 1_000_000_000);
        assert_eq!(c.cycle_at(1_000), 72);
        assert_eq!(c.cycle_at(1), 1, "rounded up");
        // 64 MHz from the first second on.
        c.retune(64_000_000, 72_000_000);
        assert_eq!(c.ns_at(72_000_000 + 64_000_000), 2_000_000_000);
        assert_eq!(c.cycle_at(2_000_000_000), 136_000_000);
        assert_eq!(c.cycles_for(1_000), 64);
        for t in [1_000_000_001, 1_500_000_007, 1_999_999_999] {
            assert!(c.ns_at(c.cycle_at(t)) >= t);
            assert!(c.ns_at(c.cycle_at(t) - 1) < t);
        }
    }

    #[test]
    fn the_clock_tree_follows_cfgr() {
        let mut r = Rcc::new(ResetCause::PowerOn, 0);
        assert_eq!(r.sysclk_hz(), HSI_HZ);
        // HSI/2 × 16, APB1 ÷ 2: the firmware's fallback.
        let cfgr = (14 << 18) | (4 << 8);
        assert_eq!(r.write(0x04, cfgr, 0), Some(Ok(())));
        assert_eq!(r.write(0x00, 0x83 | (1 << 24), 0), Some(Ok(())));
        assert_eq!(r.write(0x04, cfgr | 2, PLL_LOCK_NS), Some(Ok(())));
        assert_eq!(r.sysclk_hz(), 64_000_000);
        assert_eq!(r.pclk1_hz(), 32_000_000);
        assert_eq!(r.apb1_timer_hz(), 64_000_000, "×2: APB1 prescaler ≠ 1");
        assert_eq!(r.pclk2_hz(), 64_000_000);
        // APB1 at 64 MHz breaks §7.2's 36 MHz limit.
        assert!(matches!(
            r.write(0x04, (14 << 18) | 2, PLL_LOCK_NS),
            Some(Err(_))
        ));
    }
}
