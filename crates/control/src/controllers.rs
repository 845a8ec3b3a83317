//! Cascaded controllers: altitude hold and attitude (angle → rate) per axis.
//!
//! # Altitude hold
//!
//! ```text
//! height error (m) ─► P: height_kp ((m/s)/m = 1/s) ─► clamp(−max_descent, +max_climb)
//!     ─► vertical-speed setpoint (m/s) ─► PID (m/s → throttle) + hover_throttle ─► throttle 0..1
//! ```
//!
//! Gains of the speed PID ([`AltitudeHoldConfig::speed_pid`]): `kp` in
//! throttle per (m/s) = s/m, `ki` in throttle per m = 1/m, `kd` in throttle
//! per (m/s²) = s²/m; its output and integral limits are throttle
//! (normalised, `0..1` = motors off .. full). `hover_throttle` is the
//! feed-forward; the integral learns the remaining mismatch (payload,
//! battery sag), so there is no steady-state height error.
//!
//! # Attitude
//!
//! Per axis (roll, pitch, yaw):
//!
//! ```text
//! angle error (rad) ─► P: angle_kp ((rad/s)/rad = 1/s) ─► clamp(±max_rate_rps)
//!     ─► body-rate setpoint (rad/s) ─► PID (rad/s → torque) ─► normalised torque −1..1
//! ```
//!
//! Rate-PID gains ([`AxisConfig::rate_pid`]): `kp` in torque per (rad/s) =
//! s/rad, `ki` in torque per rad = 1/rad, `kd` in torque per (rad/s²) =
//! s²/rad. A torque command is normalised: the [`mixer`](crate::mixer)
//! moves each motor's command by ±½ per unit, so what one unit does is the
//! airframe's. Around the hover it is 2·a·dT/dc about roll and pitch (a: a
//! motor's offset from that axis; dT/dc: thrust per unit motor command) and
//! 2·(k_m/k_f)·dT/dc about yaw; for the simulator's 250-class quad (0.60 kg,
//! 125 mm arms) at a full pack that is about 490, 410 and 34 rad/s² per
//! unit (`sim/tests/quad.rs`), so its roll `kp` of 0.25 turns 1 rad/s of
//! rate error into about 120 rad/s² of angular acceleration.
//! Angles are the AHRS's Euler angles (NED/FRD, radians), rates the
//! gyro's FRD body rates; Euler-angle errors are used directly as body-rate
//! demands, which is accurate for small roll and pitch (within ~30°, the
//! usual self-levelling envelope). The yaw error is wrapped to ±π. Yaw can be
//! commanded as an angle or as a rate only ([`YawTarget`]);
//! [`AttitudeController::update_rates`] is the rate-only (acro) mode.
//!
//! Every update checks all its inputs first and updates a copy, so an error
//! leaves the controller untouched.

pub use crate::body::{BodyRates, TorqueCommand};
use crate::error::{check_dt, check_gain, check_limits, check_positive, finite, Error};
use crate::loops::{RateConfig, RateController};
use crate::pid::{clamp, Pid, PidConfig};
use core::f32::consts::PI;

const TWO_PI: f32 = 2.0 * PI;

/// Altitude-hold tuning. See the [module docs](self) for the units.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AltitudeHoldConfig {
    /// Height P gain, (m/s)/m = 1/s. `>= 0`.
    pub height_kp: f32,
    /// Largest commanded climb speed, m/s, `> 0`.
    pub max_climb_mps: f32,
    /// Largest commanded descent speed (a magnitude), m/s, `> 0`.
    pub max_descent_mps: f32,
    /// Throttle that holds a hover (feed-forward), within the speed PID's
    /// output limits.
    pub hover_throttle: f32,
    /// Vertical-speed PID: m/s → throttle. Its output limits are the throttle limits.
    pub speed_pid: PidConfig,
}

