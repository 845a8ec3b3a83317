//! The CPU clock as measured at boot, and busy-wait delays on the DWT
//! cycle counter, for boot-time chip resets, the crystal's start-up and
//! the hand-made I2C clock (never used in the 1 kHz task).
//!
//! Waits are measured on CYCCNT, not counted in loop iterations: an
//! iteration of `cortex_m::asm::delay`'s loop takes ~3 cycles on a
//! Cortex-M3 (1 on the emulated board), so a wait of n cycles through it
//! lasts ~3n on silicon and every budget built on it (the boot and
//! run-time watchdog, `watchdog.rs`) would depend on the core's CPI.
//! CYCCNT counts the clock itself: a wait lasts at least what was asked
//! (plus at most one poll, a few cycles), whatever the loop costs and
//! whichever interrupts run meanwhile (their time counts toward it).

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::DWT;
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

/// The longest single wait, cycles: below half the counter's range so the
/// elapsed count never wraps past the end (29.8 s at 72 MHz).
const MAX_WAIT_CYCLES: u32 = 1 << 31;

/// Busy-waits until CYCCNT has advanced by `cycles` (at most
/// [`MAX_WAIT_CYCLES`]). The counter must be running (`init` starts it
/// before the first wait).
#[inline(never)]
pub fn wait_cycles(cycles: u32) {
    let cycles = cycles.min(MAX_WAIT_CYCLES);
    let t0 = DWT::cycle_count();
    while DWT::cycle_count().wrapping_sub(t0) < cycles {}
}

/// Busy-wait delay on the DWT cycle counter (see the module docs; the
/// name stays from the `cortex_m::asm::delay` loop it replaced).
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
        wait_cycles(cycles.max(1));
    }

    #[inline(never)]
    fn delay_us(&mut self, us: u32) {
        wait_cycles(us.saturating_mul(cpu_hz() / 1_000_000).max(1));
    }

    #[inline(never)]
    fn delay_ms(&mut self, ms: u32) {
        for _ in 0..ms {
            wait_cycles(cpu_hz() / 1_000);
        }
    }
}
