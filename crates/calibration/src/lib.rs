//! Sensor calibration: gyro bias, magnetometer hard/soft iron, accelerometer six-position.
#![no_std]
