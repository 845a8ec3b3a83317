//! The 1 kHz rate loop and the quad-X mixer in fixed point: the same laws
//! as [`RateController`](crate::loops::RateController) (three
//! [`Pid`](crate::pid::Pid)s) and [`Mixer`](crate::mixer::Mixer), in
//! integer arithmetic at a constant period, so the per-sample part of the
//! flight controller needs no soft-float call on the Cortex-M3.
//!
//! # Q-formats, ranges and resolution
//!
//! | quantity | format | range | resolution |
//! |---|---|---|---|
//! | rate setpoint, gyro, rate error (rad/s) | Q16 `i32` | ±32 768 rad/s | 1.5e-5 rad/s |
//! | torque, integral, their limits (−1..1) | Q30 `i32` | ±2 (limits ±1.99) | 9.3e-10 |
//! | throttle, motor commands (0..1) | Q30 `i32` | ±2 in, [idle, 1] out | 9.3e-10 |
//! | mixer intermediates (motor sums) | Q29 `i32` | ±4 | 1.9e-9 |
//! | desaturation gains (0..1) | Q16 | 0..1 | 15 significant bits |
//!
//! * **Rates.** The MPU-9250's widest range is ±2000 °/s = ±34.9 rad/s, so
//!   a rate error is at most ±70 rad/s (a full-scale setpoint against a
//!   full-scale gyro the other way): 4.6·10⁶ in Q16, 460 times inside
//!   `i32`. Q16's step (1.5e-5 rad/s = 8.7e-4 °/s) is 70 times finer than
//!   the gyro's own (0.061 °/s at ±2000 °/s), so the conversion adds no
//!   visible quantisation. [`crate::fixed::PidQ`] saturates every
//!   difference of two Q16 values.
//! * **PID terms** ([`crate::fixed::PidQ`]): gains in Q24 with the period
//!   folded in (`kp`, `ki·dt`, `kd/dt`, each below 128; the default rate
//!   tuning needs 0.25, 8e-4 and 3). Each product is a 64-bit `SMULL`, so
//!   `kp·e` at 70 rad/s and `kd/dt·Δgyro` at a 70 rad/s step (≈ 210 torque
//!   units) are held exactly and summed in 64 bits before the output
//!   clamp; the integrator is clamped to its bound (±0.3 by default, well
//!   inside Q30's ±2) and not integrated towards a saturated output. The
//!   integrator's step `ki·dt·e` is 1.2e-8 at one Q16 quantum of error, 13
//!   Q30 quanta: the slowest drift still integrates.
//! * **Mixer.** A motor sum `T + roll/pitch part + yaw part` spans
//!   `[−1.5, 2.5]` before desaturation (throttle 0..1, roll/pitch ±1, yaw
//!   ±½), beyond Q30's ±2: the mixer works in Q29 (±4) and returns Q30.
//!   Its two gains are one 32-bit `UDIV` each, normalised to 16
//!   significant bits of the divisor (rounded up) and the quotient rounded
//!   down: a gain error below 5e-5 of its value, at most 1.2 of the 24,000
//!   timer ticks between 0 and full throttle on the Blue Pill's PWM
//!   outputs; rounded down, so the motors' span never exceeds `1 − idle`
//!   by it.
//! * **ESC.** [`EscTimer::compare_q30`](crate::esc::EscTimer::compare_q30)
//!   maps a Q30 command to the compare value with one `UMULL`.
//!
//! # The constant period
//!
//! The period is fixed when the loop is built ([`RateControllerQ::new`]'s
//! `dt_s`: the IMU's 1 ms). Each update is one period: a step that stands
//! for two samples (a merged sample) integrates one period and divides the
//! gyro's change by one period, as Betaflight's loop does at its target
//! loop time. The `f32` loop divides by the measured `dt` instead.
//!
//! # Agreement with the `f32` loop
//!
//! Tested side by side (`tests/rateq.rs`: [`crate::loops::RateController`]
//! with the same configuration and `dt`, and [`crate::mixer::Mixer`]):
//! torques and integrals within 5e-5 (0.005 % of ±1; most of it the `f32`
//! integrator's own rounding, 3e-8 a step at 0.3) over random sequences of
//! setpoints and gyro rates across ±2000 °/s that drive the integrators
//! and outputs into their limits, except after a step where the two
//! decide conditional integration differently (an unclamped output within
//! rounding of a limit: one integrator step apart, which persists until
//! the integrators reach a bound; rare, under 1 % of the steps); motor
//! commands within 1e-4 (2.4 ticks of 24,000) of the `f32` mixer's over
//! the whole input box, saturated or not; and a closed-loop step of
//! 400/−300/150 °/s on a rigid-body plant with motor lag, saturating the
//! mixer, whose rate traces stay within 0.02 °/s (measured 0.006 °/s).
//!
//! ```
//! use control::loops::RateConfig;
//! use control::mixer::MixerConfig;
//! use control::rateq::{MixerQ, RateControllerQ};
//! use control::fixed::ONE_Q30;
//! let mut rate = RateControllerQ::new(&RateConfig::default(), 0.001)?;
//! let mixer = MixerQ::new(&MixerConfig::default())?;
//! // 1 rad/s roll demanded, not turning yet: right wing down, left motors up.
//! let torque = rate.update([65_536, 0, 0], [0, 0, 0]);
//! let out = mixer.mix(ONE_Q30 / 2, torque);
//! assert!(torque[0] > 0 && out.motors_q30[2] > out.motors_q30[0]);
//! # Ok::<(), control::Error>(())
//! ```

