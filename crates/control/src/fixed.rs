//! Fixed-point PID, attitude and altitude-hold controllers for a loop with
//! a constant period: the same control laws as [`crate::pid::Pid`] and
//! [`crate::controllers`] in integer arithmetic, so a 100 Hz control step
//! on a Cortex-M3 without FPU costs a few hundred instructions instead of
//! thousands (every `f32` operation there is a library call).
//!
//! # Q-formats
//!
//! | quantity | format | range |
//! |---|---|---|
//! | setpoint, measurement (rad, rad/s, m, m/s) | Q16 | ±32 768 |
//! | output, integral, feed-forward, their limits (torque, throttle) | Q30 | ±2 (limits must lie within ±1.99) |
//! | gains with the period folded in (`kp`, `ki·dt`, `kd/dt`) | Q24 | 0..128 |
//! | D-filter coefficient `α = dt/(τ + dt)` | Q30 | 0..1 |
//! | D-filter state (measurement change per period) | Q24 | ±128 per period |
//!
//! Products are formed in `i64` (one `SMULL` on the M3) and every stored
//! value saturates, so no input can overflow.
//!
//! # Agreement with the f32 controllers
//!
//! For the same configuration, period and Q16-representable inputs the
//! outputs stay within 2e-4 (output units, i.e. 0.02 % of a ±1 torque) of
//! [`crate::pid::Pid`] and the f32 controllers over long random sequences
//! that reach the limits (the tests drive both side by side). The D
//! filter's state, the measurement change per period, is kept in Q24 (8
//! bits below the inputs), so its rounding is far below `kd/dt` times one
//! Q16 input quantum.
//!
//! # What differs
//!
//! The period is fixed at construction ([`PidQ::new`]'s `dt_s`); a loop
//! whose period changes needs a new controller (or the f32 one). Gains
//! above 128 in Q24 (after folding in the period) and limits beyond ±1.99
//! are refused with [`Error::InvalidParameter`] / [`Error::InvalidLimits`].

use core::f32::consts::PI;

use crate::controllers::{AltitudeHoldConfig, AttitudeConfig, AxisConfig};
use crate::error::{check_dt, finite, Error};
use crate::pid::PidConfig;

// Limits are combined with `max`/`min` rather than `clamp`, whose
// `min <= max` assertion would link a panic path into the firmware (the
// limits are validated at construction).

/// `1.0` in Q30.
pub const ONE_Q30: i32 = 1 << 30;
/// π in Q16.
const PI_Q16: i32 = 205_887;
/// 2π in Q16.
const TWO_PI_Q16: i32 = 411_775;

fn sat32(x: i64) -> i32 {
    x.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// Q24 of a non-negative gain, [`Error::InvalidParameter`] at or above 128.
#[inline(always)]
fn gain_q24(g: f32) -> Result<i32, Error> {
    if !(g.is_finite() && (0.0..128.0).contains(&g)) {
        return Err(Error::InvalidParameter);
    }
    Ok((g * 16_777_216.0 + 0.5) as i32)
}

/// Q16 of a value within ±32 767, [`Error::InvalidParameter`] otherwise.
#[inline(always)]
pub fn to_q16(x: f32) -> Result<i32, Error> {
    if !(x.is_finite() && x.abs() < 32_767.0) {
        return Err(Error::InvalidParameter);
    }
    let v = x * 65_536.0;
    Ok((if v >= 0.0 { v + 0.5 } else { v - 0.5 }) as i32)
}

/// Q30 of an output-unit value within ±1.99, [`Error::InvalidLimits`] otherwise.
#[inline(always)]
pub fn to_q30(x: f32) -> Result<i32, Error> {
    if !(x.is_finite() && x.abs() <= 1.99) {
        return Err(Error::InvalidLimits);
    }
    let v = x * ONE_Q30 as f32;
    Ok((if v >= 0.0 { v + 0.5 } else { v - 0.5 }) as i32)
}

/// `kq24 · x_q16`, Q30, saturated.
#[inline]
fn mul_q24_q16(k_q24: i32, x_q16: i32) -> i64 {
    (i64::from(k_q24) * i64::from(x_q16)) >> 10
}

/// A PID controller at a fixed period; see the [module docs](self) and
/// [`crate::pid`] for the control law (anti-windup by clamp and conditional
/// integration, derivative on measurement with a first-order low-pass,
/// feed-forward).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PidQ {
    kp_q24: i32,
    ki_dt_q24: i32,
    kd_per_dt_q24: i32,
    alpha_q30: i32,
    output_min_q30: i32,
    output_max_q30: i32,
    integral_min_q30: i32,
    integral_max_q30: i32,
    integral_q30: i32,
    /// Low-passed measurement change per period, Q24 (±128 units per
    /// period; 8 bits below the inputs' Q16, so the filter's rounding
    /// stays far below one input quantum).
    dmeas_filt_q24: i32,
    prev_meas_q16: i32,
    has_prev: bool,
}

