//! MS5611 barometer driver (embedded-hal 1.0).
#![no_std]
