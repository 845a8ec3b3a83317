//! Vertical estimator: fuses barometric height with earth-frame vertical
//! acceleration into height, vertical speed and accelerometer bias.
//!
//! # Inputs
//!
//! * [`VerticalEstimator::predict`]: vertical acceleration in the earth frame,
//!   **gravity removed, up positive**, m/s² (for an NED AHRS output that is
//!   `−(a_ned_z + g)` of the specific force rotated to NED), at up to 1 kHz,
//!   with its own `dt_s`.
//! * [`VerticalEstimator::update_baro`]: barometric height, m, up positive
//!   (e.g. [`CheapBaro::height_m`](crate::baro::CheapBaro::height_m)), at
//!   ~50–100 Hz. The first baro sample initialises the height.
//!
//! # Why a third-order complementary filter
//!
//! The state is `[h, v, b]` (height, vertical speed, accelerometer bias),
//! the model `ḣ = v`, `v̇ = a_meas − b`, `ḃ = 0`, and the baro measures `h`.
//! A Kalman filter for this model with constant noise levels converges to a
//! constant gain; a complementary filter *is* that constant-gain observer,
//! with its three gains placed by one number, the crossover `ω`
//! (triple pole: `s³ + k1 s² + k2 s + k3 = (s + ω)³`, so `k1 = 3ω`,
//! `k2 = 3ω²`, `k3 = ω³`). Below `ω` the height follows the barometer, above
//! it the double-integrated accelerometer; the bias state removes the
//! accelerometer offset so there is no steady-state height or speed error.
//!
//! On an FPU-less Cortex-M3 this matters: every f32 operation is a library
//! call. The 1 kHz [`predict`](VerticalEstimator::predict) costs **2 fmul +
//! 4 fadd/fsub + 5 soft-float compares** (dt range, accel limit, interval
//! cap) — vs. ~30 multiplies for a 3×3 covariance propagation — and a baro [`update_baro`](VerticalEstimator::update_baro)
//! about **7 fmul + 5 fadd + ~8 compares** (gains scaled by the time since
//! the previous baro sample, so an irregular baro rate is handled).
//! Tuning is one physically meaningful number instead of three noise
//! densities.
//!
//! # Outlier handling
//!
//! * **Innovation gate**: a baro sample with `|z − h| > gate_sigma ·
//!   baro_sigma_m` is rejected (no state change). After `resync_after`
//!   consecutive rejections the estimator **re-syncs** (height set to the
//!   baro, speed and bias kept), so a real step (or a diverged estimate) can
//!   never lock the barometer out forever. If a re-sync does not hold (the
//!   next one follows with fewer than `resync_after` accepted samples in
//!   between), the speed is re-derived from the two re-sync heights, so a
//!   diverged speed cannot keep the estimate away from the baro either.
//! * **Ground effect**: prop-wash raises the static pressure near the
//!   ground, i.e. the baro reads spuriously *low*. In ground-effect mode —
//!   set by the caller with [`set_ground_effect`](VerticalEstimator::set_ground_effect),
//!   or automatic while the estimate is below `ground_height_m +
//!   ground_effect_band_m` — samples with an innovation below
//!   `−ground_effect_clip_m` are ignored ([`BaroOutcome::GroundEffect`]);
//!   they count toward the re-sync run like gate rejections, so a wrong
//!   estimate inside the band cannot lock the baro out either. Positive innovations keep full weight,
//!   and ordinary noise (inside the 2 σ default clip) is used as usual, so
//!   the height bias this introduces is small (≈ 0.5 cm with the defaults).
//!   Because the accelerometer carries the estimate through a real descent,
//!   a landing is still followed; if the caller knows the vehicle has left
//!   ground effect it should clear its flag.
//! * **Non-finite inputs** (NaN/∞ acceleration, height or dt) return an
//!   error and leave the state untouched.
//!
//! Counters of accepted / ground-effect-ignored / rejected samples and re-syncs are in
//! [`Stats`].
//!
//! ```
//! use control::vertical::{BaroOutcome, Config, VerticalEstimator};
//! let mut est = VerticalEstimator::new(Config::default()).unwrap();
//! assert_eq!(est.update_baro(10.0).unwrap(), BaroOutcome::Initialized);
//! for _ in 0..10 {
//!     est.predict(0.0, 0.001).unwrap(); // 1 kHz, hovering
//! }
//! assert_eq!(est.update_baro(10.05).unwrap(), BaroOutcome::Accepted);
//! assert!((est.height_m() - 10.0).abs() < 0.01);
//! assert_eq!(est.update_baro(f32::NAN), Err(control::Error::NonFinite));
//! ```

