//! Filter configuration (physical units, shared by the f32 and fixed-point filters)
//! and the per-update status report.

/// Filter configuration in physical units, so the same values work at any sample rate.
///
/// The fixed-point filter converts this once (at construction, using f32) into its
/// Q-format constants ([`crate::fixed::FixedConfig::from_config`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Which filter runs: the full filter or Madgwick's 2010 filter as published.
    pub algorithm: Algorithm,
    /// Madgwick's β (rad/s) of the [`Algorithm::Textbook`] filter: the rate at which the
    /// joint accelerometer/magnetometer gradient turns the estimate (the paper's eq. 50:
    /// β = √(3/4)·ω̃β, ω̃β the gyro error). The full filter does not use it.
    pub beta: f32,
    /// Time constant (s) of each of the two first-order low-pass stages the full filter
    /// applies to the specific force in the earth frame before correcting inclination.
    ///
    /// The estimate's earth frame is (nearly) inertial, so the accelerations of a body
    /// that moves but goes nowhere average out there, gravity does not. With the
    /// correction closing the loop, inclination follows the accelerometer through a
    /// second-order low-pass of natural frequency 1/τ: in its hand-held form (not in
    /// flight, [`crate::Madgwick::set_in_flight`], and without the multirotor mode) with
    /// damping ζ = ¾ (the first stage turns by half of each tilt correction, the second
    /// by all of it), otherwise critically damped (both turn by all of it: no overshoot
    /// on the step a stick release leaves the drag model). A linear
    /// acceleration at f is attenuated by (2π·f·τ)² either way; with ζ = ¾ a tilt error
    /// decays at e^(−¾·t/τ) with a 2.8 % overshoot and a residual gyro bias b leaves a
    /// tilt of 1.5·b·τ (critically damped: e^(−t/τ)·(1 + t/τ), 2·b·τ).
    pub tilt_tau_s: f32,
    /// Time constant (s) of the same two stages while the body is at rest (the gyro
    /// bias estimator's test, [`BiasConfig`]: rate below `rest_gyro_rps` and specific
    /// force within `rest_accel_tol` of 1 g for `rest_time_s`) in the loop's hand-held
    /// form (not flying, [`crate::Madgwick::set_in_flight`], and without the multirotor
    /// mode), where it is shorter than the time constant they would run with;
    /// `tilt_tau_s` or more: off; ≤ 0 or NaN, like `tilt_tau_s`, 1/τ = 2000/s (the
    /// accelerometer's direction taken at once). The test runs only with bias
    /// estimation on (`bias.enabled`).
    ///
    /// At rest there is no acceleration for the long `tilt_tau_s` to reject: the
    /// accelerometer's direction is the vertical, up to its noise (the MPU-9250's
    /// 300 µg/√Hz is 0.02° through this loop at 0.25 s) and a hand's tremor (8–12 Hz,
    /// attenuated 250× by it). A tilt error the gyro left (a scale error over a fast
    /// turn about a tilted axis: 3 % of 720° is 21.6°) is then gone within a second of
    /// the rest test holding instead of 70 % of it still there after 3 s, and with it
    /// the compass error it makes (tan(dip) per degree, which the norm/dip check cannot
    /// see). Never in flight or for a multirotor: a hovering craft passes the rest test
    /// while its accelerometer reads the thrust axis, not the vertical.
    pub rest_tilt_tau_s: f32,
    /// Rotor drag of a multirotor per unit mass (1/s; N per m/s of body velocity per
    /// kg); 0 (the default) for a body that is not a multirotor.
    ///
    /// A multirotor's accelerometer measures thrust, along the rotors' axis (body z), and
    /// rotor drag, in the rotor plane and proportional to the body's velocity through
    /// the air there: f_xy = −μ·v_xy (Martin & Salaün 2010; Leishman et al. 2014). While
    /// the craft accelerates sideways the specific force in the estimate's earth frame
    /// carries that acceleration, and the tilt correction's low-pass lets part of it
    /// through as a false tilt towards level. With μ > 0 the full filter takes the
    /// body-plane specific force as a measurement of the velocity, v_xy = −f_xy/μ,
    /// rotates it into the earth frame and subtracts its rate of change, low-passed by
    /// the same two stages, from the low-passed specific force: what remains is gravity,
    /// also while accelerating. Only the rate of change enters, so a steady wind (a
    /// constant offset between air and ground velocity) does not matter; a μ that is
    /// wrong by a fraction leaves that fraction of today's error. The filter takes the
    /// accelerometer's z axis as the rotors' axis (body FRD).
    pub rotor_drag_per_s: f32,
    /// Form drag of the multirotor's frame per unit mass (1/m: N per (m/s)² per kg,
    /// ½·ρ·C_d·A/m), per body axis in the rotor plane, on top of the rotor drag: the
    /// body-plane specific force is −(μ·v + κ·v·|v|) per axis, which the multirotor mode
    /// inverts for v. 0 (the default): rotor drag only. Unused without
    /// [`Config::rotor_drag_per_s`].
    pub form_drag_per_m: f32,
    /// Time constant (s) of the magnetometer's (heading only) correction of the full
    /// filter: the estimate turns about the earth vertical towards the field's heading at
    /// tan(error)/τ (first order within ±45°, 1/τ rad/s beyond), never past it.
    ///
    /// The correction only has to hold the gyro's residual bias about the vertical: a
    /// bias b leaves a heading error b·τ. The rest estimate leaves 0.004 °/s of the
    /// MPU-9250's 0.01 °/s/√Hz noise (3 s average) and MEMS bias instability is of the
    /// same order, ~0.005 °/s: τ = 40 s keeps that error at 0.2° (a tenth of the error
    /// budget), while the field's local, position- and attitude-dependent errors
    /// indoors (degrees, changing within seconds as the body moves) are averaged over
    /// 40 s instead of followed.
    pub heading_tau_s: f32,
    /// Start-up gain (rad/s): the full filter's heading turns towards the field at a
    /// constant 2·β that ramps linearly from this to 0 over [`Config::startup_s`]
    /// (added to the first-order correction). Rejection features are off during the ramp.
    pub startup_beta: f32,
    /// Duration of the start-up ramp (s). 0 disables it.
    pub startup_s: f32,
    /// Norm of the accelerometer at rest (1 g) in the units the accelerometer is fed in
    /// (9.80665 for m/s², 1.0 for g, 16384 for MPU-9250 counts at ±2 g).
    pub gravity_norm: f32,
    /// Gyro sensitivity (scale-factor) tolerance, as a fraction (MPU-9250 datasheet:
    /// ±3 % at 25 °C); 0 disables the heading gain schedule below.
    ///
    /// A scale error s makes a rotation at rate ω look like (1 + s)·ω. What accumulates
    /// into attitude error is the *net* rotation: back-and-forth motion cancels, a
    /// sustained turn does not (a yaw spin at 90 °/s drifts 2.7 °/s at 3 %), and the
    /// slow heading correction ([`Config::heading_tau_s`]) cannot follow it. Madgwick's β is the
    /// quaternion rate of the gyro error (half its angular rate), so the filter adds a
    /// heading correction about the earth vertical with
    /// β_head = ½·`gyro_scale_tol`·|ω̄_D|, ω̄_D the mean rate about the vertical
    /// (first-order low-pass of the NED z rate, time constant [`Config::gyro_scale_tau_s`]).
    /// It turns the estimate towards the magnetometer's heading (only when the
    /// magnetometer is used), at the full rate beyond ~3° of heading error and
    /// proportionally below (so magnetometer noise is not chased). Tilt is left to the
    /// accelerometer's β: raising β with the rate made fast manoeuvres with large linear
    /// accelerations worse (see the crate README).
    pub gyro_scale_tol: f32,
    /// Time constant (s) of the mean rate about the vertical behind the scale-factor
    /// heading correction. Turns that reverse within about this time average out and
    /// leave the gain alone; after a sustained turn starts, the heading error it builds
    /// before the gain catches up is at most about `gyro_scale_tol` × (the angle turned in
    /// this time): 5.4° for 90 °/s at 3 % with 2 s.
    pub gyro_scale_tau_s: f32,
    /// Gyroscope bias estimation at rest.
    pub bias: BiasConfig,
    /// Accelerometer rejection during strong dynamics.
    pub accel_rejection: AccelRejectionConfig,
    /// Magnetic disturbance rejection.
    pub mag_rejection: MagRejectionConfig,
}

