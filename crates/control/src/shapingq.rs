//! Stick shaping in fixed point: the same laws as
//! [`StickShaping`](crate::shaping::StickShaping) (deadband, expo, rates,
//! maximum tilt, throttle curve) for each new pilot frame, in integer
//! arithmetic, with the tilt setpoint's quaternion from integer sine and
//! cosine polynomials. In `f32` one frame's shaping costs ~10,000
//! instructions on the Cortex-M3 (a CRSF frame arrives every 4–7 ms, and
//! the step that meets it is the loop's worst); here a few hundred.
//!
//! # Q-formats, ranges and resolution
//!
//! | quantity | format | range | resolution |
//! |---|---|---|---|
//! | sticks, shaped sticks, throttle | Q30 `i32` | ±1 (clamped), throttle 0..1 | 9.3e-10 |
//! | expo, deadband, throttle mid | Q30 | 0..1 | 9.3e-10 |
//! | `1/(1 − deadband)` | Q30 | 1..1.25 | 9.3e-10 |
//! | throttle curve's `1/span` | Q24 | 1.05..20 | 6e-8 |
//! | rate setpoints (rad/s) | Q16 | ±34.9 (2000 °/s) | 1.5e-5 rad/s |
//! | tilt angle, its half (rad) | Q30 | ±1.40 (80°) | 9.3e-10 |
//! | tilt quaternion | Q30 ([`TiltQ30`]) | unit | 9.3e-10 |
//!
//! Products are 32×32→64-bit and shifted back; each step's rounding is
//! one Q30 quantum, so the shaped sticks agree with the `f32` law to a few
//! parts in 10⁹ of full scale (the `f32` law's own rounding, 6e-8, is the
//! larger). Sine and cosine of the half tilt (at most 40°) are Taylor
//! polynomials to degree 9 and 10 in Horner form: the truncation is below
//! 5e-10 there.
//!
//! # Agreement with the `f32` law
//!
//! Tested side by side (`tests/shapingq.rs`) over random sticks (beyond
//! their ranges too) and random valid configurations: rates within 1e-4
//! rad/s, the tilt quaternion within 1e-6, the throttle within 1e-6.
//!
//! ```
//! use control::shaping::{Sticks, SticksConfig};
//! use control::shapingq::StickShapingQ;
//! let shaping = StickShapingQ::new(&SticksConfig::default())?;
//! let s = shaping.shape(&Sticks { roll: 1.0, pitch: 0.0, yaw: 0.0, throttle: 0.5 });
//! // Full roll stick: 500 °/s in Q16 rad/s.
//! assert!((s.acro_q16[0] - (500f32.to_radians() * 65_536.0) as i32).abs() < 8);
//! # Ok::<(), control::Error>(())
//! ```

use crate::error::Error;
use crate::fixed::{f32_to_q, ONE_Q30};
use crate::levelq::TiltQ30;
use crate::shaping::{AxisRates, Sticks, SticksConfig, ThrottleCurve};

const RAD_PER_DEG: f32 = core::f32::consts::PI / 180.0;

/// `a · b` of two Q30 values, Q30.
fn mul30(a: i32, b: i32) -> i32 {
    ((i64::from(a) * i64::from(b)) >> 30) as i32
}

/// `(1 − e)·x + e·x³` in Q30 (`|x| ≤ 1`).
fn expo_q30(x: i32, e: i32) -> i32 {
    let x3 = mul30(mul30(x, x), x);
    mul30(ONE_Q30 - e, x) + mul30(e, x3)
}

/// A stick clamped to `[lo, hi]` in Q30 (NaN: 0; callers check
/// finiteness first).
fn stick_q30(x: f32, lo: i32, hi: i32) -> i32 {
    f32_to_q(x, 30).max(lo).min(hi)
}

