//! The flight controller: pilot input + attitude + gyro + time → four motor
//! commands, the flight state and events. The firmware calls
//! [`FlightController::step`] once per IMU sample (1 kHz) and writes
//! [`Motors`] to the ESC timer; nothing else decides anything.
//!
//! ```
//! use control::esc::{EscProtocol, EscTimer};
//! use flight::flightctl::*;
//! use sensor_stack::pipeline::{Pipeline, PipelineConfig};
//!
//! let pipeline = Pipeline::new(PipelineConfig::new(), &Default::default()).unwrap();
//! let esc = EscTimer::for_clock(EscProtocol::Pwm, 400, 72_000_000).unwrap();
//! let mut fc = FlightController::new(FlightConfig::default()).unwrap();
//! let status = SystemStatus {
//!     sensors_healthy: true,
//!     gyro_bias_done: true,
//!     calibration_running: false,
//!     accel_calibrated: true,
//! };
//! let mut pilot = PilotInput { link_ok: true, ..Default::default() };
//! let vehicle = VehicleState::from_pipeline(&pipeline);
//! let out = fc.step(1_000, &pilot, &status, &vehicle);       // switch off
//! assert_eq!(out.motors.compares(&esc), [esc.off_compare(); 4]);
//! pilot.arm_switch = true;                                    // off → on: arm
//! let out = fc.step(2_000, &pilot, &status, &vehicle);
//! assert!(out.events.contains(Event::Armed));
//! let out = fc.step(3_000, &pilot, &status, &vehicle);       // from the next step: idle
//! assert!(out.motors.compares(&esc)[0] > esc.off_compare());
//! ```
//!
//! # Rules
//!
//! **Arming** happens on the arm switch going off → on (a switch already on
//! at boot, or when the link comes up, never arms) when none of the
//! [`ArmRefusal`]s applies: link up, no calibration running, sensors
//! healthy, gyro bias measured, attitude usable, tilt ≤
//! [`SafetyConfig::arm_max_tilt_deg`] (25°), throttle stick ≤
//! [`SafetyConfig::arm_throttle_max`], no motor test, and in angle and
//! altitude-hold mode an applied accelerometer calibration
//! ([`SystemStatus::accel_calibrated`]; the MPU-9250's zero-g offset of
//! ±60–80 mg per axis is 3–5° of false level and a steady drift; acro, which
//! never uses the level reference, arms without it; once armed, switching
//! to a self-levelling mode is not refused, and the failsafe levels on the
//! uncalibrated reference). A refusal is reported
//! once as [`Event::ArmRefused`] with its first reason; the switch must go
//! off and on again. Armed, the motors run at least at the mixer's idle.
//!
//! **Modes** ([`FlightMode`]): acro (sticks → body rates), angle
//! (self-level: sticks → tilt, P on the quaternion error → rates,
//! [`control::levelq`] on the Q30 quaternion) and altitude hold (angle +
//! [`AltitudeHoldQ`] on the estimator's height; the
//! throttle stick centred ± [`SafetyConfig::althold_deadband`] holds
//! height, beyond it climbs or descends up to
//! [`SafetyConfig::althold_max_climb_mps`]). Without an altitude estimate
//! altitude hold falls back to angle with manual throttle. Until take-off
//! (the collective first above [`SafetyConfig::land_collective_max`]) the
//! rate loop is reset every step, so nothing winds up on the ground; after
//! it the loop runs at any throttle (the mixer raises the collective to keep
//! authority at idle), its integrals held while the collective is below
//! that threshold (a landed craft waiting for the landing disarm does not
//! wind up against the ground; a descent at low throttle keeps its trim).
//!
//! **Disarm** ([`DisarmCause`]): arm switch off; crash (tilt > 70° for
//! 0.5 s in a self-levelling mode or failsafe — acro may fly inverted — or
//! any body rate ≥ 950 °/s for 0.3 s in any mode); landing (after having
//! taken off, for 2 s: collective < 0.15, every rate < 20 °/s, and with an
//! altitude estimate |vertical speed| < 0.3 m/s, without one the throttle
//! stick ≤ [`SafetyConfig::arm_throttle_max`] (5 %); see "Landing
//! detection" below); no take-off within 5 s of arming;
//! unusable attitude/gyro for [`SafetyConfig::bad_input_disarm_s`]
//! (0.25 s, bridged until then: below); runaway take-off (torque ≥ 0.6
//! while turning for 75 ms before 0.5 s of normal flight,
//! [`crate::runaway`]). The motors are [`Motors::Off`] whenever disarmed.
//!
//! **Sensor loss** while armed (no gyro sample, or an unusable attitude;
//! see [`VehicleState`]: the sample was lost, the MPU-9250 is being
//! re-initialised or settling): the last
//! motor commands for [`BAD_INPUT_HOLD_US`] (10 ms: single lost samples
//! pass unnoticed), then even thrust at the last collective (the mixer with
//! no torque, so the craft keeps the attitude and rate it had and nothing
//! the rate loop last commanded keeps accelerating it), until
//! [`SafetyConfig::bad_input_disarm_s`] (0.25 s) without a usable sample
//! disarms ([`DisarmCause::SensorFault`]). Each such step reports
//! [`Event::InputRejected`]; the arm switch still disarms at once. Why
//! 0.25 s: it covers an MPU-9250 reset in flight (its samples stop for the
//! reset's steps, ≤ 40 ms, and the 100 ms settle after it) with margin;
//! open loop, a 250-class quad (≈ 2·10⁻³ kg·m² about roll, rotors 0.09 m
//! off the axis) with a 1 % thrust mismatch (≈ 0.05 N) turns ≈ 4° in
//! 0.25 s from a steady hover, plus whatever rate it had when the samples
//! stopped; much longer and it would not be recoverable.
//!
//! **Pilot signal loss** while armed: level hold (tilt 0, yaw rate 0) for
//! [`SafetyConfig::failsafe_hold_s`] (1 s) at the current height with
//! altitude hold if an altitude estimate exists, else at the last
//! collective but never above the hover estimate (see "Hover estimate"
//! below; a link lost in a full-throttle climb does not keep full power);
//! then, with altitude, a descent at
//! [`SafetyConfig::failsafe_descent_mps`] (0.5 m/s) until the landing
//! detector disarms ([`DisarmCause::FailsafeLanded`]); without altitude a
//! disarm ([`DisarmCause::FailsafeNoAltitude`]). Should the altitude
//! estimate fail during the descent, the collective ramps down at
//! [`FAILSAFE_BLIND_RAMP_PER_S`] to zero, and the disarm
//! ([`DisarmCause::FailsafeLanded`]) follows 2 s at zero without rotation.
//! If the link returns during
//! the failsafe, the pilot has control again (and the arm switch decides).
//!
//! **Motor test** (props off!): each off → on flip of the motor-test switch
//! ([`PilotInput::motor_test_switch`], rules in [`crate::motortest`]) or a
//! call of [`FlightController::start_motor_test`], while disarmed, link up,
//! arm switch off and throttle low, spins one motor at
//! [`SafetyConfig::motor_test_command`] (8 %), the others off, for at most
//! [`SafetyConfig::motor_test_max_s`]; the flips take motors 1, 2, 3, 4,
//! then 1 again. Any stick movement beyond
//! [`SafetyConfig::motor_test_stick_tolerance`], the arm switch, link loss
//! or (when the switch started it) the switch going off end it. A refused
//! flip is reported as [`Event::MotorTestRefused`] with its reason, and
//! arming is refused while the switch is on.
//!
//! # Landing detection
//!
//! A craft descending steadily at low throttle and a craft standing on the
//! ground both measure about 1 g of specific force and no rotation: the
//! accelerometer and gyro alone cannot tell them apart, and neither can a
//! low collective (the descent is what a low collective makes). The
//! detector therefore needs evidence that only a landed craft shows:
//!
//! * **with an altitude estimate** (barometer): |vertical speed| < 0.3 m/s
//!   with the collective < 0.15 and every rate < 20 °/s, for 2 s. At a
//!   collective that low the thrust is a fraction of the weight, so a craft
//!   in the air sinks faster than 0.3 m/s within a fraction of a second;
//! * **without one**, under pilot control: the pilot's throttle stick at
//!   its minimum (≤ [`SafetyConfig::arm_throttle_max`], 5 %) with the same
//!   collective and rate limits, for 2 s. A pilot holding zero throttle
//!   commands idle anyway; a descent flown with any throttle above that
//!   never disarms, however slow or fast;
//! * **without one, in a failsafe**: no landing disarm but the failsafe's
//!   own: the level hold disarms after 1 s
//!   ([`DisarmCause::FailsafeNoAltitude`]), and a descent that lost its
//!   altitude estimate ramps its collective to zero, then disarms after
//!   2 s at zero without rotation.
//!
//! # Hover estimate
//!
//! The collective low-passed with a time constant of [`HOVER_TAU_S`]
//! (1.5 s) while the pilot flies (armed, taken off, no failsafe) within 15°
//! of level ([`HOVER_LEVEL_COS_TILT`]), seeded by the first such step
//! ([`FlightController::hover_collective`]). The failsafe's level hold
//! without altitude flies at the lower of the last collective and this
//! estimate bounded between [`SafetyConfig::land_collective_max`] (0.15)
//! and [`SafetyConfig::failsafe_collective_max`] (0.6): about a hover when
//! the link is lost in a hover, at most 0.6 when it is lost in a climb
//! (a full-throttle second moves the estimate about halfway up).
//!
//! # Time
//!
//! `now_us` is a free-running, wrapping microsecond clock (e.g.
//! [`sensor_stack::schedule::MicrosClock`]). The step's `dt` is the wrapped
//! difference, limited to [`MAX_DT_US`] (a stalled loop does not integrate
//! a huge step); two calls with the same time do not run the loops again.

