//! PID controller with anti-windup, derivative on measurement, a filtered D
//! term, feed-forward and bumpless reset.
//!
//! # Control law
//!
//! With error `e = setpoint − measurement` and a per-call sample time `dt_s`:
//!
//! ```text
//! P = kp · e
//! I = clamp(I + ki · e · dt,  integral_min, integral_max)   (conditional, see below)
//! D = −kd · LPF(d measurement / dt)                          (derivative on measurement)
//! u = clamp(P + I + D + feed_forward,  output_min, output_max)
//! ```
//!
//! * **Integral in output units.** `I` is stored already multiplied by `ki`,
//!   so its limits are in output units and changing `ki` never makes the
//!   output jump.
//! * **Anti-windup**, two mechanisms: the integral is clamped to
//!   `[integral_min, integral_max]`, *and* it is not integrated further in
//!   the direction of a saturated output (conditional integration: if the
//!   unclamped output is at/above `output_max` a positive increment is
//!   dropped, at/below `output_min` a negative one).
//! * **Derivative on measurement**: a setpoint step gives no derivative kick.
//!   The first update after construction/[`Pid::clear`] has `D = 0`.
//! * **D low-pass**: first order, `y += α·(x − y)` with `α = dt/(τ + dt)`,
//!   `τ = 1/(2π·d_cutoff_hz)`; `d_cutoff_hz = 0` disables the filter. `α` and
//!   `1/dt` are cached, so at a constant `dt_s` an update has no division.
//! * **Saturating arithmetic**: every term is limited to ±1e30 before the
//!   sum, so *any* finite inputs give a finite output within the limits.
//! * **Errors**: a NaN/∞ setpoint, measurement or feed-forward gives
//!   [`Error::NonFinite`], a `dt_s` that is not finite and > 0 gives
//!   [`Error::InvalidDt`]; the state is untouched in both cases.
//!
//! # Units of the gains
//!
//! For an error in units `E` and an output in units `U`:
//! `kp` is in `U/E`, `ki` in `U/(E·s)`, `kd` in `U·s/E`; feed-forward, output
//! and integral limits are in `U`. In this crate:
//!
//! | loop | E | U | kp | ki | kd |
//! |---|---|---|---|---|---|
//! | vertical speed ([`AltitudeHold`](crate::controllers::AltitudeHold)) | m/s | throttle (0..1) | 1/(m/s) = s/m | 1/m | s²/m |
//! | body rate ([`AttitudeController`](crate::controllers::AttitudeController)) | rad/s | torque command (−1..1) | s/rad | 1/rad | s²/rad |
//!
//! # Cost
//!
//! About 10 fmul/fadd plus ~14 soft-float compares per update at constant
//! `dt_s` (two divisions more when `dt_s` changes).
//!
//! ```
//! use control::pid::{Pid, PidConfig};
//! let cfg = PidConfig::new(2.0, 0.5, 0.0).with_output_limits(-1.0, 1.0);
//! let mut pid = Pid::new(cfg).unwrap();
//! let u = pid.update(1.0, 0.8, 0.001).unwrap(); // setpoint, measurement, dt_s
//! assert!((u - 0.4001).abs() < 1e-4);           // P = 2·0.2, I = 0.5·0.2·0.001
//! ```

use crate::error::{check_dt, check_gain, check_limits, finite, Error};

/// Terms are saturated to ±this before summing, so sums never overflow.
const TERM_LIMIT: f32 = 1.0e30;

/// Clamps without the `assert!(min <= max)` of `f32::clamp` (callers pass
/// validated limits). NaN passes through unchanged.
#[inline]
pub(crate) fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

#[inline]
fn sat(x: f32) -> f32 {
    clamp(x, -TERM_LIMIT, TERM_LIMIT)
}

/// PID gains and limits. Plain fields plus [`validate`](Self::validate); the
/// `with_*` methods are `const` builders.
///
/// See the [module docs](self) for the units of each gain.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PidConfig {
    /// Proportional gain, `U/E` (output units per error unit). `>= 0`.
    pub kp: f32,
    /// Integral gain, `U/(E·s)`. `>= 0`; 0 disables the integral.
    pub ki: f32,
    /// Derivative gain, `U·s/E`. `>= 0`; acts on the measurement only.
    pub kd: f32,
    /// Cut-off of the first-order low-pass on the D term, Hz. `0` = no filter.
    pub d_cutoff_hz: f32,
    /// Lowest output, `U`.
    pub output_min: f32,
    /// Highest output, `U`.
    pub output_max: f32,
    /// Lowest value of the integral term, `U`.
    pub integral_min: f32,
    /// Highest value of the integral term, `U`.
    pub integral_max: f32,
}

