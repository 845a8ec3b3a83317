//! The ESC outputs' rules that hold whatever the IMU does: the off pulse
//! when the pilot's arm switch goes off or when the 1 kHz sample chain
//! stops, and when the watchdog may be fed.
//!
//! The flight controller ([`crate::flightctl`]) runs once per IMU sample,
//! so it cannot act when no sample arrives (the sensor board lost power or
//! its INT wire). [`OutputGuard`] is called from contexts that do not
//! depend on the IMU and owns the last word on the outputs:
//!
//! * **Arm switch off** ([`OutputGuard::on_pilot`], from the receiver's
//!   task on every channel frame): while armed, a frame with the link up
//!   and the arm switch off forces the outputs off at once
//!   ([`ForceOffReason::ArmSwitchOff`]). The off pulse is on all four pins
//!   within [`ARM_SWITCH_OFF_BOUND_US`] of the end of that frame: the
//!   receiver task's latency (≤ 1.5 ms, the interrupts defmt holds off),
//!   the PWM frame in flight (the compare registers are preloaded: ≤ 2.5 ms
//!   at 400 Hz) and the off pulse itself (1 ms). A CRSF frame comes every
//!   4 ms, so the pilot's flip reaches the pins within 10 ms; a PPM frame
//!   is only known complete at the next sync gap (≤ 22.5 ms later), which
//!   the receiver, not this rule, adds.
//! * **No samples** ([`OutputGuard::on_tick`], from a periodic task every
//!   [`CHECK_PERIOD_US`] at a priority above the sensor tasks): while the
//!   outputs carry anything but the off pulse (armed, or the motor test),
//!   no completed sample step for [`NO_SAMPLE_TIMEOUT_US`] forces them off
//!   ([`ForceOffReason::NoSamples`]): off on the pins within
//!   [`NO_SAMPLE_BOUND_US`] of the last step. A sample step counts when
//!   the sample task ran, whether its read succeeded or not: failed reads
//!   (a bus fault) are the flight controller's to bridge and, beyond its
//!   limit, to disarm for; a total absence of steps (INT dead, the chain
//!   stuck) is this rule's. 50 ms lies above the longest gap a healthy
//!   board makes (a flash page erase stalls the CPU ≤ 40 ms; a bus
//!   recovery ≤ 11 ms) and below the controller's 100 ms for unusable
//!   input: the motors do not hold a fixed throttle, blind, for longer
//!   than a failed-read episode would leave them. Off, not a descent: a
//!   level-less descent needs an attitude, which is what is missing.
//! * **MPU re-initialisation** ([`OutputGuard::set_mpu_recovering`], from
//!   the sensor-maintenance task): while the MPU-9250 answered wrong and is
//!   being re-checked, reset or is settling after its reset (a brown-out
//!   on the sensor board put its registers back to their defaults, so its
//!   data-ready interrupt stopped), the steps stop for the reset's length,
//!   which the sensor stack flies through (`sensor_stack::sensors`, "Armed").
//!   Then the outputs go to even thrust at the last collective (the mean
//!   of the four commands: the quad-X mixer's torques cancel in it) once
//!   no step came for [`BAD_INPUT_HOLD_US`], as the flight controller's
//!   own sensor-loss bridge does, and off only after
//!   [`RESET_BRIDGE_US`] without a step, the controller's 0.25 s limit for
//!   unusable input. An MPU that does not answer at all is not recovering
//!   (it lost power): the 50 ms rule above holds.
//! * **Latch**: a forced off stays until the next sample step has
//!   disarmed the flight controller for it ([`OutputGuard::take_forced`],
//!   then `FlightController::force_disarm`), so a sample arriving after
//!   the off cannot spin the motors again; after that only the controller's
//!   own rules start them (a fresh arm-switch flip off → on).
//! * **Watchdog** ([`OutputGuard::may_feed_watchdog`]): fed while sample
//!   steps complete (one within [`NO_SAMPLE_TIMEOUT_US`]), or while the
//!   outputs are at the off pulse, disarmed (or forced off), with the
//!   MPU-9250 out of the loop (missing, failed, being re-initialised:
//!   then no sample is expected, and the service task keeps re-probing).
//!   Never while the outputs run without samples. An MPU that reports
//!   healthy while no sample arrives (the INT line dead) is not fed for:
//!   the watchdog resets the board, which boots with the outputs at the
//!   off pulse and arms only on a fresh switch flip.

use crate::arming::DisarmCause;
use crate::flightctl::BAD_INPUT_HOLD_US;

/// No completed sample step for this long while the outputs run: off.
pub const NO_SAMPLE_TIMEOUT_US: u32 = 50_000;

