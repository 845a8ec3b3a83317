//! Arming, disarming, failsafe and motor-test vocabulary: the safety
//! limits ([`SafetyConfig`]), every reason the controller refuses to arm
//! ([`ArmRefusal`]), every cause of a disarm ([`DisarmCause`]), and the
//! events the [`FlightController`](crate::flightctl::FlightController)
//! reports ([`Event`], [`Events`]). All are `defmt::Format` with the
//! `defmt` feature, so the firmware logs them as they are.
//!
//! The rules themselves are in [`crate::flightctl`]; this module holds the
//! numbers and names.

use core::f32::consts::PI;

const RAD_PER_DEG: f32 = PI / 180.0;

/// Why an arm request (arm switch off → on) was refused. Checked in this
/// order; [`ArmBlockers`] holds all that apply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArmRefusal {
    /// The pilot link is down (no valid frames). Only in [`ArmBlockers`]:
    /// without a link there is no trusted switch edge to refuse.
    LinkLost,
    /// A calibration mode (magnetometer/accelerometer) is running.
    CalibrationRunning,
    /// A required sensor is not healthy.
    SensorsUnhealthy,
    /// The start-up gyro bias has not been measured yet.
    GyroBiasPending,
    /// The attitude or gyro input is not usable (non-finite, zero quaternion).
    AttitudeInvalid,
    /// Tilted more than [`SafetyConfig::arm_max_tilt_deg`].
    NotLevel,
    /// Throttle stick above [`SafetyConfig::arm_throttle_max`].
    ThrottleNotLow,
    /// The props-off motor test is running. Only in [`ArmBlockers`]: the
    /// arm switch ends the motor test instead.
    MotorTestActive,
    /// The motor-test switch is on (bench mode, props off): turn it off
    /// first (see [`crate::motortest`]).
    MotorTestSwitchOn,
    /// Angle or altitude-hold mode selected without an accelerometer
    /// calibration: the MPU-9250's zero-g offset (±60–80 mg per axis) would
    /// level the craft 3–5° off and make it drift. Calibrate (six-position)
    /// or arm in acro.
    AccelNotCalibrated,
}

impl ArmRefusal {
    /// Every refusal, in checking order.
    pub const ALL: [Self; 10] = [
        Self::LinkLost,
        Self::CalibrationRunning,
        Self::SensorsUnhealthy,
        Self::GyroBiasPending,
        Self::AttitudeInvalid,
        Self::NotLevel,
        Self::ThrottleNotLow,
        Self::MotorTestActive,
        Self::MotorTestSwitchOn,
        Self::AccelNotCalibrated,
    ];

    const fn bit(self) -> u16 {
        1 << (self as u16)
    }
}

/// The set of reasons that currently block arming (empty = ready).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ArmBlockers(u16);

impl ArmBlockers {
    /// No blocker.
    pub const NONE: Self = Self(0);

    /// Adds a reason.
    pub fn insert(&mut self, r: ArmRefusal) {
        self.0 |= r.bit();
    }

    /// Whether `r` is among the blockers.
    pub fn contains(&self, r: ArmRefusal) -> bool {
        self.0 & r.bit() != 0
    }

    /// True when nothing blocks arming.
    pub fn is_empty(&self) -> bool {
        self.0 == 0
    }

    /// The first blocker in [`ArmRefusal::ALL`] order.
    pub fn first(&self) -> Option<ArmRefusal> {
        ArmRefusal::ALL.into_iter().find(|r| self.contains(*r))
    }

    /// The raw bit set (bit `n` = `ArmRefusal::ALL[n]`), for compact logs.
    pub fn bits(&self) -> u16 {
        self.0
    }
}