impl PidConfig {
    /// Gains `kp`, `ki`, `kd`; no D filter; output and integral limits ±1.
    pub const fn new(kp: f32, ki: f32, kd: f32) -> Self {
        Self {
            kp,
            ki,
            kd,
            d_cutoff_hz: 0.0,
            output_min: -1.0,
            output_max: 1.0,
            integral_min: -1.0,
            integral_max: 1.0,
        }
    }

    /// Sets the output limits, `U`.
    pub const fn with_output_limits(mut self, min: f32, max: f32) -> Self {
        self.output_min = min;
        self.output_max = max;
        self
    }

    /// Sets the integral-term limits, `U`.
    pub const fn with_integral_limits(mut self, min: f32, max: f32) -> Self {
        self.integral_min = min;
        self.integral_max = max;
        self
    }

    /// Sets the D-term low-pass cut-off, Hz (`0` = no filter).
    pub const fn with_d_cutoff_hz(mut self, hz: f32) -> Self {
        self.d_cutoff_hz = hz;
        self
    }

    /// Checks the configuration: gains finite and `>= 0`
    /// ([`Error::NegativeGain`]), limits finite with `min <= max`
    /// ([`Error::InvalidLimits`]), cut-off finite and `>= 0`
    /// ([`Error::InvalidParameter`]).
    #[inline(always)]
    pub fn validate(&self) -> Result<(), Error> {
        check_gain(self.kp)?;
        check_gain(self.ki)?;
        check_gain(self.kd)?;
        check_limits(self.output_min, self.output_max)?;
        check_limits(self.integral_min, self.integral_max)?;
        if !(self.d_cutoff_hz.is_finite() && self.d_cutoff_hz >= 0.0) {
            return Err(Error::InvalidParameter);
        }
        Ok(())
    }

    /// D-filter time constant `1/(2π fc)`, s (0 when unfiltered).
    fn d_tau_s(&self) -> f32 {
        if self.d_cutoff_hz > 0.0 {
            1.0 / (2.0 * core::f32::consts::PI * self.d_cutoff_hz)
        } else {
            0.0
        }
    }
}

/// A PID controller. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Pid {
    cfg: PidConfig,
    d_tau_s: f32,
    /// Integral term, output units.
    integral: f32,
    /// Low-passed d(measurement)/dt, measurement units per second.
    dmeas_filt: f32,
    prev_meas: f32,
    has_prev: bool,
    last_output: f32,
    /// dt for which `inv_dt` and `alpha` were computed (0 = none).
    cached_dt_s: f32,
    inv_dt: f32,
    alpha: f32,
}

