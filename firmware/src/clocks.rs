//! The clock tree: 72 MHz from the 8 MHz crystal, or 64 MHz from the
//! internal oscillator when the crystal does not start within a bounded
//! time (a cracked crystal or a bad solder joint must not hang the boot).

use cortex_m::peripheral::DWT;
use stm32f1xx_hal::{flash::ACR, pac, rcc, rcc::RccExt};

use crate::delay;

/// Longest wait for HSERDY. The crystal oscillator typically starts in
/// 2 ms (STM32F103x8 datasheet, t_SU(HSE)); ST's own start-up code gives
/// up after a few ms. Measured on CYCCNT (started before this step) in
/// cycles of the 8 MHz HSI the core runs on at reset.
const HSE_TIMEOUT_HSI_CYCLES: u32 = 8_000_000 / 1_000 * 20;

/// Which oscillator the PLL runs from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// The 8 MHz crystal: SYSCLK 72 MHz, APB1 36 MHz.
    Hse,
    /// The crystal did not start: HSI, SYSCLK 64 MHz, APB1 32 MHz.
    HsiFallback,
}

impl defmt::Format for Source {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Self::Hse => defmt::write!(f, "8 MHz crystal"),
            Self::HsiFallback => defmt::write!(f, "internal RC oscillator, no crystal"),
        }
    }
}

/// Starts the crystal (bounded wait) and sets up the PLL and buses;
/// records the CPU clock for the delay and the timing code.
pub fn start(rcc: pac::RCC, acr: &mut ACR) -> (rcc::Rcc, Source) {
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    let t0 = DWT::cycle_count();
    while rcc.cr().read().hserdy().bit_is_clear()
        && DWT::cycle_count().wrapping_sub(t0) < HSE_TIMEOUT_HSI_CYCLES
    {}
    let hse_ok = rcc.cr().read().hserdy().bit_is_set();
    // The register values are written out (what `rcc::Config::hse(8 MHz)
    // .sysclk(72 MHz).pclk1(36 MHz)` computes) so the clock-tree search
    // code is not linked. PLLMUL field = multiplier − 2.
    let (source, hse, pllmul, hz) = if hse_ok {
        (Source::Hse, Some(8_000_000), 9 - 2, delay::CPU_HZ_HSE)
    } else {
        rcc.cr().modify(|_, w| w.hseon().clear_bit());
        (Source::HsiFallback, None, 16 - 2, delay::CPU_HZ_HSI)
    };
    let cfg = rcc::RawConfig {
        hse,
        hse_bypass: false,
        pllmul: Some(pllmul),
        hpre: rcc::HPre::Div1,
        ppre1: rcc::PPre::Div2,
        ppre2: rcc::PPre::Div1,
        usbpre: rcc::UsbPre::Div1_5,
        adcpre: rcc::AdcPre::Div6,
        // Both setups are within the limits (SYSCLK ≤ 72 MHz, APB1 ≤
        // 36 MHz); `true` lets the HAL's limit check, which cannot fold
        // for a setup chosen at run time, drop out of the image.
        allow_overclock: true,
    };
    let rcc = rcc.constrain().freeze(cfg, acr);
    delay::set_cpu_hz(hz);
    (rcc, source)
}