/// Why the controller disarmed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DisarmCause {
    /// The pilot turned the arm switch off.
    Switch,
    /// Tilt beyond [`SafetyConfig::crash_tilt_deg`] for
    /// [`SafetyConfig::crash_tilt_time_s`] in a self-levelling mode.
    CrashTilt,
    /// A body rate at or beyond [`SafetyConfig::crash_rate_dps`] for
    /// [`SafetyConfig::crash_rate_time_s`] (gyro saturated: tumbling).
    CrashRate,
    /// Landing detected: collective low, no rotation and no vertical speed
    /// (without an altitude estimate: the throttle stick at its minimum)
    /// for [`SafetyConfig::land_time_s`] after having taken off.
    Landed,
    /// Armed but never took off within [`SafetyConfig::idle_disarm_s`].
    NoTakeOff,
    /// Pilot link lost without an altitude estimate: disarmed after the
    /// level hold of [`SafetyConfig::failsafe_hold_s`].
    FailsafeNoAltitude,
    /// Pilot link lost: the failsafe descent ended in a detected landing
    /// (or, having lost its altitude estimate, its collective ramped to
    /// zero with no rotation for [`SafetyConfig::land_time_s`]).
    FailsafeLanded,
    /// The attitude or gyro input stayed unusable for
    /// [`SafetyConfig::bad_input_disarm_s`].
    SensorFault,
    /// No IMU sample reached the controller for
    /// [`NO_SAMPLE_TIMEOUT_US`](crate::outputguard::NO_SAMPLE_TIMEOUT_US):
    /// the outputs were forced off from outside the sample step
    /// ([`crate::outputguard`]).
    NoImuSamples,
    /// Runaway take-off: the rate loop's torque command at or beyond
    /// [`SafetyConfig::runaway_torque_min`] while turning, for
    /// [`SafetyConfig::runaway_time_s`], before normal flight switched the
    /// check off (rule in [`crate::runaway`]). Check the motor order, the
    /// motors' directions and the propellers.
    RunawayTakeoff,
}

/// Why a motor-test request was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotorTestRefusal {
    /// Only while disarmed.
    Armed,
    /// Only with the pilot link up.
    LinkLost,
    /// Only with the arm switch off.
    ArmSwitchOn,
    /// Only with the throttle stick at or below
    /// [`SafetyConfig::arm_throttle_max`].
    ThrottleNotLow,
    /// Not while a calibration runs (the craft is in someone's hands).
    CalibrationRunning,
    /// Motor index not 0..=3.
    InvalidMotor,
}

words!(MotorTestRefusal {
    Armed => "motor test refused: armed",
    LinkLost => "motor test refused: pilot link lost",
    ArmSwitchOn => "motor test refused: arm switch on",
    ThrottleNotLow => "motor test refused: throttle not low",
    CalibrationRunning => "motor test refused: calibration running",
    InvalidMotor => "motor test refused: motor index not 0..=3",
});

impl core::error::Error for MotorTestRefusal {}

words!(ArmRefusal {
    LinkLost => "pilot link lost",
    CalibrationRunning => "calibration running",
    SensorsUnhealthy => "a sensor is not healthy",
    GyroBiasPending => "gyro bias not measured yet (keep the craft still)",
    AttitudeInvalid => "attitude or gyro unusable",
    NotLevel => "not level",
    ThrottleNotLow => "throttle not low",
    MotorTestActive => "motor test running",
    MotorTestSwitchOn => "motor-test switch on",
    AccelNotCalibrated => "accelerometer not calibrated: angle and altitude hold need it (acro does not)",
});

words!(DisarmCause {
    Switch => "arm switch off",
    CrashTilt => "crash: tilted past the limit",
    CrashRate => "crash: tumbling (gyro at its limit)",
    Landed => "landed",
    NoTakeOff => "no take-off within the idle time",
    FailsafeNoAltitude => "failsafe: no altitude estimate to descend on",
    FailsafeLanded => "failsafe: landed",
    SensorFault => "sensor fault: attitude or gyro unusable",
    NoImuSamples => "no IMU samples: outputs were forced off",
    RunawayTakeoff => "runaway take-off: check the motor order and directions and the propellers",
});

/// Why the motor test stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotorTestEnd {
    /// A stick moved more than [`SafetyConfig::motor_test_stick_tolerance`].
    StickMoved,
    /// The pilot link was lost.
    LinkLost,
    /// The arm switch was turned on.
    ArmSwitch,
    /// [`SafetyConfig::motor_test_max_s`] elapsed.
    Timeout,
    /// The firmware stopped it.
    Stopped,
    /// The motor-test switch that started it was turned off.
    SwitchOff,
}