/// One axis's deadband and expo, and the value at full stick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct AxisQ {
    deadband_q30: i32,
    /// `1/(1 − deadband)`, Q30.
    inv_span_q30: i32,
    expo_q30: i32,
    /// Output at full stick (Q16 rad/s for rates, Q30 rad for a tilt).
    full: i32,
}

impl AxisQ {
    /// From the `f32` axis (validated) and its full-stick output already
    /// in its format.
    #[inline(always)]
    fn new(a: &AxisRates, full: i32) -> Self {
        Self {
            deadband_q30: f32_to_q(a.deadband, 30),
            inv_span_q30: f32_to_q(1.0 / (1.0 - a.deadband), 30),
            expo_q30: f32_to_q(a.expo, 30),
            full,
        }
    }

    /// A rate axis: full stick = its maximum rate, Q16 rad/s.
    #[inline(always)]
    fn rate(a: &AxisRates) -> Self {
        Self::new(a, f32_to_q(a.max_rate_dps * RAD_PER_DEG, 16))
    }

    /// The shaped stick times the full-stick output, in its format.
    fn apply(&self, s_q30: i32) -> i32 {
        let mag = s_q30.unsigned_abs() as i32;
        let d = if mag <= self.deadband_q30 {
            0
        } else {
            mul30(mag - self.deadband_q30, self.inv_span_q30).min(ONE_Q30)
        };
        let x = expo_q30(if s_q30 < 0 { -d } else { d }, self.expo_q30);
        mul30(x, self.full)
    }
}

/// The throttle curve in fixed point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct ThrottleQ {
    mid_q30: i32,
    expo_q30: i32,
    /// `1/mid` and `1/(1 − mid)`, Q24 (mid in 0.05..0.95: at most 20).
    inv_lo_q24: i32,
    inv_hi_q24: i32,
}

impl ThrottleQ {
    #[inline(always)]
    fn new(c: &ThrottleCurve) -> Self {
        Self {
            mid_q30: f32_to_q(c.mid, 30),
            expo_q30: f32_to_q(c.expo, 30),
            inv_lo_q24: f32_to_q(1.0 / c.mid, 24),
            inv_hi_q24: f32_to_q(1.0 / (1.0 - c.mid), 24),
        }
    }

    /// The curve at a throttle stick in 0..1 (Q30).
    fn apply(&self, x_q30: i32) -> i32 {
        let (span, inv) = if x_q30 < self.mid_q30 {
            (self.mid_q30, self.inv_lo_q24)
        } else {
            (ONE_Q30 - self.mid_q30, self.inv_hi_q24)
        };
        // |x − mid| ≤ span, so |t| ≤ 1 (clamped against the inverse's
        // rounding).
        let t = ((i64::from(x_q30 - self.mid_q30) * i64::from(inv)) >> 24) as i32;
        let t = t.clamp(-ONE_Q30, ONE_Q30);
        (self.mid_q30 + mul30(span, expo_q30(t, self.expo_q30))).clamp(0, ONE_Q30)
    }
}

/// One pilot frame's setpoints, in the loops' formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ShapedQ {
    /// Acro rate setpoints (roll, pitch, yaw), Q16 rad/s, FRD.
    pub acro_q16: [i32; 3],
    /// The self-level tilt setpoint.
    pub tilt: TiltQ30,
    /// The yaw rate setpoint in every mode, Q16 rad/s.
    pub yaw_q16: i32,
    /// The shaped throttle, Q30 (0..1).
    pub throttle_q30: i32,
}

/// Stick shaping in fixed point. See the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StickShapingQ {
    roll: AxisQ,
    pitch: AxisQ,
    yaw: AxisQ,
    /// Self-level roll/pitch: the roll deadband, the angle expo, full
    /// stick = the maximum tilt in Q30 rad.
    angle: AxisQ,
    throttle: ThrottleQ,
}

