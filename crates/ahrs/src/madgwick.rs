//! Madgwick's gradient-descent AHRS in f32, with start-up gain ramp, gyro bias
//! estimation at rest, accelerometer rejection and magnetic disturbance rejection.
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

use crate::config::{Config, UpdatePath, UpdateStatus};
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
/// 1 / [`HEADING_LINEAR_ZONE`] in Q16, for the fixed-point filter.
pub(crate) const HEADING_LINEAR_GAIN_Q16: i64 = (1 << 16) * 20;

/// Madgwick AHRS in f32. See the crate docs for an example.
#[derive(Debug, Clone)]
pub struct Madgwick {
    cfg: Config,
    q: Quaternion,
    bias_rps: [f32; 3],
    time_s: f32,
    rest_time_s: f32,
    accel_reject_s: f32,
    accel_forced: bool,
    mag_ref_valid: bool,
    mag_ref_norm_sq: f32,
    mag_ref_hz: f32,
    mag_ref_hz_tol: f32,
    mag_cand_norm_sq: f32,
    mag_cand_hz: f32,
    mag_cand_s: f32,
    mag_cand_valid: bool,
    rate_lp_down_rps: f32,
    // constants derived from cfg
    cos_accel_angle: f32,
    sin_dip_tol: f32,
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
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
            mag_ref_valid: false,
            mag_ref_norm_sq: 0.0,
            mag_ref_hz: 0.0,
            mag_ref_hz_tol: 0.0,
            mag_cand_norm_sq: 0.0,
            mag_cand_hz: 0.0,
            mag_cand_s: 0.0,
            mag_cand_valid: false,
            rate_lp_down_rps: 0.0,
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
        self.mag_ref_valid = false;
        if let Some((mu, n2)) = m {
            self.set_mag_reference(n2, dot(mu, d));
        }
        true
    }

    fn set_mag_reference(&mut self, norm_sq: f32, hz: f32) {
        self.mag_ref_valid = true;
        self.mag_ref_norm_sq = norm_sq;
        self.mag_ref_hz = hz;
        // |Δ sin(dip)| ≈ cos(dip)·Δdip
        let c = libm::sqrtf((1.0 - hz * hz).max(0.0));
        self.mag_ref_hz_tol = self.sin_dip_tol * c.max(0.05);
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

    /// Set the orientation (normalised; ignored if zero or not finite).
    pub fn set_quaternion(&mut self, q: Quaternion) {
        if let Some(q) = q.normalized() {
            self.q = q;
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
        self.mag_ref_valid.then(|| {
            (
                libm::sqrtf(self.mag_ref_norm_sq),
                libm::asinf(self.mag_ref_hz.clamp(-1.0, 1.0)),
            )
        })
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
        let cfg = self.cfg;
        let q = self.q;
        let initialising = self.time_s < cfg.startup_s;
        st.initialising = initialising;

        let acc = unit3(accel);
        st.accel_invalid = acc.is_none();
        let g2 = cfg.gravity_norm * cfg.gravity_norm;

        // --- gyro bias estimation at rest ---------------------------------------
        if cfg.bias.enabled {
            let w = [
                gyro_rps[0] - self.bias_rps[0],
                gyro_rps[1] - self.bias_rps[1],
                gyro_rps[2] - self.bias_rps[2],
            ];
            let tol = cfg.bias.rest_accel_tol;
            let still = dot(w, w) < cfg.bias.rest_gyro_rps * cfg.bias.rest_gyro_rps
                && acc.is_some_and(|(_, n2)| {
                    n2 > g2 * (1.0 - tol) * (1.0 - tol) && n2 < g2 * (1.0 + tol) * (1.0 + tol)
                });
            if still {
                self.rest_time_s = (self.rest_time_s + dt_s).min(1e6);
            } else {
                self.rest_time_s = 0.0;
            }
            if self.rest_time_s >= cfg.bias.rest_time_s {
                st.at_rest = true;
                let k = (dt_s / cfg.bias.tau_s).clamp(0.0, 1.0);
                for (b, w) in self.bias_rps.iter_mut().zip(w) {
                    *b = (*b + k * w).clamp(-cfg.bias.max_rps, cfg.bias.max_rps);
                }
            }
        }
        let b = if cfg.bias.enabled {
            self.bias_rps
        } else {
            [0.0; 3]
        };
        let w = [gyro_rps[0] - b[0], gyro_rps[1] - b[1], gyro_rps[2] - b[2]];

        let rot = q.to_matrix(); // rows: NED axes in body coordinates
        let down = rot[2];
        // Mean rate about the earth vertical (NED z = down·ω) for the scale-factor
        // heading gain schedule (`Config::gyro_scale_tol`).
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
        let Quaternion {
            w: q1,
            x: q2,
            y: q3,
            z: q4,
        } = q;

        // --- accelerometer: eqs. (25)-(26), gradient J_gᵀ f_g ----------------------
        let mut grad = [0.0f32; 4];
        let mut grad_mag = [0.0f32; 4];
        let mut use_acc = false;
        if let Some((a, n2)) = acc {
            let d = [-a[0], -a[1], -a[2]];
            let ar = cfg.accel_rejection;
            let mut reject = false;
            if ar.enabled && !initialising {
                let lo = (1.0 - ar.norm_tol) * (1.0 - ar.norm_tol) * g2;
                let hi = (1.0 + ar.norm_tol) * (1.0 + ar.norm_tol) * g2;
                reject = n2 < lo || n2 > hi || dot(d, down) < self.cos_accel_angle;
            }
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
            if !reject {
                use_acc = true;
                // f_g (eq. 25) with the measured direction d = −a/‖a‖.
                let f1 = 2.0 * (q2 * q4 - q1 * q3) - d[0];
                let f2 = 2.0 * (q1 * q2 + q3 * q4) - d[1];
                let f3 = 1.0 - 2.0 * (q2 * q2 + q3 * q3) - d[2];
                // ∇f = J_gᵀ f_g (eq. 26 Jacobian).
                grad[0] += -2.0 * q3 * f1 + 2.0 * q2 * f2;
                grad[1] += 2.0 * q4 * f1 + 2.0 * q1 * f2 - 4.0 * q2 * f3;
                grad[2] += -2.0 * q1 * f1 + 2.0 * q4 * f2 - 4.0 * q3 * f3;
                grad[3] += 2.0 * q2 * f1 + 2.0 * q3 * f2;
            }
        }

        // --- magnetometer ---------------------------------------------------------
        let mut use_mag = false;
        let mut head_err = 0.0f32;
        if let Some(mag) = mag {
            match unit3(mag) {
                None => st.mag_invalid = true,
                Some((m, n2)) => {
                    // h = q ⊗ m ⊗ q* (eq. 45): the field in NED; hz = m·down.
                    let h = mat_vec(&rot, m);
                    let hz = h[2];
                    let accept = self.check_mag(n2, hz, dot(w, w), dt_s, initialising, &mut st);
                    if accept {
                        use_mag = true;
                        // b = (0, √(hx²+hy²), 0, hz) (eq. 46), the earth field with
                        // zero east component; bx > 0, bz > 0 north of the equator.
                        let bx = libm::sqrtf(h[0] * h[0] + h[1] * h[1]);
                        // Heading error of the estimate (sin, from the field's east
                        // component), saturated to ±1 beyond HEADING_LINEAR_ZONE.
                        if bx > 1e-6 {
                            head_err = (h[1] / (bx * HEADING_LINEAR_ZONE)).clamp(-1.0, 1.0);
                        }
                        let bz = hz;
                        // f_b (eq. 29) and J_b (eq. 30) with the correct 2bx, 2bz factors.
                        let f1 = 2.0 * bx * (0.5 - q3 * q3 - q4 * q4)
                            + 2.0 * bz * (q2 * q4 - q1 * q3)
                            - m[0];
                        let f2 =
                            2.0 * bx * (q2 * q3 - q1 * q4) + 2.0 * bz * (q1 * q2 + q3 * q4) - m[1];
                        let f3 = 2.0 * bx * (q1 * q3 + q2 * q4)
                            + 2.0 * bz * (0.5 - q2 * q2 - q3 * q3)
                            - m[2];
                        let mut gb = [
                            -2.0 * bz * q3 * f1
                                + (-2.0 * bx * q4 + 2.0 * bz * q2) * f2
                                + 2.0 * bx * q3 * f3,
                            2.0 * bz * q4 * f1
                                + (2.0 * bx * q3 + 2.0 * bz * q1) * f2
                                + (2.0 * bx * q4 - 4.0 * bz * q2) * f3,
                            (-4.0 * bx * q3 - 2.0 * bz * q1) * f1
                                + (2.0 * bx * q2 + 2.0 * bz * q4) * f2
                                + (2.0 * bx * q1 - 4.0 * bz * q3) * f3,
                            (-4.0 * bx * q4 + 2.0 * bz * q2) * f1
                                + (-2.0 * bx * q1 + 2.0 * bz * q3) * f2
                                + 2.0 * bx * q2 * f3,
                        ];
                        if cfg.mag_heading_only {
                            gb = project_heading(&q, gb, down);
                        }
                        grad_mag = gb;
                    }
                }
            }
        }

        st.path = match (use_acc, use_mag) {
            (true, true) => UpdatePath::Marg,
            (true, false) => UpdatePath::Imu,
            (false, true) => UpdatePath::MagOnly,
            (false, false) => UpdatePath::GyroOnly,
        };

        // --- fusion: q̇ = ½ q ⊗ (0, ω) − β ∇f/‖∇f‖ (eqs. 12 and 43-44) -------------
        let ramp = |b: f32| {
            if initialising && cfg.startup_s > 0.0 {
                cfg.startup_beta + (b - cfg.startup_beta) * (self.time_s / cfg.startup_s)
            } else {
                b
            }
        };
        let beta = ramp(cfg.beta);
        let beta_mag = ramp(cfg.beta_mag);
        // Heading gain for the gyro scale-factor error (`Config::gyro_scale_tol`):
        // β_head = ½·tol·|ω̄_D|, the quaternion rate of the worst-case heading drift.
        let beta_head = 0.5 * cfg.gyro_scale_tol.max(0.0) * self.rate_lp_down_rps.abs();
        let mut qdot = [
            0.5 * (-q2 * w[0] - q3 * w[1] - q4 * w[2]),
            0.5 * (q1 * w[0] + q3 * w[2] - q4 * w[1]),
            0.5 * (q1 * w[1] - q2 * w[2] + q4 * w[0]),
            0.5 * (q1 * w[2] + q2 * w[1] - q3 * w[0]),
        ];
        for (grad, beta) in [(grad, beta), (grad_mag, beta_mag)] {
            let gn2 = grad.iter().map(|g| g * g).sum::<f32>();
            if gn2 > 1e-30 && gn2.is_finite() {
                // Step per update min(β·dt, ‖∇f‖/4, ½): ‖∇f‖/4 is the quaternion step that
                // removes a small error, so a large gain·dt (start-up β with a long dt)
                // reaches but cannot pass the minimum. Same limit as the fixed filter's
                // `grad_step`.
                let n = libm::sqrtf(gn2);
                let r = (beta * dt_s).min(0.25 * n).min(0.5) / (n * dt_s);
                for (qd, g) in qdot.iter_mut().zip(grad) {
                    *qd -= r * g;
                }
            }
        }
        // Scale-factor heading correction: rotate about the earth vertical towards the
        // magnetometer's heading, q̇ = ½ (0, 0, 0, −2·β_head·e) ⊗ q with e the saturated
        // heading error (`head_err`, > 0 when the estimate is east of the field).
        if use_mag && beta_head > 0.0 && head_err != 0.0 {
            let t = beta_head * head_err;
            qdot[0] += t * q4;
            qdot[1] += t * q3;
            qdot[2] -= t * q2;
            qdot[3] -= t * q1;
        }
        let new = Quaternion::new(
            q1 + qdot[0] * dt_s,
            q2 + qdot[1] * dt_s,
            q3 + qdot[2] * dt_s,
            q4 + qdot[3] * dt_s,
        );
        match new.normalized() {
            Some(n) => self.q = n,
            None => {
                st.path = UpdatePath::Skipped;
                return st;
            }
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
        if !self.mag_ref_valid {
            self.set_mag_reference(n2, hz);
            return true;
        }
        if initialising {
            // Refine the reference while the start-up gain settles.
            let k = (dt_s / 1.0).clamp(0.0, 1.0);
            let n2r = self.mag_ref_norm_sq + k * (n2 - self.mag_ref_norm_sq);
            let hzr = self.mag_ref_hz + k * (hz - self.mag_ref_hz);
            self.set_mag_reference(n2r, hzr);
            return true;
        }
        if !mr.enabled {
            return true;
        }
        let lo = (1.0 - mr.norm_tol) * (1.0 - mr.norm_tol);
        let hi = (1.0 + mr.norm_tol) * (1.0 + mr.norm_tol);
        let ok = |rn2: f32, rhz: f32, tol: f32| {
            n2 >= lo * rn2 && n2 <= hi * rn2 && (hz - rhz).abs() <= tol
        };
        if ok(self.mag_ref_norm_sq, self.mag_ref_hz, self.mag_ref_hz_tol) {
            self.mag_cand_valid = false;
            self.mag_cand_s = 0.0;
            return true;
        }
        st.mag_rejected = true;
        // Recovery: a new field that stays consistent while rotating becomes the reference.
        if self.mag_cand_valid && ok(self.mag_cand_norm_sq, self.mag_cand_hz, self.mag_ref_hz_tol) {
            if w2 > mr.recovery_min_rate_rps * mr.recovery_min_rate_rps {
                self.mag_cand_s += dt_s;
            }
            if self.mag_cand_s >= mr.recovery_s {
                self.set_mag_reference(self.mag_cand_norm_sq, self.mag_cand_hz);
                self.mag_cand_valid = false;
                self.mag_cand_s = 0.0;
                st.mag_rejected = false;
                st.mag_reference_relearned = true;
                return true;
            }
        } else {
            self.mag_cand_valid = true;
            self.mag_cand_norm_sq = n2;
            self.mag_cand_hz = hz;
            self.mag_cand_s = 0.0;
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

/// Keep only the heading part of a quaternion-space gradient: convert it to a body
/// rate (eq. 47: ω = 2 q* ⊗ ∇f), project that onto the estimated vertical (body frame)
/// and convert back (∇f' = ½ q ⊗ (0, ω_vertical)).
fn project_heading(q: &Quaternion, g: [f32; 4], down: [f32; 3]) -> [f32; 4] {
    let gq = Quaternion::new(g[0], g[1], g[2], g[3]);
    let wq = q.conj().mul(&gq);
    let s = 2.0 * (wq.x * down[0] + wq.y * down[1] + wq.z * down[2]);
    let v = Quaternion::new(0.0, 0.5 * s * down[0], 0.5 * s * down[1], 0.5 * s * down[2]);
    let r = q.mul(&v);
    [r.w, r.x, r.y, r.z]
}
