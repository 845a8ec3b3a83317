//! The independent watchdog (IWDG), programmed from its prescaler and
//! reload directly so the timeout is known at the LSI's whole 30–60 kHz
//! range (`flight::schedule::iwdg_config`), not only at the nominal
//! 40 kHz a period in milliseconds assumes.

use flight::schedule::iwdg_config;
use stm32f1xx_hal::pac;

/// KR key: enable write access to PR and RLR.
const KEY_ACCESS: u16 = 0x5555;
/// KR key: reload the counter (feed).
const KEY_RELOAD: u16 = 0xAAAA;
/// KR key: start the watchdog (it cannot be stopped afterwards).
const KEY_START: u16 = 0xCCCC;

/// The started watchdog.
pub struct Watchdog {
    iwdg: pac::IWDG,
}

impl Watchdog {
    /// Starts the watchdog with a timeout of at least `min_timeout_ms`
    /// (at most twice that, at the slowest LSI).
    pub fn start(iwdg: pac::IWDG, min_timeout_ms: u32) -> Self {
        let mut w = Self { iwdg };
        w.kr(KEY_START);
        w.set_timeout(min_timeout_ms);
        w
    }

    /// Changes the timeout (at least `min_timeout_ms` at 60 kHz) and feeds.
    pub fn set_timeout(&mut self, min_timeout_ms: u32) {
        let (pr, rlr) = iwdg_config(min_timeout_ms);
        // PR and RLR may only be written while no earlier update is in
        // flight (SR.PVU / SR.RVU clear; an update takes ≤ 5 LSI cycles,
        // 170 µs at 30 kHz). Bounded: the LSI runs once the watchdog is
        // started, so the flags clear.
        let mut n = 0u32;
        while self.iwdg.sr().read().bits() & 0b11 != 0 && n < 1_000_000 {
            n += 1;
        }
        self.kr(KEY_ACCESS);
        // SAFETY: PR takes 0..=6 and RLR 0..=0xFFF, the ranges
        // `iwdg_config` returns.
        #[allow(unsafe_code)]
        unsafe {
            self.iwdg.pr().write(|w| w.bits(u16::from(pr)));
            self.iwdg.rlr().write(|w| w.bits(rlr));
        }
        self.feed();
    }

    /// Reloads the counter.
    pub fn feed(&mut self) {
        self.kr(KEY_RELOAD);
    }

    fn kr(&mut self, key: u16) {
        // SAFETY: KR is write-only and takes one of the three documented
        // keys (RM0008 §19.4.1).
        #[allow(unsafe_code)]
        self.iwdg.kr().write(|w| unsafe { w.bits(key) });
    }
}
