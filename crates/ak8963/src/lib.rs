//! AK8963 magnetometer driver (embedded-hal 1.0).
#![no_std]
