//! Flight-controller sensor app for the STM32F103C8 "Blue Pill".
//!
//! Skeleton: 72 MHz from the 8 MHz HSE through the PLL, I2C1 on PB6/PB7 at
//! 400 kHz, the MPU-9250 INT line on PB5 (EXTI5), the PC13 LED blinking from
//! the SysTick monotonic, and defmt over RTT.
#![no_std]
#![no_main]

use defmt_rtt as _;
use panic_probe as _;

#[rtic::app(device = stm32f1xx_hal::pac, dispatchers = [USART1, USART2])]
mod app {
    use rtic_monotonics::systick::prelude::*;
    use stm32f1xx_hal::{
        gpio::{Edge, ExtiPin, Input, Output, PinState, PullUp, PushPull, PB5, PC13},
        i2c::{BlockingI2c, DutyCycle, Mode},
        pac::{self, I2C1},
        prelude::*,
        rcc,
    };

    systick_monotonic!(Mono, 1_000);

    /// The I2C1 bus shared by the MPU-9250, AK8963 and MS5611.
    pub type Bus = BlockingI2c<I2C1>;

    #[shared]
    struct Shared {
        bus: Bus,
    }

    #[local]
    struct Local {
        led: PC13<Output<PushPull>>,
        mpu_int: PB5<Input<PullUp>>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp: pac::Peripherals = cx.device;
        let mut flash = dp.FLASH.constrain();
        // 8 MHz HSE -> PLL x9 -> 72 MHz SYSCLK; APB1 (I2C1) at its 36 MHz maximum.
        let mut rcc = dp.RCC.constrain().freeze(
            rcc::Config::hse(8.MHz()).sysclk(72.MHz()).pclk1(36.MHz()),
            &mut flash.acr,
        );
        let mut afio = dp.AFIO.constrain(&mut rcc);
        Mono::start(cx.core.SYST, rcc.clocks.sysclk().to_Hz());

        let mut gpiob = dp.GPIOB.split(&mut rcc);
        let mut gpioc = dp.GPIOC.split(&mut rcc);
        // The Blue Pill LED is active low: start with it off.
        let led = gpioc
            .pc13
            .into_push_pull_output_with_state(&mut gpioc.crh, PinState::High);

        // I2C1 on PB6 (SCL) / PB7 (SDA), 400 kHz fast mode. Timeouts in µs
        // bound every wait, so a stuck bus returns an error instead of hanging.
        let bus = BlockingI2c::new(
            dp.I2C1,
            (gpiob.pb6, gpiob.pb7),
            Mode::Fast {
                frequency: 400.kHz(),
                duty_cycle: DutyCycle::Ratio2to1,
            },
            &mut rcc,
            1_000,
            3,
            1_000,
            1_000,
        );

        let mut exti = dp.EXTI;
        let mut mpu_int = gpiob.pb5.into_pull_up_input(&mut gpiob.crl);
        mpu_int.make_interrupt_source(&mut afio);
        mpu_int.trigger_on_edge(&mut exti, Edge::Rising);
        mpu_int.enable_interrupt(&mut exti);

        defmt::info!("boot: 72 MHz, I2C1 400 kHz on PB6/PB7, MPU INT on PB5");
        blink::spawn().ok();
        (Shared { bus }, Local { led, mpu_int })
    }

    #[task(binds = EXTI9_5, local = [mpu_int])]
    fn mpu_data_ready(cx: mpu_data_ready::Context) {
        cx.local.mpu_int.clear_interrupt_pending_bit();
    }

    #[task(local = [led])]
    async fn blink(cx: blink::Context) {
        loop {
            cx.local.led.toggle();
            Mono::delay(rtic_monotonics::fugit::ExtU32::millis(500)).await;
        }
    }
}
