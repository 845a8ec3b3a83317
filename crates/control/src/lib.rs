//! Barometric altitude, vertical estimation, PID and the altitude/attitude controllers.
#![no_std]