words!(MotorTestEnd {
    StickMoved => "a stick moved",
    LinkLost => "pilot link lost",
    ArmSwitch => "arm switch on",
    Timeout => "time limit",
    Stopped => "stopped by the firmware",
    SwitchOff => "motor-test switch off",
});

/// Something the flight controller wants logged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// Armed: motors at idle.
    Armed,
    /// An arm request was refused; the switch must go off and on again.
    ArmRefused(ArmRefusal),
    /// Disarmed: motors off.
    Disarmed(DisarmCause),
    /// Pilot link lost while armed: holding level. `altitude`: a descent
    /// will follow (else a disarm).
    FailsafeHold {
        /// Altitude estimate available.
        altitude: bool,
    },
    /// The failsafe hold ended: descending at
    /// [`SafetyConfig::failsafe_descent_mps`].
    FailsafeDescent,
    /// The link came back during failsafe: the pilot has control again.
    FailsafeCleared,
    /// Motor test started on motor index `0..=3`.
    MotorTestStarted(u8),
    /// Motor test ended.
    MotorTestEnded(MotorTestEnd),
    /// A flip of the motor-test switch was refused.
    MotorTestRefused(MotorTestRefusal),
    /// Altitude hold requested without an altitude estimate: flying
    /// self-level with manual throttle.
    AltitudeUnavailable,
    /// One step's attitude/gyro input was unusable: the previous motor
    /// commands were kept.
    InputRejected,
}

impl core::fmt::Display for Event {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Armed => f.write_str("ARMED"),
            Self::ArmRefused(r) => write!(f, "arm refused: {r}"),
            Self::Disarmed(c) => write!(f, "disarmed: {c}"),
            Self::FailsafeHold { altitude: true } => {
                f.write_str("failsafe: no link: holding level and the height")
            }
            Self::FailsafeHold { altitude: false } => f.write_str(
                "failsafe: no link: holding level and the last collective (no altitude estimate)",
            ),
            Self::FailsafeDescent => f.write_str("failsafe: descending"),
            Self::FailsafeCleared => f.write_str("failsafe cleared: the pilot has control"),
            Self::MotorTestStarted(m) => write!(f, "motor test: motor {} spinning", m + 1),
            Self::MotorTestEnded(e) => write!(f, "motor test ended: {e}"),
            Self::MotorTestRefused(r) => write!(f, "{r}"),
            Self::AltitudeUnavailable => f.write_str(
                "altitude hold unavailable (no estimate): self-level with manual throttle",
            ),
            Self::InputRejected => {
                f.write_str("one step's attitude or gyro unusable: kept the last commands")
            }
        }
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Event {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Self::Armed => defmt::write!(f, "ARMED"),
            Self::ArmRefused(r) => defmt::write!(f, "arm refused: {}", r),
            Self::Disarmed(c) => defmt::write!(f, "disarmed: {}", c),
            Self::FailsafeHold { altitude: true } => {
                defmt::write!(f, "failsafe: no link: holding level and the height")
            }
            Self::FailsafeHold { altitude: false } => defmt::write!(
                f,
                "failsafe: no link: holding level and the last collective (no altitude estimate)"
            ),
            Self::FailsafeDescent => defmt::write!(f, "failsafe: descending"),
            Self::FailsafeCleared => defmt::write!(f, "failsafe cleared: the pilot has control"),
            Self::MotorTestStarted(m) => {
                defmt::write!(f, "motor test: motor {=u8} spinning", m.saturating_add(1))
            }
            Self::MotorTestEnded(e) => defmt::write!(f, "motor test ended: {}", e),
            Self::MotorTestRefused(r) => defmt::write!(f, "{}", r),
            Self::AltitudeUnavailable => defmt::write!(
                f,
                "altitude hold unavailable (no estimate): self-level with manual throttle"
            ),
            Self::InputRejected => defmt::write!(
                f,
                "one step's attitude or gyro unusable: kept the last commands"
            ),
        }
    }
}

