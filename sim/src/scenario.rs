//! The scripted pilots of the closed-loop scenarios: what the pilot's
//! transmitter sends at each instant (sticks, arm switch, mode switch, or
//! nothing while the link is lost) and which motor fails when. One
//! implementation for both rigs: the host simulator's `cargo sim
//! --scenario` (the `flight` crate's host build) and the emulated board's
//! flight in the loop (the real firmware ELF, `emulator::rig`).
//!
//! The pilot speaks in channels, as a transmitter does
//! ([`Pilot::channels_us`]): AETR on channels 1–4, the arm switch on
//! channel 5 (high = armed), the mode switch on channel 6 (low angle,
//! middle altitude hold, high acro) — the firmware's default channel map.

/// Sticks as the pilot holds them: roll, pitch, yaw −1..1 (+1 = right,
/// forward, right), throttle 0..1.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sticks {
    /// Roll stick, −1 (left) .. 1 (right).
    pub roll: f32,
    /// Pitch stick, −1 (back) .. 1 (forward, nose down).
    pub pitch: f32,
    /// Yaw stick, −1 (left) .. 1 (right).
    pub yaw: f32,
    /// Throttle stick, 0 (low) .. 1 (high).
    pub throttle: f32,
}

/// The mode switch's three positions (channel 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Low: angle (self-level).
    Angle,
    /// Middle: altitude hold.
    AltitudeHold,
    /// High: acro (rates).
    Acro,
}

/// What the pilot's radio delivers in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pilot {
    /// Sticks, normalised.
    pub sticks: Sticks,
    /// Arm switch.
    pub arm: bool,
    /// Mode switch.
    pub mode: Mode,
}

use crate::quad::QuadParams;

/// Frame period of the scripted transmitter (s): 250 Hz, ExpressLRS'
/// common CRSF rate.
pub const FRAME_PERIOD_S: f64 = 0.004;

/// Pulse width (µs) of a stick at `x` in −1..1: 1000..2000 µs.
fn stick_us(x: f32) -> u16 {
    (1500.0 + 500.0 * x.clamp(-1.0, 1.0)).round() as u16
}

impl Pilot {
    /// Channels 1–6 as pulse widths (µs, 1000..2000): roll, pitch,
    /// throttle, yaw, arm switch (2000 = armed), mode switch (1000 angle,
    /// 1500 altitude hold, 2000 acro).
    pub fn channels_us(&self) -> [u16; 6] {
        let s = self.sticks;
        [
            stick_us(s.roll),
            stick_us(s.pitch),
            stick_us(2.0 * s.throttle - 1.0),
            stick_us(s.yaw),
            if self.arm { 2000 } else { 1000 },
            match self.mode {
                Mode::Angle => 1000,
                Mode::AltitudeHold => 1500,
                Mode::Acro => 2000,
            },
        ]
    }
}

/// The scripted flights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scenario {
    /// Arm, climb in altitude hold to about 2 m, hover.
    Takeoff,
    /// After the take-off: roll, pitch and yaw stick steps in angle mode.
    Steps,
    /// After the take-off: a 2 m/s climb, then forward flight at 20°, in altitude hold.
    AltHold,
    /// After the take-off: the radio link is lost and stays lost.
    LinkLoss,
    /// After the take-off: motor 1 (rear right) stops for good, as a
    /// burnt ESC or a lost propeller would.
    MotorFailure,
    /// The take-off with the ESC signal wires of motors 1 and 2 (rear
    /// right, front right) swapped at the flight controller.
    Swapped,
    /// The take-off with motor 1 (rear right, CW) turning the wrong way
    /// and its propeller at [`REVERSED_PROP_FRACTION`] of the thrust
    /// ([`QuadParams::with_reversed_motor`]).
    ReversedProp,
    /// After the take-off: angle mode with full throttle from
    /// [`CLIMB_LOSS_THROTTLE_S`], and the link lost 0.5 s into that climb,
    /// for good.
    ClimbLinkLoss,
    /// After the take-off: the link flaps (100 ms of frames, 100 ms
    /// without) for [`FLAP_HOLD_S`] from [`FLAP_S`], then comes back
    /// steadily.
    Flapping,
    /// After the take-off: in acro, a logarithmic sweep of the roll, then
    /// the pitch, then the yaw stick ([`chirp_stick`]), each from altitude
    /// hold and back to it; the pilot's hand ([`AcroHand`]) keeps the
    /// height and the tilt by eye meanwhile (both rigs fly it). The script
    /// alone, without the hand, leaves acro's throttle at mid stick and
    /// the tilt to drift.
    Chirp,
    /// The take-off and a hover in altitude hold on a small, nearly empty
    /// pack ([`LOW_BATTERY_CAPACITY_AH`], [`LOW_BATTERY_CHARGE`] left): the
    /// loaded cell voltage crosses the warning and then the critical
    /// level within a minute; a board with battery monitoring warns, then
    /// descends and lands itself. The pilot's sticks stay centred.
    LowBattery,
}

