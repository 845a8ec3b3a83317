//! The CPU clock as measured at boot, and a busy-wait delay from it, for
//! boot-time chip resets and the hand-made I2C clock (never used in the
//! 1 kHz task).

use core::sync::atomic::{AtomicU32, Ordering};
use embedded_hal::delay::DelayNs;

/// CPU clock with the 8 MHz crystal (HSE × 9), Hz.
pub const CPU_HZ_HSE: u32 = 72_000_000;
/// CPU clock on the internal oscillator when the crystal does not start
/// (HSI / 2 × 16; 64 MHz is the most the PLL makes from HSI), Hz.
pub const CPU_HZ_HSI: u32 = 64_000_000;

/// The CPU clock in use, Hz (set once in `init`, before anything reads it).
static CPU_HZ: AtomicU32 = AtomicU32::new(CPU_HZ_HSE);

/// Records the CPU clock chosen at boot.
pub fn set_cpu_hz(hz: u32) {
    CPU_HZ.store(hz, Ordering::Relaxed);
}

/// The CPU clock in use, Hz (DWT CYCCNT counts at this rate).
pub fn cpu_hz() -> u32 {
    CPU_HZ.load(Ordering::Relaxed)
}

/// Busy-wait delay counting CPU cycles (`cortex_m::asm::delay`).
///
/// All arithmetic is 32-bit: a 64-bit division would link
/// `__aeabi_uldivmod` (~0.9 KiB of flash) for a boot-time delay.
#[derive(Clone, Copy, Debug, Default)]
pub struct AsmDelay;

// Not inlined: the recovery sequences call these a dozen times each, and
// every inlined copy repeats the clock division (flash is the scarce
// resource; a call costs nothing next to the wait itself).
impl DelayNs for AsmDelay {
    #[inline(never)]
    fn delay_ns(&mut self, ns: u32) {
        let per_us = cpu_hz() / 1_000_000;
        // ns / 1000 · 72 ≤ 3.1e8 and (ns % 1000) · 72 < 72 000: no overflow.
        let cycles = (ns / 1_000) * per_us + (ns % 1_000) * per_us / 1_000;
        cortex_m::asm::delay(cycles.max(1));
    }

    #[inline(never)]
    fn delay_us(&mut self, us: u32) {
        cortex_m::asm::delay(us.saturating_mul(cpu_hz() / 1_000_000).max(1));
    }

    #[inline(never)]
    fn delay_ms(&mut self, ms: u32) {
        for _ in 0..ms {
            cortex_m::asm::delay(cpu_hz() / 1_000);
        }
    }
}
