//! Firmware in the loop: runs the release firmware ELF (the exact file
//! `cargo embed` flashes) on an emulated STM32F103 "Blue Pill".
//!
//! The CPU core is unicorn's Cortex-M3; the peripherals the firmware
//! touches are register-level models written from RM0008; the sensor chips
//! on I2C1 are the simulator's (`sim`).

pub mod i2c1;