/// [`Scenario::LowBattery`]'s pack capacity (A·h): a 3S 650 mAh pack, a
/// minute of hover at its last tenth of charge instead of minutes.
pub const LOW_BATTERY_CAPACITY_AH: f64 = 0.65;
/// [`Scenario::LowBattery`]'s charge left at the start (fraction): the
/// cell's resting voltage on the steep end of the LiPo curve.
pub const LOW_BATTERY_CHARGE: f64 = 0.16;

/// Time the arm switch is flipped (s): after boot and the start-up gyro bias.
pub const ARM_AT_S: f64 = 2.5;
/// Take-off: climb stick from here...
pub const CLIMB_FROM_S: f64 = 3.0;
/// ...to here (then centred: hold).
pub const CLIMB_TO_S: f64 = 6.0;
/// Throttle stick during the take-off climb (altitude hold: 3/4 of the
/// largest climb rate above the centre band).
pub const CLIMB_STICK: f32 = 0.9;
/// Stick steps: roll stick at 0.5 from here for [`STEP_HOLD_S`].
pub const ROLL_STEP_S: f64 = 10.0;
/// Pitch stick step start (s).
pub const PITCH_STEP_S: f64 = 14.0;
/// Yaw stick step start (s).
pub const YAW_STEP_S: f64 = 18.0;
/// How long each stick step is held (s).
pub const STEP_HOLD_S: f64 = 2.0;
/// Stick deflection of the steps.
pub const STEP_STICK: f32 = 0.5;
/// Altitude hold: full-up throttle from here for [`CLIMB2_HOLD_S`].
pub const CLIMB2_S: f64 = 10.0;
/// Length of the second climb (s).
pub const CLIMB2_HOLD_S: f64 = 2.0;
/// Altitude hold: forward stick from here for [`FORWARD_HOLD_S`].
pub const FORWARD_S: f64 = 18.0;
/// Length of the forward flight (s).
pub const FORWARD_HOLD_S: f64 = 3.0;
/// Forward stick (pitch) during the forward flight: 2/3 of 30° = 20°.
pub const FORWARD_STICK: f32 = 0.667;
/// The radio link is lost from here on (s).
pub const LINK_LOSS_S: f64 = 10.0;
/// Motor 1 (index 0) stops from here on (s).
pub const MOTOR_FAILURE_S: f64 = 10.0;
/// Climb-then-loss: full throttle (angle mode) from here (s)...
pub const CLIMB_LOSS_THROTTLE_S: f64 = 10.0;
/// ...and the link lost from here on (s).
pub const CLIMB_LOSS_S: f64 = 10.5;
/// Flapping link: from here (s)...
pub const FLAP_S: f64 = 10.0;
/// ...for this long (s), 100 ms of frames then 100 ms without.
pub const FLAP_HOLD_S: f64 = 3.0;
/// Half period of the flapping (s).
pub const FLAP_HALF_PERIOD_S: f64 = 0.1;

/// Thrust of the wrongly turning motor's propeller in
/// [`Scenario::ReversedProp`], as a fraction of a correct one's: an
/// assumption (a propeller running with its airfoil backwards), not a
/// measurement.
pub const REVERSED_PROP_FRACTION: f64 = 0.7;

impl Scenario {
    /// Names for the command line.
    pub const NAMES: [&'static str; 11] = [
        "takeoff",
        "steps",
        "althold",
        "linkloss",
        "motorfail",
        "swapped",
        "reversedprop",
        "climbloss",
        "flapping",
        "chirp",
        "lowbattery",
    ];