/// No completed sample step for this long while the MPU-9250 is being
/// re-initialised: off (the flight controller's default
/// `SafetyConfig::bad_input_disarm_s`, 0.25 s).
pub const RESET_BRIDGE_US: u32 = 250_000;

/// The periodic check's period (the firmware's guard task).
pub const CHECK_PERIOD_US: u32 = 5_000;

/// From the last sample step to the off pulse on all four pins: the
/// timeout, one check period, the PWM frame in flight (2.5 ms at 400 Hz)
/// and the off pulse itself (1 ms), rounded up.
pub const NO_SAMPLE_BOUND_US: u32 = NO_SAMPLE_TIMEOUT_US + CHECK_PERIOD_US + 5_000;

/// From the end of a receiver frame with the arm switch off to the off
/// pulse on all four pins (see the [module docs](self)).
pub const ARM_SWITCH_OFF_BOUND_US: u32 = 5_000;

/// Why the guard forced the outputs off.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ForceOffReason {
    /// The receiver saw the arm switch off (link up) while armed.
    ArmSwitchOff,
    /// No sample step for [`NO_SAMPLE_TIMEOUT_US`] while the outputs ran.
    NoSamples,
}

#[cfg(feature = "defmt")]
impl defmt::Format for ForceOffReason {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Self::ArmSwitchOff => defmt::write!(f, "the arm switch went off"),
            Self::NoSamples => defmt::write!(f, "no IMU sample for 50 ms while the motors ran"),
        }
    }
}

impl ForceOffReason {
    /// The flight controller's disarm cause for this reason.
    pub const fn disarm_cause(self) -> DisarmCause {
        match self {
            Self::ArmSwitchOff => DisarmCause::Switch,
            Self::NoSamples => DisarmCause::NoImuSamples,
        }
    }
}

/// What the periodic check asks of the outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TickAction {
    /// Even thrust at the last collective: every output at the mean of
    /// the four commands (once per re-initialisation).
    Level,
    /// The off pulse, for this reason.
    ForceOff(ForceOffReason),
}

/// What the outputs carry after a sample step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OutputVerdict {
    /// The flight controller's motor commands.
    Run,
    /// The off pulse, for this reason.
    ForceOff(ForceOffReason),
}

/// The outputs' guard. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputGuard {
    last_step_us: u32,
    armed: bool,
    outputs_off: bool,
    forced: Option<ForceOffReason>,
    mpu_recovering: bool,
    levelled: bool,
}

impl OutputGuard {
    /// Outputs at the off pulse, disarmed; `now_us` counts as the last
    /// sample step (the watchdog rule's grace after boot).
    pub const fn new(now_us: u32) -> Self {
        Self {
            last_step_us: now_us,
            armed: false,
            outputs_off: true,
            forced: None,
            mpu_recovering: false,
            levelled: false,
        }
    }

    /// The latched reason, while the outputs are forced off and no sample
    /// step has disarmed the flight controller for it yet.
    pub fn forced(&self) -> Option<ForceOffReason> {
        self.forced
    }

    /// Whether the outputs carry the off pulse (as far as the guard was
    /// told or decided).
    pub fn outputs_off(&self) -> bool {
        self.outputs_off
    }

    /// Start of a sample step: the latched reason, cleared. The caller
    /// disarms the flight controller for it before stepping it; the
    /// outputs stay off until [`on_step`](Self::on_step) says otherwise.
    pub fn take_forced(&mut self) -> Option<ForceOffReason> {
        self.forced.take()
    }

    /// End of a sample step at `now_us`: `armed`, the controller's state
    /// after it; `motors_run`, whether it commands anything but off (armed
    /// or the motor test). What to write: the controller's motors, or the
    /// off pulse while a reason latched since [`take_forced`](Self::take_forced).
    pub fn on_step(&mut self, now_us: u32, armed: bool, motors_run: bool) -> OutputVerdict {
        self.last_step_us = now_us;
        self.armed = armed;
        self.outputs_off = !motors_run || self.forced.is_some();
        match self.forced {
            Some(r) => OutputVerdict::ForceOff(r),
            None => OutputVerdict::Run,
        }
    }

    /// A receiver frame: the arm switch and whether the link is up, as the
    /// flight controller would see them. `Some` when this forces the
    /// outputs off now (write the off pulse and say why).
    pub fn on_pilot(&mut self, arm_switch: bool, link_ok: bool) -> Option<ForceOffReason> {
        if self.armed && link_ok && !arm_switch && self.forced.is_none() {
            return Some(self.force(ForceOffReason::ArmSwitchOff));
        }
        None
    }