impl PidQ {
    /// The controller for `cfg` run every `dt_s` seconds. Errors: the
    /// config's own ([`PidConfig::validate`]), [`Error::InvalidDt`],
    /// [`Error::InvalidParameter`] (a gain ≥ 128 after folding in `dt_s`),
    /// [`Error::InvalidLimits`] (a limit beyond ±1.99).
    // `inline(always)`: with a constant configuration (the firmware's) the
    // conversions fold at compile time; out of line they are soft-float
    // code in flash.
    #[inline(always)]
    pub fn new(cfg: &PidConfig, dt_s: f32) -> Result<Self, Error> {
        cfg.validate()?;
        check_dt(dt_s)?;
        let alpha = if cfg.d_cutoff_hz > 0.0 {
            let tau = 1.0 / (2.0 * PI * cfg.d_cutoff_hz);
            dt_s / (tau + dt_s)
        } else {
            1.0
        };
        let integral_min_q30 = to_q30(cfg.integral_min)?;
        let integral_max_q30 = to_q30(cfg.integral_max)?;
        Ok(Self {
            kp_q24: gain_q24(cfg.kp)?,
            ki_dt_q24: gain_q24(cfg.ki * dt_s)?,
            kd_per_dt_q24: gain_q24(cfg.kd / dt_s)?,
            alpha_q30: to_q30(alpha)?,
            output_min_q30: to_q30(cfg.output_min)?,
            output_max_q30: to_q30(cfg.output_max)?,
            integral_min_q30,
            integral_max_q30,
            integral_q30: 0.max(integral_min_q30).min(integral_max_q30),
            dmeas_filt_q24: 0,
            prev_meas_q16: 0,
            has_prev: false,
        })
    }

    /// Integral term, Q30 output units.
    pub fn integral_q30(&self) -> i32 {
        self.integral_q30
    }

    /// Forgets everything, as [`Pid::clear`](crate::pid::Pid::clear):
    /// integral 0 (or the integral limit nearest to 0), no measurement
    /// history (the next update has no D term).
    pub fn clear(&mut self) {
        self.integral_q30 = 0.max(self.integral_min_q30).min(self.integral_max_q30);
        self.dmeas_filt_q24 = 0;
        self.has_prev = false;
    }

    /// Bumpless transfer, as [`Pid::reset_for`](crate::pid::Pid::reset_for):
    /// the integral set (within its limits) so that an update with this
    /// setpoint, measurement and feed-forward, and no D term, outputs
    /// `output_q30`; the measurement becomes the D term's history.
    pub fn reset_for(
        &mut self,
        setpoint_q16: i32,
        measurement_q16: i32,
        feed_forward_q30: i32,
        output_q30: i32,
    ) {
        let p = mul_q24_q16(self.kp_q24, setpoint_q16.saturating_sub(measurement_q16));
        let i = i64::from(output_q30) - p - i64::from(feed_forward_q30);
        self.integral_q30 = sat32(i)
            .max(self.integral_min_q30)
            .min(self.integral_max_q30);
        self.dmeas_filt_q24 = 0;
        self.prev_meas_q16 = measurement_q16;
        self.has_prev = true;
    }