use crate::error::{check_gain, check_positive, finite, Error};
use crate::pid::clamp;

/// Acceleration inputs are limited to ±this, m/s² (16 g, the MPU-9250's
/// largest range), so garbage cannot overflow the state.
const ACCEL_LIMIT_MPS2: f32 = 16.0 * 9.806_65;

/// The time since the last re-sync stops counting here, s.
const RESYNC_MEMORY_S: f32 = 3600.0;

/// Estimator tuning. Plain fields; check with [`validate`](Self::validate).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Crossover frequency `ω` of the complementary filter, rad/s (triple
    /// pole). Lower = smoother height, slower bias convergence. Default 1.0.
    pub crossover_rad_s: f32,
    /// Baro height noise, 1 σ, m (MS5611 at OSR 4096 ≈ 0.1 m). Default 0.1.
    pub baro_sigma_m: f32,
    /// Innovation gate in σ: `|z − h| > gate_sigma · baro_sigma_m` is
    /// rejected. Default 5 (0.5 m).
    pub gate_sigma: f32,
    /// Consecutive rejections (gate or ground effect) after which the height
    /// re-syncs to the baro.
    /// Must be ≥ 1. Default 25 (0.25 s at 100 Hz).
    pub resync_after: u16,
    /// Limit of the accelerometer-bias estimate, ±m/s². Default 1.0.
    pub max_bias_mps2: f32,
    /// Height of the ground in the estimator's frame, m (0 when the baro
    /// reference is the take-off pressure). Default 0.
    pub ground_height_m: f32,
    /// Automatic ground-effect mode below `ground_height_m` + this, m.
    /// 0 disables the automatic mode (the caller's flag still works). Default 0.5.
    pub ground_effect_band_m: f32,
    /// In ground effect, samples with an innovation below −this are ignored, m.
    /// Default 0.2 (2 σ).
    pub ground_effect_clip_m: f32,
    /// Largest accepted `dt_s` for `predict`, s. Default 0.05.
    pub max_dt_s: f32,
    /// Baro period assumed when `update_baro` is called with no `predict`
    /// since the previous sample, s. Default 0.01.
    pub nominal_baro_period_s: f32,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            crossover_rad_s: 1.0,
            baro_sigma_m: 0.1,
            gate_sigma: 5.0,
            resync_after: 25,
            max_bias_mps2: 1.0,
            ground_height_m: 0.0,
            ground_effect_band_m: 0.5,
            ground_effect_clip_m: 0.2,
            max_dt_s: 0.05,
            nominal_baro_period_s: 0.01,
        }
    }
}

impl Config {
    /// Checks the configuration. Errors: [`Error::InvalidParameter`] for a
    /// non-positive or non-finite crossover, sigma, gate, bias limit, clip,
    /// `max_dt_s` or baro period, `resync_after == 0`, or a crossover so
    /// high that `ω · max(max_dt_s, nominal_baro_period_s) > 0.5` (the
    /// discrete correction would be unstable); [`Error::NonFinite`] for a
    /// non-finite ground height; [`Error::NegativeGain`] for a negative band.
    pub fn validate(&self) -> Result<(), Error> {
        check_positive(self.crossover_rad_s)?;
        check_positive(self.baro_sigma_m)?;
        check_positive(self.gate_sigma)?;
        check_positive(self.max_bias_mps2)?;
        check_positive(self.ground_effect_clip_m)?;
        check_positive(self.max_dt_s)?;
        check_positive(self.nominal_baro_period_s)?;
        finite(self.ground_height_m)?;
        check_gain(self.ground_effect_band_m)?;
        if self.resync_after == 0 {
            return Err(Error::InvalidParameter);
        }
        let longest = self.max_dt_s.max(self.nominal_baro_period_s);
        if self.crossover_rad_s * longest > 0.5 {
            return Err(Error::InvalidParameter);
        }
        Ok(())
    }
}

/// What [`VerticalEstimator::update_baro`] did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BaroOutcome {
    /// First sample: the height was initialised to it (speed and bias 0).
    Initialized,
    /// Used with full weight.
    Accepted,
    /// Ground effect: innovation below `−ground_effect_clip_m`, ignored.
    GroundEffect,
    /// Outside the gate: ignored.
    Rejected,
    /// `resync_after` rejections in a row: the height was set to this sample.
    Resynced,
}