impl Default for AltitudeHoldConfig {
    /// Tuned on the closed-loop test model: ~1 kg quad, full throttle =
    /// 2 × weight (hover ≈ 0.5), 1 kHz loop.
    fn default() -> Self {
        Self {
            height_kp: 3.0,
            max_climb_mps: 2.0,
            max_descent_mps: 1.5,
            hover_throttle: 0.5,
            speed_pid: PidConfig::new(0.5, 0.5, 0.0)
                .with_output_limits(0.0, 1.0)
                .with_integral_limits(-0.3, 0.3),
        }
    }
}

impl AltitudeHoldConfig {
    /// Checks the configuration: [`Error::NegativeGain`],
    /// [`Error::InvalidParameter`] (speed limits), [`Error::InvalidLimits`]
    /// (hover throttle outside the output limits), or the PID's errors.
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        check_gain(self.height_kp)?;
        check_positive(self.max_climb_mps)?;
        check_positive(self.max_descent_mps)?;
        self.speed_pid.validate()?;
        check_limits(self.speed_pid.output_min, self.hover_throttle)?;
        check_limits(self.hover_throttle, self.speed_pid.output_max)?;
        Ok(())
    }
}

/// Altitude hold: height P → vertical-speed PID → throttle.
///
/// ```
/// use control::controllers::{AltitudeHold, AltitudeHoldConfig};
/// let mut hold = AltitudeHold::new(AltitudeHoldConfig::default()).unwrap();
/// // At the target and not moving: hover throttle.
/// let t = hold.update(10.0, 10.0, 0.0, 0.001).unwrap();
/// assert!((t - 0.5).abs() < 1e-6);
/// // Below the target: more throttle.
/// assert!(hold.update(10.0, 9.0, 0.0, 0.001).unwrap() > 0.5);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AltitudeHold {
    cfg: AltitudeHoldConfig,
    speed: Pid,
    speed_setpoint_mps: f32,
}

impl AltitudeHold {
    /// Creates the controller. Errors: see [`AltitudeHoldConfig::validate`].
    #[inline(always)]
    pub fn new(cfg: AltitudeHoldConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            speed: Pid::new(cfg.speed_pid)?,
            speed_setpoint_mps: 0.0,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &AltitudeHoldConfig {
        &self.cfg
    }

    /// One update. `target_height_m`, `height_m` (estimate) in m, up;
    /// `velocity_mps` (estimate) in m/s, up; `dt_s` in s. Returns the
    /// throttle within the speed PID's output limits.
    ///
    /// Errors: [`Error::NonFinite`], [`Error::InvalidDt`]; nothing changes on error.
    pub fn update(
        &mut self,
        target_height_m: f32,
        height_m: f32,
        velocity_mps: f32,
        dt_s: f32,
    ) -> Result<f32, Error> {
        finite(target_height_m)?;
        finite(height_m)?;
        finite(velocity_mps)?;
        check_dt(dt_s)?;
        let v_sp = clamp(
            self.cfg.height_kp * (target_height_m - height_m),
            -self.cfg.max_descent_mps,
            self.cfg.max_climb_mps,
        );
        let throttle =
            self.speed
                .update_with_ff(v_sp, velocity_mps, self.cfg.hover_throttle, dt_s)?;
        self.speed_setpoint_mps = v_sp;
        Ok(throttle)
    }

    /// Bumpless engage at the current height (target = height, so the speed
    /// setpoint is 0): the integral is set so the next throttle equals
    /// `throttle` (e.g. the pilot's stick). Errors: [`Error::NonFinite`].
    pub fn reset(&mut self, velocity_mps: f32, throttle: f32) -> Result<(), Error> {
        self.speed
            .reset_for(0.0, velocity_mps, self.cfg.hover_throttle, throttle)?;
        self.speed_setpoint_mps = 0.0;
        Ok(())
    }

    /// The last vertical-speed setpoint, m/s, up.
    pub fn speed_setpoint_mps(&self) -> f32 {
        self.speed_setpoint_mps
    }

    /// The speed PID's integral, throttle units.
    pub fn integral(&self) -> f32 {
        self.speed.integral()
    }
}

/// One attitude axis: angle P → rate PID. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisConfig {
    /// Angle P gain, (rad/s)/rad = 1/s. `>= 0`.
    pub angle_kp: f32,
    /// Largest body-rate setpoint magnitude, rad/s, `> 0`.
    pub max_rate_rps: f32,
    /// Rate PID: rad/s → normalised torque.
    pub rate_pid: PidConfig,
}