use control::controllers::{AltitudeHoldConfig, BodyRates, TorqueCommand};
use control::esc::EscTimer;
use control::fixed::{f32_to_q, q_to_f32, AltitudeHoldQ, ONE_Q30};
use control::levelq::{LevelControllerQ, QuatQ30, TiltQ30};
use control::loops::{LevelConfig, Quat, RateConfig};
use control::mixer::{MixerConfig, MOTORS};
use control::rateq::{torque_from_q30, MixOutputQ, MixerQ, RateControllerQ};
use control::shaping::{Sticks, SticksConfig};
use control::shapingq::StickShapingQ;

use crate::motortest::{MotorTestSwitch, SwitchRequest};
use crate::runaway::RunawayCheck;
use sensor_stack::pipeline::Pipeline;

use crate::arming::q16_limit;
pub use crate::arming::{
    ArmBlockers, ArmRefusal, DisarmCause, Event, Events, MotorTestEnd, MotorTestRefusal,
    SafetyConfig, SafetyField,
};

const RAD_PER_DEG: f32 = core::f32::consts::PI / 180.0;

/// Longest step the loops integrate, µs.
pub const MAX_DT_US: u32 = 20_000;
/// Collective ramp-down per second in a failsafe descent that lost its
/// altitude estimate (hover at ~0.5 reaches the landing threshold in ~7 s).
pub const FAILSAFE_BLIND_RAMP_PER_S: f32 = 0.05;
/// Unusable attitude/gyro input for this long keeps the last motor
/// commands, µs; then even thrust at the last collective (see "Sensor
/// loss" in the [module docs](self)). Held longer, a torque the rate loop
/// commanded in a manoeuvre keeps accelerating the craft: 10 ms of a
/// 0.5 N thrust differential (10 % of a 0.5 kg quad's hover thrust) on a
/// 250-class quad (≈ 2·10⁻³ kg·m², 0.09 m lever) builds ≈ 13 °/s.
pub const BAD_INPUT_HOLD_US: u32 = 10_000;
/// How long the collective must stay above the landing threshold before
/// the craft counts as flying ([`FlightController::in_flight`], µs): the
/// altitude hold's take-off spins the motors up to lift-off in about 1 s of
/// it, a manual one is quicker.
pub const IN_FLIGHT_AFTER_US: u32 = 1_500_000;
// The sensor stack calls the MPU-9250 suspect after the same gap.
const _: () = assert!(BAD_INPUT_HOLD_US == sensor_stack::sensors::MPU_STALL_US);
/// Time constant of the hover-collective estimate's low-pass, s: long
/// enough that a manoeuvre of a second or two moves it by less than half
/// its excursion, short enough to follow the battery's sag.
pub const HOVER_TAU_S: f32 = 1.5;
/// The hover estimate's low-pass gain per µs, Q30: `2³⁰/τ` with τ in µs
/// (forward Euler: `dt/τ` rather than `dt/(τ + dt)`, 0.07 % apart at 1 ms).
const HOVER_ALPHA_Q30_PER_US: i64 = ((1u64 << 30) as f32 / (HOVER_TAU_S * 1.0e6) + 0.5) as i64;
/// Cosine of the largest tilt at which the collective counts towards the
/// hover estimate (15°: tilted, a hover needs `1/cos` more, here ≤ 3.5 %).
pub const HOVER_LEVEL_COS_TILT: f32 = 0.966;
/// [`HOVER_LEVEL_COS_TILT`] in Q30.
const HOVER_LEVEL_COS_TILT_Q30: i32 = (HOVER_LEVEL_COS_TILT * (1u32 << 30) as f32) as i32;
/// Step assumed for the first call, µs (the 1 kHz IMU period).
pub const FIRST_DT_US: u32 = 1_000;
/// The rate loop's constant period, s: the IMU's 1 kHz. The loop runs in
/// fixed point ([`control::rateq`]) and counts every step as one period
/// (a step that stands for two merged samples integrates one), as
/// Betaflight's loop does at its target loop time.
pub const RATE_LOOP_PERIOD_S: f32 = 0.001;

/// How the pilot flies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FlightMode {
    /// Sticks command body rates.
    Acro,
    /// Self-level: sticks command tilt, yaw stick a rate.
    #[default]
    Angle,
    /// Self-level with altitude hold on the throttle stick.
    AltitudeHold,
}

/// The pilot's input as the receiver code delivers it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PilotInput {
    /// Normalised sticks (roll/pitch/yaw −1..1, throttle 0..1).
    pub sticks: Sticks,
    /// Arm switch position (true = arm).
    pub arm_switch: bool,
    /// Requested flight mode.
    pub mode: FlightMode,
    /// Valid frames are arriving (false = signal lost; the other fields are
    /// then ignored).
    pub link_ok: bool,
    /// Motor-test switch position (true = on; see [`crate::motortest`]).
    pub motor_test_switch: bool,
}

impl PilotInput {
    /// From the receiver crate's mapped sticks (same conventions: roll and
    /// yaw +1 = right, pitch +1 = forward = nose down, throttle 0..1), the
    /// arm switch, the selected mode and the link state; the motor-test
    /// switch off.
    pub fn from_rc(
        sticks: &rc_input::Sticks,
        arm_switch: bool,
        mode: FlightMode,
        link_ok: bool,
    ) -> Self {
        Self {
            sticks: Sticks {
                roll: sticks.roll,
                pitch: sticks.pitch,
                yaw: sticks.yaw,
                throttle: sticks.throttle,
            },
            arm_switch,
            mode,
            link_ok,
            motor_test_switch: false,
        }
    }
}

/// Readiness of the rest of the firmware, for the arming checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SystemStatus {
    /// Every sensor the flight needs (IMU at least) is healthy.
    pub sensors_healthy: bool,
    /// The start-up gyro bias has been measured.
    pub gyro_bias_done: bool,
    /// A calibration mode is running.
    pub calibration_running: bool,
    /// The accelerometer calibration (six-position fit) is applied: the
    /// pipeline's [`Pipeline::accel_calibrated`]. Without it only acro arms.
    pub accel_calibrated: bool,
}

/// Vertical state from the estimator, in Q16 (the altitude hold's
/// format: ±32 768 m, m/s).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AltitudeEstimate {
    /// Height above the take-off reference, Q16 m, up.
    pub height_m_q16: i32,
    /// Vertical speed, Q16 m/s, up.
    pub vertical_speed_mps_q16: i32,
}

impl AltitudeEstimate {
    /// From the estimator's `f32` height (m) and vertical speed (m/s), by
    /// the bits ([`f32_to_q`], saturating); `None` unless both are finite.
    pub fn from_f32(height_m: f32, vertical_speed_mps: f32) -> Option<Self> {
        (height_m.is_finite() && vertical_speed_mps.is_finite()).then(|| Self {
            height_m_q16: f32_to_q(height_m, 16),
            vertical_speed_mps_q16: f32_to_q(vertical_speed_mps, 16),
        })
    }

    /// Height, m, up (logs, plots, tests).
    pub fn height_m(&self) -> f32 {
        q_to_f32(self.height_m_q16, 16)
    }

    /// Vertical speed, m/s, up (logs, plots, tests).
    pub fn vertical_speed_mps(&self) -> f32 {
        q_to_f32(self.vertical_speed_mps_q16, 16)
    }
}