/// The filter variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Algorithm {
    /// Madgwick's 2010 report exactly (IMU and MARG): the gradient of the accelerometer
    /// and magnetometer objective functions normalised jointly, the b = (bx, 0, bz)
    /// reference derived from the measured field, one fixed β, the raw gyro. No bias
    /// estimation, rejection, start-up ramp or step limit. For comparison: every
    /// extension of the full filter is measured against this.
    Textbook,
    /// Inclination from the accelerometer low-passed in the earth frame, heading from
    /// the magnetometer only, gyro bias estimation, disturbance rejection (see
    /// [`Config`]).
    Full,
}

/// Gyroscope bias estimation while the sensor is at rest.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BiasConfig {
    /// Switch.
    pub enabled: bool,
    /// Rest when |ω − bias| is below this (rad/s) ...
    pub rest_gyro_rps: f32,
    /// ... and |‖a‖ − g| is below this fraction of g ...
    pub rest_accel_tol: f32,
    /// ... for at least this long (s).
    pub rest_time_s: f32,
    /// Time constant of the bias average while at rest (s).
    pub tau_s: f32,
    /// Bias estimate is clamped to ± this (rad/s).
    pub max_rps: f32,
}

/// Accelerometer rejection: skip the accelerometer correction when the measured
/// specific force is not gravity.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelRejectionConfig {
    /// Switch.
    pub enabled: bool,
    /// Reject when |‖a‖ − g| exceeds this fraction of g.
    pub norm_tol: f32,
    /// Reject when the angle between measured and estimated gravity exceeds this (deg).
    pub angle_deg: f32,
    /// After this long rejected without a break (s), accept the accelerometer again
    /// until it agrees with the estimate (recovery, so it cannot lock out forever).
    pub recovery_s: f32,
}