use crate::body::TorqueCommand;
use crate::error::Error;
use crate::fixed::{q_to_f32, to_q30, PidQ};
use crate::loops::RateConfig;
use crate::mixer::{MixOutput, MixerConfig, MOTORS};

/// The body-rate loop in fixed point: one [`PidQ`] per FRD axis (roll p,
/// pitch q, yaw r), rates in Q16 rad/s → torques in Q30 (−1..1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RateControllerQ {
    axes: [PidQ; 3],
}

impl RateControllerQ {
    /// The loop for `cfg` run every `dt_s` seconds (the gains converted
    /// once, here). Errors: [`RateConfig::validate`]'s, and [`PidQ::new`]'s
    /// for gains or limits the formats cannot hold.
    // `inline(always)`, as the `f32` loops' constructors: a constant
    // configuration (the firmware's) then folds at compile time (1.4 KiB
    // of flash out of line).
    #[inline(always)]
    pub fn new(cfg: &RateConfig, dt_s: f32) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self {
            axes: [
                PidQ::new(&cfg.roll, dt_s)?,
                PidQ::new(&cfg.pitch, dt_s)?,
                PidQ::new(&cfg.yaw, dt_s)?,
            ],
        })
    }

    /// One period: setpoints and gyro rates (roll, pitch, yaw), Q16 rad/s.
    /// Returns the torques (roll, pitch, yaw), Q30, within each PID's
    /// output limits. Total: every input is accepted (differences saturate).
    pub fn update(&mut self, setpoint_q16: [i32; 3], gyro_q16: [i32; 3]) -> [i32; 3] {
        self.update_holding(setpoint_q16, gyro_q16, false)
    }

    /// [`update`](Self::update), with the three integrals held where they
    /// are when `hold` ([`PidQ::update_holding`]).
    pub fn update_holding(
        &mut self,
        setpoint_q16: [i32; 3],
        gyro_q16: [i32; 3],
        hold: bool,
    ) -> [i32; 3] {
        let [r, p, y] = &mut self.axes;
        [
            r.update_holding(setpoint_q16[0], gyro_q16[0], 0, hold),
            p.update_holding(setpoint_q16[1], gyro_q16[1], 0, hold),
            y.update_holding(setpoint_q16[2], gyro_q16[2], 0, hold),
        ]
    }

    /// Forgets the integrals and derivative history (at arming, on the
    /// ground before take-off, at a disarm).
    pub fn clear(&mut self) {
        for a in &mut self.axes {
            a.clear();
        }
    }

    /// The integrals (roll, pitch, yaw), Q30 torque units.
    pub fn integrals_q30(&self) -> [i32; 3] {
        self.axes.map(|a| a.integral_q30())
    }
}

/// `1.0` in Q29, the mixer's working format.
const ONE_Q29: i32 = 1 << 29;
/// `1.0` in Q16, the desaturation gains' format.
const ONE_Q16: i32 = 1 << 16;

