//! Firmware in the loop: runs the release firmware ELF (the exact file
//! `cargo embed` flashes) on an emulated STM32F103 "Blue Pill".
//!
//! The CPU core is unicorn's Cortex-M3; the exception model (stacking,
//! NVIC priorities, tail-chaining) and every peripheral the firmware
//! touches are register-level models written from RM0008 and PM0056
//! (`scs`, `exceptions`, `rcc`, `flash`, `gpio`, `exti`, `iwdg`, `i2c1`,
//! `tim` for TIM3 and TIM4, `usart` for USART1's receiver and transmitter,
//! `dma` for DMA1, `adc` for ADC1);
//! the sensor chips on I2C1 are the simulator's (`sim`). The firmware's
//! defmt-RTT output is read like a probe does and decoded from the ELF's
//! own table (`rtt`). Any access to a register that is not modelled stops
//! the board with an error.
//!
//! The clock tree follows RCC (`rcc`): the core runs on the 8 MHz HSI
//! from reset and at the PLL's 72 MHz (crystal) or 64 MHz (HSI fallback)
//! once the firmware switches, and the timers, USART1 and I2C1 run on
//! their APB clocks.
//!
//! Not modelled: the HSI's and LSE's frequency error (both exact), the
//! switch's few-cycle delay, instruction timing beyond the per-block cycle
//! model of `cycles` (no bus contention with DMA, no data-dependent
//! multiply/divide times),
//! the process stack, MPU/FPU (none on the M3 part used), DMA2, timers
//! other than TIM3 and TIM4, USART2/3, ADC2, sleep modes beyond
//! "idle until the next event".

pub mod adc;
pub mod board;
pub mod calpage;
pub mod crsf;
pub mod cycles;
pub mod dma;
pub mod elf;
pub mod exceptions;
pub mod exti;
pub mod flash;
pub mod flightplot;
pub mod gpio;
pub mod i2c1;
pub mod iwdg;
pub mod rate_view;
pub mod rcc;
pub mod rig;
pub mod rtt;
pub mod scs;
pub mod tim;
pub mod usart;

pub use board::{
    Board, BoardConfig, BoardError, BoardEvent, BoardFault, Executed, ADC1_2_IRQ, ADC1_PINS,
    DMA1_CHANNEL4_IRQ, DMA1_CHANNEL5_IRQ, EXTI9_5, TIM3_IRQ, TIM3_PINS, TIM4_IRQ, TIM4_PINS,
    USART1_IRQ,
};
pub use cycles::CycleModel;
pub use elf::{release_elf_path, Firmware};
pub use rcc::ResetCause;
pub use rtt::{LogLine, RttError, RttMode};
pub use usart::TxByte;
