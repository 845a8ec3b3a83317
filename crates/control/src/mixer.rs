//! Quad-X mixer: collective throttle + normalised body torques → four motor
//! commands in `[idle, 1]`, keeping attitude authority under saturation.
//!
//! # Layout (Betaflight numbering, "props in")
//!
//! Seen from above, nose up the page:
//!
//! ```text
//!        front
//!    4 (CW)   2 (CCW)
//!         \ /
//!          X
//!         / \
//!    3 (CCW)  1 (CW)
//!        rear
//! ```
//!
//! | index | Betaflight motor | position | spin (from above) | roll | pitch | yaw |
//! |---|---|---|---|---|---|---|
//! | 0 | 1 | rear right | CW | −½ | −½ | −½ |
//! | 1 | 2 | front right | CCW | −½ | +½ | +½ |
//! | 2 | 3 | rear left | CCW | +½ | −½ | +½ |
//! | 3 | 4 | front left | CW | +½ | +½ | −½ |
//!
//! This is Betaflight's default quad-X (props in: the front props' blades
//! move towards the centre line at the front). PX4 numbers the same frame
//! differently (its motor 1 is front right CCW, 2 rear left CCW, 3 front
//! left CW, 4 rear right CW); map the outputs accordingly when wiring.
//!
//! Signs are body FRD: roll + = right wing down (left motors up), pitch + =
//! nose up (front motors up), yaw + = nose right, clockwise from above: a
//! prop spinning CCW pushes the frame CW, so the CCW motors speed up. A
//! torque command of 1 on one axis alone at half throttle spans the motors
//! from 0 to 1.
//!
//! # Saturation
//!
//! With throttle `T` (clamped to `[idle, 1]`), roll/pitch part `d` and yaw
//! part `y` (both from the table above):
//!
//! 1. Roll/pitch: the largest gain `g_rp ≤ 1` such that `T + g_rp·d` spans
//!    no more than `1 − idle` (so *some* collective fits it). Roll and pitch
//!    are scaled together, so their ratio is kept.
//! 2. Yaw: the largest `g_y ≤ 1` such that `T + g_rp·d + g_y·y` still spans
//!    no more than `1 − idle`: yaw gives up its authority first.
//! 3. Collective: the smallest shift (towards 0) that brings every motor
//!    into `[idle, 1]` — throttle is reduced when a motor would exceed 1 and
//!    raised when one would fall below idle.
//!
//! Unsaturated, `g_rp = g_y = 1` and the shift is 0: the commanded torques
//! and throttle are reproduced exactly. This is PX4's desaturation order
//! (roll/pitch, then yaw, throttle shifted both ways).
//!
//! ```
//! use control::controllers::TorqueCommand;
//! use control::mixer::{Mixer, MixerConfig};
//! let mixer = Mixer::new(MixerConfig::default())?;
//! let out = mixer.mix(0.5, &TorqueCommand { roll: 0.2, pitch: 0.0, yaw: 0.0 })?;
//! assert!(out.motors[2] > out.motors[0]); // left motors up: right wing down
//! assert_eq!(out.roll_pitch_gain, 1.0);
//! # Ok::<(), control::Error>(())
//! ```

use crate::body::TorqueCommand;
use crate::error::{finite, Error};
use crate::pid::clamp;

/// Number of motors.
pub const MOTORS: usize = 4;

/// Roll, pitch, yaw coefficient of each motor (see the [module docs](self)).
pub const QUAD_X: [[f32; 3]; MOTORS] = [
    [-0.5, -0.5, -0.5], // 1 rear right, CW
    [-0.5, 0.5, 0.5],   // 2 front right, CCW
    [0.5, -0.5, 0.5],   // 3 rear left, CCW
    [0.5, 0.5, -0.5],   // 4 front left, CW
];

/// Mixer configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MixerConfig {
    /// Lowest motor command while armed (props keep turning), in `[0, 0.3]`.
    pub idle: f32,
}

impl Default for MixerConfig {
    /// 5 % idle.
    fn default() -> Self {
        Self { idle: 0.05 }
    }
}

impl MixerConfig {
    /// Checks the idle: [`Error::InvalidParameter`] unless in `[0, 0.3]`.
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        if self.idle.is_finite() && (0.0..=0.3).contains(&self.idle) {
            Ok(())
        } else {
            Err(Error::InvalidParameter)
        }
    }
}

/// One mix: the motor commands and how much was given up.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MixOutput {
    /// Motor commands in `[idle, 1]`, indexed as in the [module docs](self)
    /// (index 0 = Betaflight motor 1).
    pub motors: [f32; MOTORS],
    /// Scale applied to roll and pitch, 0..1 (1 = unsaturated).
    pub roll_pitch_gain: f32,
    /// Scale applied to yaw, 0..1 (1 = unsaturated).
    pub yaw_gain: f32,
    /// Change of collective throttle applied, motor-command units.
    pub collective_shift: f32,
}