    /// One period: `setpoint_q16`, `measurement_q16` in Q16 of the error
    /// unit, `feed_forward_q30` in Q30 output units. Returns the output in
    /// Q30 within the output limits. Total: every input is accepted.
    pub fn update(
        &mut self,
        setpoint_q16: i32,
        measurement_q16: i32,
        feed_forward_q30: i32,
    ) -> i32 {
        self.update_holding(setpoint_q16, measurement_q16, feed_forward_q30, false)
    }

    /// [`update`](Self::update), with the integral held where it is (not
    /// integrated) when `hold`; the output keeps the held integral.
    pub fn update_holding(
        &mut self,
        setpoint_q16: i32,
        measurement_q16: i32,
        feed_forward_q30: i32,
        hold: bool,
    ) -> i32 {
        let e = setpoint_q16.saturating_sub(measurement_q16);
        let p = mul_q24_q16(self.kp_q24, e);
        let dmeas_q24 = if self.has_prev {
            let raw = i64::from(measurement_q16) - i64::from(self.prev_meas_q16);
            let raw_q24 = i64::from(sat32(raw << 8));
            let f = i64::from(self.dmeas_filt_q24);
            // |raw − f| < 2³², α ≤ 2³⁰: the product fits 63 bits.
            sat32(f + ((i64::from(self.alpha_q30) * (raw_q24 - f)) >> 30))
        } else {
            0
        };
        // Q24 gain × Q24 change = Q48; Q30 after the shift.
        let d = -((i64::from(self.kd_per_dt_q24) * i64::from(dmeas_q24)) >> 18);
        let ff = i64::from(feed_forward_q30);
        let i = i64::from(self.integral_q30);
        // Conditional integration: never integrate toward a saturated output.
        let unclamped = p + i + d + ff;
        let di = mul_q24_q16(self.ki_dt_q24, e);
        let toward_saturation = (unclamped >= i64::from(self.output_max_q30) && di > 0)
            || (unclamped <= i64::from(self.output_min_q30) && di < 0);
        let integral = if toward_saturation || hold {
            self.integral_q30
        } else {
            sat32(i + di)
                .max(self.integral_min_q30)
                .min(self.integral_max_q30)
        };
        let out = (p + i64::from(integral) + d + ff)
            .max(i64::from(self.output_min_q30))
            .min(i64::from(self.output_max_q30)) as i32;
        self.integral_q30 = integral;
        self.dmeas_filt_q24 = dmeas_q24;
        self.prev_meas_q16 = measurement_q16;
        self.has_prev = true;
        out
    }
}

/// Angle P → rate PID for one axis, fixed point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct AxisQ {
    angle_kp_q24: i32,
    max_rate_q16: i32,
    rate: PidQ,
}

impl AxisQ {
    fn new(a: &AxisConfig, dt_s: f32) -> Result<Self, Error> {
        a.validate()?;
        Ok(Self {
            angle_kp_q24: gain_q24(a.angle_kp)?,
            max_rate_q16: to_q16(a.max_rate_rps)?,
            rate: PidQ::new(&a.rate_pid, dt_s)?,
        })
    }

    /// Rate setpoint, Q16 rad/s, for an angle error in Q16 rad.
    fn rate_setpoint(&self, err_q16: i32) -> i32 {
        sat32(mul_q24_q16(self.angle_kp_q24, err_q16) >> 14)
            .max(-self.max_rate_q16)
            .min(self.max_rate_q16)
    }
}

/// Yaw command of [`AttitudeQ::update`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum YawTargetQ16 {
    /// Hold a heading, Q16 rad.
    Angle(i32),
    /// Rate only, Q16 rad/s.
    Rate(i32),
}

/// Fixed-point [`AttitudeController`](crate::controllers::AttitudeController):
/// per axis (roll, pitch, yaw) angle P → clamp → rate PID, at a fixed period.
/// Angles (NED/FRD ZYX Euler) in Q16 rad, rates (FRD body) in Q16 rad/s,
/// torques in Q30.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AttitudeQ {
    axes: [AxisQ; 3],
}