    /// By name.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "takeoff" => Self::Takeoff,
            "steps" => Self::Steps,
            "althold" => Self::AltHold,
            "linkloss" => Self::LinkLoss,
            "motorfail" => Self::MotorFailure,
            "swapped" => Self::Swapped,
            "reversedprop" => Self::ReversedProp,
            "climbloss" => Self::ClimbLinkLoss,
            "flapping" => Self::Flapping,
            "chirp" => Self::Chirp,
            "lowbattery" => Self::LowBattery,
            _ => return None,
        })
    }

    /// Short name.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Takeoff => "takeoff",
            Self::Steps => "steps",
            Self::AltHold => "althold",
            Self::LinkLoss => "linkloss",
            Self::MotorFailure => "motorfail",
            Self::Swapped => "swapped",
            Self::ReversedProp => "reversedprop",
            Self::ClimbLinkLoss => "climbloss",
            Self::Flapping => "flapping",
            Self::Chirp => "chirp",
            Self::LowBattery => "lowbattery",
        }
    }

    /// Length of the scenario (s).
    pub fn duration_s(&self) -> f64 {
        match self {
            Self::Takeoff => 20.0,
            Self::Steps => 22.0,
            Self::AltHold => 26.0,
            Self::LinkLoss => 30.0,
            Self::MotorFailure => 16.0,
            Self::Swapped | Self::ReversedProp => 8.0,
            Self::ClimbLinkLoss => 26.0,
            Self::Flapping => 18.0,
            Self::Chirp => CHIRP_START_S + 3.0 * CHIRP_AXIS_PERIOD_S,
            Self::LowBattery => 45.0,
        }
    }

    /// The airframe as built: the 250-class quad, with the scenario's
    /// wiring error.
    pub fn airframe(&self) -> QuadParams {
        let quad = QuadParams::class_250();
        match self {
            Self::Swapped => quad.with_swapped_esc_signals(0, 1),
            Self::ReversedProp => quad.with_reversed_motor(0, REVERSED_PROP_FRACTION),
            Self::LowBattery => {
                let mut q = quad;
                q.battery.capacity_ah = LOW_BATTERY_CAPACITY_AH;
                q.battery.used_at_start_ah = LOW_BATTERY_CAPACITY_AH * (1.0 - LOW_BATTERY_CHARGE);
                q
            }
            _ => quad,
        }
    }

    /// Whether motor index `i` has failed at `t_s` (it then gets no power
    /// whatever it is commanded).
    pub fn motor_failed(&self, i: usize, t_s: f64) -> bool {
        *self == Self::MotorFailure && i == 0 && t_s >= MOTOR_FAILURE_S
    }

    /// Whether the script's link is down at `t_s`.
    pub fn link_down(&self, t_s: f64) -> bool {
        match self {
            Self::LinkLoss => t_s >= LINK_LOSS_S,
            Self::ClimbLinkLoss => t_s >= CLIMB_LOSS_S,
            Self::Flapping => {
                let since = t_s - FLAP_S;
                (0.0..FLAP_HOLD_S).contains(&since)
                    && (since / FLAP_HALF_PERIOD_S).floor() as i64 % 2 == 1
            }
            _ => false,
        }
    }

    /// The radio frame at `t_s` (`None`: link lost).
    pub fn pilot(&self, t_s: f64) -> Option<Pilot> {
        if self.link_down(t_s) {
            return None;
        }
        let mut sticks = Sticks {
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
            throttle: 0.5,
        };
        if t_s < CLIMB_FROM_S {
            // Arming wants the throttle low; it is centred (hold) only once airborne is asked for.
            sticks.throttle = 0.0;
        } else if t_s < CLIMB_TO_S {
            sticks.throttle = CLIMB_STICK;
        }
        let within = |t0: f64, len: f64| t_s >= t0 && t_s < t0 + len;
        let mut mode = Mode::AltitudeHold;
        match self {
            Self::Steps => {
                if within(ROLL_STEP_S, STEP_HOLD_S) {
                    sticks.roll = STEP_STICK;
                }
                if within(PITCH_STEP_S, STEP_HOLD_S) {
                    sticks.pitch = STEP_STICK;
                }
                if within(YAW_STEP_S, STEP_HOLD_S) {
                    sticks.yaw = STEP_STICK;
                }
            }
            Self::AltHold => {
                if within(CLIMB2_S, CLIMB2_HOLD_S) {
                    sticks.throttle = 1.0;
                }
                if within(FORWARD_S, FORWARD_HOLD_S) {
                    sticks.pitch = FORWARD_STICK;
                }
            }
            Self::ClimbLinkLoss => {
                if t_s >= CLIMB_LOSS_THROTTLE_S {
                    sticks.throttle = 1.0;
                    mode = Mode::Angle;
                }
            }
            Self::Chirp => {
                if let Some((axis, stick)) = chirp_stick(t_s) {
                    mode = Mode::Acro;
                    match axis {
                        0 => sticks.roll = stick,
                        1 => sticks.pitch = stick,
                        _ => sticks.yaw = stick,
                    }
                }
            }
            Self::Takeoff
            | Self::LinkLoss
            | Self::MotorFailure
            | Self::Swapped
            | Self::ReversedProp
            | Self::Flapping
            | Self::LowBattery => {}
        }
        if t_s < ARM_AT_S {
            mode = Mode::Angle;
        }
        Some(Pilot {
            sticks,
            arm: t_s >= ARM_AT_S,
            mode,
        })
    }
}