/// The events of one step (at most [`Events::CAPACITY`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Events {
    list: [Option<Event>; Events::CAPACITY],
}

impl Default for Events {
    fn default() -> Self {
        Self::new()
    }
}

impl Events {
    /// Most events one step can produce.
    pub const CAPACITY: usize = 4;

    /// Empty.
    pub const fn new() -> Self {
        Self {
            list: [None; Self::CAPACITY],
        }
    }

    /// Appends (drops the event if full; one step never makes more than
    /// `CAPACITY`).
    pub fn push(&mut self, e: Event) {
        if let Some(slot) = self.list.iter_mut().find(|s| s.is_none()) {
            *slot = Some(e);
        }
    }

    /// The events in order.
    pub fn iter(&self) -> impl Iterator<Item = Event> + '_ {
        self.list.iter().filter_map(|e| *e)
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.list[0].is_none()
    }

    /// Whether `e` is among them.
    pub fn contains(&self, e: Event) -> bool {
        self.iter().any(|x| x == e)
    }
}

/// Safety limits and timings. Angles in degrees, times in seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SafetyConfig {
    /// Highest throttle stick that allows arming, 0..0.2.
    pub arm_throttle_max: f32,
    /// Largest tilt that allows arming, °, 1..=45.
    pub arm_max_tilt_deg: f32,
    /// Crash tilt, °, 30..=180.
    pub crash_tilt_deg: f32,
    /// Time beyond the crash tilt before disarming, s.
    pub crash_tilt_time_s: f32,
    /// Body rate counted as saturated, °/s (set just below the gyro's full
    /// scale), > 0.
    pub crash_rate_dps: f32,
    /// Time at the crash rate before disarming, s.
    pub crash_rate_time_s: f32,
    /// Collective below which the vehicle may be landed, 0..0.5.
    pub land_collective_max: f32,
    /// Largest body rate on every axis counted as "no motion", °/s.
    pub land_rate_max_dps: f32,
    /// Largest vertical speed counted as "not moving", m/s.
    pub land_vertical_speed_max_mps: f32,
    /// Time the landed conditions must hold, s.
    pub land_time_s: f32,
    /// Armed without taking off for this long: disarm, s.
    pub idle_disarm_s: f32,
    /// Level hold after the pilot link is lost, s.
    pub failsafe_hold_s: f32,
    /// Failsafe descent speed, m/s, > 0.
    pub failsafe_descent_mps: f32,
    /// Highest collective of the failsafe's level hold without an altitude
    /// estimate: the bound on the hover estimate it flies at
    /// (above `land_collective_max`, ≤ 1).
    pub failsafe_collective_max: f32,
    /// Motor-test command, 0..=0.2.
    pub motor_test_command: f32,
    /// Longest motor test, s.
    pub motor_test_max_s: f32,
    /// Stick movement (any axis, from the position at the start) that ends
    /// the motor test, 0.02..0.5.
    pub motor_test_stick_tolerance: f32,
    /// Altitude hold: climb/descent rate at full stick deflection from the
    /// centre, m/s.
    pub althold_max_climb_mps: f32,
    /// Altitude hold: throttle-stick deadband around 0.5 (hold height).
    pub althold_deadband: f32,
    /// Unusable attitude/gyro input for this long while armed: disarm, s
    /// (0.25: the bridge of [`crate::flightctl`]'s "Sensor loss" rule,
    /// longer than an MPU-9250 reset with its 100 ms settle).
    pub bad_input_disarm_s: f32,
    /// Runaway take-off: torque command (any axis, ±1 = the mixer's full
    /// authority) counted as pushing hard, 0.2..=1 (see [`crate::runaway`]).
    pub runaway_torque_min: f32,
    /// Runaway take-off: roll or pitch rate above which the craft counts as
    /// turning, °/s, 1..=500.
    pub runaway_rate_roll_pitch_dps: f32,
    /// Runaway take-off: yaw rate above which the craft counts as turning,
    /// °/s, 1..=500.
    pub runaway_rate_yaw_dps: f32,
    /// Runaway take-off: time both must hold without a break to disarm, s.
    pub runaway_time_s: f32,
    /// Runaway take-off: lowest collective counted as normal flight, 0..=1.
    pub runaway_off_collective_min: f32,
    /// Runaway take-off: every torque command below this counts as normal
    /// flight, above 0 and below `runaway_torque_min`.
    pub runaway_off_torque_max: f32,
    /// Runaway take-off: normal flight since arming that switches the check
    /// off until the next arming, s.
    pub runaway_off_time_s: f32,
}