impl AxisConfig {
    /// Checks the axis: [`Error::NegativeGain`], [`Error::InvalidParameter`], PID errors.
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        check_gain(self.angle_kp)?;
        check_positive(self.max_rate_rps)?;
        self.rate_pid.validate()
    }
}

/// Attitude-controller tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AttitudeConfig {
    /// Roll (about body x, forward).
    pub roll: AxisConfig,
    /// Pitch (about body y, right).
    pub pitch: AxisConfig,
    /// Yaw (about body z, down).
    pub yaw: AxisConfig,
}

impl Default for AttitudeConfig {
    /// Starting point tuned on the test model (roll/pitch: 100 rad/s² per
    /// unit torque, yaw 30 rad/s², 20 ms motor lag, 1 kHz loop); re-tune
    /// for a real airframe.
    fn default() -> Self {
        let tilt = AxisConfig {
            angle_kp: 6.0,
            max_rate_rps: 3.5,
            rate_pid: PidConfig::new(0.3, 0.4, 0.002)
                .with_d_cutoff_hz(40.0)
                .with_integral_limits(-0.2, 0.2),
        };
        Self {
            roll: tilt,
            pitch: tilt,
            yaw: AxisConfig {
                angle_kp: 3.0,
                max_rate_rps: 2.0,
                rate_pid: PidConfig::new(0.3, 0.1, 0.0).with_integral_limits(-0.2, 0.2),
            },
        }
    }
}

impl AttitudeConfig {
    /// Checks all three axes.
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        self.roll.validate()?;
        self.pitch.validate()?;
        self.yaw.validate()
    }
}

/// Euler attitude (NED/FRD, ZYX), rad.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Attitude {
    /// Roll, rad, right wing down positive.
    pub roll_rad: f32,
    /// Pitch, rad, nose up positive.
    pub pitch_rad: f32,
    /// Yaw (heading), rad, clockwise from north seen from above.
    pub yaw_rad: f32,
}

/// How yaw is commanded.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum YawTarget {
    /// Hold a heading, rad.
    Angle(f32),
    /// Rate only, rad/s (no heading hold).
    Rate(f32),
}

/// Attitude setpoint.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AttitudeTarget {
    /// Roll, rad.
    pub roll_rad: f32,
    /// Pitch, rad.
    pub pitch_rad: f32,
    /// Yaw as angle or rate.
    pub yaw: YawTarget,
}

/// Attitude controller: per-axis angle P → rate PID.
///
/// ```
/// use control::controllers::*;
/// let mut att = AttitudeController::new(AttitudeConfig::default()).unwrap();
/// let target = AttitudeTarget { roll_rad: 0.1, pitch_rad: 0.0, yaw: YawTarget::Rate(0.0) };
/// let tq = att.update(&target, &Attitude::default(), &BodyRates::default(), 0.001).unwrap();
/// assert!(tq.roll > 0.0 && tq.pitch == 0.0 && tq.yaw == 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AttitudeController {
    cfg: AttitudeConfig,
    /// The inner loop: the same rate PIDs the 1 kHz flight loop runs.
    rates: RateController,
    rate_setpoint: BodyRates,
}

/// Wraps an angle difference to [−π, π].
fn wrap_pi(mut e: f32) -> f32 {
    if !(-TWO_PI..=TWO_PI).contains(&e) {
        e = libm::remainderf(e, TWO_PI); // rare: inputs far outside ±π
    }
    if e > PI {
        e -= TWO_PI;
    } else if e < -PI {
        e += TWO_PI;
    }
    e
}

