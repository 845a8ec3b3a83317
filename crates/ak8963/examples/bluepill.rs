//! Blue Pill (STM32F103C8): AK8963 inside an MPU-9250 on I2C1 (PB6 SCL, PB7
//! SDA, 400 kHz) through the MPU-9250's bypass; measurements over defmt-rtt.
//!
//! ```text
//! cargo build -p ak8963 --example bluepill --target thumbv7m-none-eabi --release
//! probe-rs run --chip STM32F103C8 target/thumbv7m-none-eabi/release/examples/bluepill
//! ```
//!
//! On the host this example only prints how to build it.

// The board set-up repeats the other drivers' examples on purpose: each example stands alone.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod board {
    use ak8963::{Ak8963, Config};
    use cortex_m_rt::entry;
    use defmt_rtt as _;
    use embedded_hal::delay::DelayNs;
    use embedded_hal::i2c::I2c;
    use panic_probe as _;
    use stm32f1xx_hal::{i2c, pac, prelude::*, rcc};

    #[entry]
    fn main() -> ! {
        let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take())
        else {
            defmt::panic!("peripherals taken twice");
        };
        // The HAL's blocking I2C times out on the DWT cycle counter.
        cp.DCB.enable_trace();
        cp.DWT.enable_cycle_counter();
        let mut flash = dp.FLASH.constrain();
        let mut rcc = dp.RCC.freeze(
            rcc::Config::hse(8.MHz()).sysclk(72.MHz()).pclk1(36.MHz()),
            &mut flash.acr,
        );
        let mut delay = dp.TIM2.delay_us(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let mut bus = i2c::BlockingI2c::new(
            dp.I2C1,
            (gpiob.pb6, gpiob.pb7),
            i2c::Mode::fast(400.kHz(), i2c::DutyCycle::Ratio2to1),
            &mut rcc,
            1_000,
            3,
            1_000,
            1_000,
        );
        DelayNs::delay_ms(&mut delay, 100);
        // MPU-9250 bypass on (the mpu9250 crate's `set_bypass` does the same).
        if I2c::write(&mut bus, 0x68u8, &[0x6A, 0x00]).is_err()
            || I2c::write(&mut bus, 0x68u8, &[0x37, 0x02]).is_err()
        {
            defmt::panic!("no MPU-9250 at 0x68");
        }
        let mut mag = Ak8963::new(bus);
        if let Err(e) = mag.init(&mut delay, &Config::default()) {
            defmt::panic!("AK8963 init failed: {}", defmt::Debug2Format(&e));
        }
        loop {
            match mag.read() {
                Ok(s) => defmt::info!("field {} uT (MPU frame)", s.field_mpu_ut()),
                Err(ak8963::Error::NotReady) => {}
                Err(e) => defmt::warn!("read failed: {}", defmt::Debug2Format(&e)),
            }
            DelayNs::delay_ms(&mut delay, 10);
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("build this example with --target thumbv7m-none-eabi");
}
