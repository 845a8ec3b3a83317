//! The flight loops: a body-rate loop on the gyro (run at the IMU rate,
//! 1 kHz) and a self-levelling angle loop feeding it, with the attitude
//! error taken from quaternions (no Euler angles, no gimbal lock).
//!
//! * [`RateController`]: one [`Pid`] per body axis (anti-windup, derivative
//!   on measurement with its low-pass, bumpless reset), body rates in rad/s
//!   (FRD: p about x forward, q about y right, r about z down) →
//!   [`TorqueCommand`] normalised −1..1 for the [`mixer`](crate::mixer).
//! * [`LevelController`]: tilt setpoint (roll, pitch) → body-rate setpoint.
//!   The desired attitude is the current heading with the commanded roll
//!   and pitch, `q_d = q_z(ψ) ⊗ q_y(θ) ⊗ q_x(φ)` with ψ the ZYX heading of
//!   `q`; the error
//!   `q_e = q⁻¹ ⊗ q_d` is a body-frame rotation whose vector part, times
//!   `2·sign(w)`, is the rotation vector (exact direction, magnitude
//!   `2 sin(angle/2)`), and the rate setpoint is `kp` times it, limited to
//!   `max_rate_rps` per axis. Yaw comes from the pilot as a rate, replacing
//!   the error's z component.
//!
//! ```
//! use control::controllers::BodyRates;
//! use control::loops::{LevelConfig, LevelController, Quat};
//! use control::shaping::TiltSetpoint;
//! let level = LevelController::new(LevelConfig::default())?;
//! // Level now, commanded 10° right roll: positive roll-rate demand.
//! let sp = level.rate_setpoint(&Quat::IDENTITY, &TiltSetpoint { roll_rad: 0.17, pitch_rad: 0.0 }, 0.0)?;
//! assert!(sp.roll_rps > 0.0 && sp.pitch_rps.abs() < 1e-6);
//! # Ok::<(), control::Error>(())
//! ```

use crate::body::{BodyRates, TorqueCommand};
use crate::error::{check_dt, check_positive, finite, Error};
use crate::pid::{clamp, Pid, PidConfig};
use crate::shaping::TiltSetpoint;

/// A rotation quaternion `q_ned_from_body` (Hamilton, scalar first), as the
/// AHRS produces it. Need not be exactly unit length.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Quat {
    /// Scalar part.
    pub w: f32,
    /// x (north / forward) component.
    pub x: f32,
    /// y (east / right) component.
    pub y: f32,
    /// z (down) component.
    pub z: f32,
}

impl Quat {
    /// No rotation: body axes aligned with NED.
    pub const IDENTITY: Self = Self {
        w: 1.0,
        x: 0.0,
        y: 0.0,
        z: 0.0,
    };

    /// Hamilton product `self ⊗ o`.
    pub fn mul(&self, o: &Self) -> Self {
        Self {
            w: self.w * o.w - self.x * o.x - self.y * o.y - self.z * o.z,
            x: self.w * o.x + self.x * o.w + self.y * o.z - self.z * o.y,
            y: self.w * o.y - self.x * o.z + self.y * o.w + self.z * o.x,
            z: self.w * o.z + self.x * o.y - self.y * o.x + self.z * o.w,
        }
    }

    /// Conjugate (the inverse of a unit quaternion).
    pub fn conj(&self) -> Self {
        Self {
            w: self.w,
            x: -self.x,
            y: -self.y,
            z: -self.z,
        }
    }

    /// Rotation about body x by `a` rad.
    pub fn about_x(a_rad: f32) -> Self {
        let (s, c) = half(a_rad);
        Self {
            w: c,
            x: s,
            y: 0.0,
            z: 0.0,
        }
    }

    /// Rotation about y by `a` rad.
    pub fn about_y(a_rad: f32) -> Self {
        let (s, c) = half(a_rad);
        Self {
            w: c,
            x: 0.0,
            y: s,
            z: 0.0,
        }
    }

    /// Rotation about z by `a` rad.
    pub fn about_z(a_rad: f32) -> Self {
        let (s, c) = half(a_rad);
        Self {
            w: c,
            x: 0.0,
            y: 0.0,
            z: s,
        }
    }

    /// From ZYX Euler angles (NED/FRD): `q_z(yaw) ⊗ q_y(pitch) ⊗ q_x(roll)`.
    pub fn from_euler(roll_rad: f32, pitch_rad: f32, yaw_rad: f32) -> Self {
        Self::about_z(yaw_rad)
            .mul(&Self::about_y(pitch_rad))
            .mul(&Self::about_x(roll_rad))
    }

