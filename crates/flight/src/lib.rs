//! Hardware-free firmware logic: sensor pipeline, scheduling, health, calibration modes, calibration storage.
#![no_std]