impl MixOutput {
    /// True when any torque was scaled down or the collective shifted.
    pub fn saturated(&self) -> bool {
        self.roll_pitch_gain < 1.0 || self.yaw_gain < 1.0 || self.collective_shift != 0.0
    }
}

/// The quad-X mixer.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Mixer {
    cfg: MixerConfig,
}

impl Mixer {
    /// Validates the configuration. Errors: [`Error::InvalidParameter`].
    #[inline(always)]
    pub fn new(cfg: MixerConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self { cfg })
    }

    /// The configuration in use.
    pub fn config(&self) -> &MixerConfig {
        &self.cfg
    }

    /// Mixes throttle (0..1, clamped to `[idle, 1]`) and torques (each
    /// clamped to −1..1). Errors: [`Error::NonFinite`].
    pub fn mix(&self, throttle: f32, torque: &TorqueCommand) -> Result<MixOutput, Error> {
        let lo = self.cfg.idle;
        let hi = 1.0;
        let width = hi - lo;
        let t = clamp(finite(throttle)?, lo, hi);
        let roll = clamp(finite(torque.roll)?, -1.0, 1.0);
        let pitch = clamp(finite(torque.pitch)?, -1.0, 1.0);
        let yaw = clamp(finite(torque.yaw)?, -1.0, 1.0);

        let mut rp = [0.0f32; MOTORS];
        let mut y = [0.0f32; MOTORS];
        let mut m = [0.0f32; MOTORS];
        let mut fits = true;
        for i in 0..MOTORS {
            rp[i] = QUAD_X[i][0] * roll + QUAD_X[i][1] * pitch;
            y[i] = QUAD_X[i][2] * yaw;
            m[i] = t + rp[i] + y[i];
            fits &= m[i] >= lo && m[i] <= hi;
        }
        // The usual case in flight: nothing to give up, no division.
        if fits {
            return Ok(MixOutput {
                motors: m,
                roll_pitch_gain: 1.0,
                yaw_gain: 1.0,
                collective_shift: 0.0,
            });
        }
        // Roll/pitch from a flat base: the gain is width / span (one division).
        let (rp_lo, rp_hi) = min_max(&rp);
        let rp_span = rp_hi - rp_lo;
        let g_rp = if rp_span > width {
            width / rp_span
        } else {
            1.0
        };
        let mut base = [0.0f32; MOTORS];
        for i in 0..MOTORS {
            base[i] = g_rp * rp[i];
        }
        let g_y = max_gain(&base, &y, width);
        for i in 0..MOTORS {
            m[i] = t + base[i] + g_y * y[i];
        }
        let (lo_v, hi_v) = min_max(&m);
        // The span fits, so `lo − lo_v <= hi − hi_v` up to rounding; take
        // the shift nearest to 0 (keeps the pilot's throttle when possible).
        let shift = if hi_v > hi {
            hi - hi_v
        } else if lo_v < lo {
            lo - lo_v
        } else {
            0.0
        };
        for v in m.iter_mut() {
            *v = clamp(*v + shift, lo, hi); // rounding only
        }
        Ok(MixOutput {
            motors: m,
            roll_pitch_gain: g_rp,
            yaw_gain: g_y,
            collective_shift: shift,
        })
    }
}

fn min_max(v: &[f32; MOTORS]) -> (f32, f32) {
    let (mut lo, mut hi) = (v[0], v[0]);
    for x in &v[1..] {
        if *x < lo {
            lo = *x;
        }
        if *x > hi {
            hi = *x;
        }
    }
    (lo, hi)
}

/// The largest `g` in `[0, 1]` with `span(base + g·add) <= width`, given
/// `span(base) <= width`: every pair `(i, j)` bounds it by
/// `(width − (bᵢ − bⱼ)) / (aᵢ − aⱼ)` where `aᵢ > aⱼ`.
fn max_gain(base: &[f32; MOTORS], add: &[f32; MOTORS], width: f32) -> f32 {
    let mut g = 1.0f32;
    for i in 0..MOTORS {
        for j in 0..MOTORS {
            let da = add[i] - add[j];
            if da > 0.0 {
                let room = width - (base[i] - base[j]);
                // Only saturating pairs divide.
                if room < g * da {
                    g = if room > 0.0 { room / da } else { 0.0 };
                }
            }
        }
    }
    g
}

/// Collective and torques reproduced by a set of motor commands (the
/// least-squares inverse of [`QUAD_X`]): `(throttle, torque)`.
pub fn unmix(motors: &[f32; MOTORS]) -> (f32, TorqueCommand) {
    let mut tq = [0.0f32; 3];
    let mut thr = 0.0;
    for (m, row) in motors.iter().zip(QUAD_X.iter()) {
        thr += 0.25 * m;
        for (k, c) in row.iter().enumerate() {
            tq[k] += c * m; // Σ c² = 1 per column
        }
    }
    (
        thr,
        TorqueCommand {
            roll: tq[0],
            pitch: tq[1],
            yaw: tq[2],
        },
    )
}
