//! The attitude filter in f32. [`Algorithm::Full`]: gyro integration, inclination from
//! the specific force low-passed in the earth frame, heading-only magnetometer correction,
//! gyro bias estimation at rest, accelerometer and magnetic disturbance rejection, each a
//! named step of `update_inner` (the same steps as the fixed-point filter's).
//! [`Algorithm::Textbook`]: Madgwick's gradient-descent filter as published.
//!
//! Equation numbers refer to S. O. H. Madgwick, "An efficient orientation filter for
//! inertial and inertial/magnetic sensor arrays", internal report, Univ. of Bristol, 2010.
//! The paper's q1..q4 are our w, x, y, z; its sensor frame is our body frame and its
//! earth frame is NED, so `q` here is `q_ned_from_body` (body vectors into NED).
//!
//! NED specifics: at rest the accelerometer measures the specific force pointing up,
//! (0, 0, −g) in NED. The paper's gravity reference is (0, 0, 1), so the filter feeds
//! it the direction of −a (gravity "down" as seen in the body frame). The magnetic
//! reference is b = (bx, 0, bz) with bz > 0 in the northern hemisphere.

// fixed.rs repeats these steps and checks under the same names, on purpose (see there).

use crate::config::{Algorithm, Config, MagState, UpdatePath, UpdateStatus};
use crate::quat::mat_vec;
use crate::Quaternion;

/// Standard gravity (m/s²), used by the linear-acceleration helpers.
pub const STANDARD_GRAVITY_MPS2: f32 = 9.80665;

/// Longest accepted time step (s); longer (or non-positive) steps are rejected.
pub const MAX_DT_S: f32 = 1.0;

/// Bound on the earth-frame rate entering the mean used by the heading gain schedule
/// (rad/s; the MPU-9250's largest full scale is 2000 °/s ≈ 35 rad/s).
pub(crate) const MAX_MEAN_RATE_RPS: f32 = 64.0;

/// Heading error (rad, as sin) beyond which the scale-factor heading correction runs at
/// its full rate; below it the correction is proportional (so magnetometer noise of a
/// degree or two is not chased at full rate).
pub(crate) const HEADING_LINEAR_ZONE: f32 = 0.05;
/// 1 / [`HEADING_LINEAR_ZONE`], for the fixed-point filter.
pub(crate) const HEADING_LINEAR_GAIN: i32 = 20;

/// Time constant (s) of each tilt low-pass stage at the start of the start-up phase.
pub(crate) const STARTUP_TILT_TAU_S: f32 = 0.2;

/// Largest inclination correction per update (rad): the correction is a first-order
/// rotation, exact enough for the small steps of normal operation; a start from far off
/// converges over several updates instead of one inexact jump.
pub(crate) const MAX_TILT_STEP_RAD: f32 = 0.05;

/// Cut-off (Hz) of the first-order low-pass on the rotor-plane specific force before
/// the drag model differentiates it. A velocity through the air changes over
/// seconds; a multirotor's accelerometer also carries the rotors' vibration
/// (100–400 Hz and its aliases), which the derivative would multiply by 1/(μ·τ)
/// and the correction's rotation of the tilt states would rectify. 5 Hz delays the
/// drag's velocity by 32 ms, nothing next to the tilt stages' τ.
pub(crate) const DRAG_INPUT_CUTOFF_HZ: f32 = 5.0;

/// Smallest rotor drag per unit mass the multirotor mode takes (1/s): a smaller
/// [`Config::rotor_drag_per_s`] is raised to it (1/μ then fits the fixed filter's
/// Q16, and the velocity it implies stays bounded).
pub(crate) const MIN_ROTOR_DRAG_PER_S: f32 = 0.01;
/// Largest β = κ·g/μ² the drag model takes (1/g; the 250-class quad's is 3.5), so
/// 1 + β·|p| fits the fixed filter's 32-bit Q16; a β below [`MIN_DRAG_BETA`] is 0.
pub(crate) const MAX_DRAG_BETA: f32 = 64.0;
/// Smallest β the drag model keeps (below it the quadratic term is < 0.1 % at 1 g).
pub(crate) const MIN_DRAG_BETA: f32 = 1.0e-3;
/// Body-plane specific force the drag model inverts at most (g): larger readings
/// (a crash, a hand slap) are clamped, as no flight reaches them on drag alone.
pub(crate) const MAX_DRAG_G: f32 = 4.0;

/// The multirotor mode's drag law, per body axis in the rotor plane: the specific
/// force (g) is x = p + β·p·|p| with p = −μ·v/g the rotor (linear) part and
/// β = κ·g/μ² the form drag's share ([`Config::rotor_drag_per_s`] μ,
/// [`Config::form_drag_per_m`] κ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct DragModel {
    /// μ (1/s).
    pub(crate) mu: f32,
    /// β (1/g); 0: rotor drag only.
    pub(crate) beta: f32,
}

impl DragModel {
    /// p of a body-plane specific force x (g), x clamped to ±[`MAX_DRAG_G`], given
    /// the previous sample's p: one step of the fixed-point iteration
    /// p ← x/(1 + β·|p|) of x = p + β·p·|p|. Its slope is β|p|/(1 + β|p|) < 1, so it
    /// converges (to within 1 % in 4 samples at β|p| = 0.3), and at 1 kHz the
    /// previous sample is a close start: one division instead of a square root.
    pub(crate) fn linear_part(&self, x: f32, p_prev: f32) -> f32 {
        let x = x.clamp(-MAX_DRAG_G, MAX_DRAG_G);
        x / (1.0 + self.beta * p_prev.abs())
    }

    /// h = −μ·v/g in the estimate's NED frame, horizontal part: R·(p_x, p_y, 0) of the
    /// accelerometer's body-plane axes (`a_g` in g); `p` the body-plane linear parts,
    /// updated.
    pub(crate) fn velocity_ned(
        &self,
        rot: &[[f32; 3]; 3],
        a_g: [f32; 2],
        p: &mut [f32; 2],
    ) -> [f32; 2] {
        let px = self.linear_part(a_g[0], p[0]);
        let py = self.linear_part(a_g[1], p[1]);
        *p = [px, py];
        [
            rot[0][0] * px + rot[0][1] * py,
            rot[1][0] * px + rot[1][1] * py,
        ]
    }
}