    /// Angle between body down and earth down, rad (0 = level, π = inverted).
    pub fn tilt_rad(&self) -> f32 {
        // Body z in NED, z component: 1 − 2(x² + y²) for a unit quaternion.
        let n2 = self.norm2();
        let c = if n2 > 0.0 {
            1.0 - 2.0 * (self.x * self.x + self.y * self.y) / n2
        } else {
            1.0
        };
        libm::acosf(clamp(c, -1.0, 1.0))
    }

    fn norm2(&self) -> f32 {
        self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z
    }

    fn check(&self) -> Result<(), Error> {
        finite(self.w)?;
        finite(self.x)?;
        finite(self.y)?;
        finite(self.z)?;
        if self.norm2() < 0.25 {
            return Err(Error::OutOfRange);
        }
        Ok(())
    }
}

/// `(sin(a/2), cos(a/2))` in f32 without libm's `sinf`/`cosf` (whose
/// argument reduction runs in f64 on a chip without an FPU and costs
/// ~4.8 KiB of flash).
///
/// The half angle is reduced by the nearest multiple `k·π` (π in two parts,
/// Cody–Waite, so `k·π_hi` is exact) to `|r| ≤ π/2`, where Taylor
/// polynomials to degree 11 (sine) and 12 (cosine) are within 6e-8 of the
/// functions; an odd `k` flips both signs. Accuracy (tested against the
/// f64 functions): within 2.5e-7 for `|a| ≤ 2π` -- every tilt setpoint and
/// heading -- and within 1e-6 for `|a| ≤ 200` rad; beyond that the
/// reduction's rounding grows with `|a|`. NaN in, NaN out.
// Out of line: one copy for the quaternion builders and the tilt limits.
#[inline(never)]
pub fn half_angle_sin_cos(a_rad: f32) -> (f32, f32) {
    const PI_HI: f32 = 3.140_625; // 8 significant bits: k·PI_HI is exact
    const PI_LO: f32 = 9.676_536e-4; // π − PI_HI
    let h = 0.5 * a_rad;
    let kf = h * core::f32::consts::FRAC_1_PI;
    // Round to nearest; `as` saturates (and maps NaN to 0, which keeps NaN).
    let k = (if kf >= 0.0 { kf + 0.5 } else { kf - 0.5 }) as i32;
    let r = (h - k as f32 * PI_HI) - k as f32 * PI_LO;
    let r2 = r * r;
    let s = r
        * (1.0
            + r2 * (-1.0 / 6.0
                + r2 * (1.0 / 120.0
                    + r2 * (-1.0 / 5_040.0 + r2 * (1.0 / 362_880.0 - r2 / 39_916_800.0)))));
    let c = 1.0
        + r2 * (-0.5
            + r2 * (1.0 / 24.0
                + r2 * (-1.0 / 720.0
                    + r2 * (1.0 / 40_320.0 + r2 * (-1.0 / 3_628_800.0 + r2 / 479_001_600.0)))));
    if k & 1 == 0 {
        (s, c)
    } else {
        (-s, -c)
    }
}

#[inline]
fn half(a_rad: f32) -> (f32, f32) {
    half_angle_sin_cos(a_rad)
}

/// Rate-loop tuning: one PID per axis, rad/s → torque (−1..1).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RateConfig {
    /// Roll (p).
    pub roll: PidConfig,
    /// Pitch (q).
    pub pitch: PidConfig,
    /// Yaw (r).
    pub yaw: PidConfig,
}

impl Default for RateConfig {
    /// Starting point for a 250-class quad at 1 kHz (roll/pitch D
    /// low-passed at 40 Hz; what a torque unit is physically: the module
    /// docs of [`controllers`](crate::controllers)); the board flies the
    /// `settings` crate's tuning, measured on the simulator's 0.60 kg
    /// model. Re-tune for a real airframe.
    fn default() -> Self {
        let tilt = PidConfig::new(0.25, 0.8, 0.003)
            .with_d_cutoff_hz(40.0)
            .with_integral_limits(-0.3, 0.3);
        Self {
            roll: tilt,
            pitch: tilt,
            yaw: PidConfig::new(0.5, 0.8, 0.0).with_integral_limits(-0.3, 0.3),
        }
    }
}

impl RateConfig {
    /// Checks the three PIDs.
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        self.roll.validate()?;
        self.pitch.validate()?;
        self.yaw.validate()
    }
}

/// The body-rate loop.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RateController {
    roll: Pid,
    pitch: Pid,
    yaw: Pid,
}

