//! Stick shaping: pilot sticks → body-rate setpoints (acro), tilt-angle
//! setpoints (self-level) and a shaped throttle.
//!
//! Inputs are the receiver's normalised sticks: roll, pitch and yaw in
//! −1..1, throttle in 0..1. Sign conventions follow body FRD: roll stick
//! right (+) → right wing down (+p), pitch stick **forward/up (+) → nose
//! down**, i.e. a *negative* pitch rate/angle, yaw stick right (+) → nose
//! right (+r, clockwise seen from above). Out-of-range sticks are clamped;
//! a non-finite stick is [`Error::NonFinite`].
//!
//! # Expo
//!
//! Per axis, `s' = (1 − expo)·s + expo·s³` (expo 0 = linear, 1 = cubic): the
//! same full deflection, a softer centre. The rate setpoint is
//! `s' · max_rate_dps` after a centre deadband (rescaled so the output is
//! continuous at the deadband edge).
//!
//! # Throttle curve
//!
//! Piecewise about `mid` (the stick where the curve is anchored, usually
//! near hover): with `t = (x − mid)/span` (span = `mid` below, `1 − mid`
//! above), `out = mid + span·((1 − expo)·t + expo·t³)`: 0 ↦ 0, `mid` ↦ `mid`,
//! 1 ↦ 1, flatter around `mid` for finer height control.
//!
//! ```
//! use control::shaping::{Sticks, StickShaping, SticksConfig};
//! let shaping = StickShaping::new(SticksConfig::default())?;
//! let s = Sticks { roll: 1.0, pitch: 0.0, yaw: 0.0, throttle: 0.5 };
//! let rates = shaping.rate_setpoint(&s)?;
//! assert!((rates.roll_rps - 500f32.to_radians()).abs() < 1e-4); // full stick = max rate
//! # Ok::<(), control::Error>(())
//! ```

use crate::body::BodyRates;
use crate::error::{finite, Error};
use crate::pid::clamp;

const RAD_PER_DEG: f32 = core::f32::consts::PI / 180.0;

/// Normalised pilot sticks as the receiver delivers them. `rc_input::Sticks`
/// has the same fields on purpose: control does not depend on a receiver
/// crate, and `flight::flightctl::PilotInput::from_rc` converts between them.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sticks {
    /// Roll stick, −1 (left) .. 1 (right).
    pub roll: f32,
    /// Pitch stick, −1 (back, nose up) .. 1 (forward, nose down).
    pub pitch: f32,
    /// Yaw stick, −1 (left) .. 1 (right, clockwise from above).
    pub yaw: f32,
    /// Throttle stick, 0 (low) .. 1 (full).
    pub throttle: f32,
}

impl Sticks {
    /// Checks every stick is finite and clamps it to its range.
    /// Errors: [`Error::NonFinite`].
    pub fn clamped(&self) -> Result<Self, Error> {
        Ok(Self {
            roll: clamp(finite(self.roll)?, -1.0, 1.0),
            pitch: clamp(finite(self.pitch)?, -1.0, 1.0),
            yaw: clamp(finite(self.yaw)?, -1.0, 1.0),
            throttle: clamp(finite(self.throttle)?, 0.0, 1.0),
        })
    }
}

/// Shaping of one rate axis.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisRates {
    /// Rate at full stick, °/s, in (0, 2000].
    pub max_rate_dps: f32,
    /// Expo, 0 (linear) .. 1 (cubic).
    pub expo: f32,
    /// Centre deadband, stick units, 0 .. 0.2.
    pub deadband: f32,
}

impl AxisRates {
    /// Checks the axis: [`Error::InvalidParameter`] when out of range.
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        let ok = in_range(self.max_rate_dps, 0.0, 2000.0)
            && self.max_rate_dps > 0.0
            && in_range(self.expo, 0.0, 1.0)
            && in_range(self.deadband, 0.0, 0.2);
        if ok {
            Ok(())
        } else {
            Err(Error::InvalidParameter)
        }
    }

    /// Shaped stick (−1..1) after deadband and expo; `s` already clamped.
    fn shape(&self, s: f32) -> f32 {
        let mag = if s >= 0.0 { s } else { -s };
        let d = if mag <= self.deadband {
            0.0
        } else {
            (mag - self.deadband) / (1.0 - self.deadband)
        };
        let x = if s >= 0.0 { d } else { -d };
        expo(x, self.expo)
    }
}

/// Throttle curve, see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ThrottleCurve {
    /// Anchor stick position, in (0, 1).
    pub mid: f32,
    /// Expo around `mid`, 0 .. 1.
    pub expo: f32,
}

impl ThrottleCurve {
    /// Linear (`out = stick`).
    pub const LINEAR: Self = Self {
        mid: 0.5,
        expo: 0.0,
    };

    /// Checks the curve: [`Error::InvalidParameter`] when out of range.
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        if in_range(self.mid, 0.05, 0.95) && in_range(self.expo, 0.0, 1.0) {
            Ok(())
        } else {
            Err(Error::InvalidParameter)
        }
    }

    /// Shaped throttle for a stick already clamped to 0..1.
    pub fn apply(&self, x: f32) -> f32 {
        let span = if x < self.mid {
            self.mid
        } else {
            1.0 - self.mid
        };
        let t = (x - self.mid) / span;
        clamp(self.mid + span * expo(t, self.expo), 0.0, 1.0)
    }
}