/// The multirotor mode's drag law, `None` if the mode is off
/// ([`Config::rotor_drag_per_s`] 0, negative or not finite).
pub(crate) fn drag_model(cfg: &Config) -> Option<DragModel> {
    let mu = cfg.rotor_drag_per_s;
    if cfg!(feature = "no-multirotor") || !(mu > 0.0 && mu.is_finite()) {
        return None;
    }
    let mu = mu.max(MIN_ROTOR_DRAG_PER_S);
    let kappa = cfg.form_drag_per_m;
    let beta = if kappa.is_finite() {
        (kappa * STANDARD_GRAVITY_MPS2 / (mu * mu)).min(MAX_DRAG_BETA)
    } else {
        0.0
    };
    Some(DragModel {
        mu,
        beta: if beta < MIN_DRAG_BETA { 0.0 } else { beta },
    })
}

/// A magnetic field reference: ‖m‖² in input units, the sine of the dip (hz of the unit
/// field in NED) and the tolerance on it for the configured dip tolerance.
#[derive(Debug, Clone, Copy, PartialEq)]
struct MagReference {
    norm_sq: f32,
    hz: f32,
    hz_tol: f32,
}

impl MagReference {
    fn new(norm_sq: f32, hz: f32, sin_dip_tol: f32) -> Self {
        // |Δ sin(dip)| ≈ cos(dip)·Δdip
        let c = libm::sqrtf((1.0 - hz * hz).max(0.0));
        Self {
            norm_sq,
            hz,
            hz_tol: sin_dip_tol * c.max(0.05),
        }
    }
}