impl StickShapingQ {
    /// Validates and converts the configuration. Errors:
    /// [`SticksConfig::validate`]'s.
    #[inline(always)]
    pub fn new(cfg: &SticksConfig) -> Result<Self, Error> {
        cfg.validate()?;
        let angle = AxisRates {
            max_rate_dps: 1.0,
            expo: cfg.angle_expo,
            deadband: cfg.roll.deadband,
        };
        // No closure here: the firmware's constant configuration must fold
        // at compile time, and a closure need not be inlined.
        Ok(Self {
            roll: AxisQ::rate(&cfg.roll),
            pitch: AxisQ::rate(&cfg.pitch),
            yaw: AxisQ::rate(&cfg.yaw),
            angle: AxisQ::new(&angle, f32_to_q(cfg.max_angle_deg * RAD_PER_DEG, 30)),
            throttle: ThrottleQ::new(&cfg.throttle),
        })
    }

    /// The setpoints of one frame's sticks (clamped to their ranges; a
    /// NaN stick counts as centred: check finiteness first, as the flight
    /// controller does). Pitch stick forward (+) is nose down (−).
    pub fn shape(&self, sticks: &Sticks) -> ShapedQ {
        let one = ONE_Q30;
        let roll = stick_q30(sticks.roll, -one, one);
        let pitch = stick_q30(sticks.pitch, -one, one);
        let yaw_q16 = self.yaw.apply(stick_q30(sticks.yaw, -one, one));
        let roll_rad = self.angle.apply(roll);
        let pitch_rad = -self.angle.apply(pitch);
        ShapedQ {
            acro_q16: [self.roll.apply(roll), -self.pitch.apply(pitch), yaw_q16],
            tilt: tilt_q30(roll_rad, pitch_rad),
            yaw_q16,
            throttle_q30: self.throttle.apply(stick_q30(sticks.throttle, 0, one)),
        }
    }
}

/// `q_y(θ) ⊗ q_x(φ)` for roll φ and pitch θ in Q30 rad (|.| ≤ 80°):
/// `(cθ cφ, cθ sφ, sθ cφ, −sθ sφ)` of the half angles.
pub fn tilt_q30(roll_q30: i32, pitch_q30: i32) -> TiltQ30 {
    let (sr, cr) = half_sin_cos_q30(roll_q30);
    let (sp, cp) = half_sin_cos_q30(pitch_q30);
    TiltQ30::from_q30([mul30(cp, cr), mul30(cp, sr), mul30(sp, cr), -mul30(sp, sr)])
}

/// `(sin(a/2), cos(a/2))` in Q30 for `|a| ≤ 1.4` rad (80°), Q30 in:
/// Taylor polynomials to degree 9 and 10 in Horner form (truncation below
/// 5e-10 at a half angle of 40°).
fn half_sin_cos_q30(a_q30: i32) -> (i32, i32) {
    // Q30 reciprocals of the Horner factors.
    const INV: [i32; 4] = [
        ONE_Q30 / 6,  // 2·3
        ONE_Q30 / 20, // 4·5
        ONE_Q30 / 42, // 6·7
        ONE_Q30 / 72, // 8·9
    ];
    const INV_C: [i32; 5] = [
        ONE_Q30 / 2,  // 1·2
        ONE_Q30 / 12, // 3·4
        ONE_Q30 / 30, // 5·6
        ONE_Q30 / 56, // 7·8
        ONE_Q30 / 90, // 9·10
    ];
    let h = a_q30 / 2;
    let h2 = mul30(h, h);
    // sin: h(1 − h²/6(1 − h²/20(1 − h²/42(1 − h²/72)))).
    let mut s = ONE_Q30;
    for inv in INV.iter().rev() {
        s = ONE_Q30 - mul30(mul30(h2, *inv), s);
    }
    // cos: 1 − h²/2(1 − h²/12(1 − h²/30(1 − h²/56(1 − h²/90)))).
    let mut c = ONE_Q30;
    for inv in INV_C.iter().rev() {
        c = ONE_Q30 - mul30(mul30(h2, *inv), c);
    }
    (mul30(h, s), c)
}