    /// The sensor stack's word on the MPU-9250: `true` while it answered
    /// wrong and is being re-checked, reset or settled (see the [module
    /// docs](self)).
    pub fn set_mpu_recovering(&mut self, recovering: bool) {
        self.mpu_recovering = recovering;
    }

    /// The longest time without a step before the off pulse: 50 ms, or
    /// the re-initialisation's bridge.
    fn timeout_us(&self) -> u32 {
        if self.mpu_recovering {
            RESET_BRIDGE_US
        } else {
            NO_SAMPLE_TIMEOUT_US
        }
    }

    /// The periodic check at `now_us`. `Some` when the outputs must change
    /// now: levelled for an MPU re-initialisation, or forced off (write
    /// the off pulse and say why).
    pub fn on_tick(&mut self, now_us: u32) -> Option<TickAction> {
        if self.outputs_off {
            return None;
        }
        let since = self.since_step_us(now_us);
        if since > self.timeout_us() {
            return Some(TickAction::ForceOff(self.force(ForceOffReason::NoSamples)));
        }
        // Levelled once per gap: a check that sees a recent step (or the
        // MPU not recovering) re-arms it.
        let level = self.mpu_recovering && since > BAD_INPUT_HOLD_US;
        let first = level && !self.levelled;
        self.levelled = level;
        first.then_some(TickAction::Level)
    }

    /// Whether the watchdog may be fed at `now_us`; `mpu_in_loop`: the
    /// MPU-9250 is healthy, so its samples are expected.
    pub fn may_feed_watchdog(&self, now_us: u32, mpu_in_loop: bool) -> bool {
        let progress = self.since_step_us(now_us) <= self.timeout_us();
        let safe = self.outputs_off && (!self.armed || self.forced.is_some());
        progress || (safe && !mpu_in_loop)
    }

    fn force(&mut self, reason: ForceOffReason) -> ForceOffReason {
        self.forced = Some(reason);
        self.outputs_off = true;
        reason
    }

