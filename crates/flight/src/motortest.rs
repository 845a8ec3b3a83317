//! The props-off motor test from the transmitter: a switch channel that,
//! while the craft is disarmed, spins one motor per off → on flip, in
//! motor order 1, 2, 3, 4, then 1 again.
//!
//! The [`FlightController`](crate::flightctl::FlightController) reads the
//! switch from [`PilotInput::motor_test_switch`](crate::flightctl::PilotInput)
//! every step; this module holds the edge detection and the motor sequence.
//!
//! Why these rules:
//! * **An edge, never a level.** A switch already on at boot, or when the
//!   link comes back after a loss, starts nothing: the pilot must turn it
//!   off and on again with the link up, so a motor never starts without a
//!   deliberate flip seen by the board.
//! * **The switch off ends the test** (a level, checked every step), as do
//!   the controller's own end conditions (stick movement, arm switch, link
//!   loss, timeout).
//! * **Arming is refused while the switch is on**
//!   ([`ArmRefusal::MotorTestSwitchOn`](crate::arming::ArmRefusal)): the
//!   switch on means "bench, props off"; a craft armed in that state would
//!   spin all four motors where the pilot expects one, and after a disarm
//!   the next flip of the switch would be read as a motor-test request.
//! * Every refused flip is reported with its reason
//!   ([`Event::MotorTestRefused`](crate::arming::Event)); the sequence only
//!   advances when a motor really started, so a refused flip retries the
//!   same motor.

use control::mixer::MOTORS;

/// Position of each motor (index = mixer order, `0` = motor 1), as the
/// log names it; the layout of [`control::mixer`] (Betaflight quad-X).
pub const MOTOR_POSITIONS: [&str; MOTORS] =
    ["rear right", "front right", "rear left", "front left"];

/// The motor's position for motor index `motor` (0..=3), `"?"` outside.
pub fn motor_position(motor: u8) -> &'static str {
    MOTOR_POSITIONS
        .get(usize::from(motor))
        .copied()
        .unwrap_or("?")
}

/// What one step's switch position asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SwitchRequest {
    /// No change (or a change that must not act: at boot, after a link loss).
    None,
    /// Off → on with the link up: start motor index `0..=3`.
    Start(u8),
}

/// Edge detector and motor sequence of the motor-test switch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MotorTestSwitch {
    /// Last position seen with the link up (`None` at boot and after a
    /// link loss, so a switch found on never starts a motor).
    prev: Option<bool>,
    /// Motor index the next flip starts.
    next: u8,
}

impl MotorTestSwitch {
    /// At boot: no position seen, motor 1 next.
    pub const fn new() -> Self {
        Self {
            prev: None,
            next: 0,
        }
    }

    /// One step's switch position; `link_ok` false forgets the position.
    pub fn update(&mut self, link_ok: bool, on: bool) -> SwitchRequest {
        let edge = link_ok && on && self.prev == Some(false);
        self.prev = link_ok.then_some(on);
        if edge {
            SwitchRequest::Start(self.next)
        } else {
            SwitchRequest::None
        }
    }

    /// The motor started: the next flip runs the following one.
    pub fn advance(&mut self) {
        self.next = (self.next + 1) % MOTORS as u8;
    }

    /// Motor index the next flip starts.
    pub fn next_motor(&self) -> u8 {
        self.next
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_an_off_to_on_flip_with_the_link_up_requests_a_start() {
        let mut s = MotorTestSwitch::new();
        assert_eq!(s.update(true, true), SwitchRequest::None, "on at boot");
        assert_eq!(s.update(true, true), SwitchRequest::None);
        assert_eq!(s.update(true, false), SwitchRequest::None);
        assert_eq!(s.update(true, true), SwitchRequest::Start(0));
        assert_eq!(s.update(true, true), SwitchRequest::None, "held on");
        s.update(true, false);
        assert_eq!(s.update(false, true), SwitchRequest::None, "link down");
        assert_eq!(s.update(true, true), SwitchRequest::None, "on at link up");
    }

    #[test]
    fn the_sequence_wraps_after_motor_4() {
        let mut s = MotorTestSwitch::new();
        let mut seen = [0u8; 6];
        for m in seen.iter_mut() {
            *m = s.next_motor();
            s.advance();
        }
        assert_eq!(seen, [0, 1, 2, 3, 0, 1]);
        assert_eq!(motor_position(1), "front right");
        assert_eq!(motor_position(4), "?");
    }
}
