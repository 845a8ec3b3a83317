//! Blue Pill (STM32F103C8): MS5611 at 0x77 on I2C1 (PB6 SCL, PB7 SDA,
//! 400 kHz), driven by the non-blocking `Sampler`; pressures over defmt-rtt.
//!
//! ```text
//! cargo build -p ms5611 --example bluepill --target thumbv7m-none-eabi --release
//! probe-rs run --chip STM32F103C8 target/thumbv7m-none-eabi/release/examples/bluepill
//! ```
//!
//! On the host this example only prints how to build it.

// The board set-up repeats the other drivers' examples on purpose: each example stands alone.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod board {
    use cortex_m_rt::entry;
    use defmt_rtt as _;
    use embedded_hal::delay::DelayNs;
    use ms5611::{Address, Ms5611, Sampler, SamplerConfig};
    use panic_probe as _;
    use stm32f1xx_hal::{i2c, pac, prelude::*, rcc};

    #[entry]
    fn main() -> ! {
        let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take())
        else {
            defmt::panic!("peripherals taken twice");
        };
        // The HAL's blocking I2C times out on the DWT cycle counter, which
        // also serves as the sampler's microsecond clock here.
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
        let mut flash = dp.FLASH.constrain();
        let mut rcc = dp.RCC.freeze(
            rcc::Config::hse(8.MHz()).sysclk(72.MHz()).pclk1(36.MHz()),
            &mut flash.acr,
        );
        let mut delay = dp.TIM2.delay_us(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let bus = i2c::BlockingI2c::new(
            dp.I2C1,
            (gpiob.pb6, gpiob.pb7),
            i2c::Mode::fast(400.kHz(), i2c::DutyCycle::Ratio2to1),
            &mut rcc,
            1_000,
            3,
            1_000,
            1_000,
        );
        let mut baro = Ms5611::new(bus, Address::CsbLow);
        if let Err(e) = baro.init(&mut delay) {
            defmt::panic!("MS5611 init failed: {}", defmt::Debug2Format(&e));
        }
        let mut sampler = Sampler::new(SamplerConfig::new());
        let mut now_us = 0u32;
        let mut last = cortex_m::peripheral::DWT::cycle_count();
        loop {
            // 72 cycles per µs; wrapping arithmetic keeps the clock monotonic.
            let cycles = cortex_m::peripheral::DWT::cycle_count();
            now_us = now_us.wrapping_add(cycles.wrapping_sub(last) / 72);
            last = cycles.wrapping_sub(cycles.wrapping_sub(last) % 72);
            match sampler.poll(&mut baro, now_us) {
                Ok(Some(m)) => {
                    defmt::info!("{} Pa  {} (0.01 C)", m.pressure_pa, m.temperature_centi_c)
                }
                Ok(None) => {}
                Err(e) => defmt::warn!("baro: {}", defmt::Debug2Format(&e)),
            }
            DelayNs::delay_us(&mut delay, 500);
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("build this example with --target thumbv7m-none-eabi");
}