/// What the pipeline knows about the vehicle, in the fixed-point forms the
/// pipeline keeps and the per-sample path flies on (no `f32` round trip
/// between them); [`from_f32`](Self::from_f32) builds it on a host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VehicleState {
    /// Attitude `q_ned_from_body` in Q30 (`[w, x, y, z]`). Unusable, as a
    /// lost attitude is, when a component is beyond ±1.5 or `|q|²` outside
    /// 0.25..2 ([`QuatQ30::norm2_q60`]), for example
    /// [`VehicleState::NO_ATTITUDE`].
    pub attitude_q30: QuatQ30,
    /// Gyro body rates (bias removed), Q16 rad/s, FRD (roll, pitch, yaw);
    /// `None` without a usable sample.
    pub gyro_rps_q16: Option<[i32; 3]>,
    /// Height and vertical speed, when a barometer is running.
    pub altitude: Option<AltitudeEstimate>,
}

/// What goes to the ESCs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Motors {
    /// Every ESC at its "off" pulse.
    Off,
    /// Commands 0..1 per motor in Q30 (`1 << 30` = full), as the
    /// fixed-point mixer makes them (mixer order: index 0 = Betaflight
    /// motor 1, rear right; see [`control::mixer`]); to the timer with one
    /// `UMULL` each ([`EscTimer::compare_q30`]).
    Run([i32; MOTORS]),
}

impl Motors {
    /// Commands per motor as `f32` 0..1, 0 for off (logs, plots, tests).
    pub fn commands(&self) -> [f32; MOTORS] {
        match self {
            Self::Off => [0.0; MOTORS],
            Self::Run(m) => m.map(|c| q_to_f32(c, 30)),
        }
    }

    /// Running at `f32` commands 0..1 (converted to Q30 by their bits).
    pub fn run_f32(commands: [f32; MOTORS]) -> Self {
        Self::Run(commands.map(|c| f32_to_q(c, 30)))
    }

    /// Timer compare values per motor (`CCRn`), the "off" pulse for
    /// [`Motors::Off`]: what the firmware writes and the emulator expects.
    pub fn compares(&self, esc: &EscTimer) -> [u16; MOTORS] {
        match self {
            Self::Off => [esc.off_compare(); MOTORS],
            Self::Run(m) => [
                esc.compare_q30(m[0]),
                esc.compare_q30(m[1]),
                esc.compare_q30(m[2]),
                esc.compare_q30(m[3]),
            ],
        }
    }
}

impl VehicleState {
    /// An attitude the controller refuses (zero norm).
    pub const NO_ATTITUDE: QuatQ30 = QuatQ30([0; 4]);

    /// The pipeline's latest attitude (Q30) and gyro (Q16 rad/s) as it
    /// keeps them, and (when the barometer runs) the altitude.
    pub fn from_pipeline(p: &Pipeline) -> Self {
        Self {
            attitude_q30: QuatQ30(p.quaternion_q30()),
            gyro_rps_q16: Some(p.body_rates_q16()),
            altitude: p
                .altitude_estimate()
                .and_then(|(h, v)| AltitudeEstimate::from_f32(h, v)),
        }
    }

    /// From `f32` values (hosts, tests): the attitude to Q30 and the rates
    /// to Q16 rad/s by the bits ([`f32_to_q`]); a non-finite attitude
    /// becomes [`NO_ATTITUDE`](Self::NO_ATTITUDE), non-finite rates `None`.
    pub fn from_f32(attitude: &Quat, gyro: &BodyRates, altitude: Option<AltitudeEstimate>) -> Self {
        let q = [attitude.w, attitude.x, attitude.y, attitude.z];
        let g = [gyro.roll_rps, gyro.pitch_rps, gyro.yaw_rps];
        Self {
            attitude_q30: if q.iter().all(|c| c.is_finite()) {
                QuatQ30(q.map(|c| f32_to_q(c, 30)))
            } else {
                Self::NO_ATTITUDE
            },
            gyro_rps_q16: g
                .iter()
                .all(|r| r.is_finite())
                .then(|| g.map(|r| f32_to_q(r, 16))),
            altitude,
        }
    }

    /// The attitude as an `f32` quaternion (logs, tests).
    pub fn attitude(&self) -> Quat {
        let [w, x, y, z] = self.attitude_q30.0.map(|c| q_to_f32(c, 30));
        Quat { w, x, y, z }
    }

    /// The gyro in `f32` rad/s, `None` without a usable sample (logs, tests).
    pub fn gyro(&self) -> Option<BodyRates> {
        self.gyro_rps_q16.map(|[r, p, y]| BodyRates {
            roll_rps: q_to_f32(r, 16),
            pitch_rps: q_to_f32(p, 16),
            yaw_rps: q_to_f32(y, 16),
        })
    }
}

/// Failsafe phase.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FailsafePhase {
    /// Holding level (and height, if known).
    Hold,
    /// Descending at the failsafe rate.
    Descend,
}

/// The controller's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FlightState {
    /// Motors off.
    Disarmed,
    /// Flying under pilot control.
    Armed,
    /// Pilot link lost while armed.
    Failsafe(FailsafePhase),
    /// Props-off motor test on motor index `0..=3`.
    MotorTest(u8),
}

/// One step's result.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightOutput {
    /// ESC commands.
    pub motors: Motors,
    /// State after this step.
    pub state: FlightState,
    /// What happened in this step.
    pub events: Events,
    /// Mode actually flown (altitude hold falls back to angle without altitude).
    pub mode: FlightMode,
    /// Body-rate setpoint, rad/s (zero when not flying).
    pub rate_setpoint: BodyRates,
    /// Rate-loop torque command, −1..1.
    pub torque: TorqueCommand,
    /// Collective throttle asked of the mixer, 0..1.
    pub collective: f32,
    /// The mixer's saturation report in fixed point (`None` when not
    /// flying; [`MixOutputQ::to_f32`] for the `f32` form).
    pub mix: Option<MixOutputQ>,
}

/// Every tuning of the flight controller.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightConfig {
    /// Stick shaping.
    pub sticks: SticksConfig,
    /// Rate loop.
    pub rate: RateConfig,
    /// Self-level loop.
    pub level: LevelConfig,
    /// Altitude hold (its output limits are the collective limits).
    pub altitude_hold: AltitudeHoldConfig,
    /// Mixer (idle).
    pub mixer: MixerConfig,
    /// Arming, crash, landing, failsafe, motor test.
    pub safety: SafetyConfig,
}

/// Why [`FlightController::new`] refused its configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FlightConfigError {
    /// A control-crate configuration (sticks, loops, mixer, altitude hold).
    Control(control::Error),
    /// A safety limit.
    Safety(SafetyField),
}

impl From<control::Error> for FlightConfigError {
    fn from(e: control::Error) -> Self {
        Self::Control(e)
    }
}

impl core::fmt::Display for FlightConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Control(e) => write!(f, "flight configuration: {e}"),
            Self::Safety(field) => write!(f, "safety configuration: {field:?} out of range"),
        }
    }
}

impl core::error::Error for FlightConfigError {}

/// Seconds → µs, saturating (config times are validated ≤ 60 s).
fn us(s: f32) -> u32 {
    (s * 1.0e6) as u32
}

/// Converts the AHRS quaternion.
pub fn quat_from_ahrs(q: &fc_ahrs::Quaternion) -> Quat {
    Quat {
        w: q.w,
        x: q.x,
        y: q.y,
        z: q.z,
    }
}

/// A timer that counts while its condition holds and resets when it does not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Hold {
    us: u32,
}

impl Hold {
    /// Accumulates `dt_us` while `cond`; true once `limit_us` is reached.
    fn update(&mut self, cond: bool, dt_us: u32, limit_us: u32) -> bool {
        self.us = if cond {
            self.us.saturating_add(dt_us)
        } else {
            0
        };
        self.us >= limit_us
    }
}

/// Everything derived from one stick position (recomputed only when the
/// sticks change, at the receiver's frame rate rather than 1 kHz), in the
/// loops' formats.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Shaped {
    sticks: Sticks,
    /// Acro rate setpoints (roll, pitch, yaw), Q16 rad/s.
    acro_q16: [i32; 3],
    tilt: TiltQ30,
    /// Self-level modes' yaw rate, Q16 rad/s.
    yaw_q16: i32,
    throttle: f32,
    /// Altitude hold's climb demand, Q16 m/s.
    climb_q16: i32,
    /// The throttle stick at or below [`SafetyConfig::arm_throttle_max`].
    stick_at_min: bool,
}

