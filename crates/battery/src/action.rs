//! What the flight controller does about a low battery: the rule
//! ([`battery_action`], a pure function) and the pilot's override of the
//! automatic descent ([`LowBatteryDescent`], which remembers where the
//! descent began and whether the pilot took over).
//!
//! There is no disarm among the actions: a low battery never stops the
//! motors. The only control taken from a pilot with a live link is the
//! descent, and any stick input beyond the override limits hands it back
//! for the rest of the flight.

use crate::error::{Error, Setting};
use crate::monitor::Level;

/// 1.0 in Q30.
const ONE_Q30: i32 = 1 << 30;

/// The pilot's sticks in Q30: `flight::flightctl::PilotInput::sticks`
/// (roll, pitch, yaw −1..1, throttle 0..1) converted once per pilot frame
/// by the bits (`control::fixed::f32_to_q(x, 30)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SticksQ30 {
    /// Roll stick, Q30, −1 (left) .. 1 (right).
    pub roll_q30: i32,
    /// Pitch stick, Q30, −1 .. 1.
    pub pitch_q30: i32,
    /// Yaw stick, Q30, −1 .. 1.
    pub yaw_q30: i32,
    /// Throttle stick, Q30, 0 .. 1.
    pub throttle_q30: i32,
}

/// The flight controller's state, as far as the rule needs it (from
/// `FlightController::is_armed`, `FlightController::in_flight`,
/// `VehicleState::altitude.is_some()` and `PilotInput::link_ok`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlightContext {
    /// Armed (including a link-loss failsafe).
    pub armed: bool,
    /// Flying (`flight::flightctl::FlightController::in_flight`).
    pub in_air: bool,
    /// An altitude estimate (barometer) is available.
    pub altitude_available: bool,
    /// The pilot's link is up (sticks valid).
    pub link_ok: bool,
}

/// What the flight controller should do about the battery.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BatteryAction {
    /// Nothing (no pack, or above the thresholds).
    #[default]
    None,
    /// Tell the pilot (log, telemetry); the pilot keeps control.
    Warn,
    /// Descend at this rate with altitude hold, level, until the landing
    /// detector disarms; the pilot's sticks override it
    /// ([`LowBatteryDescent`]).
    Descend {
        /// Descent rate, Q16 m/s, positive down (as
        /// `flight`'s failsafe descent).
        descent_mps_q16: i32,
    },
}

/// The low-battery descent's settings (defaults:
/// [`DescentConfig::DEFAULT`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DescentConfig {
    /// Descent rate, Q16 m/s, positive down (0.1..=3 m/s; 0.5 m/s, the
    /// link-loss failsafe's).
    pub descent_mps_q16: i32,
    /// A roll, pitch or yaw stick beyond ± this hands control back, Q30
    /// (0.05..=0.5; 0.2 of full deflection).
    pub stick_deadband_q30: i32,
    /// The throttle stick moved more than this from where it was when the
    /// descent began hands control back, Q30 (0.05..=0.5; 0.2).
    pub throttle_move_q30: i32,
}

impl DescentConfig {
    /// 0.5 m/s down; override at 20 % of a roll, pitch or yaw stick's
    /// deflection or 20 % of throttle travel.
    pub const DEFAULT: Self = Self {
        descent_mps_q16: 1 << 15,
        stick_deadband_q30: ONE_Q30 / 5,
        throttle_move_q30: ONE_Q30 / 5,
    };

    /// Checks every setting's range.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the first setting out of range.
    pub fn check(&self) -> Result<(), Error> {
        // Rounded up: 0.1 m/s is 6553.6 in Q16, so 6553 is below it.
        let q16 = |tenths: i32| (tenths * (1 << 16) + 9) / 10;
        let bad = |ok: bool, s: Setting| if ok { Ok(()) } else { Err(Error::Setting(s)) };
        bad(
            (q16(1)..=q16(30)).contains(&self.descent_mps_q16),
            Setting::DescentRate,
        )?;
        let in_range = |x: i32| (ONE_Q30 / 20..=ONE_Q30 / 2).contains(&x);
        bad(in_range(self.stick_deadband_q30), Setting::StickDeadband)?;
        bad(in_range(self.throttle_move_q30), Setting::ThrottleMove)
    }
}