impl Default for SafetyConfig {
    /// Arm below 5 % throttle and 25° tilt; crash beyond 70° for 0.5 s or
    /// 950 °/s (±1000 °/s gyro) for 0.3 s; landed after 2 s of collective
    /// < 0.15, rates < 20 °/s, |v| < 0.3 m/s; no-take-off disarm after 5 s;
    /// failsafe hold 1 s (without altitude at most the hover estimate,
    /// ≤ 0.6) then descend at 0.5 m/s; motor test at 8 % for at
    /// most 5 s, ended by a 0.1 stick movement; runaway take-off: torque
    /// ≥ 0.6 while turning faster than 15 °/s (roll, pitch) or 50 °/s (yaw)
    /// for 75 ms, switched off by 0.5 s of collective ≥ 0.2 with every
    /// torque < 0.1.
    fn default() -> Self {
        Self {
            arm_throttle_max: 0.05,
            arm_max_tilt_deg: 25.0,
            crash_tilt_deg: 70.0,
            crash_tilt_time_s: 0.5,
            crash_rate_dps: 950.0,
            crash_rate_time_s: 0.3,
            land_collective_max: 0.15,
            land_rate_max_dps: 20.0,
            land_vertical_speed_max_mps: 0.3,
            land_time_s: 2.0,
            idle_disarm_s: 5.0,
            failsafe_hold_s: 1.0,
            failsafe_descent_mps: 0.5,
            failsafe_collective_max: 0.6,
            motor_test_command: 0.08,
            motor_test_max_s: 5.0,
            motor_test_stick_tolerance: 0.1,
            althold_max_climb_mps: 1.0,
            althold_deadband: 0.1,
            bad_input_disarm_s: 0.25,
            runaway_torque_min: 0.6,
            runaway_rate_roll_pitch_dps: 15.0,
            runaway_rate_yaw_dps: 50.0,
            runaway_time_s: 0.075,
            runaway_off_collective_min: 0.2,
            runaway_off_torque_max: 0.1,
            runaway_off_time_s: 0.5,
        }
    }
}

/// Which [`SafetyConfig`] field is out of range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SafetyField {
    /// `arm_throttle_max`.
    ArmThrottleMax,
    /// `arm_max_tilt_deg`.
    ArmMaxTilt,
    /// `crash_tilt_deg` (must also exceed `arm_max_tilt_deg`).
    CrashTilt,
    /// `crash_rate_dps`.
    CrashRate,
    /// `land_collective_max`, `land_rate_max_dps` or `land_vertical_speed_max_mps`.
    LandLimits,
    /// A time (`*_time_s`, `*_s`) not in (0, 60].
    Time,
    /// `failsafe_descent_mps` not in (0, 3].
    FailsafeDescent,
    /// `failsafe_collective_max` not in (`land_collective_max`, 1].
    FailsafeCollective,
    /// `motor_test_command` or `motor_test_stick_tolerance`.
    MotorTest,
    /// `althold_max_climb_mps` or `althold_deadband`.
    AltitudeHold,
    /// A `runaway_*` limit (the times are [`SafetyField::Time`]).
    Runaway,
}

#[inline(always)]
fn within(x: f32, lo: f32, hi: f32) -> bool {
    x.is_finite() && x >= lo && x <= hi
}