/// Chirp: the first sweep (roll) starts here (s), after the take-off
/// and 2 s of hover.
pub const CHIRP_START_S: f64 = 8.0;
/// Length of one axis' sweep (s).
pub const CHIRP_SWEEP_S: f64 = 20.0;
/// Altitude hold between two sweeps (s): the craft levels and settles.
pub const CHIRP_REST_S: f64 = 3.0;
/// One axis: its sweep and the rest after it (s).
pub const CHIRP_AXIS_PERIOD_S: f64 = CHIRP_SWEEP_S + CHIRP_REST_S;
/// Lowest frequency of the sweep (Hz): at the roll/pitch stick's ≈ 85 °/s
/// the craft swings ±19° here, within the ±30° a sweep should stay in.
pub const CHIRP_F0_HZ: f64 = 0.7;
/// Highest frequency of the sweep (Hz): the 4 ms CRSF frames hold the
/// stick for a third of a period here (the staircase is the controller's
/// own setpoint, which the analysis uses, so it only colours the
/// excitation), and the loop's response is far below its crossover.
pub const CHIRP_F1_HZ: f64 = 80.0;
/// Roll and pitch stick amplitude: ≈ 85 °/s through the default shaping
/// (500 °/s, expo 0.3, 2 % deadband); small enough that the D term at the
/// top of the sweep stays within the torque range.
pub const CHIRP_STICK_RP: f32 = 0.25;
/// Yaw stick amplitude: ≈ 75 °/s through the default yaw shaping (300 °/s).
pub const CHIRP_STICK_YAW: f32 = 0.35;

/// The chirp's stick at `t_s`: the axis (0 roll, 1 pitch, 2 yaw) and the
/// deflection, `None` outside the sweeps. A logarithmic sweep from
/// [`CHIRP_F0_HZ`] to [`CHIRP_F1_HZ`] over [`CHIRP_SWEEP_S`], phase
/// `2π f0 T / ln k · (k^(t/T) − 1)` with `k = f1/f0`, as a cosine so the
/// angle it drives (its integral) swings about the start instead of
/// drifting to one side.
pub fn chirp_stick(t_s: f64) -> Option<(usize, f32)> {
    let since = t_s - CHIRP_START_S;
    if since < 0.0 {
        return None;
    }
    let axis = (since / CHIRP_AXIS_PERIOD_S).floor() as usize;
    let t = since - axis as f64 * CHIRP_AXIS_PERIOD_S;
    if axis > 2 || t >= CHIRP_SWEEP_S {
        return None;
    }
    let k_ln = (CHIRP_F1_HZ / CHIRP_F0_HZ).ln();
    let phase = 2.0 * core::f64::consts::PI * CHIRP_F0_HZ * CHIRP_SWEEP_S / k_ln
        * ((k_ln * t / CHIRP_SWEEP_S).exp() - 1.0);
    let amplitude = if axis == 2 {
        CHIRP_STICK_YAW
    } else {
        CHIRP_STICK_RP
    };
    Some((axis, amplitude * phase.cos() as f32))
}

/// What the pilot sees of the craft (by eye: the truth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seen {
    /// Roll and pitch (rad, ZYX Euler).
    pub tilt_rad: [f64; 2],
    /// Height above the take-off point (m).
    pub height_m: f64,
    /// Vertical speed, up (m/s).
    pub climb_mps: f64,
    /// The mean of the four motor commands (0..1): what the pilot's
    /// throttle gives in altitude hold, heard as the hover's pitch.
    pub mean_motor: f64,
}