/// Magnetic disturbance rejection: the field strength and dip angle must match the
/// reference learned at initialisation (or from a stable new field).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagRejectionConfig {
    /// Switch.
    pub enabled: bool,
    /// Reject when ‖m‖ differs from the reference by more than this fraction.
    pub norm_tol: f32,
    /// Reject when the dip (inclination) differs from the reference by more than this (deg).
    pub dip_tol_deg: f32,
    /// Recovery: a field whose strength and dip stay consistent (within the tolerances)
    /// for this long while the sensor rotates becomes the new reference (s).
    pub recovery_s: f32,
    /// Recovery time only accumulates while |ω| exceeds this (rad/s), so a constant
    /// disturbance while standing still is not learnt.
    pub recovery_min_rate_rps: f32,
    /// Fallback for a disturbance that persists without becoming consistent (a magnet
    /// riding along, a new place): after this long rejected without a break (s), the
    /// current field is adopted as the reference (`UpdateStatus::mag_reference_relearned`).
    /// Heading runs on the gyro meanwhile, drifting with its residual bias (~0.005 °/s:
    /// 60 s ≈ 0.3°).
    pub fallback_s: f32,
    /// Time constant (s) with which the reference (field strength and dip) follows the
    /// field while it is accepted and the body turns faster than
    /// `recovery_min_rate_rps`; 0 (the default) freezes it after start-up. The earth
    /// field is the same at every attitude and place nearby, a local disturbance is
    /// not, so a reference averaged over motion converges on the earth's part, and a
    /// disturbance met at rest is never learnt. Off by default: indoors it makes the
    /// tolerance band follow the room's mean field and accept more of its local
    /// distortions (on the BROAD dev trials with 20 s, 5.5 % of the samples are
    /// rejected instead of 9.4 % and the mean heading error grows by 0.09°; see the
    /// crate README). The fixed-point filter follows only with the crate's
    /// `mag-ref-follow` feature (default on); without it its reference stays frozen
    /// whatever this says (the firmware leaves it out: 0.5 KiB of flash).
    pub ref_tau_s: f32,
}

/// What the magnetic disturbance handling did with this update's field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MagState {
    /// No magnetometer sample this update (IMU update), or the textbook filter, which
    /// uses every valid field unchecked.
    Absent,
    /// The sample was zero or not finite.
    Invalid,
    /// Accepted (norm and dip match the reference, or start-up, or rejection off); the
    /// reference is unchanged (the body is not moving enough to refine it).
    Undisturbed,
    /// Accepted while moving: the reference was refined towards the field
    /// ([`MagRejectionConfig::ref_tau_s`]).
    Learning,
    /// Rejected: norm or dip off the reference, heading on the gyro.
    Rejected,
    /// A new field, consistent for [`MagRejectionConfig::recovery_s`] of rotation, was
    /// adopted as the reference and used.
    Recovered,
    /// Rejected for [`MagRejectionConfig::fallback_s`] without a break: the current
    /// field was adopted as the reference and used.
    Fallback,
}

impl MagState {
    /// How many states there are.
    pub const COUNT: usize = 7;

