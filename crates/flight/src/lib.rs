//! The flight controller of the Blue Pill quadcopter, hardware-free: flight
//! modes, arming and its refusals, failsafe, crash and landing disarm, the
//! runaway-takeoff check, the motor-test switch and the output guard, and
//! the control loops they call (`control`). It consumes the sensor stack's
//! estimate (the `sensor_stack` crate: attitude, body rates, height) and the
//! pilot's input (`rc_input`), and produces the four motor commands.
//!
//! Everything here is `no_std` and heap-free, so it runs unchanged on the
//! host (tests, the `sim` closed loop) and in the RTIC firmware.
//!
//! | module | what |
//! |---|---|
//! | [`flightctl`] | [`flightctl::FlightController`]: pilot input + attitude + gyro + time → 4 motor commands, state, events (modes, arming, crash/landing disarm, failsafe, motor test) |
//! | [`arming`] | arming refusals, disarm causes, events and the safety limits |
//! | [`runaway`] | runaway-takeoff check: saturated rate loop while turning, before normal flight |
//! | [`motortest`] | the motor-test switch: off → on flips while disarmed spin motors 1, 2, 3, 4 in turn |
//! | [`outputguard`] | the ESC outputs' guard: the off pulse when no sample step comes, or at once on the arm switch off |
#![no_std]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::field_reassign_with_default
    )
)]

/// Words for a field-less enum, from one table: `Display` for the host
/// and `defmt::Format` for the board's log (one interned format string per
/// variant: the text stays in the ELF's `.defmt` table, not in flash).
macro_rules! words {
    ($ty:ident { $($v:ident => $text:literal,)* }) => {
        impl core::fmt::Display for $ty {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str(match self {
                    $(Self::$v => $text,)*
                })
            }
        }

        #[cfg(feature = "defmt")]
        impl defmt::Format for $ty {
            fn format(&self, f: defmt::Formatter) {
                match self {
                    $(Self::$v => defmt::write!(f, $text),)*
                }
            }
        }
    };
}

pub mod arming;
pub mod flightctl;
pub mod motortest;
pub mod outputguard;
pub mod runaway;