impl AttitudeQ {
    /// The controller for `cfg` run every `dt_s` seconds; errors as
    /// [`PidQ::new`] and [`AttitudeConfig::validate`].
    // Out of line: config-time only, and inlined its result is moved
    // through the caller's frame once more (less flash).
    #[inline(never)]
    pub fn new(cfg: &AttitudeConfig, dt_s: f32) -> Result<Self, Error> {
        Ok(Self {
            axes: [
                AxisQ::new(&cfg.roll, dt_s)?,
                AxisQ::new(&cfg.pitch, dt_s)?,
                AxisQ::new(&cfg.yaw, dt_s)?,
            ],
        })
    }

    /// Angle mode: `target_q16` roll and pitch (Q16 rad) and the yaw
    /// command, `attitude_q16` (roll, pitch, yaw) Q16 rad, `rates_q16`
    /// Q16 rad/s. Returns the torques (roll, pitch, yaw), Q30.
    pub fn update(
        &mut self,
        target_q16: [i32; 2],
        yaw: YawTargetQ16,
        attitude_q16: [i32; 3],
        rates_q16: [i32; 3],
    ) -> [i32; 3] {
        let [roll, pitch, yaw_axis] = &mut self.axes;
        let yaw_sp = match yaw {
            YawTargetQ16::Angle(a) => {
                yaw_axis.rate_setpoint(wrap_pi_q16(a.wrapping_sub(attitude_q16[2])))
            }
            YawTargetQ16::Rate(r) => r,
        };
        let roll_sp = roll.rate_setpoint(target_q16[0].saturating_sub(attitude_q16[0]));
        let pitch_sp = pitch.rate_setpoint(target_q16[1].saturating_sub(attitude_q16[1]));
        [
            roll.rate.update(roll_sp, rates_q16[0], 0),
            pitch.rate.update(pitch_sp, rates_q16[1], 0),
            yaw_axis.rate.update(yaw_sp, rates_q16[2], 0),
        ]
    }
}

/// Wraps a Q16 angle difference into [−π, π].
fn wrap_pi_q16(mut a: i32) -> i32 {
    // The remainder keeps the sign of `a`, so one correction suffices.
    a %= TWO_PI_Q16;
    if a > PI_Q16 {
        a - TWO_PI_Q16
    } else if a < -PI_Q16 {
        a + TWO_PI_Q16
    } else {
        a
    }
}

/// Fixed-point [`AltitudeHold`](crate::controllers::AltitudeHold): height
/// P → clamp → vertical-speed PID + hover feed-forward → throttle, at a
/// fixed period. Heights in Q16 m, speeds in Q16 m/s, throttle in Q30.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AltitudeHoldQ {
    height_kp_q24: i32,
    max_climb_q16: i32,
    max_descent_q16: i32,
    hover_q30: i32,
    speed: PidQ,
}

impl AltitudeHoldQ {
    /// The controller for `cfg` run every `dt_s` seconds; errors as
    /// [`PidQ::new`] and [`AltitudeHoldConfig::validate`].
    // `inline(always)`, as the other constructors: the flight controller's
    // constant configuration then folds at compile time (out of line,
    // 1.4 KiB of soft-float conversions and checks in flash).
    #[inline(always)]
    pub fn new(cfg: &AltitudeHoldConfig, dt_s: f32) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self {
            height_kp_q24: gain_q24(cfg.height_kp)?,
            max_climb_q16: to_q16(cfg.max_climb_mps)?,
            max_descent_q16: to_q16(cfg.max_descent_mps)?,
            hover_q30: to_q30(cfg.hover_throttle)?,
            speed: PidQ::new(&cfg.speed_pid, dt_s)?,
        })
    }

    /// One period: target and estimated height (Q16 m, up), estimated
    /// vertical speed (Q16 m/s, up). Returns the throttle, Q30.
    pub fn update(&mut self, target_q16: i32, height_q16: i32, velocity_q16: i32) -> i32 {
        let err = target_q16.saturating_sub(height_q16);
        let v_sp = sat32(mul_q24_q16(self.height_kp_q24, err) >> 14)
            .max(-self.max_descent_q16)
            .min(self.max_climb_q16);
        self.speed.update(v_sp, velocity_q16, self.hover_q30)
    }

    /// Bumpless engage at the current height (target = height, so the
    /// speed setpoint is 0), as [`AltitudeHold::reset`](crate::controllers::AltitudeHold::reset):
    /// the next update outputs `throttle_q30` (within the integral's
    /// limits).
    pub fn reset(&mut self, velocity_q16: i32, throttle_q30: i32) {
        self.speed
            .reset_for(0, velocity_q16, self.hover_q30, throttle_q30);
    }
}

