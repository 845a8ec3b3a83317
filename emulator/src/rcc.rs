//! Reset and clock control (RM0008 §7.3): oscillator ready bits with
//! start-up times, the system clock switch, peripheral clock enables and
//! resets, and the reset flags in CSR.

/// HSE start-up time (DS5319 table 22, t_SU(HSE) typical 2 ms).
pub const HSE_STARTUP_NS: u64 = 2_000_000;
/// PLL lock time (DS5319 table 30, t_LOCK max 200 µs).
pub const PLL_LOCK_NS: u64 = 200_000;
/// LSI start-up (DS5319 table 28, t_SU(LSI) max 85 µs).
pub const LSI_STARTUP_NS: u64 = 85_000;

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

    /// SYSCLK in Hz for the current CFGR.SWS.
    pub fn sysclk_hz(&self) -> u32 {
        match (self.cfgr >> 2) & 3 {
            1 => 8_000_000,
            2 => {
                let mul = ((self.cfgr >> 18) & 0xF) + 2;
                let mul = mul.min(16);
                let src = if self.cfgr & (1 << 16) != 0 {
                    if self.cfgr & (1 << 17) != 0 {
                        4_000_000
                    } else {
                        8_000_000
                    }
                } else {
                    4_000_000
                };
                src * mul
            }
            _ => 8_000_000,
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

    /// Write at `offset`; returns `Err` text when the firmware asks for a
    /// clock tree the emulator's time base does not follow.
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
                if sws == 2 && self.sysclk_hz() != 72_000_000 {
                    return Some(Err(format!(
                        "SYSCLK set to {} Hz: the emulator's time base is 72 MHz",
                        self.sysclk_hz()
                    )));
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