impl Default for DescentConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The rule:
///
/// * [`Level::NoBattery`], [`Level::Ok`] → [`BatteryAction::None`];
/// * [`Level::Warning`] → [`BatteryAction::Warn`];
/// * [`Level::Critical`] → [`BatteryAction::Descend`] when armed, with an
///   altitude estimate, not `handed_back`, and either in the air or with
///   the descent already under way (`descending`: a touch-down that ends
///   the in-air verdict does not give the pilot's throttle back before the
///   landing detector disarms); otherwise [`BatteryAction::Warn`] (on the
///   ground, disarmed, without a barometer, or after the pilot took over).
#[must_use]
pub fn battery_action(
    level: Level,
    ctx: &FlightContext,
    descending: bool,
    handed_back: bool,
    cfg: &DescentConfig,
) -> BatteryAction {
    match level {
        Level::NoBattery | Level::Ok => BatteryAction::None,
        Level::Warning => BatteryAction::Warn,
        Level::Critical => {
            let descend =
                ctx.armed && ctx.altitude_available && !handed_back && (ctx.in_air || descending);
            if descend {
                BatteryAction::Descend {
                    descent_mps_q16: cfg.descent_mps_q16,
                }
            } else {
                BatteryAction::Warn
            }
        }
    }
}

/// Where the low-battery descent is in this flight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DescentPhase {
    /// No descent yet in this flight.
    #[default]
    Idle,
    /// Descending; the throttle stick where it was when the descent began
    /// (`None` until the link gave a valid stick).
    Descending {
        /// Throttle at the start, Q30.
        throttle_at_start_q30: Option<i32>,
    },
    /// The pilot took over, or the altitude estimate was lost during the
    /// descent: the pilot flies until disarmed (only warnings).
    PilotControl,
}

/// The override of the low-battery descent: once per flight (reset by a
/// disarm), the descent begins when [`battery_action`] asks for it; with
/// the link up, a roll, pitch or yaw stick beyond
/// [`DescentConfig::stick_deadband_q30`], or the throttle moved by more
/// than [`DescentConfig::throttle_move_q30`] from where it was when the
/// descent began, hands control back to the pilot for the rest of the
/// flight. Losing the altitude estimate during the descent hands it back
/// likewise. With the link lost the sticks are not read (the link-loss
/// failsafe flies).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LowBatteryDescent {
    cfg: DescentConfig,
    phase: DescentPhase,
}

impl LowBatteryDescent {
    /// A guard for a new flight.
    ///
    /// # Errors
    /// [`Error::Setting`] for a setting out of range.
    pub fn new(cfg: DescentConfig) -> Result<Self, Error> {
        cfg.check()?;
        Ok(Self {
            cfg,
            phase: DescentPhase::Idle,
        })
    }

    /// Where the descent is.
    #[must_use]
    pub fn phase(&self) -> DescentPhase {
        self.phase
    }

    /// The action for this step (call it at every step the flight
    /// controller takes, or at least at every pilot frame).
    pub fn update(
        &mut self,
        level: Level,
        ctx: &FlightContext,
        sticks: &SticksQ30,
    ) -> BatteryAction {
        if !ctx.armed {
            self.phase = DescentPhase::Idle;
        }
        let descending = matches!(self.phase, DescentPhase::Descending { .. });
        let handed_back = self.phase == DescentPhase::PilotControl;
        let action = battery_action(level, ctx, descending, handed_back, &self.cfg);
        match (action, self.phase) {
            (BatteryAction::Descend { .. }, DescentPhase::Idle) => {
                self.phase = DescentPhase::Descending {
                    throttle_at_start_q30: None,
                };
                self.check_override(ctx, sticks, action)
            }
            (BatteryAction::Descend { .. }, DescentPhase::Descending { .. }) => {
                self.check_override(ctx, sticks, action)
            }
            // The descent stopped (altitude lost): never resumed this flight.
            (_, DescentPhase::Descending { .. }) => {
                self.phase = DescentPhase::PilotControl;
                action
            }
            _ => action,
        }
    }

    /// `action` (a descent) unless the pilot's sticks take over.
    fn check_override(
        &mut self,
        ctx: &FlightContext,
        sticks: &SticksQ30,
        action: BatteryAction,
    ) -> BatteryAction {
        let DescentPhase::Descending {
            throttle_at_start_q30,
        } = self.phase
        else {
            return action;
        };
        if !ctx.link_ok {
            return action;
        }
        let start = throttle_at_start_q30.unwrap_or(sticks.throttle_q30);
        self.phase = DescentPhase::Descending {
            throttle_at_start_q30: Some(start),
        };
        let dead = self.cfg.stick_deadband_q30.unsigned_abs();
        let deflected = [sticks.roll_q30, sticks.pitch_q30, sticks.yaw_q30]
            .iter()
            .any(|s| s.unsigned_abs() > dead);
        let moved = (i64::from(sticks.throttle_q30) - i64::from(start)).unsigned_abs()
            > u64::from(self.cfg.throttle_move_q30.unsigned_abs());
        if deflected || moved {
            self.phase = DescentPhase::PilotControl;
            return BatteryAction::Warn;
        }
        action
    }
}