impl Shaped {
    /// Shaped from no sticks: NaN sticks, never the same as a pilot's (the
    /// step refuses non-finite sticks before shaping), so the first step
    /// shapes. A constant, so the constructor has no shaping code to fold.
    const UNSET: Self = Self {
        sticks: Sticks {
            roll: f32::NAN,
            pitch: f32::NAN,
            yaw: f32::NAN,
            throttle: f32::NAN,
        },
        acro_q16: [0; 3],
        tilt: TiltQ30::LEVEL,
        yaw_q16: 0,
        throttle: 0.0,
        climb_q16: 0,
        stick_at_min: false,
    };

    /// Shapes one frame's sticks (finite: the step checked them) in fixed
    /// point ([`StickShapingQ`]).
    fn new(shaping: &StickShapingQ, climb: &ClimbQ, safety: &SafetyConfig, s: &Sticks) -> Self {
        let q = shaping.shape(s);
        Self {
            sticks: *s,
            acro_q16: q.acro_q16,
            tilt: q.tilt,
            yaw_q16: q.yaw_q16,
            throttle: q_to_f32(q.throttle_q30, 30),
            climb_q16: climb.demand_q16(s.throttle),
            stick_at_min: s.throttle <= safety.arm_throttle_max,
        }
    }

    /// Whether these are the sticks it was shaped from, by their bits (four
    /// integer compares rather than four soft-float ones; a stick that
    /// changes only between −0 and +0 is shaped once more).
    fn same_sticks(&self, s: &Sticks) -> bool {
        let a = &self.sticks;
        a.roll.to_bits() == s.roll.to_bits()
            && a.pitch.to_bits() == s.pitch.to_bits()
            && a.yaw.to_bits() == s.yaw.to_bits()
            && a.throttle.to_bits() == s.throttle.to_bits()
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct MotorTestRun {
    motor: u8,
    sticks: Sticks,
    elapsed_us: u32,
    /// Started by the motor-test switch: ends when the switch goes off.
    by_switch: bool,
}

/// Limits in the units the hot path compares against.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Limits {
    /// Q30.
    arm_cos_tilt: i32,
    /// Q30.
    crash_cos_tilt: i32,
    /// The crash rate, Q16 rad/s.
    crash_rate_q16: u32,
    /// The landing detector's rate limit, Q16 rad/s.
    land_rate_q16: u32,
    /// The landing detector's vertical speed limit, Q16 m/s.
    land_speed_q16: u32,
    crash_tilt_us: u32,
    crash_rate_us: u32,
    land_us: u32,
    idle_disarm_us: u32,
    failsafe_hold_us: u32,
    motor_test_us: u32,
    bad_input_us: u32,
    /// The failsafe descent's speed, Q16 m/s.
    failsafe_descent_q16: i32,
}

/// The flight controller. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightController {
    /// The safety rules' thresholds (the rest of [`FlightConfig`] lives on
    /// in its fixed-point forms below, not as `f32`).
    safety: SafetyConfig,
    lim: Limits,
    /// Stick shaping in fixed point, once per new pilot frame.
    shaping: StickShapingQ,
    climb: ClimbQ,
    /// The rate loop in fixed point at [`RATE_LOOP_PERIOD_S`].
    rate: RateControllerQ,
    /// The self-level loop in fixed point, on the Q30 quaternion.
    level: LevelControllerQ,
    /// The altitude hold's 1 kHz part in fixed point (Q16 m, m/s → Q30).
    alt: AltitudeHoldQ,
    mixer: MixerQ,
    state: FlightState,
    last_us: Option<u32>,
    /// Last arm-switch position seen with the link up (`None` at boot and
    /// after a link loss, so a switch found on never arms).
    prev_switch: Option<bool>,
    took_off: bool,
    /// How long the collective has been above the landing threshold without a
    /// break (µs): the in-flight verdict.
    above_land_us: u32,
    /// Altitude hold engaged (its target is valid).
    alt_engaged: bool,
    /// Altitude hold requested but unavailable (reported once per episode).
    alt_fallback: bool,
    /// The low-battery descent is asked for ([`FlightController::set_battery_descent`]).
    #[cfg(feature = "battery-descent")]
    battery_descent: bool,
    /// The height altitude hold holds, Q16 m (up).
    alt_target_q16: i32,
    last_collective: f32,
    /// The collective low-passed while flying near level under pilot
    /// control (`None` until the first such step after arming).
    hover_collective_q30: Option<i32>,
    /// This step's throttle stick at or below
    /// [`SafetyConfig::arm_throttle_max`] (pilot control only).
    stick_at_min: bool,
    last_motors: Motors,
    armed_us: u32,
    failsafe_us: u32,
    crash_tilt: Hold,
    crash_rate: Hold,
    landed: Hold,
    bad_input: Hold,
    runaway: RunawayCheck,
    motor_test: Option<MotorTestRun>,
    /// A calibration was running at the last step (refuses the motor test).
    calibrating: bool,
    test_switch: MotorTestSwitch,
    shaped: Shaped,
}

impl FlightController {
    /// Validates the configuration and starts disarmed.
    // `inline(always)` here and on the control crate's constructors and
    // validations: the firmware's configuration is a constant, so inlined
    // they fold at compile time (1.2 KiB of flash; out of line each check
    // is a soft-float call).
    #[inline(always)]
    pub fn new(cfg: FlightConfig) -> Result<Self, FlightConfigError> {
        cfg.safety.validate().map_err(FlightConfigError::Safety)?;
        let s = &cfg.safety;
        let lim = Limits {
            arm_cos_tilt: f32_to_q(s.arm_cos_tilt(), 30),
            crash_cos_tilt: f32_to_q(s.crash_cos_tilt(), 30),
            crash_rate_q16: q16_limit(s.crash_rate_dps * RAD_PER_DEG),
            land_rate_q16: q16_limit(s.land_rate_max_dps * RAD_PER_DEG),
            land_speed_q16: q16_limit(s.land_vertical_speed_max_mps),
            crash_tilt_us: us(s.crash_tilt_time_s),
            crash_rate_us: us(s.crash_rate_time_s),
            land_us: us(s.land_time_s),
            idle_disarm_us: us(s.idle_disarm_s),
            failsafe_hold_us: us(s.failsafe_hold_s),
            motor_test_us: us(s.motor_test_max_s),
            bad_input_us: us(s.bad_input_disarm_s),
            failsafe_descent_q16: f32_to_q(s.failsafe_descent_mps, 16),
        };
        let shaping = StickShapingQ::new(&cfg.sticks)?;
        Ok(Self {
            safety: cfg.safety,
            lim,
            shaping,
            climb: ClimbQ::new(s),
            rate: RateControllerQ::new(&cfg.rate, RATE_LOOP_PERIOD_S)?,
            level: LevelControllerQ::new(&cfg.level)?,
            alt: AltitudeHoldQ::new(&cfg.altitude_hold, RATE_LOOP_PERIOD_S)?,
            mixer: MixerQ::new(&cfg.mixer)?,
            state: FlightState::Disarmed,
            last_us: None,
            prev_switch: None,
            took_off: false,
            above_land_us: 0,
            alt_engaged: false,
            alt_fallback: false,
            #[cfg(feature = "battery-descent")]
            battery_descent: false,
            alt_target_q16: 0,
            last_collective: 0.0,
            hover_collective_q30: None,
            stick_at_min: false,
            last_motors: Motors::Off,
            armed_us: 0,
            failsafe_us: 0,
            crash_tilt: Hold::default(),
            crash_rate: Hold::default(),
            landed: Hold::default(),
            bad_input: Hold::default(),
            runaway: RunawayCheck::new(s),
            motor_test: None,
            calibrating: false,
            test_switch: MotorTestSwitch::new(),
            shaped: Shaped::UNSET,
        })
    }

    /// The safety rules in use (arming, crash and landing checks,
    /// failsafe, motor test).
    pub fn safety(&self) -> &SafetyConfig {
        &self.safety
    }

    /// The current state.
    pub fn state(&self) -> FlightState {
        self.state
    }

    /// True while the motors may spin under flight control.
    pub fn is_armed(&self) -> bool {
        matches!(self.state, FlightState::Armed | FlightState::Failsafe(_))
    }

    /// Asks for (`true`) or ends the low-battery descent. Armed under
    /// pilot control in a self-levelling mode (angle or altitude hold)
    /// with an altitude estimate, the craft then levels and descends at [`SafetyConfig::failsafe_descent_mps`] through the
    /// altitude hold until the landing detector disarms it on the ground
    /// ([`DisarmCause::Landed`]); in acro (which arms without the
    /// accelerometer's calibration, and may be flying inverted) or without
    /// an altitude estimate the request changes nothing (the low battery
    /// is then a warning only). When to
    /// ask, and how the pilot's sticks end it, is the caller's rule
    /// (`battery::LowBatteryDescent` in the firmware).
    #[cfg(feature = "battery-descent")]
    pub fn set_battery_descent(&mut self, on: bool) {
        self.battery_descent = on;
    }

