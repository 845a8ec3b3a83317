//! MPU-9250 accelerometer/gyroscope driver (embedded-hal 1.0).
#![no_std]