impl RateController {
    /// Creates the loop. Errors: see [`RateConfig::validate`].
    #[inline(always)]
    pub fn new(cfg: RateConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self {
            roll: Pid::new(cfg.roll)?,
            pitch: Pid::new(cfg.pitch)?,
            yaw: Pid::new(cfg.yaw)?,
        })
    }

    /// One step: setpoint and gyro in rad/s (FRD), `dt_s` in s.
    /// Errors: [`Error::NonFinite`], [`Error::InvalidDt`]; nothing changes on error.
    pub fn update(
        &mut self,
        setpoint: &BodyRates,
        gyro: &BodyRates,
        dt_s: f32,
    ) -> Result<TorqueCommand, Error> {
        for x in [
            setpoint.roll_rps,
            setpoint.pitch_rps,
            setpoint.yaw_rps,
            gyro.roll_rps,
            gyro.pitch_rps,
            gyro.yaw_rps,
        ] {
            finite(x)?;
        }
        check_dt(dt_s)?;
        let (mut r, mut p, mut y) = (self.roll, self.pitch, self.yaw);
        let out = TorqueCommand {
            roll: r.update(setpoint.roll_rps, gyro.roll_rps, dt_s)?,
            pitch: p.update(setpoint.pitch_rps, gyro.pitch_rps, dt_s)?,
            yaw: y.update(setpoint.yaw_rps, gyro.yaw_rps, dt_s)?,
        };
        self.roll = r;
        self.pitch = p;
        self.yaw = y;
        Ok(out)
    }

    /// Bumpless engage: integrals zero, derivative history set to the
    /// measured `rates` (no D kick). Errors: [`Error::NonFinite`]; nothing
    /// changes on error.
    pub fn reset(&mut self, rates: &BodyRates) -> Result<(), Error> {
        finite(rates.roll_rps)?;
        finite(rates.pitch_rps)?;
        finite(rates.yaw_rps)?;
        self.roll.reset(rates.roll_rps, 0.0)?;
        self.pitch.reset(rates.pitch_rps, 0.0)?;
        self.yaw.reset(rates.yaw_rps, 0.0)?;
        Ok(())
    }

    /// Forgets the integrals and derivative history (at arming, and while
    /// the vehicle sits on the ground at low throttle so nothing winds up).
    pub fn clear(&mut self) {
        self.roll.clear();
        self.pitch.clear();
        self.yaw.clear();
    }

    /// The integrals (roll, pitch, yaw), torque units.
    pub fn integrals(&self) -> TorqueCommand {
        TorqueCommand {
            roll: self.roll.integral(),
            pitch: self.pitch.integral(),
            yaw: self.yaw.integral(),
        }
    }
}

/// Self-level tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LevelConfig {
    /// Attitude-error P gain, (rad/s)/rad = 1/s, `> 0`.
    pub kp_per_s: f32,
    /// Largest roll/pitch rate setpoint, rad/s, `> 0`.
    pub max_rate_rps: f32,
}

impl Default for LevelConfig {
    /// 6 /s (≈ 0.17 s time constant), rates limited to 200 °/s.
    fn default() -> Self {
        Self {
            kp_per_s: 6.0,
            max_rate_rps: 200.0 * core::f32::consts::PI / 180.0,
        }
    }
}

impl LevelConfig {
    /// Checks: [`Error::InvalidParameter`].
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        check_positive(self.kp_per_s)?;
        check_positive(self.max_rate_rps)
    }
}

/// The self-level (angle) loop. Stateless apart from its configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LevelController {
    cfg: LevelConfig,
}

impl LevelController {
    /// Validates the configuration.
    #[inline(always)]
    pub fn new(cfg: LevelConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self { cfg })
    }

    /// The configuration in use.
    pub fn config(&self) -> &LevelConfig {
        &self.cfg
    }

    /// Body-rate setpoint (rad/s, FRD) for attitude `q` (`q_ned_from_body`),
    /// tilt setpoint and pilot yaw rate (rad/s). Errors: [`Error::NonFinite`];
    /// [`Error::OutOfRange`] for a quaternion far from unit length. Builds
    /// the [`TiltQuat`] on every call; at 1 kHz keep one per setpoint and
    /// call [`rate_setpoint_q`](Self::rate_setpoint_q).
    pub fn rate_setpoint(
        &self,
        q: &Quat,
        tilt: &TiltSetpoint,
        yaw_rate_rps: f32,
    ) -> Result<BodyRates, Error> {
        self.rate_setpoint_q(q, &TiltQuat::new(tilt)?, yaw_rate_rps)
    }

    /// [`rate_setpoint`](Self::rate_setpoint) with the tilt already a
    /// quaternion (no trigonometry: two square roots, ~40 multiplies).
    pub fn rate_setpoint_q(
        &self,
        q: &Quat,
        tilt: &TiltQuat,
        yaw_rate_rps: f32,
    ) -> Result<BodyRates, Error> {
        q.check()?;
        finite(yaw_rate_rps)?;
        let e = attitude_error_q(q, tilt);
        let k = self.cfg.kp_per_s;
        let m = self.cfg.max_rate_rps;
        Ok(BodyRates {
            roll_rps: clamp(k * e[0], -m, m),
            pitch_rps: clamp(k * e[1], -m, m),
            yaw_rps: yaw_rate_rps,
        })
    }
}

