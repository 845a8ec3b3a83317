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

/// Where a motor sits on the frame: the layout of [`control::mixer`]
/// (Betaflight quad-X, seen from above, nose forward).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotorPosition {
    /// Motor 1 (index 0), clockwise.
    RearRight,
    /// Motor 2 (index 1), counter-clockwise.
    FrontRight,
    /// Motor 3 (index 2), counter-clockwise.
    RearLeft,
    /// Motor 4 (index 3), clockwise.
    FrontLeft,
}

words!(MotorPosition {
    RearRight => "rear right, clockwise",
    FrontRight => "front right, counter-clockwise",
    RearLeft => "rear left, counter-clockwise",
    FrontLeft => "front left, clockwise",
});

impl MotorPosition {
    /// The position of motor index `motor` (0..=3, mixer order), `None`
    /// outside.
    pub fn of(motor: u8) -> Option<Self> {
        match motor {
            0 => Some(Self::RearRight),
            1 => Some(Self::FrontRight),
            2 => Some(Self::RearLeft),
            3 => Some(Self::FrontLeft),
            _ => None,
        }
    }

    /// Lower-case words, as the README names the positions.
    pub fn name(self) -> &'static str {
        match self {
            Self::RearRight => "rear right",
            Self::FrontRight => "front right",
            Self::RearLeft => "rear left",
            Self::FrontLeft => "front left",
        }
    }
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

    /// The positions follow the mixer's roll and pitch signs: left motors
    /// have +roll, front motors +pitch.
    #[test]
    fn positions_match_the_mixer_table() {
        use control::mixer::QUAD_X;
        for (m, [roll, pitch, _]) in (0u8..).zip(QUAD_X) {
            let p = MotorPosition::of(m).unwrap();
            let left = matches!(p, MotorPosition::RearLeft | MotorPosition::FrontLeft);
            let front = matches!(p, MotorPosition::FrontRight | MotorPosition::FrontLeft);
            assert_eq!(roll > 0.0, left, "{p:?}");
            assert_eq!(pitch > 0.0, front, "{p:?}");
        }
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
        assert_eq!(MotorPosition::of(1), Some(MotorPosition::FrontRight));
        assert_eq!(
            MotorPosition::of(1).map(MotorPosition::name),
            Some("front right")
        );
        assert_eq!(MotorPosition::of(4), None);
    }
}
