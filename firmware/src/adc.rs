//! The battery voltage on PA4 (ADC12_IN4) through ADC1, one regular
//! conversion per call of [`BatteryAdc::poll`], started by software and read
//! at the next call: the conversion (21 µs) runs while the CPU does other
//! work, and nothing of it touches the 1 kHz sample path.
//!
//! Set-up (RM0008 §11): ADCCLK = PCLK2 / 6 = 12 MHz (≤ 14 MHz, §11.1);
//! the longest sample time, 239.5 cycles, for the divider's source
//! impedance (10 kΩ ∥ 1 kΩ ≈ 0.9 kΩ; §11.6 and the datasheet's R_AIN
//! table allow 50 kΩ at 239.5 cycles); a conversion takes 239.5 + 12.5 =
//! 252 cycles, 21 µs. Power-up and calibration follow §11.3.1 and §11.4:
//! ADON, t_STAB (1 µs), RSTCAL until it clears, CAL until it clears (each
//! waited for with a bound: a missing ADC leaves the pack unread, never
//! hangs the boot). Regular group of one channel (SQR1.L = 0, SQR3.SQ1 =
//! 4), triggered by SWSTART (EXTSEL = 111, EXTTRIG, §11.12.3).

use stm32f1xx_hal::pac;

/// The pack's ADC channel: PA4 = ADC12_IN4 (datasheet, pinout table).
pub const CHANNEL: u8 = 4;
/// SMPx = 111: 239.5 ADC cycles (RM0008 §11.12.4).
const SMP_239_5: u32 = 0b111;
/// RCC_CFGR.ADCPRE = 10: PCLK2 / 6 (RM0008 §7.3.2).
const ADCPRE_DIV6: u32 = 0b10;
const CR2_ADON: u32 = 1 << 0;
const CR2_CAL: u32 = 1 << 2;
const CR2_RSTCAL: u32 = 1 << 3;
const CR2_EXTSEL_SWSTART: u32 = 0b111 << 17;
const CR2_EXTTRIG: u32 = 1 << 20;
const CR2_SWSTART: u32 = 1 << 22;
const SR_EOC: u32 = 1 << 1;
/// Polls of a self-clearing bit before the ADC counts as absent: the
/// calibration takes 83 ADC cycles, 7 µs (§11.4); a poll is ≥ 4 CPU
/// cycles, so 10,000 polls is ≥ 0.5 ms at 72 MHz.
const WAIT_POLLS: u32 = 10_000;

/// Why the ADC is not read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum AdcError {
    /// RSTCAL or CAL did not clear within the bound.
    CalibrationTimeout,
}

/// ADC1 converting PA4 on request.
pub struct BatteryAdc {
    adc: pac::ADC1,
    started: bool,
}

impl BatteryAdc {
    /// Clocks ADC1 and GPIOA, makes PA4 an analog input, sets the clock,
    /// the sample time and the regular sequence, powers the ADC up and
    /// calibrates it. `cpu_hz` sizes the t_STAB wait.
    pub fn start(adc: pac::ADC1, cpu_hz: u32) -> Result<Self, AdcError> {
        // SAFETY: register writes in init, before any task runs: RCC's
        // APB2ENR and CFGR.ADCPRE (read-modify-write of those bits only)
        // and PA4's CRL nibble (read-modify-write); ADC1 is owned.
        #[allow(unsafe_code)]
        unsafe {
            let rcc = &*pac::RCC::ptr();
            rcc.apb2enr()
                .modify(|_, w| w.iopaen().set_bit().adc1en().set_bit());
            rcc.cfgr()
                .modify(|r, w| w.bits((r.bits() & !(0b11 << 14)) | (ADCPRE_DIV6 << 14)));
            // CRL nibble 4: MODE = 00, CNF = 00 (analog, §9.2.1 table 20).
            let gpioa = &*pac::GPIOA::ptr();
            gpioa
                .crl()
                .modify(|r, w| w.bits(r.bits() & !(0xF << (4 * u32::from(CHANNEL)))));
            adc.smpr2()
                .write(|w| w.bits(SMP_239_5 << (3 * u32::from(CHANNEL))));
            adc.sqr1().write(|w| w.bits(0));
            adc.sqr3().write(|w| w.bits(u32::from(CHANNEL)));
            let cr2 = CR2_EXTSEL_SWSTART | CR2_EXTTRIG | CR2_ADON;
            adc.cr2().write(|w| w.bits(cr2));
            // t_STAB ≤ 1 µs (datasheet) before calibrating.
            cortex_m::asm::delay(cpu_hz / 1_000_000 + 1);
            adc.cr2().write(|w| w.bits(cr2 | CR2_RSTCAL));
            wait_clear(&adc, CR2_RSTCAL)?;
            adc.cr2().write(|w| w.bits(cr2 | CR2_CAL));
            wait_clear(&adc, CR2_CAL)?;
        }
        Ok(Self {
            adc,
            started: false,
        })
    }

    /// The conversion started at the last call, if it has ended (counts,
    /// 12 bits, 0..=4095 for 0..=3.3 V), and the next one started.
    pub fn poll(&mut self) -> Option<u16> {
        let done = self.started && self.adc.sr().read().bits() & SR_EOC != 0;
        // Reading DR clears EOC (§11.12.1).
        let counts = done.then(|| (self.adc.dr().read().bits() & 0x0FFF) as u16);
        let cr2 = self.adc.cr2().read().bits();
        // SAFETY: CR2 with SWSTART added to the value just read; the
        // other bits are this driver's configuration.
        #[allow(unsafe_code)]
        unsafe {
            self.adc.cr2().write(|w| w.bits(cr2 | CR2_SWSTART));
        }
        self.started = true;
        counts
    }
}

/// Waits for a self-clearing CR2 bit, at most [`WAIT_POLLS`] reads.
fn wait_clear(adc: &pac::ADC1, bit: u32) -> Result<(), AdcError> {
    for _ in 0..WAIT_POLLS {
        if adc.cr2().read().bits() & bit == 0 {
            return Ok(());
        }
    }
    Err(AdcError::CalibrationTimeout)
}