impl AttitudeController {
    /// Creates the controller. Errors: see [`AttitudeConfig::validate`].
    pub fn new(cfg: AttitudeConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            rates: RateController::new(RateConfig {
                roll: cfg.roll.rate_pid,
                pitch: cfg.pitch.rate_pid,
                yaw: cfg.yaw.rate_pid,
            })?,
            rate_setpoint: BodyRates::default(),
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &AttitudeConfig {
        &self.cfg
    }

    /// Angle mode: angle P → rate PID on every axis (yaw per [`YawTarget`]).
    ///
    /// Errors: [`Error::NonFinite`], [`Error::InvalidDt`]; nothing changes on error.
    pub fn update(
        &mut self,
        target: &AttitudeTarget,
        attitude: &Attitude,
        rates: &BodyRates,
        dt_s: f32,
    ) -> Result<TorqueCommand, Error> {
        finite(target.roll_rad)?;
        finite(target.pitch_rad)?;
        finite(attitude.roll_rad)?;
        finite(attitude.pitch_rad)?;
        finite(attitude.yaw_rad)?;
        let axis_rate =
            |a: &AxisConfig, err: f32| clamp(a.angle_kp * err, -a.max_rate_rps, a.max_rate_rps);
        let yaw_rps = match target.yaw {
            YawTarget::Angle(y) => {
                finite(y)?;
                axis_rate(&self.cfg.yaw, wrap_pi(y - attitude.yaw_rad))
            }
            YawTarget::Rate(r) => finite(r)?,
        };
        let sp = BodyRates {
            roll_rps: axis_rate(&self.cfg.roll, target.roll_rad - attitude.roll_rad),
            pitch_rps: axis_rate(&self.cfg.pitch, target.pitch_rad - attitude.pitch_rad),
            yaw_rps,
        };
        self.update_rates(&sp, rates, dt_s)
    }

    /// Rate mode: body-rate setpoints (rad/s, FRD) → rate PIDs.
    ///
    /// Errors: [`Error::NonFinite`], [`Error::InvalidDt`]; nothing changes on error.
    pub fn update_rates(
        &mut self,
        setpoint: &BodyRates,
        rates: &BodyRates,
        dt_s: f32,
    ) -> Result<TorqueCommand, Error> {
        let out = self.rates.update(setpoint, rates, dt_s)?;
        self.rate_setpoint = *setpoint;
        Ok(out)
    }

    /// Bumpless engage (e.g. at arming): integrals zero, derivative history
    /// set to the measured `rates` (no D kick), so the first output is just
    /// the P response. Errors: [`Error::NonFinite`]; nothing changes on error.
    pub fn reset(&mut self, rates: &BodyRates) -> Result<(), Error> {
        self.rates.reset(rates)?;
        self.rate_setpoint = *rates;
        Ok(())
    }

    /// The last body-rate setpoints, rad/s.
    pub fn rate_setpoint(&self) -> BodyRates {
        self.rate_setpoint
    }

    /// The rate PIDs' integrals (roll, pitch, yaw), torque units.
    pub fn integrals(&self) -> TorqueCommand {
        self.rates.integrals()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_pi_wraps() {
        assert!((wrap_pi(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-5);
        assert!((wrap_pi(-3.0 * PI / 2.0) - PI / 2.0).abs() < 1e-5);
        assert!((wrap_pi(0.3) - 0.3).abs() < 1e-7);
        let w = wrap_pi(1.0e6);
        assert!((-PI..=PI).contains(&w));
    }

    #[test]
    fn yaw_takes_short_way_round() {
        let mut att = AttitudeController::new(AttitudeConfig::default()).unwrap();
        // Heading 170°, target −170°: turn +20° (clockwise), not −340°.
        let target = AttitudeTarget {
            roll_rad: 0.0,
            pitch_rad: 0.0,
            yaw: YawTarget::Angle(-170f32.to_radians()),
        };
        let now = Attitude {
            yaw_rad: 170f32.to_radians(),
            ..Attitude::default()
        };
        let tq = att
            .update(&target, &now, &BodyRates::default(), 0.001)
            .unwrap();
        assert!(tq.yaw > 0.0);
        assert!(att.rate_setpoint().yaw_rps > 0.0);
    }
}