/// One fixed-point mix: the motor commands and how much was given up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MixOutputQ {
    /// Motor commands in `[idle, 1]`, Q30, in the
    /// [mixer's order](crate::mixer) (index 0 = Betaflight motor 1).
    pub motors_q30: [i32; MOTORS],
    /// Scale applied to roll and pitch, Q16 (`1 << 16` = unsaturated).
    pub roll_pitch_gain_q16: i32,
    /// Scale applied to yaw, Q16 (`1 << 16` = unsaturated).
    pub yaw_gain_q16: i32,
    /// Change of collective throttle applied, Q30.
    pub collective_shift_q30: i32,
}

impl MixOutputQ {
    /// True when any torque was scaled down or the collective shifted.
    pub fn saturated(&self) -> bool {
        self.roll_pitch_gain_q16 < ONE_Q16
            || self.yaw_gain_q16 < ONE_Q16
            || self.collective_shift_q30 != 0
    }

    /// The same report in `f32` ([`MixOutput`], for logs and the flight
    /// controller's output), by the bits ([`q_to_f32`]).
    pub fn to_f32(&self) -> MixOutput {
        MixOutput {
            motors: self.motor_commands(),
            roll_pitch_gain: q_to_f32(self.roll_pitch_gain_q16, 16),
            yaw_gain: q_to_f32(self.yaw_gain_q16, 16),
            collective_shift: q_to_f32(self.collective_shift_q30, 30),
        }
    }

    /// The motor commands as `f32` 0..1.
    pub fn motor_commands(&self) -> [f32; MOTORS] {
        let m = &self.motors_q30;
        [
            q_to_f32(m[0], 30),
            q_to_f32(m[1], 30),
            q_to_f32(m[2], 30),
            q_to_f32(m[3], 30),
        ]
    }
}

/// The quad-X mixer in fixed point: [`Mixer`](crate::mixer::Mixer)'s
/// table, idle and desaturation (roll/pitch scaled together, then yaw,
/// then the collective shifted towards 0), in Q29 inside.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MixerQ {
    idle_q29: i32,
}

impl MixerQ {
    /// Validates the configuration ([`MixerConfig::validate`]) and converts
    /// the idle once. Errors: [`Error::InvalidParameter`].
    #[inline(always)]
    pub fn new(cfg: &MixerConfig) -> Result<Self, Error> {
        cfg.validate()?;
        Ok(Self {
            idle_q29: to_q30(cfg.idle)? >> 1,
        })
    }

    /// Mixes throttle (Q30, clamped to `[idle, 1]`) and torques (roll,
    /// pitch, yaw, Q30, each clamped to −1..1). Total: every input is
    /// accepted.
    pub fn mix(&self, throttle_q30: i32, torque_q30: [i32; 3]) -> MixOutputQ {
        let lo = self.idle_q29;
        let hi = ONE_Q29;
        let t = (throttle_q30 >> 1).max(lo).min(hi);
        let c = |v: i32| (v >> 1).clamp(-ONE_Q29, ONE_Q29);
        let (roll, pitch, yaw) = (c(torque_q30[0]), c(torque_q30[1]), c(torque_q30[2]));
        // Roll/pitch part ±1 and yaw part ±½ per motor, Q29: the signs of
        // [`QUAD_X`](crate::mixer::QUAD_X) (its ±½ are the shifts), written
        // out (array `map`s here cost a `memcpy` each).
        let rp = [
            (-roll - pitch) >> 1,
            (pitch - roll) >> 1,
            (roll - pitch) >> 1,
            (roll + pitch) >> 1,
        ];
        let (yp, yn) = (yaw >> 1, (-yaw) >> 1);
        let m = [
            t + rp[0] + yn,
            t + rp[1] + yp,
            t + rp[2] + yp,
            t + rp[3] + yn,
        ];
        let fits = m.iter().all(|&v| v >= lo && v <= hi);
        if fits {
            return MixOutputQ {
                motors_q30: [m[0] << 1, m[1] << 1, m[2] << 1, m[3] << 1],
                roll_pitch_gain_q16: ONE_Q16,
                yaw_gain_q16: ONE_Q16,
                collective_shift_q30: 0,
            };
        }
        desaturate(t, &rp, (yp, yn), lo, hi)
    }
}