impl Pid {
    /// Creates a controller with zero integral (or the integral limit
    /// nearest to zero if 0 is outside the limits) and no measurement history.
    /// Errors: see [`PidConfig::validate`].
    #[inline(always)]
    pub fn new(cfg: PidConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            d_tau_s: cfg.d_tau_s(),
            integral: clamp(0.0, cfg.integral_min, cfg.integral_max),
            dmeas_filt: 0.0,
            prev_meas: 0.0,
            has_prev: false,
            last_output: 0.0,
            cached_dt_s: 0.0,
            inv_dt: 0.0,
            alpha: 0.0,
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &PidConfig {
        &self.cfg
    }

    /// Replaces gains/limits at run time, keeping the integral (clamped to the
    /// new limits) and the derivative history. On error nothing changes.
    pub fn set_config(&mut self, cfg: PidConfig) -> Result<(), Error> {
        cfg.validate()?;
        self.cfg = cfg;
        self.d_tau_s = cfg.d_tau_s();
        self.cached_dt_s = 0.0;
        self.integral = clamp(self.integral, cfg.integral_min, cfg.integral_max);
        Ok(())
    }

    /// Integral term, output units.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// The last output returned by an update (0 before the first).
    pub fn last_output(&self) -> f32 {
        self.last_output
    }

    /// Forgets everything: integral 0 (or the integral limit nearest to 0),
    /// no measurement history, output 0.
    pub fn clear(&mut self) {
        self.integral = clamp(0.0, self.cfg.integral_min, self.cfg.integral_max);
        self.dmeas_filt = 0.0;
        self.has_prev = false;
        self.last_output = 0.0;
    }

    /// Bumpless engage, assuming the next update has `setpoint == measurement`
    /// and no feed-forward (the usual "hold what you have" engage): the
    /// integral is set to `output` (clamped to the integral limits) and the
    /// derivative history to `measurement`, so the first output equals
    /// `output`. Errors: [`Error::NonFinite`]; nothing changes on error.
    pub fn reset(&mut self, measurement: f32, output: f32) -> Result<(), Error> {
        self.reset_for(measurement, measurement, 0.0, output)
    }

    /// General bumpless engage: sets the integral so that an update with these
    /// `setpoint`, `measurement` and `feed_forward` returns `output` (as far
    /// as the integral limits allow). Errors: [`Error::NonFinite`].
    pub fn reset_for(
        &mut self,
        setpoint: f32,
        measurement: f32,
        feed_forward: f32,
        output: f32,
    ) -> Result<(), Error> {
        finite(setpoint)?;
        finite(measurement)?;
        finite(feed_forward)?;
        finite(output)?;
        let p = sat(self.cfg.kp * sat(setpoint - measurement));
        let i = sat(output) - p - sat(feed_forward);
        self.integral = clamp(i, self.cfg.integral_min, self.cfg.integral_max);
        self.dmeas_filt = 0.0;
        self.prev_meas = measurement;
        self.has_prev = true;
        self.last_output = clamp(output, self.cfg.output_min, self.cfg.output_max);
        Ok(())
    }

    /// One update without feed-forward. Returns the output in
    /// `[output_min, output_max]`. See [`update_with_ff`](Self::update_with_ff).
    #[inline]
    pub fn update(&mut self, setpoint: f32, measurement: f32, dt_s: f32) -> Result<f32, Error> {
        self.update_with_ff(setpoint, measurement, 0.0, dt_s)
    }

    /// One update: `setpoint` and `measurement` in `E`, `feed_forward` in `U`
    /// (added to the output before the limits), `dt_s` the time since the
    /// previous update, s.
    ///
    /// Errors: [`Error::NonFinite`] (setpoint, measurement, feed-forward),
    /// [`Error::InvalidDt`]; the state is untouched on error.
    pub fn update_with_ff(
        &mut self,
        setpoint: f32,
        measurement: f32,
        feed_forward: f32,
        dt_s: f32,
    ) -> Result<f32, Error> {
        finite(setpoint)?;
        finite(measurement)?;
        finite(feed_forward)?;
        check_dt(dt_s)?;
        let c = &self.cfg;

        // Divisions only when dt changes (the loop rate is normally fixed).
        let (inv_dt, alpha) = if dt_s == self.cached_dt_s {
            (self.inv_dt, self.alpha)
        } else {
            let alpha = if self.d_tau_s > 0.0 {
                dt_s / (self.d_tau_s + dt_s)
            } else {
                1.0
            };
            (1.0 / dt_s, alpha)
        };

        let e = sat(setpoint - measurement);
        let p = sat(c.kp * e);

        let dmeas_filt = if self.has_prev {
            let raw = sat(sat(measurement - self.prev_meas) * inv_dt);
            self.dmeas_filt + alpha * (raw - self.dmeas_filt)
        } else {
            0.0
        };
        let d = sat(-c.kd * dmeas_filt);
        let ff = sat(feed_forward);

        // Conditional integration: never integrate toward a saturated output.
        let unclamped = p + self.integral + d + ff;
        let di = c.ki * e * dt_s;
        let toward_saturation =
            (unclamped >= c.output_max && di > 0.0) || (unclamped <= c.output_min && di < 0.0);
        let integral = if toward_saturation {
            self.integral
        } else {
            clamp(self.integral + di, c.integral_min, c.integral_max)
        };
        let output = clamp(p + integral + d + ff, c.output_min, c.output_max);

        // Belt and braces: the saturations above make this unreachable for
        // finite inputs, but never commit a non-finite state.
        if !(output.is_finite() && integral.is_finite() && dmeas_filt.is_finite()) {
            return Err(Error::Overflow);
        }
        self.cached_dt_s = dt_s;
        self.inv_dt = inv_dt;
        self.alpha = alpha;
        self.integral = integral;
        self.dmeas_filt = dmeas_filt;
        self.prev_meas = measurement;
        self.has_prev = true;
        self.last_output = output;
        Ok(output)
    }
}