    /// Whether the craft is flying: armed, with the collective above the
    /// landing threshold for the last [`IN_FLIGHT_AFTER_US`] without a break (a
    /// take-off is in the air by then; a collective at the landing threshold
    /// ends it at once, before a touch-down). For the AHRS's multirotor mode
    /// (`sensor_stack::pipeline::Pipeline::set_in_flight`), whose drag model
    /// does not hold on the ground.
    pub fn in_flight(&self) -> bool {
        self.is_armed() && self.above_land_us >= IN_FLIGHT_AFTER_US
    }

    /// The height altitude hold is holding (m, up), while it is engaged.
    pub fn altitude_target_m(&self) -> Option<f32> {
        (self.is_armed() && self.alt_engaged).then(|| q_to_f32(self.alt_target_q16, 16))
    }

    /// Everything that would refuse an arm request now (for a status LED
    /// or log; arming itself still needs the switch edge).
    pub fn arm_blockers(
        &self,
        pilot: &PilotInput,
        status: &SystemStatus,
        vehicle: &VehicleState,
    ) -> ArmBlockers {
        let mut b = ArmBlockers::NONE;
        if !pilot.link_ok {
            b.insert(ArmRefusal::LinkLost);
        }
        if status.calibration_running {
            b.insert(ArmRefusal::CalibrationRunning);
        }
        if !status.sensors_healthy {
            b.insert(ArmRefusal::SensorsUnhealthy);
        }
        if !status.gyro_bias_done {
            b.insert(ArmRefusal::GyroBiasPending);
        }
        match usable_input(vehicle) {
            None => b.insert(ArmRefusal::AttitudeInvalid),
            Some((_, c, _)) if c < self.lim.arm_cos_tilt => b.insert(ArmRefusal::NotLevel),
            Some(_) => {}
        }
        if !self.throttle_low(pilot) {
            b.insert(ArmRefusal::ThrottleNotLow);
        }
        if self.motor_test.is_some() {
            b.insert(ArmRefusal::MotorTestActive);
        }
        if pilot.motor_test_switch {
            b.insert(ArmRefusal::MotorTestSwitchOn);
        }
        if !status.accel_calibrated && pilot.mode != FlightMode::Acro {
            b.insert(ArmRefusal::AccelNotCalibrated);
        }
        b
    }

    /// Throttle stick at or below [`SafetyConfig::arm_throttle_max`].
    fn throttle_low(&self, pilot: &PilotInput) -> bool {
        let t = pilot.sticks.throttle;
        t.is_finite() && t <= self.safety.arm_throttle_max
    }

    /// Starts the props-off motor test on motor index `motor` (0..=3, mixer
    /// order) with the sticks where they are now. Takes effect from the next
    /// [`step`](Self::step). Refused unless disarmed (or already testing),
    /// link up, arm switch off and throttle low.
    pub fn start_motor_test(
        &mut self,
        motor: u8,
        pilot: &PilotInput,
    ) -> Result<(), MotorTestRefusal> {
        if let Some(r) = self.motor_test_refusal(pilot) {
            return Err(r);
        }
        if usize::from(motor) >= MOTORS {
            return Err(MotorTestRefusal::InvalidMotor);
        }
        let sticks = pilot
            .sticks
            .clamped()
            .map_err(|_| MotorTestRefusal::LinkLost)?;
        self.begin_motor_test(motor, sticks, false);
        Ok(())
    }

    /// The first reason to refuse a motor test now (the motor index
    /// aside).
    fn motor_test_refusal(&self, pilot: &PilotInput) -> Option<MotorTestRefusal> {
        if self.state != FlightState::Disarmed && self.motor_test.is_none() {
            Some(MotorTestRefusal::Armed)
        } else if !pilot.link_ok {
            Some(MotorTestRefusal::LinkLost)
        } else if pilot.arm_switch {
            Some(MotorTestRefusal::ArmSwitchOn)
        } else if !self.throttle_low(pilot) {
            Some(MotorTestRefusal::ThrottleNotLow)
        } else if self.calibrating {
            Some(MotorTestRefusal::CalibrationRunning)
        } else {
            None
        }
    }

    /// Starts the test; `sticks` is the reference a movement is measured from.
    fn begin_motor_test(&mut self, motor: u8, sticks: Sticks, by_switch: bool) {
        self.motor_test = Some(MotorTestRun {
            motor,
            sticks,
            elapsed_us: 0,
            by_switch,
        });
        self.state = FlightState::MotorTest(motor);
    }

    /// Stops the motor test (no effect otherwise); the next step reports
    /// [`MotorTestEnd::Stopped`].
    pub fn stop_motor_test(&mut self) {
        if let Some(t) = self.motor_test.as_mut() {
            t.elapsed_us = u32::MAX;
        }
    }

    /// One step: see the [module docs](self). Never fails; bad inputs are
    /// handled by the rules (and reported as events).
    pub fn step(
        &mut self,
        now_us: u32,
        pilot: &PilotInput,
        status: &SystemStatus,
        vehicle: &VehicleState,
    ) -> FlightOutput {
        let dt_us = match self.last_us {
            None => FIRST_DT_US,
            Some(t) => now_us.wrapping_sub(t).min(MAX_DT_US),
        };
        self.last_us = Some(now_us);
        // A pilot frame with a non-finite stick is as good as no frame
        // (`is_finite` tests the bits: no soft-float call).
        let mut pilot = *pilot;
        let st = &pilot.sticks;
        if ![st.roll, st.pitch, st.yaw, st.throttle]
            .iter()
            .all(|x| x.is_finite())
        {
            pilot.link_ok = false;
        }
        let edge = pilot.link_ok && pilot.arm_switch && self.prev_switch == Some(false);
        self.prev_switch = if pilot.link_ok {
            Some(pilot.arm_switch)
        } else {
            None
        };

        let mut out = FlightOutput {
            motors: Motors::Off,
            state: self.state,
            events: Events::new(),
            mode: pilot.mode,
            rate_setpoint: BodyRates::default(),
            torque: TorqueCommand::default(),
            collective: 0.0,
            mix: None,
        };
        self.calibrating = status.calibration_running;
        self.on_test_switch(&pilot, &mut out);
        match self.state {
            FlightState::Disarmed => self.step_disarmed(edge, &pilot, status, vehicle, &mut out),
            FlightState::MotorTest(_) => self.step_motor_test(dt_us, edge, &pilot, &mut out),
            FlightState::Armed | FlightState::Failsafe(_) => {
                if dt_us > 0 {
                    self.step_flying(dt_us, &pilot, vehicle, &mut out);
                } else {
                    out.motors = self.last_motors;
                }
            }
        }
        if !self.is_armed() && !matches!(self.state, FlightState::MotorTest(_)) {
            out.motors = Motors::Off;
        }
        self.last_motors = out.motors;
        out.state = self.state;
        out
    }

    /// Starts the next motor on an off → on flip of the motor-test switch.
    // Out of line: inlined into `step`, the firmware measured 120 B larger.
    #[inline(never)]
    fn on_test_switch(&mut self, pilot: &PilotInput, out: &mut FlightOutput) {
        let req = self
            .test_switch
            .update(pilot.link_ok, pilot.motor_test_switch);
        if let SwitchRequest::Start(motor) = req {
            // `MotorTestSwitch` only hands out indices below MOTORS.
            match self.motor_test_refusal(pilot) {
                Some(r) => out.events.push(Event::MotorTestRefused(r)),
                // The sticks are finite here (`step` checked them).
                None => {
                    self.begin_motor_test(motor, pilot.sticks, true);
                    self.test_switch.advance();
                }
            }
        }
    }

    fn step_disarmed(
        &mut self,
        edge: bool,
        pilot: &PilotInput,
        status: &SystemStatus,
        vehicle: &VehicleState,
        out: &mut FlightOutput,
    ) {
        if !edge {
            return;
        }
        match self.arm_blockers(pilot, status, vehicle).first() {
            Some(r) => out.events.push(Event::ArmRefused(r)),
            None => {
                self.arm();
                out.events.push(Event::Armed);
            }
        }
    }

    fn arm(&mut self) {
        self.rate.clear();
        self.state = FlightState::Armed;
        self.took_off = false;
        self.alt_engaged = false;
        self.last_collective = 0.0;
        self.hover_collective_q30 = None;
        self.stick_at_min = false;
        self.armed_us = 0;
        self.above_land_us = 0;
        self.failsafe_us = 0;
        self.crash_tilt = Hold::default();
        self.crash_rate = Hold::default();
        self.landed = Hold::default();
        self.bad_input = Hold::default();
        self.runaway.restart();
    }

