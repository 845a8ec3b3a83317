//! A busy-wait delay from the CPU clock, for boot-time chip resets and the
//! hand-made I2C clock (never used in the 1 kHz task).

use embedded_hal::delay::DelayNs;

/// CPU clock, Hz.
pub const CPU_HZ: u32 = 72_000_000;

/// CPU cycles per microsecond.
const CYCLES_PER_US: u32 = CPU_HZ / 1_000_000;

/// Busy-wait delay counting CPU cycles (`cortex_m::asm::delay`).
///
/// All arithmetic is 32-bit: a 64-bit division would link
/// `__aeabi_uldivmod` (~0.9 KiB of flash) for a boot-time delay.
#[derive(Clone, Copy, Debug, Default)]
pub struct AsmDelay;

impl DelayNs for AsmDelay {
    fn delay_ns(&mut self, ns: u32) {
        // ns / 1000 · 72 ≤ 3.1e8 and (ns % 1000) · 72 < 72 000: no overflow.
        let cycles = (ns / 1_000) * CYCLES_PER_US + (ns % 1_000) * CYCLES_PER_US / 1_000;
        cortex_m::asm::delay(cycles.max(1));
    }

    fn delay_us(&mut self, us: u32) {
        cortex_m::asm::delay(us.saturating_mul(CYCLES_PER_US).max(1));
    }

    fn delay_ms(&mut self, ms: u32) {
        for _ in 0..ms {
            cortex_m::asm::delay(CPU_HZ / 1_000);
        }
    }
}