/// The attitude filter in f32. See the crate docs for an example.
#[derive(Debug, Clone)]
pub struct Madgwick {
    cfg: Config,
    q: Quaternion,
    bias_rps: [f32; 3],
    time_s: f32,
    rest_time_s: f32,
    accel_reject_s: f32,
    accel_forced: bool,
    /// The earth field's reference (`None` before any valid magnetometer sample).
    mag_ref: Option<MagReference>,
    /// A different field seen while the reference is rejected, and how long it has
    /// stayed consistent while rotating (s).
    mag_cand: Option<MagReference>,
    mag_cand_s: f32,
    /// Time rejected without a break (s), for the fallback.
    mag_reject_s: f32,
    rate_lp_down_rps: f32,
    /// Two first-order low-pass stages of the specific force (in g) in the estimate's
    /// NED frame.
    acc_lp: [[f32; 3]; 2],
    /// The rotor-plane specific force in NED through the drag model's input low-pass
    /// ([`DRAG_INPUT_CUTOFF_HZ`], g).
    drag_lp: [f32; 2],
    /// The drag law's linear part of the previous sample, body x and y (g).
    drag_p: [f32; 2],
    /// In flight: the multirotor mode's drag model applies ([`Madgwick::set_in_flight`]).
    in_flight: bool,
    /// The tilt loop's hand-held form (ζ = ¾, the rest correction): neither in flight
    /// nor configured for a multirotor ([`Madgwick::set_in_flight`]).
    hand_held_tilt: bool,
    /// Samples the tilt correction skipped since the drag model last ran.
    drag_skipped: u32,
    /// The last heading correction (rad), for the drag model's states.
    drag_tz: f32,
    acc_lp_valid: bool,
    // constants derived from cfg
    cos_accel_angle: f32,
    sin_dip_tol: f32,
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn dot4(a: [f32; 4], b: [f32; 4]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

fn sub3(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Normalise a 3-vector; `None` for zero, tiny or non-finite input. Also returns ‖v‖².
fn unit3(v: [f32; 3]) -> Option<([f32; 3], f32)> {
    if !finite3(v) {
        return None;
    }
    let n2 = dot(v, v);
    if n2 <= 1e-30 || !n2.is_finite() {
        return None;
    }
    let r = 1.0 / libm::sqrtf(n2);
    let u = [v[0] * r, v[1] * r, v[2] * r];
    if finite3(u) {
        Some((u, n2))
    } else {
        None
    }
}

/// Gravity ("down") direction in the body frame for `q_ned_from_body`: R(q)ᵀ·(0,0,1).
pub(crate) fn down_body(q: &Quaternion) -> [f32; 3] {
    let Quaternion { w, x, y, z } = *q;
    [
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        w * w - x * x - y * y + z * z,
    ]
}

impl Madgwick {
    /// New filter at the identity orientation (body aligned with NED).
    ///
    /// ```
    /// use fc_ahrs::{Config, Madgwick};
    /// let mut f = Madgwick::new(Config::default());
    /// // Level, at rest, nose north: FRD accel (0,0,−g), field (bx, 0, bz).
    /// let st = f.update_marg([0.0; 3], [0.0, 0.0, -9.81], [20.0, 0.0, 45.0], 0.001);
    /// assert_eq!(st.path, fc_ahrs::UpdatePath::Marg);
    /// assert!((f.quaternion().norm() - 1.0).abs() < 1e-6);
    /// ```
    #[must_use]
    pub fn new(cfg: Config) -> Self {
        Self {
            cfg,
            q: Quaternion::IDENTITY,
            bias_rps: [0.0; 3],
            time_s: 0.0,
            rest_time_s: 0.0,
            accel_reject_s: 0.0,
            accel_forced: false,
            mag_ref: None,
            mag_cand: None,
            mag_cand_s: 0.0,
            mag_reject_s: 0.0,
            rate_lp_down_rps: 0.0,
            acc_lp: [[0.0; 3]; 2],
            drag_lp: [0.0; 2],
            drag_p: [0.0; 2],
            in_flight: false,
            hand_held_tilt: drag_model(&cfg).is_none(),
            drag_skipped: 0,
            drag_tz: 0.0,
            acc_lp_valid: false,
            cos_accel_angle: crate::quat::cos_deg(cfg.accel_rejection.angle_deg),
            sin_dip_tol: crate::quat::sin_deg(cfg.mag_rejection.dip_tol_deg),
        }
    }

    /// New filter initialised from one accelerometer and magnetometer sample (body frame,
    /// any consistent units). Falls back to roll/pitch only (yaw 0) if the field is
    /// unusable, and to the identity if the accelerometer is.
    ///
    /// ```
    /// use fc_ahrs::{Config, Madgwick};
    /// // Level, nose east: the field appears to come from the left (−y body).
    /// let f = Madgwick::from_accel_mag(Config::default(), [0.0, 0.0, -9.81], [0.0, -20.0, 45.0]);
    /// let [_, _, yaw] = f.euler_rad();
    /// assert!((yaw - core::f32::consts::FRAC_PI_2).abs() < 1e-4);
    /// ```
    #[must_use]
    pub fn from_accel_mag(cfg: Config, accel: [f32; 3], mag: [f32; 3]) -> Self {
        let mut f = Self::new(cfg);
        f.init_from_accel_mag(accel, mag);
        f
    }

    /// Reset the orientation from an accelerometer and magnetometer sample (see
    /// [`Madgwick::from_accel_mag`]); also learns the magnetic reference (strength, dip).
    /// Returns false (orientation unchanged) if the accelerometer is zero or not finite.
    pub fn init_from_accel_mag(&mut self, accel: [f32; 3], mag: [f32; 3]) -> bool {
        let Some((a, _)) = unit3(accel) else {
            return false;
        };
        let d = [-a[0], -a[1], -a[2]]; // down, in body
        let m = unit3(mag);
        // east = down × m, north = east × down (rows of R = NED axes in body).
        let east = m.and_then(|(m, _)| unit3(cross(d, m)));
        let (north, east) = match east {
            Some((e, _)) => (cross(e, d), e),
            None => {
                // No heading information: keep yaw 0, pick north ⟂ down.
                let helper = if d[0].abs() < 0.9 {
                    [1.0, 0.0, 0.0]
                } else {
                    [0.0, 1.0, 0.0]
                };
                let e = unit3(cross(d, helper)).map_or([0.0, 1.0, 0.0], |(e, _)| e);
                (cross(e, d), e)
            }
        };
        let rot = [north, east, d];
        let q = Quaternion::from_matrix(&rot);
        if !q.is_finite() {
            return false;
        }
        self.q = q;
        self.acc_lp_valid = false;
        self.mag_ref = None;
        if let Some((mu, n2)) = m {
            self.set_mag_reference(n2, dot(mu, d));
        }
        true
    }

    fn set_mag_reference(&mut self, norm_sq: f32, hz: f32) {
        self.mag_ref = Some(MagReference::new(norm_sq, hz, self.sin_dip_tol));
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Orientation `q_ned_from_body` (rotates body vectors into NED).
    #[must_use]
    pub fn quaternion(&self) -> Quaternion {
        self.q
    }

    /// Whether the body is flying (false at construction). The multirotor mode's drag
    /// model applies only then: on the ground the accelerometer's body-plane reading
    /// is the ground's reaction to gravity on a slope, not drag, and a lift-off would
    /// read as a sudden change of velocity (sin θ/(μ·τ·e) rad of false tilt from a
    /// slope θ: 3.7° from 5° for the 250-class quad). And the tilt loop's hand-held
    /// form (ζ = ¾ and the rest correction, [`Config::rest_tilt_tau_s`]) applies only
    /// when not: a hovering craft passes the rest test while its accelerometer reads
    /// the thrust axis. (With the multirotor mode configured the loop never takes the
    /// hand-held form: the flight controller's verdict comes after lift-off and ends
    /// before touch-down.) The flight controller knows: set it once the craft is in
    /// the air.
    pub fn set_in_flight(&mut self, in_flight: bool) {
        self.in_flight = in_flight;
        self.hand_held_tilt = !in_flight && drag_model(&self.cfg).is_none();
    }

    /// Set the orientation (normalised; ignored if zero or not finite).
    pub fn set_quaternion(&mut self, q: Quaternion) {
        if let Some(q) = q.normalized() {
            self.q = q;
            self.acc_lp_valid = false;
        }
    }

    /// Current gyro bias estimate (rad/s, body frame).
    #[must_use]
    pub fn gyro_bias_rps(&self) -> [f32; 3] {
        self.bias_rps
    }

    /// Learned magnetic reference: (‖m‖ in input units, dip angle in rad, positive down),
    /// or `None` before any valid magnetometer sample.
    #[must_use]
    pub fn mag_reference(&self) -> Option<(f32, f32)> {
        self.mag_ref
            .map(|r| (libm::sqrtf(r.norm_sq), libm::asinf(r.hz.clamp(-1.0, 1.0))))
    }

    /// Euler angles (roll, pitch, yaw) in radians, ZYX, of `q_ned_from_body`.
    #[must_use]
    pub fn euler_rad(&self) -> [f32; 3] {
        self.q.to_euler_rad()
    }

    /// Unit gravity direction ("down") in the body frame.
    #[must_use]
    pub fn gravity_body(&self) -> [f32; 3] {
        down_body(&self.q)
    }

    /// Earth-frame (NED) linear acceleration (m/s²) from the body specific force (m/s²):
    /// `a_ned = R·f + (0, 0, g)`.
    #[must_use]
    pub fn linear_accel_ned_mps2(&self, accel_body_mps2: [f32; 3]) -> [f32; 3] {
        let a = self.q.rotate(accel_body_mps2);
        [a[0], a[1], a[2] + STANDARD_GRAVITY_MPS2]
    }

    /// Vertical linear acceleration, up positive (m/s²): `−a_ned.z`.
    #[must_use]
    pub fn vertical_accel_up_mps2(&self, accel_body_mps2: [f32; 3]) -> f32 {
        -self.linear_accel_ned_mps2(accel_body_mps2)[2]
    }

    /// IMU update (gyro + accelerometer). `gyro_rps` body rates (rad/s), `accel` body
    /// specific force in the units of [`Config::gravity_norm`], `dt_s` step (s).
    pub fn update_imu(&mut self, gyro_rps: [f32; 3], accel: [f32; 3], dt_s: f32) -> UpdateStatus {
        self.update_inner(gyro_rps, accel, None, dt_s)
    }

    /// MARG update (gyro + accelerometer + magnetometer, any unit; normalised inside).
    /// Falls back to IMU / gyro-only when inputs are missing or rejected; see the status.
    pub fn update_marg(
        &mut self,
        gyro_rps: [f32; 3],
        accel: [f32; 3],
        mag: [f32; 3],
        dt_s: f32,
    ) -> UpdateStatus {
        self.update_inner(gyro_rps, accel, Some(mag), dt_s)
    }

    fn update_inner(
        &mut self,
        gyro_rps: [f32; 3],
        accel: [f32; 3],
        mag: Option<[f32; 3]>,
        dt_s: f32,
    ) -> UpdateStatus {
        let mut st = UpdateStatus::new();
        if !finite3(gyro_rps) || !dt_s.is_finite() || dt_s <= 0.0 || dt_s > MAX_DT_S {
            st.gyro_invalid = true;
            return st;
        }
        if self.cfg.algorithm == Algorithm::Textbook {
            return self.update_textbook(gyro_rps, accel, mag, dt_s);
        }
        let initialising = self.time_s < self.cfg.startup_s;
        st.initialising = initialising;
        let acc = unit3(accel);
        st.accel_invalid = acc.is_none();

        let w = self.estimate_bias(gyro_rps, acc.map(|(_, n2)| n2), dt_s, &mut st);
        // Gyro step, renormalised only after the corrections (as the fixed filter): the
        // rows of R carry ‖q‖² ≤ 1 + 3/16 as a common scale the corrections do not see.
        // A step whose rotation is too large for one first-order step is split into
        // equal sub-steps (as the fixed filter), renormalised between them.
        let (n, dt_sub) = substeps(w, dt_s);
        let mut q0 = self.q;
        for _ in 1..n {
            let (step, clamped) = half_angle_step(w, dt_sub);
            st.gyro_step_clamped |= clamped;
            q0 = q0.mul(&step).normalized().unwrap_or(q0);
        }
        let (step, clamped) = half_angle_step(w, dt_sub);
        st.gyro_step_clamped |= clamped;
        let q = q0.mul(&step);
        let rot = q.to_matrix(); // rows: NED axes in body coordinates (× ‖q‖²)
        self.track_vertical_rate(rot[2], w, dt_s);
        let tilt = self.correct_tilt(&rot, accel, acc, dt_s, initialising, &mut st);
        let heading = match mag {
            Some(m) => self.correct_heading(&rot, m, dot(w, w), dt_s, initialising, &mut st),
            None => None,
        };
        st.path = match (tilt.is_some(), heading.is_some()) {
            (true, true) => UpdatePath::Marg,
            (true, false) => UpdatePath::Imu,
            (false, true) => UpdatePath::MagOnly,
            (false, false) => UpdatePath::GyroOnly,
        };
        let [tx, ty] = tilt.unwrap_or([0.0; 2]);
        if !self.fuse(q, [tx, ty, heading.unwrap_or(0.0)]) {
            st.path = UpdatePath::Skipped;
            return st;
        }
        self.time_s = (self.time_s + dt_s).min(1e9);
        st
    }

    /// Gyro bias estimation at rest; returns the bias-corrected rate (rad/s).
    fn estimate_bias(
        &mut self,
        gyro_rps: [f32; 3],
        accel_norm_sq: Option<f32>,
        dt_s: f32,
        st: &mut UpdateStatus,
    ) -> [f32; 3] {
        let cfg = self.cfg.bias;
        if !cfg.enabled {
            return gyro_rps;
        }
        let w = sub3(gyro_rps, self.bias_rps);
        let g2 = self.cfg.gravity_norm * self.cfg.gravity_norm;
        let tol = cfg.rest_accel_tol;
        let still = dot(w, w) < cfg.rest_gyro_rps * cfg.rest_gyro_rps
            && accel_norm_sq.is_some_and(|n2| {
                n2 > g2 * (1.0 - tol) * (1.0 - tol) && n2 < g2 * (1.0 + tol) * (1.0 + tol)
            });
        self.rest_time_s = if still {
            (self.rest_time_s + dt_s).min(1e6)
        } else {
            0.0
        };
        if self.rest_time_s >= cfg.rest_time_s {
            st.at_rest = true;
            let k = (dt_s / cfg.tau_s).clamp(0.0, 1.0);
            for (b, w) in self.bias_rps.iter_mut().zip(w) {
                *b = (*b + k * w).clamp(-cfg.max_rps, cfg.max_rps);
            }
        }
        sub3(gyro_rps, self.bias_rps)
    }

    /// Mean rate about the earth vertical (NED z = down·ω) for the scale-factor heading
    /// gain schedule (`Config::gyro_scale_tol`).
    fn track_vertical_rate(&mut self, down: [f32; 3], w: [f32; 3], dt_s: f32) {
        let cfg = self.cfg;
        if cfg.gyro_scale_tol > 0.0 {
            let w_down = dot(down, w);
            if w_down.is_finite() {
                let k = (dt_s / cfg.gyro_scale_tau_s.max(dt_s)).clamp(0.0, 1.0);
                let x = w_down.clamp(-MAX_MEAN_RATE_RPS, MAX_MEAN_RATE_RPS);
                let lp = self.rate_lp_down_rps;
                self.rate_lp_down_rps =
                    (lp + k * (x - lp)).clamp(-MAX_MEAN_RATE_RPS, MAX_MEAN_RATE_RPS);
            }
        }
    }

    /// Accelerometer (inclination) correction: the specific force in the estimate's earth
    /// frame, low-passed there by two first-order stages (time constant
    /// [`Config::tilt_tau_s`] each); returns the earth-frame rotation (x, y in rad) that
    /// takes the low-passed vector onto the vertical, or `None` if the accelerometer is
    /// invalid or rejected.
    fn correct_tilt(
        &mut self,
        rot: &[[f32; 3]; 3],
        accel: [f32; 3],
        acc: Option<([f32; 3], f32)>,
        dt_s: f32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> Option<[f32; 2]> {
        // A skipped sample is not seen by the drag model either: the velocity change
        // across the gap then enters spread over the samples it spans (the first stage
        // took one step of the specific force for them, not one each).
        let Some((a, n2)) = acc else {
            self.drag_skipped = self.drag_skipped.saturating_add(1);
            return None;
        };
        if self.reject_accel(rot[2], a, n2, dt_s, initialising, st) {
            self.drag_skipped = self.drag_skipped.saturating_add(1);
            return None;
        }
        let cfg = self.cfg;
        let inv_g = 1.0 / cfg.gravity_norm;
        let u = mat_vec(rot, [accel[0] * inv_g, accel[1] * inv_g, accel[2] * inv_g]);
        if !finite3(u) {
            return None;
        }
        let first = !self.acc_lp_valid;
        if first {
            self.acc_lp = [u, u];
            self.acc_lp_valid = true;
        }
        let mut inv_tau = inv_tilt_tau(&cfg, self.time_s, initialising);
        // At rest, hand-held: `rest_tilt_tau_s` where that is faster.
        if st.at_rest && self.hand_held_tilt {
            inv_tau = inv_tau.max(inv_tau_of(cfg.rest_tilt_tau_s));
        }
        let k = (dt_s * inv_tau).clamp(0.0, 1.0);
        let [s1, s2] = &mut self.acc_lp;
        for i in 0..3 {
            s1[i] += k * (u[i] - s1[i]);
            s2[i] += k * (s1[i] - s2[i]);
        }
        let y = *s2;
        // θ = ŷ × (0, 0, −1): rotates y onto the vertical (up = −z in NED). y is nearly
        // vertical after every correction, so ŷ ≈ y/|y_z| (a mean specific force far from
        // 1 g must not turn into a loop gain above 1); |y_z| = 1 g if y points down.
        let n = if -y[2] > 1.0 / 1024.0 { -y[2] } else { 1.0 };
        let lim = MAX_TILT_STEP_RAD;
        let theta = [(-y[1] / n).clamp(-lim, lim), (y[0] / n).clamp(-lim, lim)];
        // Multirotor mode: −(the drag's acceleration) into the first stage, which the
        // second takes from the next sample on, so the stages low-pass the specific
        // force less the acceleration: gravity. Only in flight, and not during the
        // start-up ramp (the identity in `drag_rate` needs a constant τ); the state
        // follows the accelerometer regardless, so switching on adds no step.
        if let Some(d) = drag_model(&cfg) {
            let on = self.in_flight && !initialising;
            let inv_tau = if on { inv_tau } else { 0.0 };
            let span = 1.0 + self.drag_skipped as f32;
            self.drag_skipped = 0;
            let [d0, d1] = self.drag_rate(d, rot, accel, inv_g, first, inv_tau / span, dt_s);
            self.acc_lp[0][0] += d0;
            self.acc_lp[0][1] += d1;
        }
        Some(theta)
    }

    /// What the drag's acceleration takes from the first tilt stage this sample (g,
    /// NED, horizontal), with `inv_tau` = 1/τ of the stages (0: nothing) and `first`
    /// starting from this sample: the stage's step k·(x − s) with k = dt/τ applied to
    /// −a/g, and a/g = −(1/μ)·dh/dt for h = −μ·v/g ([`DragModel::velocity_ned`]), is
    /// k·(1/μ)·Δh/dt = Δh/(μ·τ). The second stage smooths the sample-to-sample
    /// difference; with the 5 Hz input low-pass ahead ([`DRAG_INPUT_CUTOFF_HZ`], gain
    /// k_in per sample) white accelerometer noise reaches the second stage's output as
    /// about √(k_in/2)·√(k/2)/(μ·τ) of it.
    #[allow(clippy::too_many_arguments)]
    fn drag_rate(
        &mut self,
        d: DragModel,
        rot: &[[f32; 3]; 3],
        accel: [f32; 3],
        inv_g: f32,
        first: bool,
        inv_tau: f32,
        dt_s: f32,
    ) -> [f32; 2] {
        let raw = d.velocity_ned(rot, [accel[0] * inv_g, accel[1] * inv_g], &mut self.drag_p);
        if first {
            self.drag_lp = raw;
        }
        // The last heading correction turns the low-pass's state with the frame (its
        // tilt part leaves a horizontal vector horizontal to first order).
        let tz = self.drag_tz;
        let [h0, h1] = self.drag_lp;
        let h = [h0 - tz * h1, h1 + tz * h0];
        // The input low-pass, k = dt·ω_c (forward Euler, as the fixed filter): its
        // step is this sample's Δh.
        let k = (dt_s * 2.0 * core::f32::consts::PI * DRAG_INPUT_CUTOFF_HZ).clamp(0.0, 1.0);
        let dh = [k * (raw[0] - h[0]), k * (raw[1] - h[1])];
        self.drag_lp = [h[0] + dh[0], h[1] + dh[1]];
        let c = inv_tau / d.mu;
        [c * dh[0], c * dh[1]]
    }

    /// Accelerometer rejection with its recovery timeout; true if the sample is rejected.
    fn reject_accel(
        &mut self,
        down: [f32; 3],
        a: [f32; 3],
        n2: f32,
        dt_s: f32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> bool {
        let ar = self.cfg.accel_rejection;
        if !ar.enabled || initialising {
            return false;
        }
        let g2 = self.cfg.gravity_norm * self.cfg.gravity_norm;
        let lo = (1.0 - ar.norm_tol) * (1.0 - ar.norm_tol) * g2;
        let hi = (1.0 + ar.norm_tol) * (1.0 + ar.norm_tol) * g2;
        let d = [-a[0], -a[1], -a[2]];
        let mut reject = n2 < lo || n2 > hi || dot(d, down) < self.cos_accel_angle;
        if reject {
            self.accel_reject_s = (self.accel_reject_s + dt_s).min(1e6);
            if self.accel_reject_s > ar.recovery_s {
                self.accel_forced = true;
            }
            if self.accel_forced {
                st.accel_recovering = true;
                reject = false;
            }
        } else {
            self.accel_reject_s = 0.0;
            self.accel_forced = false;
        }
        st.accel_rejected = reject;
        reject
    }

    /// Magnetometer (heading only) correction: the earth-frame rotation about the vertical
    /// (rad) towards the field's heading, or `None` if the field is invalid or disturbed.
    fn correct_heading(
        &mut self,
        rot: &[[f32; 3]; 3],
        mag: [f32; 3],
        w2: f32,
        dt_s: f32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> Option<f32> {
        let Some((m, n2)) = unit3(mag) else {
            st.mag_invalid = true;
            st.mag_state = MagState::Invalid;
            return None;
        };
        // The field in NED (eq. 45); hz = m·down.
        let h = mat_vec(rot, m);
        if !self.check_mag(n2, h[2], w2, dt_s, initialising, st) {
            return None;
        }
        // Heading error (> 0 when the estimate is east of the field) as tan = h_E/h_N:
        // `e` in units of HEADING_LINEAR_ZONE, `e_mag` in radians, each saturated to ±1
        // beyond its zone or with the field pointing south.
        let (e, e_mag) = if h[0] > 0.0 {
            let t = h[1] / h[0];
            (
                (t / HEADING_LINEAR_ZONE).clamp(-1.0, 1.0),
                t.clamp(-1.0, 1.0),
            )
        } else {
            (sign(h[1]), sign(h[1]))
        };
        let cfg = self.cfg;
        // Start-up: a constant rate 2β ramping from `startup_beta` to 0.
        let beta_start = if initialising && cfg.startup_s > 0.0 {
            cfg.startup_beta * (1.0 - self.time_s / cfg.startup_s).max(0.0)
        } else {
            0.0
        };
        let inv_tau = inv_heading_tau(cfg.heading_tau_s);
        // Scale-factor heading gain β_head = ½·tol·|ω̄_D| (`Config::gyro_scale_tol`).
        let beta_head = 0.5 * cfg.gyro_scale_tol.max(0.0) * self.rate_lp_down_rps.abs();
        // Earth rate 2β about the vertical (β is a quaternion rate), towards the field;
        // a step never passes the field's heading (a large gain·dt reaches it instead).
        // (|h_E| ≤ the sine of the error.)
        let lim = h[1].abs().min(0.5);
        // First order with τ = `heading_tau_s` (it holds the residual gyro bias), β_head
        // proportionally within HEADING_LINEAR_ZONE (it follows the turn rate).
        let rate = 2.0 * (beta_start * sign(h[1]) + beta_head * e) + inv_tau * e_mag;
        Some((-rate * dt_s).clamp(-lim, lim))
    }

    /// Apply the earth-frame correction θ (rad) to the propagated orientation,
    /// q ← (1, θ/2) ⊗ q, and rotate the low-passed accelerometer state with it so it
    /// stays in the (corrected) estimate's earth frame. False if the result is not finite.
    fn fuse(&mut self, q: Quaternion, theta: [f32; 3]) -> bool {
        let d = Quaternion::new(1.0, 0.5 * theta[0], 0.5 * theta[1], 0.5 * theta[2]);
        let Some(n) = d.mul(&q).normalized() else {
            return false;
        };
        self.q = n;
        // The second stage turns with the estimate; the first, hand-held, by half its
        // tilt (all of its heading): that damps the loop at ζ = ¾ instead of 1 with the
        // same natural frequency 1/τ, so the same rejection of linear acceleration
        // (see `Config::tilt_tau_s`). Otherwise by all of it: critically damped, no
        // overshoot on the step the drag model's error leaves at a stick release.
        let first = if self.hand_held_tilt {
            [0.5 * theta[0], 0.5 * theta[1], theta[2]]
        } else {
            theta
        };
        for (s, t) in self.acc_lp.iter_mut().zip([first, theta]) {
            let c = cross(t, *s);
            for (v, c) in s.iter_mut().zip(c) {
                *v += c;
            }
        }
        // The drag model turns its states by it when it next runs.
        self.drag_tz = theta[2];
        true
    }

    /// Madgwick's 2010 filter exactly (the crate's [`Algorithm::Textbook`]): one gradient
    /// J_gᵀf_g + J_bᵀf_b (eqs. 25–26, 29–30, 45–46), normalised jointly, one fixed β, the
    /// raw gyro, no extensions (eqs. 42–44); only a step beyond ¼ rad of half angle per
    /// axis is clamped (`UpdateStatus::gyro_step_clamped`).
    // `update_inner`'s arguments, as it hands the call over when the configured
    // algorithm is `Algorithm::Textbook`.
    fn update_textbook(
        &mut self,
        gyro_rps: [f32; 3],
        accel: [f32; 3],
        mag: Option<[f32; 3]>,
        dt_s: f32,
    ) -> UpdateStatus {
        let mut st = UpdateStatus::new();
        let q = self.q;
        let Quaternion {
            w: q1,
            x: q2,
            y: q3,
            z: q4,
        } = q;
        // The half angles are clamped to ±¼ rad as in the full filter (and reported), so
        // both number types integrate the same way even for long steps at high rates.
        let (_, clamped) = half_angle_step(gyro_rps, dt_s);
        st.gyro_step_clamped = clamped;
        let lim = 0.5 / dt_s;
        let w = if clamped {
            gyro_rps.map(|x| x.clamp(-lim, lim))
        } else {
            gyro_rps
        };
        let mut qdot = [
            0.5 * (-q2 * w[0] - q3 * w[1] - q4 * w[2]),
            0.5 * (q1 * w[0] + q3 * w[2] - q4 * w[1]),
            0.5 * (q1 * w[1] - q2 * w[2] + q4 * w[0]),
            0.5 * (q1 * w[2] + q2 * w[1] - q3 * w[0]),
        ];
        let acc = unit3(accel);
        st.accel_invalid = acc.is_none();
        st.path = UpdatePath::GyroOnly;
        if let Some((a, _)) = acc {
            // The report's gravity reference is (0, 0, 1) "down" here: it is fed −a.
            let mut grad = accel_gradient(&q, [-a[0], -a[1], -a[2]]);
            st.path = UpdatePath::Imu;
            if let Some(mag) = mag {
                match unit3(mag) {
                    None => st.mag_invalid = true,
                    Some((m, _)) => {
                        let h = mat_vec(&q.to_matrix(), m);
                        let bx = libm::sqrtf(h[0] * h[0] + h[1] * h[1]);
                        let gb = mag_gradient(&q, m, bx, h[2]);
                        for (g, b) in grad.iter_mut().zip(gb) {
                            *g += b;
                        }
                        st.path = UpdatePath::Marg;
                    }
                }
            }
            let gn2 = dot4(grad, grad);
            if gn2 > 1e-30 && gn2.is_finite() {
                let r = self.cfg.beta / libm::sqrtf(gn2);
                for (qd, g) in qdot.iter_mut().zip(grad) {
                    *qd -= r * g;
                }
            }
        }
        let new = Quaternion::new(
            q1 + qdot[0] * dt_s,
            q2 + qdot[1] * dt_s,
            q3 + qdot[2] * dt_s,
            q4 + qdot[3] * dt_s,
        );
        match new.normalized() {
            Some(n) => self.q = n,
            None => st.path = UpdatePath::Skipped,
        }
        self.time_s = (self.time_s + dt_s).min(1e9);
        st
    }
    /// Magnetic disturbance check and recovery; returns true if the sample may be used.
    fn check_mag(
        &mut self,
        n2: f32,
        hz: f32,
        w2: f32,
        dt_s: f32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> bool {
        let mr = self.cfg.mag_rejection;
        st.mag_state = MagState::Undisturbed;
        let Some(re) = self.mag_ref else {
            self.set_mag_reference(n2, hz);
            return true;
        };
        if initialising {
            // Refine the reference while the start-up gain settles.
            let k = (dt_s / 1.0).clamp(0.0, 1.0);
            let n2r = re.norm_sq + k * (n2 - re.norm_sq);
            let hzr = re.hz + k * (hz - re.hz);
            self.set_mag_reference(n2r, hzr);
            return true;
        }
        if !mr.enabled {
            return true;
        }
        let lo = (1.0 - mr.norm_tol) * (1.0 - mr.norm_tol);
        let hi = (1.0 + mr.norm_tol) * (1.0 + mr.norm_tol);
        // The candidate is judged with the reference's dip tolerance.
        let ok = |r: &MagReference| {
            n2 >= lo * r.norm_sq && n2 <= hi * r.norm_sq && (hz - r.hz).abs() <= re.hz_tol
        };
        if ok(&re) {
            self.clear_disturbance();
            if mr.ref_tau_s > 0.0 && w2 > mr.recovery_min_rate_rps * mr.recovery_min_rate_rps {
                self.follow_reference(n2, hz, re, dt_s);
                st.mag_state = MagState::Learning;
            }
            return true;
        }
        self.on_rejected(n2, hz, w2, dt_s, st, ok)
    }

    /// The field matches the reference: no disturbance, no candidate.
    // Inlined: a call here costs every undisturbed update ~9 instructions.
    #[inline(always)]
    fn clear_disturbance(&mut self) {
        self.mag_cand = None;
        self.mag_cand_s = 0.0;
        self.mag_reject_s = 0.0;
    }

    /// Moving and undisturbed: the reference `re` follows the field (the dip
    /// tolerance, set from the dip, is kept).
    fn follow_reference(&mut self, n2: f32, hz: f32, re: MagReference, dt_s: f32) {
        let k = (dt_s / self.cfg.mag_rejection.ref_tau_s).clamp(0.0, 1.0);
        self.mag_ref = Some(MagReference {
            norm_sq: re.norm_sq + k * (n2 - re.norm_sq),
            hz: re.hz + k * (hz - re.hz),
            hz_tol: re.hz_tol,
        });
    }

    /// The field is off the reference: reject it, unless the disturbance has lasted
    /// long enough to adopt the field (fallback) or a candidate field has stayed
    /// consistent (by `ok`) through enough rotation (recovery). Returns true if the
    /// sample may be used.
    fn on_rejected(
        &mut self,
        n2: f32,
        hz: f32,
        w2: f32,
        dt_s: f32,
        st: &mut UpdateStatus,
        ok: impl Fn(&MagReference) -> bool,
    ) -> bool {
        let mr = self.cfg.mag_rejection;
        st.mag_rejected = true;
        st.mag_state = MagState::Rejected;
        self.mag_reject_s = (self.mag_reject_s + dt_s).min(1e6);
        if self.mag_reject_s >= mr.fallback_s {
            // Fallback: the disturbance persisted; adopt the field as it is now.
            self.set_mag_reference(n2, hz);
            self.clear_disturbance();
            st.mag_rejected = false;
            st.mag_reference_relearned = true;
            st.mag_state = MagState::Fallback;
            return true;
        }
        // Recovery: a new field that stays consistent while rotating becomes the reference.
        match self.mag_cand {
            Some(cand) if ok(&cand) => {
                if w2 > mr.recovery_min_rate_rps * mr.recovery_min_rate_rps {
                    self.mag_cand_s += dt_s;
                }
                if self.mag_cand_s >= mr.recovery_s {
                    self.set_mag_reference(cand.norm_sq, cand.hz);
                    self.clear_disturbance();
                    st.mag_rejected = false;
                    st.mag_reference_relearned = true;
                    st.mag_state = MagState::Recovered;
                    return true;
                }
            }
            _ => {
                self.mag_cand = Some(MagReference::new(n2, hz, self.sin_dip_tol));
                self.mag_cand_s = 0.0;
            }
        }
        false
    }
}

pub(crate) fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Most sub-steps of one gyro step: 2000 °/s (the MPU-9250's full scale) on every axis
/// for [`MAX_DT_S`] takes 559. Beyond 1024 (64 rad/s for 1 s) the sub-steps grow
/// instead, and past ¼ rad (512 rad in one step) their half angles are clamped
/// (`UpdateStatus::gyro_step_clamped`).
pub(crate) const MAX_SUBSTEPS: u32 = 1024;

/// Sub-steps of the full filter's gyro step and their dt (s): 1 + ⌊|ω·dt|max / (1/16)⌋
/// (half angles ≤ 1/32 rad each, the first-order step's error 0.001° each), at most
/// [`MAX_SUBSTEPS`], as the fixed filter computes it.
fn substeps(w: [f32; 3], dt_s: f32) -> (u32, f32) {
    let m = w.iter().fold(0.0f32, |m, x| m.max((x * dt_s).abs()));
    if m < 0.0625 {
        return (1, dt_s);
    }
    let n = ((m * 16.0) as u32).min(MAX_SUBSTEPS - 1) + 1;
    (n, dt_s / n as f32)
}

/// Quaternion of a gyro step, (1, ½ω·dt) (first order, eq. 12 integrated over dt), each
/// half angle clamped to ±¼ rad (as the fixed filter).
/// True if a clamp acted.
fn half_angle_step(w: [f32; 3], dt_s: f32) -> (Quaternion, bool) {
    let h = w.map(|x| 0.5 * x * dt_s);
    let c = h.map(|x| x.clamp(-0.25, 0.25));
    (Quaternion::new(1.0, c[0], c[1], c[2]), c != h)
}

/// 1/τ of the heading correction (1/s, ≤ 100; 0 for τ ≤ 0 or NaN: no correction).
pub(crate) fn inv_heading_tau(tau_s: f32) -> f32 {
    if tau_s > 0.0 {
        (1.0 / tau_s).min(100.0)
    } else {
        0.0
    }
}

/// 1/τ (1/s, ≤ 2000; 2000 for τ ≤ 0 or NaN) of a tilt stage's time constant τ (s).
fn inv_tau_of(tau_s: f32) -> f32 {
    if tau_s > 0.0 {
        (1.0 / tau_s).min(2000.0)
    } else {
        2000.0
    }
}

/// 1/τ of the tilt low-pass stages (1/s, ≤ 2000): ramps linearly from
/// 1/[`STARTUP_TILT_TAU_S`] to 1/[`Config::tilt_tau_s`] during the start-up phase.
fn inv_tilt_tau(cfg: &Config, time_s: f32, initialising: bool) -> f32 {
    let inv = inv_tau_of;
    let i = inv(cfg.tilt_tau_s);
    if initialising && cfg.startup_s > 0.0 {
        let i0 = inv(cfg.tilt_tau_s.min(STARTUP_TILT_TAU_S));
        i0 + (i - i0) * (time_s / cfg.startup_s).clamp(0.0, 1.0)
    } else {
        i
    }
}

/// ∇f = J_gᵀ f_g (eqs. 25–26) for the measured "down" direction `d` (unit).
fn accel_gradient(q: &Quaternion, d: [f32; 3]) -> [f32; 4] {
    let Quaternion {
        w: q1,
        x: q2,
        y: q3,
        z: q4,
    } = *q;
    let f1 = 2.0 * (q2 * q4 - q1 * q3) - d[0];
    let f2 = 2.0 * (q1 * q2 + q3 * q4) - d[1];
    let f3 = 1.0 - 2.0 * (q2 * q2 + q3 * q3) - d[2];
    [
        -2.0 * q3 * f1 + 2.0 * q2 * f2,
        2.0 * q4 * f1 + 2.0 * q1 * f2 - 4.0 * q2 * f3,
        -2.0 * q1 * f1 + 2.0 * q4 * f2 - 4.0 * q3 * f3,
        2.0 * q2 * f1 + 2.0 * q3 * f2,
    ]
}

/// ∇f = J_bᵀ f_b (eqs. 29–30 with the correct 2bx, 2bz factors) for the unit field `m`
/// and the reference b = (bx, 0, bz) (eq. 46).
fn mag_gradient(q: &Quaternion, m: [f32; 3], bx: f32, bz: f32) -> [f32; 4] {
    let Quaternion {
        w: q1,
        x: q2,
        y: q3,
        z: q4,
    } = *q;
    let f1 = 2.0 * bx * (0.5 - q3 * q3 - q4 * q4) + 2.0 * bz * (q2 * q4 - q1 * q3) - m[0];
    let f2 = 2.0 * bx * (q2 * q3 - q1 * q4) + 2.0 * bz * (q1 * q2 + q3 * q4) - m[1];
    let f3 = 2.0 * bx * (q1 * q3 + q2 * q4) + 2.0 * bz * (0.5 - q2 * q2 - q3 * q3) - m[2];
    [
        -2.0 * bz * q3 * f1 + (-2.0 * bx * q4 + 2.0 * bz * q2) * f2 + 2.0 * bx * q3 * f3,
        2.0 * bz * q4 * f1
            + (2.0 * bx * q3 + 2.0 * bz * q1) * f2
            + (2.0 * bx * q4 - 4.0 * bz * q2) * f3,
        (-4.0 * bx * q3 - 2.0 * bz * q1) * f1
            + (2.0 * bx * q2 + 2.0 * bz * q4) * f2
            + (2.0 * bx * q1 - 4.0 * bz * q3) * f3,
        (-4.0 * bx * q4 + 2.0 * bz * q2) * f1
            + (-2.0 * bx * q1 + 2.0 * bz * q3) * f2
            + 2.0 * bx * q2 * f3,
    ]
}