/// The mixer's saturated path ([`Mixer`](crate::mixer::Mixer)'s steps 1–3)
/// from the collective `t`, the per-motor roll/pitch parts and the yaw
/// part of the CCW motors (1, 2) and of the CW ones (0, 3), all Q29.
#[inline(never)]
fn desaturate(t: i32, rp: &[i32; MOTORS], (yp, yn): (i32, i32), lo: i32, hi: i32) -> MixOutputQ {
    let y = [yn, yp, yp, yn];
    let width = hi - lo;
    let (rp_lo, rp_hi) = min_max(rp);
    let rp_span = rp_hi - rp_lo;
    let g_rp = if rp_span > width {
        ratio_q16(width, rp_span)
    } else {
        ONE_Q16
    };
    let mut base = [0i32; MOTORS];
    for (b, &v) in base.iter_mut().zip(rp) {
        *b = mul_q16(g_rp, v);
    }
    let g_y = yaw_gain_q16(&base, yp, yn, width);
    let mut m = [0i32; MOTORS];
    for i in 0..MOTORS {
        m[i] = t + base[i] + mul_q16(g_y, y[i]);
    }
    let (lo_v, hi_v) = min_max(&m);
    // The span fits (gains rounded down), so at most one side is out:
    // the shift nearest to 0.
    let shift = if hi_v > hi {
        hi - hi_v
    } else if lo_v < lo {
        lo - lo_v
    } else {
        0
    };
    for v in &mut m {
        *v = (*v + shift).max(lo).min(hi) << 1;
    }
    MixOutputQ {
        motors_q30: m,
        roll_pitch_gain_q16: g_rp,
        yaw_gain_q16: g_y,
        collective_shift_q30: shift << 1,
    }
}

/// `g_q16 · x` for a Q16 gain in `[0, 1]`, rounded towards −∞ (64-bit
/// product, one `SMULL`).
#[inline]
fn mul_q16(g_q16: i32, x: i32) -> i32 {
    ((i64::from(g_q16) * i64::from(x)) >> 16) as i32
}

/// `num / den` in Q16 for `0 ≤ num < den`, rounded down: the divisor
/// normalised to its top 16 bits (rounded up), one 32-bit `UDIV`. Relative
/// error below 2⁻¹⁵; never above the exact quotient. 0 for `den ≤ 0`.
fn ratio_q16(num: i32, den: i32) -> i32 {
    if den <= 0 || num <= 0 {
        return 0;
    }
    let (n, d) = (num as u32, den as u32);
    let s = d.leading_zeros(); // ≥ 1: den is positive
                               // n < d, so n << s < d << s < 2³².
    let (n, d) = (n << s, d << s);
    let d16 = (d >> 16) + u32::from(d & 0xffff != 0); // 2¹⁵..=2¹⁶
    (n / d16).min(ONE_Q16 as u32) as i32
}

/// The largest Q16 `g` in `[0, 1]` with `span(base + g·y) ≤ width`, given
/// `span(base) ≤ width`, for the quad-X yaw parts `y = [yn, yp, yp, yn]`
/// (as `mixer::max_gain`, whose pairs `(i, j)` with `yᵢ > yⱼ` all have the
/// same `da = |yp − yn|`, so the binding pair is the one with the least
/// room `width − (bᵢ − bⱼ)`: one division).
fn yaw_gain_q16(base: &[i32; MOTORS], yp: i32, yn: i32, width: i32) -> i32 {
    // The motors the yaw pushes up and those it pushes down.
    let ((u0, u1), (d0, d1), da) = if yp > yn {
        ((base[1], base[2]), (base[0], base[3]), yp - yn)
    } else {
        ((base[0], base[3]), (base[1], base[2]), yn - yp)
    };
    let room = width - (u0.max(u1) - d0.min(d1));
    if room >= da {
        ONE_Q16
    } else {
        ratio_q16(room, da) // 0 for no room
    }
}

fn min_max(v: &[i32; MOTORS]) -> (i32, i32) {
    let (mut lo, mut hi) = (v[0], v[0]);
    for &x in &v[1..] {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    (lo, hi)
}

/// A torque command from Q30 (for logs and the `f32` consumers).
pub fn torque_from_q30(t_q30: [i32; 3]) -> TorqueCommand {
    TorqueCommand {
        roll: q_to_f32(t_q30[0], 30),
        pitch: q_to_f32(t_q30[1], 30),
        yaw: q_to_f32(t_q30[2], 30),
    }
}