/// `x · 2^frac` rounded to the nearest integer (halves away from zero),
/// saturating at `i32::MIN`/`i32::MAX`; NaN gives 0. By the bits of the
/// IEEE single (sign, exponent, 24-bit significand shifted into place), so
/// on the Cortex-M3 it costs about fifteen integer instructions instead of
/// a soft-float multiply and `__aeabi_f2iz` (≈ 80). Exact for every input
/// whose result fits: the shift drops only bits below the rounding bit.
/// `frac` ≤ 62.
#[inline]
pub fn f32_to_q(x: f32, frac: u32) -> i32 {
    let bits = x.to_bits();
    let exp = ((bits >> 23) & 0xff) as i32;
    if exp == 0xff && bits & 0x7f_ffff != 0 {
        return 0; // NaN
    }
    let mant = (bits & 0x7f_ffff) | if exp == 0 { 0 } else { 0x80_0000 };
    // value = mant · 2^(exp − 150) (subnormals: exp 1), times 2^frac.
    let shift = exp.max(1) - 150 + frac.min(62) as i32;
    let mag: u32 = if shift >= 8 {
        if mant == 0 {
            0
        } else {
            u32::MAX // ≥ 2³¹: saturates below
        }
    } else if shift >= 0 {
        mant << shift
    } else if shift >= -24 {
        let s = (-shift) as u32;
        (mant + (1 << (s - 1))) >> s
    } else {
        0
    };
    if bits >> 31 == 0 {
        mag.min(i32::MAX as u32) as i32
    } else if mag >= 1 << 31 {
        i32::MIN
    } else {
        -(mag as i32)
    }
}

/// `x / 2^frac` as an `f32` (truncated to 24 significant bits: relative
/// error < 1.2e-7), by the bits: one `CLZ` and a few shifts instead of
/// `__aeabi_i2f` and a multiply. `frac` ≤ 100.
#[inline]
pub fn q_to_f32(x: i32, frac: u32) -> f32 {
    if x == 0 {
        return 0.0;
    }
    let sign = (x as u32) & (1 << 31);
    let a = x.unsigned_abs();
    let lz = a.leading_zeros();
    // a = 1.f · 2^(31 − lz); the biased exponent of x / 2^frac.
    let exp = 127 + 31 - lz as i32 - frac.min(100) as i32;
    if exp <= 0 {
        return 0.0; // below the normal range: not reached by this crate's formats
    }
    let mant = ((a << lz) >> 8) & 0x7f_ffff;
    f32::from_bits(sign | ((exp as u32) << 23) | mant)
}

