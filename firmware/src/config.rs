//! The board's wiring settings: which receiver channel does what, how the
//! MPU-9250 is mounted, the ESC protocol and which calibration sessions
//! the build carries. Change them here and rebuild (`cargo fw`, `cargo
//! embed --release`); the boot log prints what the firmware uses
//! ("outputs: ...", "flight controller: ready ..."). The flight settings
//! (the MPU-9250's filter, the gyro filters, rates, gains, failsafe) are
//! in the `settings` crate (`crates/settings`), which `cargo sim` and the
//! emulated board fly too.
//!
//! The receiver protocol is a cargo feature, like OneShot125: CRSF on
//! USART1 RX (PA10) by default, a PPM sum signal on PB8 with `--features
//! ppm` (`ppm.rs`); the channel settings below apply to both.
//!
//! Channel numbers below are 0-based indices (channel 1 = index 0), as
//! `rc_input` counts them; the log and the README count from 1.
//!
//! # How do I change my channel order?
//!
//! Edit [`channel_map`]: `ChannelMap::DEFAULT` is AETR (roll, pitch,
//! throttle, yaw on channels 1-4) with the arm switch on channel 5 high.
//! For a Futaba/Spektrum-style TAER radio:
//!
//! ```ignore
//! pub fn channel_map() -> ChannelMap {
//!     ChannelMap::new(ChannelOrder::TAER) // arm switch stays on channel 5
//! }
//! ```
//!
//! A stick that runs the wrong way: `.with_reversed(Axis::Pitch, true)`;
//! the arm switch elsewhere: `ChannelMap::with_arm_switch` (it refuses a
//! channel a stick uses). Any other order: `ChannelOrder::new(roll, pitch,
//! yaw, throttle)`. Keep [`MODE_CHANNEL`] and [`MOTOR_TEST_CHANNEL`] off
//! the stick and arm channels.

use control::esc::EscProtocol;
use rc_input::ChannelMap;
use sensor_stack::Mounting;

/// Sticks and arm switch: AETR on channels 1-4, arm on channel 5 (AUX1,
/// which ExpressLRS always sends at full rate) in the high position.
#[inline(always)]
pub const fn channel_map() -> ChannelMap {
    ChannelMap::DEFAULT
}

/// Flight-mode switch (index 5 = channel 6, AUX2): low angle, middle
/// altitude hold, high acro. Absent from the frame: angle.
pub const MODE_CHANNEL: u8 = 5;

/// Motor-test switch (index 6 = channel 7, AUX3), on in the high
/// position. While disarmed, with the arm switch off and the throttle low,
/// each off → on flip spins the next motor alone (1, 2, 3, 4, then 1
/// again) at [`MOTOR_TEST_COMMAND`] until the switch goes off, a stick
/// moves, the arm switch goes on, the link is lost or 5 s pass. Arming is
/// refused while it is on. Absent from the frame: off. PROPS OFF.
pub const MOTOR_TEST_CHANNEL: u8 = 6;

/// Motor-test command: the settings crate's (`settings::MOTOR_TEST_COMMAND`).
pub use settings::MOTOR_TEST_COMMAND;

const _: () = assert!(
    MODE_CHANNEL != MOTOR_TEST_CHANNEL && MODE_CHANNEL < 16 && MOTOR_TEST_CHANNEL < 16,
    "the mode and motor-test switches need two distinct channels of the 16"
);

/// How the MPU-9250 breakout sits on the frame (MPU axes → body FRD).
/// The default: face up, its x arrow forward. Another orientation is a
/// signed axis permutation, checked when the firmware compiles (a
/// left-handed or repeated-axis map does not build); for the board face
/// up with its x arrow pointing right:
///
/// ```ignore
/// pub const MOUNTING: Mounting = match Mounting::new([
///     AxisMap { source: 1, negate: false }, // forward = y_mpu
///     AxisMap { source: 0, negate: false }, // right = x_mpu
///     AxisMap { source: 2, negate: true },  // down = −z_mpu
/// ]) {
///     Ok(m) => m,
///     Err(_) => panic!("MOUNTING is not a rotation"),
/// };
/// ```
///
/// It replaces the mounting of the calibration record at every boot (the
/// calibrations are in the sensor's own axes, so they stay valid).
pub const MOUNTING: Mounting = Mounting::FACE_UP_X_FORWARD;

/// ESC protocol of the four outputs (TIM3 CH1-4): standard PWM
/// 1000-2000 µs at 400 Hz, or OneShot125 (125-250 µs at 2 kHz) with
/// `--features oneshot125`.
#[cfg(not(feature = "oneshot125"))]
pub const ESC_PROTOCOL: EscProtocol = EscProtocol::Pwm;
/// ESC protocol of the four outputs: OneShot125 at 2 kHz (feature
/// `oneshot125`).
#[cfg(feature = "oneshot125")]
pub const ESC_PROTOCOL: EscProtocol = EscProtocol::OneShot125;

/// The calibration sessions of this build. The flight build runs none
/// ([`NotBuilt`](sensor_stack::calmode::NotBuilt): the button held at boot or a
/// long press logs where they are; ~3 KiB of flash the flight build keeps
/// for what comes next). The calibration build (`--features calibrate`)
/// runs the six-position accelerometer calibration and the magnetometer
/// ellipsoid fit (`sensor_stack::calmode::MagCalMode`: integer moments, an f32
/// solve) and saves the record, which the flight build loads and applies.
#[cfg(not(feature = "calibrate"))]
pub type Session = sensor_stack::calmode::CalSession<
    sensor_stack::calmode::NotBuilt,
    sensor_stack::calmode::NotBuilt,
>;
/// The calibration build's sessions: six-position accelerometer and the
/// magnetometer ellipsoid fit.
#[cfg(feature = "calibrate")]
pub type Session = sensor_stack::calmode::CalSession<
    sensor_stack::calmode::MagCalMode,
    sensor_stack::calmode::AccelCalMode,
>;

/// This is the calibration build: its sessions report progress and save
/// the record; the flight build only loads it.
pub const CALIBRATION_BUILD: bool = cfg!(feature = "calibrate");