    /// Disarms now, from outside the sample step (the output guard forced
    /// the outputs off: [`crate::outputguard`]); ends a motor test. The
    /// event to report, `None` if already disarmed.
    pub fn force_disarm(&mut self, cause: DisarmCause) -> Option<Event> {
        if self.state == FlightState::Disarmed {
            return None;
        }
        self.motor_test = None;
        self.state = FlightState::Disarmed;
        self.rate.clear();
        self.alt_engaged = false;
        self.last_motors = Motors::Off;
        Some(Event::Disarmed(cause))
    }

    fn disarm(&mut self, cause: DisarmCause, out: &mut FlightOutput) {
        self.state = FlightState::Disarmed;
        self.rate.clear();
        self.alt_engaged = false;
        out.events.push(Event::Disarmed(cause));
        out.motors = Motors::Off;
    }

    fn step_motor_test(
        &mut self,
        dt_us: u32,
        edge: bool,
        pilot: &PilotInput,
        out: &mut FlightOutput,
    ) {
        let Some(mut t) = self.motor_test else {
            self.state = FlightState::Disarmed;
            return;
        };
        let first = t.elapsed_us == 0;
        t.elapsed_us = t.elapsed_us.saturating_add(dt_us);
        let moved = |a: f32, b: f32| {
            let d = a - b;
            d.abs() > self.safety.motor_test_stick_tolerance
        };
        let s = &pilot.sticks;
        let end = if !pilot.link_ok {
            Some(MotorTestEnd::LinkLost)
        } else if pilot.arm_switch || edge {
            Some(MotorTestEnd::ArmSwitch)
        } else if t.elapsed_us == u32::MAX {
            Some(MotorTestEnd::Stopped)
        } else if t.by_switch && !pilot.motor_test_switch {
            Some(MotorTestEnd::SwitchOff)
        } else if moved(s.roll, t.sticks.roll)
            || moved(s.pitch, t.sticks.pitch)
            || moved(s.yaw, t.sticks.yaw)
            || moved(s.throttle, t.sticks.throttle)
        {
            Some(MotorTestEnd::StickMoved)
        } else if t.elapsed_us >= self.lim.motor_test_us {
            Some(MotorTestEnd::Timeout)
        } else {
            None
        };
        if let Some(reason) = end {
            self.motor_test = None;
            self.state = FlightState::Disarmed;
            out.events.push(Event::MotorTestEnded(reason));
            out.motors = Motors::Off;
            return;
        }
        if first {
            out.events.push(Event::MotorTestStarted(t.motor));
        }
        let mut m = [0; MOTORS];
        if let Some(v) = m.get_mut(usize::from(t.motor)) {
            *v = f32_to_q(self.safety.motor_test_command, 30);
        }
        out.motors = Motors::Run(m);
        self.motor_test = Some(t);
    }

    fn step_flying(
        &mut self,
        dt_us: u32,
        pilot: &PilotInput,
        vehicle: &VehicleState,
        out: &mut FlightOutput,
    ) {
        self.armed_us = self.armed_us.saturating_add(dt_us);

        // Link and switch.
        match (self.state, pilot.link_ok) {
            (FlightState::Armed, false) => {
                self.state = FlightState::Failsafe(FailsafePhase::Hold);
                self.failsafe_us = 0;
                self.alt_engaged = false;
                out.events.push(Event::FailsafeHold {
                    altitude: vehicle.altitude.is_some(),
                });
            }
            (FlightState::Failsafe(_), true) => {
                self.state = FlightState::Armed;
                self.alt_engaged = false;
                out.events.push(Event::FailsafeCleared);
            }
            _ => {}
        }
        if self.state == FlightState::Armed && !pilot.arm_switch {
            self.disarm(DisarmCause::Switch, out);
            return;
        }

        // Vehicle input.
        let Some((att, cos_t, gyro_q16)) = usable_input(vehicle) else {
            return self.bridge_bad_input(dt_us, out);
        };
        self.bad_input = Hold::default();

        let alt = vehicle.altitude;
        let (rate_sp, collective, self_level) = match self.setpoints(dt_us, pilot, &att, alt, out) {
            Some(x) => x,
            None => return, // disarmed inside (failsafe without altitude)
        };

        // On the ground nothing can follow the setpoint: integrating
        // would only wind up and tip the vehicle at take-off. After the
        // take-off the integrals hold while the collective is below the
        // landing threshold (a landed craft, or one descending at low
        // throttle, keeps its trim): on the ground after a landing they
        // would wind up against it for the 2 s the landing takes to
        // disarm (Betaflight leaves the I term out at low throttle).
        if !self.took_off {
            self.rate.clear();
        }
        self.fly_rates(rate_sp, gyro_q16, collective, out);
        self.last_collective = collective;

        self.safety_checks(dt_us, cos_t, self_level, collective, &gyro_q16, alt, out);
        self.track_hover(dt_us, cos_t, collective);
    }

    /// The rate loop and mixer, in fixed point from here to the motor
    /// commands (`control::rateq`): Q16 rad/s setpoint and gyro, one
    /// period per step; the torques, mix and motors into `out`.
    fn fly_rates(
        &mut self,
        sp_q16: [i32; 3],
        gyro_q16: [i32; 3],
        collective: f32,
        out: &mut FlightOutput,
    ) {
        let hold = collective < self.safety.land_collective_max;
        let torque_q30 = self.rate.update_holding(sp_q16, gyro_q16, hold);
        let mix = self.mixer.mix(f32_to_q(collective, 30), torque_q30);
        out.rate_setpoint = BodyRates {
            roll_rps: q_to_f32(sp_q16[0], 16),
            pitch_rps: q_to_f32(sp_q16[1], 16),
            yaw_rps: q_to_f32(sp_q16[2], 16),
        };
        out.torque = torque_from_q30(torque_q30);
        out.collective = collective;
        out.motors = Motors::Run(mix.motors_q30);
        out.mix = Some(mix);
    }

    /// Flies a step without usable attitude/gyro ("Sensor loss" in the
    /// module docs): the last motor commands, then even thrust at the last
    /// collective, then the disarm.
    fn bridge_bad_input(&mut self, dt_us: u32, out: &mut FlightOutput) {
        if self.bad_input.update(true, dt_us, self.lim.bad_input_us) {
            return self.disarm(DisarmCause::SensorFault, out);
        }
        out.events.push(Event::InputRejected);
        out.motors = self.last_motors;
        if self.bad_input.us > BAD_INPUT_HOLD_US {
            let even = self.mixer.mix(f32_to_q(self.last_collective, 30), [0; 3]);
            out.motors = Motors::Run(even.motors_q30);
        }
    }

    /// Rate setpoint (Q16 rad/s), collective and whether the mode
    /// self-levels; `None` after a failsafe disarm.
    fn setpoints(
        &mut self,
        dt_us: u32,
        pilot: &PilotInput,
        att: &QuatQ30,
        alt: Option<AltitudeEstimate>,
        out: &mut FlightOutput,
    ) -> Option<([i32; 3], f32, bool)> {
        match (self.state, alt) {
            (FlightState::Failsafe(phase), _) => {
                self.failsafe_setpoints(phase, dt_us, att, alt, out)
            }
            #[cfg(feature = "battery-descent")]
            (FlightState::Armed, Some(a))
                if self.battery_descent && pilot.mode != FlightMode::Acro =>
            {
                Some(self.battery_descent_setpoints(dt_us, att, a, out))
            }
            _ => Some(self.pilot_setpoints(dt_us, pilot, att, alt, out)),
        }
    }

    #[cfg(feature = "battery-descent")]
    /// The low-battery descent's setpoints: level, no yaw, down at the
    /// failsafe's rate through the altitude hold (engaged from the
    /// present height and collective if the pilot flew another mode).
    fn battery_descent_setpoints(
        &mut self,
        dt_us: u32,
        att: &QuatQ30,
        a: AltitudeEstimate,
        out: &mut FlightOutput,
    ) -> ([i32; 3], f32, bool) {
        out.mode = FlightMode::AltitudeHold;
        let rate_sp = self.level_rates(att, &TiltQ30::LEVEL, 0);
        let collective = self.altitude_collective(a, -self.lim.failsafe_descent_q16, dt_us);
        (rate_sp, collective, true)
    }

    /// The self-level loop's rate setpoint (Q16 rad/s) towards `tilt`
    /// with the yaw rate `yaw_q16` (zero for an attitude the loop refuses;
    /// `attitude_q30` has already checked it).
    fn level_rates(&self, att: &QuatQ30, tilt: &TiltQ30, yaw_q16: i32) -> [i32; 3] {
        match self.level.rate_setpoint_q16(att, tilt) {
            Ok([roll, pitch]) => [roll, pitch, yaw_q16],
            Err(_) => [0; 3],
        }
    }