/// Stick shaping configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SticksConfig {
    /// Roll rate shaping (acro).
    pub roll: AxisRates,
    /// Pitch rate shaping (acro).
    pub pitch: AxisRates,
    /// Yaw rate shaping (acro and self-level: yaw is always a rate).
    pub yaw: AxisRates,
    /// Tilt at full roll/pitch stick in self-level, °, in (0, 80].
    pub max_angle_deg: f32,
    /// Expo on the self-level roll/pitch sticks, 0..1.
    pub angle_expo: f32,
    /// Throttle curve.
    pub throttle: ThrottleCurve,
}

impl Default for SticksConfig {
    /// 500 °/s roll/pitch, 300 °/s yaw, expo 0.3, 2 % deadband; 30° max
    /// tilt in self-level; linear throttle.
    fn default() -> Self {
        let rp = AxisRates {
            max_rate_dps: 500.0,
            expo: 0.3,
            deadband: 0.02,
        };
        Self {
            roll: rp,
            pitch: rp,
            yaw: AxisRates {
                max_rate_dps: 300.0,
                ..rp
            },
            max_angle_deg: 30.0,
            angle_expo: 0.0,
            throttle: ThrottleCurve::LINEAR,
        }
    }
}

impl SticksConfig {
    /// Checks everything: [`Error::InvalidParameter`].
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        self.roll.validate()?;
        self.pitch.validate()?;
        self.yaw.validate()?;
        self.throttle.validate()?;
        if in_range(self.max_angle_deg, 0.0, 80.0)
            && self.max_angle_deg > 0.0
            && in_range(self.angle_expo, 0.0, 1.0)
        {
            Ok(())
        } else {
            Err(Error::InvalidParameter)
        }
    }
}

/// Tilt setpoint for self-level, body FRD Euler (ZYX) roll and pitch, rad.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TiltSetpoint {
    /// Roll, rad, right wing down positive.
    pub roll_rad: f32,
    /// Pitch, rad, nose up positive.
    pub pitch_rad: f32,
}

/// Validated stick shaping.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StickShaping {
    cfg: SticksConfig,
}

impl StickShaping {
    /// Validates the configuration. Errors: [`Error::InvalidParameter`].
    #[inline(always)]
    pub fn new(cfg: SticksConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self { cfg })
    }

    /// The configuration in use.
    pub fn config(&self) -> &SticksConfig {
        &self.cfg
    }

    /// Acro: body-rate setpoints, rad/s, FRD. Errors: [`Error::NonFinite`].
    pub fn rate_setpoint(&self, sticks: &Sticks) -> Result<BodyRates, Error> {
        let s = sticks.clamped()?;
        Ok(BodyRates {
            roll_rps: self.cfg.roll.shape(s.roll) * self.cfg.roll.max_rate_dps * RAD_PER_DEG,
            pitch_rps: -self.cfg.pitch.shape(s.pitch) * self.cfg.pitch.max_rate_dps * RAD_PER_DEG,
            yaw_rps: self.yaw_rate_rps(&s),
        })
    }

    /// Yaw-rate setpoint, rad/s, for sticks already clamped (self-level
    /// flies yaw as a rate too).
    fn yaw_rate_rps(&self, s: &Sticks) -> f32 {
        self.cfg.yaw.shape(s.yaw) * self.cfg.yaw.max_rate_dps * RAD_PER_DEG
    }

    /// Self-level: tilt setpoint (roll, pitch) and yaw-rate setpoint, rad/s.
    /// Errors: [`Error::NonFinite`].
    pub fn level_setpoint(&self, sticks: &Sticks) -> Result<(TiltSetpoint, f32), Error> {
        let s = sticks.clamped()?;
        let max = self.cfg.max_angle_deg * RAD_PER_DEG;
        let dz = self.cfg.roll.deadband;
        let shape = |x: f32| {
            let a = AxisRates {
                max_rate_dps: 1.0,
                expo: self.cfg.angle_expo,
                deadband: dz,
            };
            a.shape(x)
        };
        Ok((
            TiltSetpoint {
                roll_rad: shape(s.roll) * max,
                pitch_rad: -shape(s.pitch) * max,
            },
            self.yaw_rate_rps(&s),
        ))
    }

    /// Shaped throttle, 0..1. Errors: [`Error::NonFinite`].
    pub fn throttle(&self, stick: f32) -> Result<f32, Error> {
        Ok(self.cfg.throttle.apply(clamp(finite(stick)?, 0.0, 1.0)))
    }
}

/// `(1 − e)·x + e·x³`.
#[inline]
fn expo(x: f32, e: f32) -> f32 {
    (1.0 - e) * x + e * x * x * x
}

/// Finite and within `[lo, hi]`.
fn in_range(x: f32, lo: f32, hi: f32) -> bool {
    x.is_finite() && x >= lo && x <= hi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn throttle_curve_fixed_points() {
        let c = ThrottleCurve {
            mid: 0.4,
            expo: 0.6,
        };
        assert_eq!(c.apply(0.0), 0.0);
        assert!((c.apply(0.4) - 0.4).abs() < 1e-6);
        assert!((c.apply(1.0) - 1.0).abs() < 1e-6);
        // Flatter around mid: a small step moves less than linear.
        assert!((c.apply(0.45) - 0.4) < 0.05 * 0.5);
    }

    #[test]
    fn deadband_is_continuous() {
        let a = AxisRates {
            max_rate_dps: 100.0,
            expo: 0.0,
            deadband: 0.1,
        };
        assert_eq!(a.shape(0.05), 0.0);
        assert_eq!(a.shape(0.1), 0.0);
        assert!(a.shape(0.1001) < 1e-3);
        assert!((a.shape(1.0) - 1.0).abs() < 1e-6);
        assert!((a.shape(-1.0) + 1.0).abs() < 1e-6);
    }
}