impl SafetyConfig {
    /// Checks every field; the error names the first bad one.
    #[inline(always)]
    pub fn validate(&self) -> Result<(), SafetyField> {
        let check = |ok: bool, f: SafetyField| if ok { Ok(()) } else { Err(f) };
        check(
            within(self.arm_throttle_max, 0.0, 0.2),
            SafetyField::ArmThrottleMax,
        )?;
        check(
            within(self.arm_max_tilt_deg, 1.0, 45.0),
            SafetyField::ArmMaxTilt,
        )?;
        check(
            within(self.crash_tilt_deg, 30.0, 180.0) && self.crash_tilt_deg > self.arm_max_tilt_deg,
            SafetyField::CrashTilt,
        )?;
        check(
            within(self.crash_rate_dps, 1.0, 5000.0),
            SafetyField::CrashRate,
        )?;
        check(
            within(self.land_collective_max, 0.0, 0.5)
                && within(self.land_rate_max_dps, 0.0, 200.0)
                && within(self.land_vertical_speed_max_mps, 0.0, 2.0),
            SafetyField::LandLimits,
        )?;
        let times = [
            self.crash_tilt_time_s,
            self.crash_rate_time_s,
            self.land_time_s,
            self.idle_disarm_s,
            self.failsafe_hold_s,
            self.motor_test_max_s,
            self.bad_input_disarm_s,
            self.runaway_time_s,
            self.runaway_off_time_s,
        ];
        check(
            times.iter().all(|t| within(*t, 0.0, 60.0) && *t > 0.0),
            SafetyField::Time,
        )?;
        check(
            within(self.failsafe_descent_mps, 0.0, 3.0) && self.failsafe_descent_mps > 0.0,
            SafetyField::FailsafeDescent,
        )?;
        check(
            within(self.failsafe_collective_max, 0.0, 1.0)
                && self.failsafe_collective_max > self.land_collective_max,
            SafetyField::FailsafeCollective,
        )?;
        check(
            within(self.motor_test_command, 0.0, 0.2)
                && within(self.motor_test_stick_tolerance, 0.02, 0.5),
            SafetyField::MotorTest,
        )?;
        check(
            within(self.althold_max_climb_mps, 0.0, 5.0)
                && self.althold_max_climb_mps > 0.0
                && within(self.althold_deadband, 0.0, 0.3),
            SafetyField::AltitudeHold,
        )?;
        check(self.runaway_limits_ok(), SafetyField::Runaway)
    }

    /// The `runaway_*` limits other than the times.
    #[inline(always)]
    fn runaway_limits_ok(&self) -> bool {
        within(self.runaway_torque_min, 0.2, 1.0)
            && within(self.runaway_rate_roll_pitch_dps, 1.0, 500.0)
            && within(self.runaway_rate_yaw_dps, 1.0, 500.0)
            && within(self.runaway_off_collective_min, 0.0, 1.0)
            // NaN fails both comparisons.
            && self.runaway_off_torque_max > 0.0
            && self.runaway_off_torque_max < self.runaway_torque_min
    }

    /// `cos(arm_max_tilt)`: the body-down · earth-down threshold.
    pub(crate) fn arm_cos_tilt(&self) -> f32 {
        cos_deg(self.arm_max_tilt_deg)
    }

    /// `cos(crash_tilt)`.
    pub(crate) fn crash_cos_tilt(&self) -> f32 {
        cos_deg(self.crash_tilt_deg)
    }
}

/// `cos` of an angle in degrees through the loops' polynomial (within
/// 2.5e-7 up to 180°, the validated range; libm's `cosf` would pull in
/// its f64 argument reduction, ~4.8 KiB of flash).
fn cos_deg(a_deg: f32) -> f32 {
    control::loops::half_angle_sin_cos(2.0 * a_deg * RAD_PER_DEG).1
}

/// A validated (positive, finite) limit in Q16, rounded to nearest as
/// [`control::fixed::f32_to_q`] rounds the values compared with it (a
/// value equal to the limit in `f32` is equal in Q16), by a multiply that
/// folds at compile time for the firmware's constant configuration (`as`
/// saturates).
#[inline(always)]
pub(crate) fn q16_limit(x: f32) -> u32 {
    (x * 65_536.0 + 0.5) as u32
}