/// The pilot's hand in acro during a sweep: the throttle holds the height
/// the sweep began at (a PD on the height about the hover throttle heard
/// in altitude hold just before, plus a slow integral), and the roll and
/// pitch sticks pull the tilt back to level at ≈ 0.15 Hz, well below the
/// sweep's band, so the sweep is the setpoint's content there. Outside
/// acro it only listens.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AcroHand {
    hover: Option<f64>,
    height_ref_m: Option<f64>,
    integral: f64,
    last_t_s: Option<f64>,
}

/// Throttle per metre of height error.
const HAND_HEIGHT_P: f64 = 0.08;
/// Throttle per m/s of vertical speed.
const HAND_CLIMB_D: f64 = 0.08;
/// Throttle per metre-second of height error.
const HAND_HEIGHT_I: f64 = 0.02;
/// Roll/pitch stick per radian of tilt: at the default 500 °/s and expo
/// 0.3 a stick `s` asks about 0.7 · 500 °/s · s, so 0.15 per radian is
/// a rate of ≈ 0.9 rad/s per rad (0.15 Hz).
const HAND_TILT_STICK_PER_RAD: f64 = 0.15;

impl AcroHand {
    /// The pilot's frame with the hand's corrections, given what is seen
    /// at `t_s`.
    pub fn fly(&mut self, pilot: Option<Pilot>, seen: &Seen, t_s: f64) -> Option<Pilot> {
        let dt_s = self.last_t_s.map_or(0.0, |t| (t_s - t).max(0.0));
        self.last_t_s = Some(t_s);
        let mut p = pilot?;
        if p.mode != Mode::Acro {
            self.hover = Some(seen.mean_motor);
            self.height_ref_m = None;
            self.integral = 0.0;
            return Some(p);
        }
        let h_ref = *self.height_ref_m.get_or_insert(seen.height_m);
        let err_m = h_ref - seen.height_m;
        self.integral += HAND_HEIGHT_I * err_m * dt_s;
        let hover = self.hover.unwrap_or(f64::from(p.sticks.throttle));
        let throttle =
            hover + self.integral + HAND_HEIGHT_P * err_m - HAND_CLIMB_D * seen.climb_mps;
        p.sticks.throttle = throttle.clamp(0.0, 1.0) as f32;
        let level = |t: f64| (-HAND_TILT_STICK_PER_RAD * t) as f32;
        p.sticks.roll += level(seen.tilt_rad[0]);
        p.sticks.pitch -= level(seen.tilt_rad[1]);
        Some(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scenario_arms_after_the_start_up_and_names_round_trip() {
        for name in Scenario::NAMES {
            let s = Scenario::from_name(name).unwrap_or(Scenario::Takeoff);
            assert_eq!(s.name(), name);
            let before = s.pilot(ARM_AT_S - 0.01).map(|p| p.arm);
            let after = s.pilot(ARM_AT_S).map(|p| p.arm);
            assert_eq!((before, after), (Some(false), Some(true)), "{name}");
            // Arming wants the throttle low.
            assert_eq!(s.pilot(ARM_AT_S).map(|p| p.sticks.throttle), Some(0.0));
        }
    }

    #[test]
    fn channels_follow_the_default_map() {
        let p = Pilot {
            sticks: Sticks {
                roll: 1.0,
                pitch: -1.0,
                yaw: 0.5,
                throttle: 0.0,
            },
            arm: true,
            mode: Mode::AltitudeHold,
        };
        assert_eq!(p.channels_us(), [2000, 1000, 1000, 1750, 2000, 1500]);
    }

    #[test]
    fn the_link_loss_script_sends_nothing_after_the_loss() {
        assert!(Scenario::LinkLoss.pilot(LINK_LOSS_S - 0.001).is_some());
        assert!(Scenario::LinkLoss.pilot(LINK_LOSS_S).is_none());
        assert!(Scenario::Flapping.pilot(FLAP_S + 0.05).is_some());
        assert!(Scenario::Flapping.pilot(FLAP_S + 0.15).is_none());
        assert!(Scenario::Flapping
            .pilot(FLAP_S + FLAP_HOLD_S + 0.15)
            .is_some());
        assert!(Scenario::ClimbLinkLoss.pilot(CLIMB_LOSS_S).is_none());
        assert!(Scenario::MotorFailure.motor_failed(0, MOTOR_FAILURE_S));
        assert!(!Scenario::MotorFailure.motor_failed(1, MOTOR_FAILURE_S));
    }
}