    /// The failsafe's setpoints: level, then (with an altitude estimate) a
    /// hold and a descent; `None` after a disarm for lack of altitude.
    fn failsafe_setpoints(
        &mut self,
        phase: FailsafePhase,
        dt_us: u32,
        att: &QuatQ30,
        alt: Option<AltitudeEstimate>,
        out: &mut FlightOutput,
    ) -> Option<([i32; 3], f32, bool)> {
        out.mode = FlightMode::Angle;
        self.failsafe_us = self.failsafe_us.saturating_add(dt_us);
        let mut phase = phase;
        if phase == FailsafePhase::Hold && self.failsafe_us >= self.lim.failsafe_hold_us {
            if alt.is_none() {
                self.disarm(DisarmCause::FailsafeNoAltitude, out);
                return None;
            }
            phase = FailsafePhase::Descend;
            self.state = FlightState::Failsafe(phase);
            out.events.push(Event::FailsafeDescent);
        }
        let rate_sp = self.level_rates(att, &TiltQ30::LEVEL, 0);
        let collective = match alt {
            Some(a) => {
                out.mode = FlightMode::AltitudeHold;
                let climb_q16 = if phase == FailsafePhase::Descend {
                    -self.lim.failsafe_descent_q16
                } else {
                    0
                };
                self.altitude_collective(a, climb_q16, dt_us)
            }
            // Altitude lost during the descent: keep going down by
            // ramping the collective off, so the landing detector ends it.
            None if phase == FailsafePhase::Descend => {
                let dt_s = dt_us as f32 * 1.0e-6;
                (self.last_collective - FAILSAFE_BLIND_RAMP_PER_S * dt_s).max(0.0)
            }
            // Level hold without altitude: never more than a hover.
            None => self.last_collective.min(self.hover_estimate()),
        };
        Some((rate_sp, collective, true))
    }

    /// The pilot's setpoints in the selected mode (altitude hold falls back
    /// to angle mode without an altitude estimate).
    fn pilot_setpoints(
        &mut self,
        dt_us: u32,
        pilot: &PilotInput,
        att: &QuatQ30,
        alt: Option<AltitudeEstimate>,
        out: &mut FlightOutput,
    ) -> ([i32; 3], f32, bool) {
        let mut mode = pilot.mode;
        let fallback = mode == FlightMode::AltitudeHold && alt.is_none();
        if fallback {
            if !self.alt_fallback {
                out.events.push(Event::AltitudeUnavailable);
            }
            mode = FlightMode::Angle;
        }
        self.alt_fallback = fallback;
        out.mode = mode;
        let s = &pilot.sticks;
        if !self.shaped.same_sticks(s) {
            self.shaped = Shaped::new(&self.shaping, &self.climb, &self.safety, s);
        }
        // By field, not a copy of the whole `Shaped` (a `memcpy` a step).
        self.stick_at_min = self.shaped.stick_at_min;
        let rate_sp = match mode {
            FlightMode::Acro => self.shaped.acro_q16,
            FlightMode::Angle | FlightMode::AltitudeHold => {
                let sh = &self.shaped;
                self.level_rates(att, &sh.tilt, sh.yaw_q16)
            }
        };
        let collective = match (mode, alt) {
            (FlightMode::AltitudeHold, Some(a)) => {
                self.altitude_collective(a, self.shaped.climb_q16, dt_us)
            }
            _ => {
                self.alt_engaged = false;
                self.shaped.throttle
            }
        };
        (rate_sp, collective, mode != FlightMode::Acro)
    }
}

/// The throttle stick's climb demand in altitude hold, in fixed point:
/// centred ± [`SafetyConfig::althold_deadband`] holds, beyond it the
/// demand grows linearly to [`SafetyConfig::althold_max_climb_mps`] at
/// either end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct ClimbQ {
    /// The deadband, Q30 stick units (≤ 0.3).
    band_q30: i32,
    /// `max_climb / (0.5 − band)`, Q16 m/s per stick unit (≤ 25).
    per_stick_q16: i32,
}

impl ClimbQ {
    #[inline(always)]
    fn new(s: &SafetyConfig) -> Self {
        Self {
            band_q30: f32_to_q(s.althold_deadband, 30),
            per_stick_q16: f32_to_q(s.althold_max_climb_mps / (0.5 - s.althold_deadband), 16),
        }
    }

    /// Climb demand, Q16 m/s (up), of a throttle stick 0..1 (clamped).
    fn demand_q16(&self, throttle: f32) -> i32 {
        let d = f32_to_q(throttle, 30).clamp(0, ONE_Q30) - ONE_Q30 / 2;
        let beyond = if d > self.band_q30 {
            d - self.band_q30
        } else if d < -self.band_q30 {
            d + self.band_q30
        } else {
            0
        };
        ((i64::from(beyond) * i64::from(self.per_stick_q16)) >> 30) as i32
    }
}

impl FlightController {
    /// Altitude-hold collective, the 1 kHz part in fixed point
    /// ([`AltitudeHoldQ`], one period per step); engages bumplessly at the
    /// current height and moves the target at `climb_q16` (Q16 m/s) for
    /// `dt_us`, kept within 2 m of the estimate so it cannot run away from
    /// a vehicle that cannot follow.
    fn altitude_collective(&mut self, a: AltitudeEstimate, climb_q16: i32, dt_us: u32) -> f32 {
        const LEASH_Q16: i32 = 2 << 16;
        let (h, v) = (a.height_m_q16, a.vertical_speed_mps_q16);
        if !self.alt_engaged {
            self.alt_target_q16 = h;
            self.alt.reset(v, f32_to_q(self.last_collective, 30));
            self.alt_engaged = true;
        }
        // climb · dt in Q16 m: Q16 m/s × µs × 2³²/10⁶ (4295, 0.0001 % high),
        // shifted by 32; below 2⁴⁴ for any climb within Q16 and dt ≤ 20 ms.
        let step = (i64::from(climb_q16) * i64::from(dt_us) * 4295) >> 32;
        let t = self.alt_target_q16.saturating_add(step as i32);
        self.alt_target_q16 = t
            .max(h.saturating_sub(LEASH_Q16))
            .min(h.saturating_add(LEASH_Q16));
        q_to_f32(self.alt.update(self.alt_target_q16, h, v), 30)
    }

    #[allow(clippy::too_many_arguments)]
    fn safety_checks(
        &mut self,
        dt_us: u32,
        cos_tilt_q30: i32,
        self_level: bool,
        collective: f32,
        gyro_q16: &[i32; 3],
        alt: Option<AltitudeEstimate>,
        out: &mut FlightOutput,
    ) {
        let max_rate_q16 = gyro_q16.iter().map(|r| r.unsigned_abs()).fold(0, u32::max);
        if self
            .runaway
            .update(dt_us, &out.torque, gyro_q16, collective)
        {
            return self.disarm(DisarmCause::RunawayTakeoff, out);
        }
        if self.crash_tilt.update(
            self_level && cos_tilt_q30 < self.lim.crash_cos_tilt,
            dt_us,
            self.lim.crash_tilt_us,
        ) {
            return self.disarm(DisarmCause::CrashTilt, out);
        }
        if self.crash_rate.update(
            max_rate_q16 >= self.lim.crash_rate_q16,
            dt_us,
            self.lim.crash_rate_us,
        ) {
            return self.disarm(DisarmCause::CrashRate, out);
        }
        // The one field, not a copy of the whole `SafetyConfig` (a
        // byte-wise `memcpy` a step).
        let low = collective < self.safety.land_collective_max;
        if !low {
            self.took_off = true;
        }
        self.above_land_us = if low {
            0
        } else {
            self.above_land_us.saturating_add(dt_us)
        };
        let landed = self.took_off && low && self.looks_landed(max_rate_q16, collective, alt);
        if self.landed.update(landed, dt_us, self.lim.land_us) {
            let cause = if matches!(self.state, FlightState::Failsafe(_)) {
                DisarmCause::FailsafeLanded
            } else {
                DisarmCause::Landed
            };
            return self.disarm(cause, out);
        }
        if !self.took_off && self.armed_us >= self.lim.idle_disarm_us {
            self.disarm(DisarmCause::NoTakeOff, out);
        }
    }
}