/// Q16 of a finite f32 (m, m/s), saturating at ±32 767: the cheap
/// conversion of the vertical estimator's outputs on the control path.
pub fn q16_saturating(x: f32) -> Result<i32, Error> {
    finite(x)?;
    // `as` saturates.
    Ok((x * 65_536.0) as i32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::controllers::{
        AltitudeHold, Attitude, AttitudeController, AttitudeTarget, BodyRates, YawTarget,
    };
    use crate::pid::Pid;

    struct Rng(u32);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 17;
            self.0 ^= self.0 << 5;
            self.0 as f32 / u32::MAX as f32 * 2.0 - 1.0
        }
    }

    fn q16(x: f32) -> i32 {
        to_q16(x).unwrap()
    }

    fn from_q30(x: i32) -> f32 {
        x as f32 / ONE_Q30 as f32
    }

    #[test]
    fn a_held_integral_stays_while_p_and_d_act() {
        let cfg = PidConfig::new(0.5, 2.0, 0.0).with_integral_limits(-0.5, 0.5);
        let mut q = PidQ::new(&cfg, 0.001).unwrap();
        let one = 1 << 16; // 1 unit of error
        for _ in 0..100 {
            q.update(one, 0, 0);
        }
        let i = q.integral_q30();
        // 0.1 s of ki = 2 on 1 unit: 0.2.
        assert!((q_to_f32(i, 30) - 0.2).abs() < 0.01, "{}", q_to_f32(i, 30));
        // Held: the integral does not move, and the output is P + I.
        for _ in 0..100 {
            let out = q.update_holding(one + one / 2, 0, 0, true);
            assert_eq!(q.integral_q30(), i);
            assert!((q_to_f32(out, 30) - (0.5 * 1.5 + 0.2)).abs() < 0.01);
        }
        // Released, it integrates again from where it was.
        q.update_holding(one, 0, 0, false);
        assert!(q.integral_q30() > i);
    }

    #[test]
    fn pid_tracks_the_f32_pid() {
        let dt = 0.01;
        for cfg in [
            PidConfig::new(0.3, 0.4, 0.002)
                .with_d_cutoff_hz(40.0)
                .with_integral_limits(-0.2, 0.2),
            PidConfig::new(0.8, 0.3, 0.05)
                .with_d_cutoff_hz(30.0)
                .with_output_limits(-0.5, 0.5)
                .with_integral_limits(-0.2, 0.2),
            PidConfig::new(0.5, 0.5, 0.0)
                .with_output_limits(0.0, 1.0)
                .with_integral_limits(-0.3, 0.3),
        ] {
            let mut f = Pid::new(cfg).unwrap();
            let mut q = PidQ::new(&cfg, dt).unwrap();
            let mut rng = Rng(7);
            let mut worst = 0.0f32;
            let mut saturated = 0;
            for k in 0..20_000 {
                // Slow wander plus noise, with stretches into saturation.
                let sp = 0.5 * rng.f() * if k % 3000 < 1500 { 1.0 } else { 12.0 };
                let m = 0.2 * sp + 0.3 * rng.f();
                let ff = if cfg.output_min >= 0.0 { 0.5 } else { 0.0 };
                let (sp, m) = (q16(sp) as f32 / 65_536.0, q16(m) as f32 / 65_536.0);
                let uf = f.update_with_ff(sp, m, ff, dt).unwrap();
                let uq = from_q30(q.update(q16(sp), q16(m), to_q30(ff).unwrap()));
                worst = worst.max((uf - uq).abs());
                if uf >= cfg.output_max || uf <= cfg.output_min {
                    saturated += 1;
                }
            }
            assert!(worst < 2e-4, "{cfg:?}: worst |f32 − Q| = {worst}");
            assert!(saturated > 100, "the sequence must reach the limits");
        }
    }

    #[test]
    fn attitude_and_altitude_track_the_f32_controllers() {
        let dt = 0.01;
        let cfg = AttitudeConfig::default();
        let mut f = AttitudeController::new(cfg).unwrap();
        let mut q = AttitudeQ::new(&cfg, dt).unwrap();
        let hcfg = AltitudeHoldConfig::default();
        let mut hf = AltitudeHold::new(hcfg).unwrap();
        let mut hq = AltitudeHoldQ::new(&hcfg, dt).unwrap();
        let mut rng = Rng(99);
        let mut worst = 0.0f32;
        for k in 0..5_000 {
            let a = [0.3 * rng.f(), 0.3 * rng.f(), 3.1 * rng.f()].map(q16);
            let r = [rng.f(), rng.f(), rng.f()].map(q16);
            let yaw_to = q16(3.1 * rng.f());
            let af = a.map(|v| v as f32 / 65_536.0);
            let rf = r.map(|v| v as f32 / 65_536.0);
            let yt = if k % 2 == 0 {
                (
                    YawTarget::Angle(yaw_to as f32 / 65_536.0),
                    YawTargetQ16::Angle(yaw_to),
                )
            } else {
                (YawTarget::Rate(0.0), YawTargetQ16::Rate(0))
            };
            let tf = f
                .update(
                    &AttitudeTarget {
                        roll_rad: 0.0,
                        pitch_rad: 0.0,
                        yaw: yt.0,
                    },
                    &Attitude {
                        roll_rad: af[0],
                        pitch_rad: af[1],
                        yaw_rad: af[2],
                    },
                    &BodyRates {
                        roll_rps: rf[0],
                        pitch_rps: rf[1],
                        yaw_rps: rf[2],
                    },
                    dt,
                )
                .unwrap();
            let tq = q.update([0, 0], yt.1, a, r).map(from_q30);
            worst = worst
                .max((tf.roll - tq[0]).abs())
                .max((tf.pitch - tq[1]).abs())
                .max((tf.yaw - tq[2]).abs());
            let (h, v) = (q16(2.0 * rng.f()), q16(rng.f()));
            let thf = hf
                .update(1.0, h as f32 / 65_536.0, v as f32 / 65_536.0, dt)
                .unwrap();
            let thq = from_q30(hq.update(q16(1.0), h, v));
            worst = worst.max((thf - thq).abs());
        }
        assert!(worst < 2e-4, "worst |f32 − Q| = {worst}");
    }

    #[test]
    fn altitude_engage_is_bumpless_like_the_f32_controller() {
        let dt = 0.001;
        let hcfg = AltitudeHoldConfig::default();
        let mut hf = AltitudeHold::new(hcfg).unwrap();
        let mut hq = AltitudeHoldQ::new(&hcfg, dt).unwrap();
        let mut rng = Rng(7);
        for _ in 0..2_000 {
            let (v, thr) = (q16(rng.f()), 0.5 + 0.4 * rng.f());
            let h = q16(3.0 * rng.f());
            hf.reset(v as f32 / 65_536.0, thr).unwrap();
            hq.reset(v, to_q30(thr).unwrap());
            // At the target, as engaged: the stick's throttle comes out
            // (where the integral's limits allow it).
            let hf_m = h as f32 / 65_536.0;
            let thf = hf.update(hf_m, hf_m, v as f32 / 65_536.0, dt).unwrap();
            let thq = from_q30(hq.update(h, h, v));
            assert!((thf - thq).abs() < 1e-4, "{thf} vs {thq}");
            // Where the integral this needs (throttle − hover − kp·(0 − v))
            // lies inside its ±0.3 limits.
            if (thr - 0.5 + 0.5 * v as f32 / 65_536.0).abs() < 0.29 {
                assert!((thq - thr).abs() < 1e-3, "bumpless: {thq} for {thr}");
            }
        }
    }

    #[test]
    fn refuses_what_the_formats_cannot_hold() {
        let dt = 0.01;
        assert_eq!(
            PidQ::new(&PidConfig::new(200.0, 0.0, 0.0), dt),
            Err(Error::InvalidParameter)
        );
        // kd / dt = 2 / 0.01 = 200.
        assert_eq!(
            PidQ::new(&PidConfig::new(1.0, 0.0, 2.0), dt),
            Err(Error::InvalidParameter)
        );
        assert_eq!(
            PidQ::new(
                &PidConfig::new(1.0, 0.0, 0.0).with_output_limits(-5.0, 5.0),
                dt
            ),
            Err(Error::InvalidLimits)
        );
        assert_eq!(
            PidQ::new(&PidConfig::new(1.0, 0.0, 0.0), 0.0),
            Err(Error::InvalidDt)
        );
        assert!(to_q16(f32::NAN).is_err() && q16_saturating(f32::INFINITY).is_err());
        assert_eq!(q16_saturating(1.0e9), Ok(i32::MAX));
    }

    #[test]
    fn extreme_inputs_stay_within_the_limits() {
        let cfg = PidConfig::new(100.0, 100.0, 1.0).with_d_cutoff_hz(10.0);
        let mut q = PidQ::new(&cfg, 0.01).unwrap();
        for (sp, m) in [
            (i32::MAX, i32::MIN),
            (i32::MIN, i32::MAX),
            (0, i32::MAX),
            (i32::MAX, 0),
        ] {
            let u = q.update(sp, m, i32::MAX);
            assert!((-ONE_Q30..=ONE_Q30).contains(&u), "{u}");
        }
        assert!(wrap_pi_q16(i32::MAX).abs() <= PI_Q16);
        assert!((wrap_pi_q16(3 * PI_Q16 / 2) + PI_Q16 / 2).abs() <= 2);
    }
}
