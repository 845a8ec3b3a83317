//! Madgwick AHRS (IMU and MARG) in f32 and fixed point.
#![no_std]