impl FlightController {
    /// With the collective already low: whether this step shows a landed
    /// craft rather than a descending one (the rule and its reasons are in
    /// the module docs' "Landing detection"). No rotation, and: with an
    /// altitude estimate, no vertical speed; without one, under pilot
    /// control the throttle stick at its minimum, in a failsafe the blind
    /// descent's collective ramped to zero.
    fn looks_landed(
        &self,
        max_rate_q16: u32,
        collective: f32,
        alt: Option<AltitudeEstimate>,
    ) -> bool {
        let no_rotation = max_rate_q16 < self.lim.land_rate_q16;
        let no_descent = match alt {
            Some(a) => a.vertical_speed_mps_q16.unsigned_abs() < self.lim.land_speed_q16,
            None if matches!(self.state, FlightState::Failsafe(_)) => collective <= 0.0,
            None => self.stick_at_min,
        };
        no_rotation && no_descent
    }

    /// Low-passes the collective over [`HOVER_TAU_S`] while the pilot flies
    /// (armed, taken off, no failsafe) within 15° of level; the first such
    /// step seeds it.
    fn track_hover(&mut self, dt_us: u32, cos_tilt_q30: i32, collective: f32) {
        let pilot_flying = self.state == FlightState::Armed && self.took_off;
        if !pilot_flying || cos_tilt_q30 < HOVER_LEVEL_COS_TILT_Q30 || !collective.is_finite() {
            return;
        }
        let c = f32_to_q(collective, 30);
        self.hover_collective_q30 = Some(match self.hover_collective_q30 {
            None => c,
            // Forward Euler, α = dt/τ in Q30 (the collective's change is
            // below 2³¹, dt ≤ 2¹⁵ µs, the rate below 2¹⁰: < 2⁵⁶).
            Some(h) => {
                let step =
                    i64::from(c.saturating_sub(h)) * i64::from(dt_us) * HOVER_ALPHA_Q30_PER_US;
                h.saturating_add((step >> 30) as i32)
            }
        });
    }

    /// The collective a level hold without altitude may use at most: the
    /// hover estimate bounded between [`SafetyConfig::land_collective_max`]
    /// and [`SafetyConfig::failsafe_collective_max`] (the lower bound when
    /// there is no estimate yet).
    fn hover_estimate(&self) -> f32 {
        let s = &self.safety;
        let h = self.hover_collective().unwrap_or(s.land_collective_max);
        // max/min, not clamp (see `altitude_collective`).
        h.max(s.land_collective_max).min(s.failsafe_collective_max)
    }

    /// The hover-collective estimate so far (`None` before the first step
    /// flown near level after take-off), unclamped.
    pub fn hover_collective(&self) -> Option<f32> {
        self.hover_collective_q30.map(|h| q_to_f32(h, 30))
    }
}

/// The attitude in Q30, the cosine of its tilt (body down · earth down,
/// Q30) and the gyro in Q16 rad/s, or `None` if the attitude or gyro is
/// unusable: no gyro sample, or the attitude refused by
/// [`QuatQ30::cos_tilt_q30`] (a component beyond ±1.5, `|q|²` outside
/// 0.25..2).
fn usable_input(v: &VehicleState) -> Option<(QuatQ30, i32, [i32; 3])> {
    let g = v.gyro_rps_q16?;
    let q = v.attitude_q30;
    q.cos_tilt_q30().ok().map(|c| (q, c, g))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift32: values in −1..1.
    struct Rng(u32);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 17;
            self.0 ^= self.0 << 5;
            self.0 as f32 / u32::MAX as f32 * 2.0 - 1.0
        }
    }

    /// The fixed-point vehicle state against its `f32` source: the
    /// attitude within 2⁻³⁰, rates within 2⁻¹⁶ rad/s, height and speed
    /// within 2⁻¹⁶; the cosine of the tilt the controller checks against
    /// the `f32` quaternion's within 3e-4 (one `SDIV` of 15-bit operands).
    #[test]
    fn vehicle_state_follows_its_f32_values() {
        let mut rng = Rng(0x1234_5678);
        for _ in 0..2_000 {
            let q = Quat::from_euler(3.2 * rng.f(), 1.6 * rng.f(), 3.2 * rng.f());
            let g = BodyRates {
                roll_rps: 30.0 * rng.f(),
                pitch_rps: 30.0 * rng.f(),
                yaw_rps: 30.0 * rng.f(),
            };
            let (h, vz) = (500.0 * rng.f(), 20.0 * rng.f());
            let v = VehicleState::from_f32(&q, &g, AltitudeEstimate::from_f32(h, vz));
            let back = v.attitude();
            for (a, b) in [(back.w, q.w), (back.x, q.x), (back.y, q.y), (back.z, q.z)] {
                assert!((a - b).abs() <= 2e-7, "{back:?} vs {q:?}");
            }
            let gb = v.gyro().unwrap();
            for (a, b) in [
                (gb.roll_rps, g.roll_rps),
                (gb.pitch_rps, g.pitch_rps),
                (gb.yaw_rps, g.yaw_rps),
            ] {
                assert!((a - b).abs() <= 2e-5, "{gb:?} vs {g:?}");
            }
            let a = v.altitude.unwrap();
            assert!((a.height_m() - h).abs() <= 1e-4, "{a:?} vs {h}");
            assert!((a.vertical_speed_mps() - vz).abs() <= 2e-5, "{a:?} vs {vz}");
            let (_, cos_q30, gyro_q16) = usable_input(&v).unwrap();
            assert_eq!(Some(gyro_q16), v.gyro_rps_q16);
            let cos_f32 = 1.0 - 2.0 * (q.x * q.x + q.y * q.y);
            assert!((q_to_f32(cos_q30, 30) - cos_f32).abs() < 3e-4);
        }
    }

    /// A non-finite value from a host is unusable, as a lost sample is:
    /// no attitude, no gyro, no altitude.
    #[test]
    fn vehicle_state_refuses_non_finite_values() {
        let g = BodyRates::default();
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let q = Quat {
                x: bad,
                ..Quat::IDENTITY
            };
            let v = VehicleState::from_f32(&q, &g, None);
            assert_eq!(v.attitude_q30, VehicleState::NO_ATTITUDE);
            assert!(usable_input(&v).is_none());
            let r = BodyRates { yaw_rps: bad, ..g };
            let v = VehicleState::from_f32(&Quat::IDENTITY, &r, None);
            assert_eq!(v.gyro_rps_q16, None);
            assert!(usable_input(&v).is_none());
            assert_eq!(AltitudeEstimate::from_f32(bad, 0.0), None);
            assert_eq!(AltitudeEstimate::from_f32(0.0, bad), None);
        }
        let v = VehicleState::from_f32(&Quat::IDENTITY, &g, None);
        assert!(usable_input(&v).is_some());
    }

    /// The rate and vertical-speed limits in Q16 decide as the `f32`
    /// limits they come from, except within 2⁻¹⁵ of the limit.
    #[test]
    fn q16_limits_decide_as_their_f32_limits() {
        let s = SafetyConfig::default();
        let fc = FlightController::new(FlightConfig::default()).unwrap();
        let lim = fc.lim;
        let cases = [
            (s.crash_rate_dps * RAD_PER_DEG, lim.crash_rate_q16),
            (s.land_rate_max_dps * RAD_PER_DEG, lim.land_rate_q16),
            (s.land_vertical_speed_max_mps, lim.land_speed_q16),
        ];
        let mut rng = Rng(99);
        for (limit, limit_q16) in cases {
            for _ in 0..5_000 {
                let x = limit * (1.0 + 0.2 * rng.f());
                if (x.abs() - limit).abs() < 1.0 / 32_768.0 {
                    continue;
                }
                let q16 = f32_to_q(x, 16).unsigned_abs();
                assert_eq!(q16 >= limit_q16, x.abs() >= limit, "{x} vs {limit}");
            }
        }
    }

    /// The climb demand against its `f32` law: `max · (d ∓ band)/(0.5 −
    /// band)` beyond the deadband about the centre, 0 inside, clamped at
    /// the stick's ends.
    #[test]
    fn climb_demand_follows_the_stick_law() {
        let s = SafetyConfig::default();
        let c = ClimbQ::new(&s);
        let (band, max) = (s.althold_deadband, s.althold_max_climb_mps);
        for k in -20..=140 {
            let stick = k as f32 / 120.0;
            let d = stick.clamp(0.0, 1.0) - 0.5;
            let expect = if d > band {
                max * (d - band) / (0.5 - band)
            } else if d < -band {
                max * (d + band) / (0.5 - band)
            } else {
                0.0
            };
            let got = q_to_f32(c.demand_q16(stick), 16);
            assert!(
                (got - expect).abs() < 1e-4,
                "stick {stick}: {got} vs {expect}"
            );
        }
        assert!((q_to_f32(c.demand_q16(1.0), 16) - max).abs() < 1e-4);
        assert_eq!(c.demand_q16(0.5), 0);
    }
}
