//! Blue Pill (STM32F103C8): MPU-9250 on I2C1 (PB6 SCL, PB7 SDA, 400 kHz),
//! samples logged over defmt-rtt.
//!
//! ```text
//! cargo build -p mpu9250 --example bluepill --target thumbv7m-none-eabi --release
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
    use mpu9250::{Address, Config, Mpu9250};
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

        let mut imu = Mpu9250::new(bus, Address::Ad0Low);
        // The chip needs 100 ms after power-up before it answers reliably.
        embedded_hal::delay::DelayNs::delay_ms(&mut delay, 100);
        match imu.init(&mut delay, &Config::default()) {
            Ok(variant) => defmt::info!("found {}", variant),
            Err(e) => defmt::panic!("MPU-9250 init failed: {}", defmt::Debug2Format(&e)),
        }
        loop {
            match imu.read() {
                Ok(s) => defmt::info!(
                    "accel {} g  gyro {} dps  {} C",
                    s.accel_g,
                    s.gyro_dps,
                    s.temp_c
                ),
                Err(e) => defmt::warn!("read failed: {}", defmt::Debug2Format(&e)),
            }
            embedded_hal::delay::DelayNs::delay_ms(&mut delay, 100);
        }
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("build this example with --target thumbv7m-none-eabi");
}