/// A tilt setpoint as the rotation `q_y(θ) ⊗ q_x(φ)` (ZYX without the
/// heading): the trigonometry done once per setpoint.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TiltQuat(Quat);

impl TiltQuat {
    /// Level.
    pub const LEVEL: Self = Self(Quat::IDENTITY);

    /// From roll and pitch, rad. Errors: [`Error::NonFinite`].
    #[inline(always)]
    pub fn new(tilt: &TiltSetpoint) -> Result<Self, Error> {
        finite(tilt.roll_rad)?;
        finite(tilt.pitch_rad)?;
        Ok(Self(
            Quat::about_y(tilt.pitch_rad).mul(&Quat::about_x(tilt.roll_rad)),
        ))
    }

    /// The quaternion.
    pub fn quat(&self) -> Quat {
        self.0
    }
}

/// Body-frame attitude error vector (`2·sign(w)·vec(q⁻¹ ⊗ q_d)`, rad for
/// small errors) towards the current heading with the commanded tilt.
/// `q` should be unit length to within a few per cent (the AHRS keeps it
/// so); the error scales with `|q|`'s deviation squared.
pub fn attitude_error(q: &Quat, tilt: &TiltSetpoint) -> [f32; 3] {
    match TiltQuat::new(tilt) {
        Ok(t) => attitude_error_q(q, &t),
        Err(_) => [0.0; 3],
    }
}

/// [`attitude_error`] for a precomputed tilt.
pub fn attitude_error_q(q: &Quat, tilt: &TiltQuat) -> [f32; 3] {
    let (w, x, y, z) = (q.w, q.x, q.y, q.z);
    let n2 = w * w + x * x + y * y + z * z;
    // 1/|q| by one Newton step from 1: within 0.4 % for |q|² in 0.9..1.1.
    let inv_n = 1.5 - 0.5 * n2;
    // Heading ψ of q (ZYX): body x projected on the horizontal is
    // (cos ψ, sin ψ)·|h| (|h| = |q|² cos θ). The half angle's direction is
    // that of (|h| + hx, hy), so q_z(ψ) needs no trigonometry.
    let hx = w * w + x * x - y * y - z * z;
    let hy = 2.0 * (w * z + x * y);
    // Near ψ = π, h + hx cancels: there the same direction is taken as
    // (|hy|, sign(hy)·(h − hx)), since (h + hx)(h − hx) = hy².
    let h = libm::sqrtf(hx * hx + hy * hy);
    let (a, b) = if hx >= 0.0 {
        (h + hx, hy)
    } else if hy >= 0.0 {
        (hy, h - hx)
    } else {
        (-hy, hx - h)
    };
    let (c, s) = if h <= 1e-6 * n2 {
        // Nose straight up or down: the heading is undefined, any will do.
        (1.0, 0.0)
    } else {
        let k = 1.0 / libm::sqrtf(a * a + b * b);
        (a * k, b * k)
    };
    // The measured tilt: p = q_z(ψ)⁻¹ ⊗ q.
    let pw = c * w + s * z;
    let px = c * x + s * y;
    let py = c * y - s * x;
    let pz = c * z - s * w;
    // e = p⁻¹ ⊗ t (p's conjugate; |p| = |q| is divided out below).
    let t = &tilt.0;
    let ew = pw * t.w + px * t.x + py * t.y + pz * t.z;
    let ex = pw * t.x - px * t.w - py * t.z + pz * t.y;
    let ey = pw * t.y + px * t.z - py * t.w - pz * t.x;
    let ez = pw * t.z - px * t.y + py * t.x - pz * t.w;
    // The shorter way round.
    let k = if ew < 0.0 { -2.0 } else { 2.0 } * inv_n;
    [k * ex, k * ey, k * ez]
}
