//! The independent watchdog (IWDG), programmed from its prescaler and
//! reload directly so the timeout is known at the LSI's whole 30–60 kHz
//! range (`sensor_stack::schedule::iwdg_config`), not only at the nominal
//! 40 kHz a period in milliseconds assumes.
//!
//! Budgets, at the LSI's fastest 60 kHz (the shortest timeout; at 30 kHz
//! each is twice as long). Every wait in them is measured on the DWT cycle
//! counter (`delay.rs`), so none depends on the core's cycles per
//! instruction:
//!
//! * **Boot** ([`BOOT_MIN_TIMEOUT_MS`], 2.0 s), from the first boot step
//!   to the end of `init`. Worst case ≤ 1.15 s: the crystal's start-up
//!   timeout 20 ms; the bus recovery ≈ 0.3 ms; the MPU-9250's power-up
//!   100 ms, then three attempts of ≤ 302 ms each (reset polls
//!   20 × 10 ms, configuration ≈ 1 ms, the 100 ms post-reset settle, the
//!   check ≈ 1 ms) and two 10 ms retry waits: 1,026 ms; the AK8963
//!   (probed only when the MPU came up) three attempts of ≤ 12 ms (reset
//!   polls 10 × 1 ms, mode changes) and two retry waits: 56 ms; the MS5611
//!   three of ≤ 4 ms (reset 2.8 ms, PROM) and two retry waits: 32 ms; the
//!   button's 0.1 ms and the rest (flash reads, set-up) < 5 ms. Margin
//!   ≥ 0.85 s (1.7×). On the emulated board the worst MPU boot ends at
//!   ≈ 1.05 s and is never reset at 60 kHz (`cargo test -p emulator
//!   --test watchdog_budget`).
//! * **Run time** ([`RUN_MIN_TIMEOUT_MS`], 500 ms), between two feeds of
//!   the `log` task (every 50 ms, when `flight::outputguard` allows it).
//!   Worst case ≤ 330 ms: the 50 ms period; a flash save inside the log
//!   task (erase and program stall the CPU ≤ 40 ms); one maintenance step
//!   of the service task at priority 2 (the longest, an MPU-9250
//!   re-initialisation whose reset needs all 20 polls: ≤ 201 ms; the
//!   service task waits ≥ 1 ms between steps, so the log task runs between
//!   two of them); the log lines (a few ms); the 1 kHz chain's share of the
//!   CPU (≤ 10 %) on all of it. Margin ≥ 170 ms (1.5×).
//! * **Not fed** (the watchdog's purpose): while the outputs run without
//!   sample steps for 50 ms, or while no step comes with the MPU-9250
//!   reporting healthy (its INT line dead): reset 0.5–1 s after the last
//!   feed, into the off pulse (`flight::outputguard`).

use sensor_stack::schedule::iwdg_config;
use stm32f1xx_hal::pac;

/// Shortest watchdog timeout while booting, ms (see the module docs).
pub const BOOT_MIN_TIMEOUT_MS: u32 = 2_000;

/// Shortest watchdog timeout at run time, ms (see the module docs).
pub const RUN_MIN_TIMEOUT_MS: u32 = 500;

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