/// Sample counters (wrapping).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// Samples used with full weight (includes the initialising one).
    pub accepted: u32,
    /// Samples ignored as prop-wash in ground effect.
    pub ground_effect: u32,
    /// Samples rejected by the gate (re-sync samples not included).
    pub rejected: u32,
    /// Re-syncs after a run of rejections.
    pub resyncs: u32,
}

/// Height / vertical-speed / accelerometer-bias estimator. See the
/// [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VerticalEstimator {
    cfg: Config,
    /// `3ω`, `3ω²`, `ω³` (continuous gains; scaled by the baro interval).
    k1: f32,
    k2: f32,
    k3: f32,
    gate_m: f32,
    height_m: f32,
    velocity_mps: f32,
    bias_mps2: f32,
    since_baro_s: f32,
    initialized: bool,
    ground_effect_forced: bool,
    reject_run: u16,
    /// Baro height at the previous re-sync, the baro time since it, and the
    /// samples accepted since it (for the velocity re-sync).
    resync_ref_m: f32,
    since_resync_s: f32,
    accepted_since_resync: u16,
    has_resync_ref: bool,
    last_innovation_m: f32,
    stats: Stats,
}

impl VerticalEstimator {
    /// Creates an uninitialised estimator (the first baro sample sets the
    /// height). Errors: see [`Config::validate`].
    // Out of line: config-time only, and inlined its result is moved
    // through the caller's frame once more (less flash).
    #[inline(never)]
    pub fn new(cfg: Config) -> Result<Self, Error> {
        cfg.validate()?;
        let w = cfg.crossover_rad_s;
        Ok(Self {
            cfg,
            k1: 3.0 * w,
            k2: 3.0 * w * w,
            k3: w * w * w,
            gate_m: cfg.gate_sigma * cfg.baro_sigma_m,
            height_m: 0.0,
            velocity_mps: 0.0,
            bias_mps2: 0.0,
            since_baro_s: 0.0,
            initialized: false,
            ground_effect_forced: false,
            reject_run: 0,
            resync_ref_m: 0.0,
            since_resync_s: 0.0,
            accepted_since_resync: 0,
            has_resync_ref: false,
            last_innovation_m: 0.0,
            stats: Stats::default(),
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Back to the uninitialised state (keeps the configuration, the
    /// caller's ground-effect flag and the counters).
    pub fn reset(&mut self) {
        self.height_m = 0.0;
        self.velocity_mps = 0.0;
        self.bias_mps2 = 0.0;
        self.since_baro_s = 0.0;
        self.initialized = false;
        self.reject_run = 0;
        self.has_resync_ref = false;
        self.last_innovation_m = 0.0;
    }

    /// Propagates with earth-frame vertical acceleration (gravity removed,
    /// up positive, m/s²) over `dt_s`. Before the first baro sample this
    /// only checks its inputs.
    ///
    /// Errors: [`Error::NonFinite`], [`Error::InvalidDt`] (`dt_s` not in
    /// `(0, max_dt_s]`); the state is untouched on error.
    #[inline]
    pub fn predict(&mut self, accel_up_mps2: f32, dt_s: f32) -> Result<(), Error> {
        finite(accel_up_mps2)?;
        if !(dt_s > 0.0 && dt_s <= self.cfg.max_dt_s) {
            return Err(Error::InvalidDt);
        }
        if !self.initialized {
            return Ok(());
        }
        let a = clamp(accel_up_mps2, -ACCEL_LIMIT_MPS2, ACCEL_LIMIT_MPS2) - self.bias_mps2;
        self.velocity_mps += a * dt_s;
        self.height_m += self.velocity_mps * dt_s;
        // Bounded: only the gain scaling reads it and clamps it anyway.
        if self.since_baro_s < self.cfg.max_dt_s {
            self.since_baro_s += dt_s;
        }
        Ok(())
    }

    /// Fuses a barometric height, m (up positive). See the [module docs](self)
    /// for the gate, re-sync and ground-effect rules.
    ///
    /// Errors: [`Error::NonFinite`]; the state is untouched on error.
    pub fn update_baro(&mut self, height_m: f32) -> Result<BaroOutcome, Error> {
        finite(height_m)?;
        if !self.initialized {
            self.height_m = height_m;
            self.velocity_mps = 0.0;
            self.bias_mps2 = 0.0;
            self.since_baro_s = 0.0;
            self.initialized = true;
            self.reject_run = 0;
            self.has_resync_ref = false;
            self.last_innovation_m = 0.0;
            self.stats.accepted = self.stats.accepted.wrapping_add(1);
            return Ok(BaroOutcome::Initialized);
        }
        let dt_s = if self.since_baro_s > 0.0 {
            self.since_baro_s.min(self.cfg.max_dt_s)
        } else {
            self.cfg.nominal_baro_period_s
        };
        self.since_baro_s = 0.0;
        if self.since_resync_s < RESYNC_MEMORY_S {
            self.since_resync_s += dt_s;
        }

        let e = height_m - self.height_m;
        self.last_innovation_m = e;

        let prop_wash = e < -self.cfg.ground_effect_clip_m && self.ground_effect_active();
        if prop_wash || e > self.gate_m || e < -self.gate_m {
            self.reject_run = self.reject_run.saturating_add(1);
            if self.reject_run >= self.cfg.resync_after {
                self.resync(height_m);
                self.stats.resyncs = self.stats.resyncs.wrapping_add(1);
                return Ok(BaroOutcome::Resynced);
            }
            return Ok(if prop_wash {
                self.stats.ground_effect = self.stats.ground_effect.wrapping_add(1);
                BaroOutcome::GroundEffect
            } else {
                self.stats.rejected = self.stats.rejected.wrapping_add(1);
                BaroOutcome::Rejected
            });
        }
        self.reject_run = 0;

        self.height_m += self.k1 * dt_s * e;
        self.velocity_mps += self.k2 * dt_s * e;
        let max_b = self.cfg.max_bias_mps2;
        self.bias_mps2 = clamp(self.bias_mps2 - self.k3 * dt_s * e, -max_b, max_b);
        self.accepted_since_resync = self.accepted_since_resync.saturating_add(1);
        self.stats.accepted = self.stats.accepted.wrapping_add(1);
        Ok(BaroOutcome::Accepted)
    }

    /// Height re-sync after a run of rejections. If the previous re-sync did
    /// not hold (fewer than `resync_after` samples accepted since), the speed
    /// has diverged too: it is re-derived from the two re-sync heights.
    fn resync(&mut self, height_m: f32) {
        if self.has_resync_ref
            && self.accepted_since_resync < self.cfg.resync_after
            && self.since_resync_s > 0.0
        {
            let v = (height_m - self.resync_ref_m) / self.since_resync_s;
            if v.is_finite() {
                self.velocity_mps = v;
            }
        }
        self.height_m = height_m;
        self.reject_run = 0;
        self.resync_ref_m = height_m;
        self.since_resync_s = 0.0;
        self.accepted_since_resync = 0;
        self.has_resync_ref = true;
    }

    /// Forces ground-effect mode on (e.g. while landed, taking off or
    /// landing) or back to automatic (`false`).
    pub fn set_ground_effect(&mut self, on: bool) {
        self.ground_effect_forced = on;
    }

    /// Whether ground-effect handling applies now (forced by the caller, or
    /// the estimate is below `ground_height_m + ground_effect_band_m`).
    pub fn ground_effect_active(&self) -> bool {
        self.ground_effect_forced
            || (self.cfg.ground_effect_band_m > 0.0
                && self.height_m < self.cfg.ground_height_m + self.cfg.ground_effect_band_m)
    }

    /// Whether a baro sample has initialised the estimate.
    pub fn is_initialized(&self) -> bool {
        self.initialized
    }

    /// Estimated height, m, up positive (same reference as the baro input).
    pub fn height_m(&self) -> f32 {
        self.height_m
    }

    /// Estimated vertical speed, m/s, up positive.
    pub fn velocity_mps(&self) -> f32 {
        self.velocity_mps
    }

    /// Estimated accelerometer bias (earth-frame vertical, up), m/s²: the
    /// amount subtracted from every `predict` input.
    pub fn accel_bias_mps2(&self) -> f32 {
        self.bias_mps2
    }

    /// The last baro innovation `z − h` before correction, m.
    pub fn last_innovation_m(&self) -> f32 {
        self.last_innovation_m
    }

    /// Sample counters.
    pub fn stats(&self) -> Stats {
        self.stats
    }
}