    /// Position in declaration order (`Absent` 0 … `Fallback` 6), for
    /// tallying states in an array.
    ///
    /// ```
    /// use fc_ahrs::MagState;
    /// assert_eq!(MagState::Absent.index(), 0);
    /// assert_eq!(MagState::Fallback.index(), MagState::COUNT - 1);
    /// ```
    pub const fn index(self) -> usize {
        self as usize
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Config {
    /// [`Config::DEFAULT`] for a multirotor whose rotor drag and form drag per unit
    /// mass are `rotor_drag_per_s` (1/s, see [`Config::rotor_drag_per_s`]) and
    /// `form_drag_per_m` (1/m, [`Config::form_drag_per_m`]).
    ///
    /// ```
    /// let c = fc_ahrs::Config::multirotor(0.17, 0.01);
    /// assert_eq!(c.rotor_drag_per_s, 0.17);
    /// assert_eq!(c.tilt_tau_s, fc_ahrs::Config::DEFAULT.tilt_tau_s);
    /// ```
    #[must_use]
    pub const fn multirotor(rotor_drag_per_s: f32, form_drag_per_m: f32) -> Config {
        Config {
            rotor_drag_per_s,
            form_drag_per_m,
            ..Config::DEFAULT
        }
    }

    /// Defaults, chosen from sensor physics (see the crate README for the rationale
    /// and the BROAD results).
    pub const DEFAULT: Config = Config {
        algorithm: Algorithm::Full,
        beta: 0.02,
        tilt_tau_s: 3.0,
        rest_tilt_tau_s: 0.25,
        rotor_drag_per_s: 0.0,
        form_drag_per_m: 0.0,
        heading_tau_s: 40.0,
        startup_beta: 2.5,
        startup_s: 3.0,
        gravity_norm: 9.80665,
        gyro_scale_tol: 0.03,
        gyro_scale_tau_s: 2.0,
        bias: BiasConfig {
            enabled: true,
            rest_gyro_rps: 0.035,
            rest_accel_tol: 0.05,
            rest_time_s: 1.5,
            tau_s: 3.0,
            max_rps: 0.1,
        },
        accel_rejection: AccelRejectionConfig {
            enabled: false,
            norm_tol: 0.2,
            angle_deg: 15.0,
            recovery_s: 5.0,
        },
        mag_rejection: MagRejectionConfig {
            enabled: true,
            norm_tol: 0.1,
            dip_tol_deg: 10.0,
            recovery_s: 20.0,
            recovery_min_rate_rps: 0.35,
            fallback_s: 60.0,
            ref_tau_s: 0.0,
        },
    };
}

/// Which corrections an update applied (the fallback chain).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum UpdatePath {
    /// Gyro + accelerometer + magnetometer corrections.
    Marg,
    /// Gyro + accelerometer (magnetometer absent, invalid or rejected).
    Imu,
    /// Gyro + magnetometer heading correction (accelerometer rejected or invalid).
    MagOnly,
    /// Gyro integration only.
    GyroOnly,
    /// Nothing: gyro or dt invalid (or the result was not finite); state untouched.
    Skipped,
}

/// What an update did and why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct UpdateStatus {
    /// Corrections applied.
    pub path: UpdatePath,
    /// Gyro or dt not finite / out of range.
    pub gyro_invalid: bool,
    /// The gyro step was limited. The full filter splits a step whose rotation is too
    /// large for one first-order step into up to 1024 sub-steps (half angles ≤ 1/32 rad
    /// each), so this only happens past 512 rad in one step (½ω·dt beyond ¼ rad per
    /// sub-step, clamped; the textbook filter, which does not sub-step, clamps every
    /// step's ½ω·dt at ¼ rad): part of that rotation is lost and the accelerometer and
    /// magnetometer corrections bring the estimate back.
    pub gyro_step_clamped: bool,
    /// Accelerometer zero or not finite.
    pub accel_invalid: bool,
    /// Magnetometer zero or not finite (only for MARG updates).
    pub mag_invalid: bool,
    /// Accelerometer rejected (strong dynamics).
    pub accel_rejected: bool,
    /// Accelerometer accepted only because the recovery timeout ran out.
    pub accel_recovering: bool,
    /// Magnetometer rejected (disturbed field).
    pub mag_rejected: bool,
    /// A new magnetic reference was adopted this update (recovery or fallback).
    pub mag_reference_relearned: bool,
    /// The magnetic disturbance handling's state this update.
    pub mag_state: MagState,
    /// Rest detected; the gyro bias estimate is being updated.
    pub at_rest: bool,
    /// Still in the start-up (high-gain) phase.
    pub initialising: bool,
}

impl UpdateStatus {
    pub(crate) const fn new() -> Self {
        Self {
            path: UpdatePath::Skipped,
            gyro_invalid: false,
            gyro_step_clamped: false,
            accel_invalid: false,
            mag_invalid: false,
            accel_rejected: false,
            accel_recovering: false,
            mag_rejected: false,
            mag_reference_relearned: false,
            mag_state: MagState::Absent,
            at_rest: false,
            initialising: false,
        }
    }
}
