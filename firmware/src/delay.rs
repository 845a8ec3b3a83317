//! A busy-wait delay from the CPU clock, for boot-time chip resets and the
//! hand-made I2C clock (never used in the 1 kHz task).

use embedded_hal::delay::DelayNs;

/// CPU clock, Hz.
pub const CPU_HZ: u32 = 72_000_000;

/// Busy-wait delay counting CPU cycles (`cortex_m::asm::delay`).
#[derive(Clone, Copy, Debug, Default)]
pub struct AsmDelay;

impl DelayNs for AsmDelay {
    fn delay_ns(&mut self, ns: u32) {
        let cycles = (u64::from(ns) * u64::from(CPU_HZ / 1_000_000)) / 1_000;
        cortex_m::asm::delay(u32::try_from(cycles).unwrap_or(u32::MAX).max(1));
    }
}