    /// µs since the last sample step (0 if that step's time is after
    /// `now_us`: a step stamped by a clock read that raced this one).
    pub fn since_step_us(&self, now_us: u32) -> u32 {
        let d = now_us.wrapping_sub(self.last_step_us) as i32;
        d.max(0) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u32 = 1_000;
    const OFF: TickAction = TickAction::ForceOff(ForceOffReason::NoSamples);

    /// Armed and running, last step at `t_us`.
    fn armed_at(t_us: u32) -> OutputGuard {
        let mut g = OutputGuard::new(0);
        assert_eq!(g.on_step(t_us, true, true), OutputVerdict::Run);
        g
    }

    #[test]
    fn arm_switch_off_forces_off_while_armed_only() {
        let mut g = armed_at(10 * MS);
        assert_eq!(g.on_pilot(true, true), None);
        assert_eq!(g.on_pilot(false, false), None, "link down: failsafe's");
        assert_eq!(g.on_pilot(false, true), Some(ForceOffReason::ArmSwitchOff));
        assert!(g.outputs_off());
        assert_eq!(g.on_pilot(false, true), None, "latched once");
        // Disarmed (or in the motor test, switch off by design): nothing.
        let mut g = OutputGuard::new(0);
        g.on_step(MS, false, true);
        assert_eq!(g.on_pilot(false, true), None);
    }

    #[test]
    fn no_samples_for_the_timeout_forces_off_while_running() {
        let mut g = armed_at(10 * MS);
        assert_eq!(g.on_tick(10 * MS + NO_SAMPLE_TIMEOUT_US), None);
        assert_eq!(g.on_tick(10 * MS + NO_SAMPLE_TIMEOUT_US + 1), Some(OFF));
        assert_eq!(g.on_tick(10 * MS + 2 * NO_SAMPLE_TIMEOUT_US), None);
        // Outputs at off (disarmed): nothing to force.
        let mut g = OutputGuard::new(0);
        g.on_step(MS, false, false);
        assert_eq!(g.on_tick(u32::MAX / 4), None);
    }

    #[test]
    fn the_timeout_holds_across_the_clock_wrap_and_a_racing_step() {
        let mut g = armed_at(u32::MAX - 10 * MS);
        assert_eq!(g.on_tick(20 * MS), None);
        assert_eq!(g.on_tick(NO_SAMPLE_TIMEOUT_US), Some(OFF));
        let mut g = armed_at(10 * MS);
        assert_eq!(g.on_tick(9 * MS), None, "a step stamped after now");
    }

    #[test]
    fn the_latch_keeps_the_outputs_off_until_a_step_has_disarmed() {
        let mut g = armed_at(MS);
        assert_eq!(g.on_tick(MS + 60 * MS), Some(OFF));
        // A step that started before the off (it did not take the latch)
        // still commands the motors: the off stays.
        assert_eq!(
            g.on_step(62 * MS, true, true),
            OutputVerdict::ForceOff(ForceOffReason::NoSamples)
        );
        assert!(g.outputs_off());
        // The next step takes it and disarms the controller.
        assert_eq!(g.take_forced(), Some(ForceOffReason::NoSamples));
        assert_eq!(g.on_step(63 * MS, false, false), OutputVerdict::Run);
        assert_eq!(g.forced(), None);
        assert!(g.outputs_off());
    }

    #[test]
    fn a_switch_off_between_take_and_step_stays_off() {
        let mut g = armed_at(MS);
        assert_eq!(g.take_forced(), None);
        assert_eq!(g.on_pilot(false, true), Some(ForceOffReason::ArmSwitchOff));
        assert_eq!(
            g.on_step(2 * MS, true, true),
            OutputVerdict::ForceOff(ForceOffReason::ArmSwitchOff)
        );
    }

    #[test]
    fn the_watchdog_is_fed_on_progress_or_safe_and_out_of_the_loop() {
        let g = armed_at(10 * MS);
        let late = 10 * MS + NO_SAMPLE_TIMEOUT_US + 1;
        assert!(g.may_feed_watchdog(10 * MS + NO_SAMPLE_TIMEOUT_US, true));
        // Running without samples: never, healthy MPU or not.
        assert!(!g.may_feed_watchdog(late, true));
        assert!(!g.may_feed_watchdog(late, false));
        // Forced off: fed only with the MPU out of the loop.
        let mut g = g;
        assert!(g.on_tick(late).is_some());
        assert!(g.may_feed_watchdog(late, false));
        assert!(!g.may_feed_watchdog(late, true), "INT dead: reset");
        // Disarmed at off.
        let mut g = OutputGuard::new(0);
        g.on_step(MS, false, false);
        assert!(g.may_feed_watchdog(late, false));
        assert!(!g.may_feed_watchdog(late, true));
        // The motor test without samples: not fed.
        g.on_step(MS, false, true);
        assert!(!g.may_feed_watchdog(late, false));
    }

    #[test]
    fn an_mpu_reset_is_bridged_level_then_off_after_the_bridge() {
        let t0 = u32::MAX - 20 * MS; // across the clock's wrap
        let mut g = armed_at(t0);
        g.set_mpu_recovering(true);
        let at = |ms: u32| t0.wrapping_add(ms * MS);
        assert_eq!(g.on_tick(at(10)), None, "the controller's hold first");
        assert_eq!(g.on_tick(at(11)), Some(TickAction::Level));
        assert_eq!(g.on_tick(at(15)), None, "levelled once");
        assert_eq!(g.on_tick(at(200)), None, "past 50 ms: bridged");
        assert!(g.may_feed_watchdog(at(200), true));
        assert_eq!(g.on_tick(at(251)), Some(OFF));
        // Steps again (the reset done, INT back): a later stall levels again.
        let mut g = armed_at(t0);
        g.set_mpu_recovering(true);
        assert_eq!(g.on_tick(at(20)), Some(TickAction::Level));
        g.on_step(at(30), true, true);
        assert_eq!(g.on_tick(at(35)), None, "steps again");
        assert_eq!(g.on_tick(at(45)), Some(TickAction::Level));
        // Recovery flagged only after the hold: levelled then.
        let mut g = armed_at(t0);
        assert_eq!(g.on_tick(at(12)), None);
        g.set_mpu_recovering(true);
        assert_eq!(g.on_tick(at(17)), Some(TickAction::Level));
    }

    #[test]
    fn an_mpu_not_recovering_keeps_the_50_ms_rule_and_holds_the_motors() {
        let mut g = armed_at(MS);
        assert_eq!(g.on_tick(40 * MS), None, "no level: the last commands");
        g.set_mpu_recovering(true);
        g.set_mpu_recovering(false);
        assert_eq!(g.on_tick(MS + NO_SAMPLE_TIMEOUT_US + 1), Some(OFF));
    }

    #[test]
    fn reasons_map_to_disarm_causes() {
        assert_eq!(
            ForceOffReason::ArmSwitchOff.disarm_cause(),
            DisarmCause::Switch
        );
        assert_eq!(
            ForceOffReason::NoSamples.disarm_cause(),
            DisarmCause::NoImuSamples
        );
    }
}
