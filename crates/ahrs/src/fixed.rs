//! Madgwick AHRS in fixed point for an FPU-less Cortex-M3: the same algorithm, API shape,
//! status reports and features as [`crate::Madgwick`], in integer arithmetic.
//!
//! Q-formats (Qm.n = n fractional bits):
//! * quaternion `q_ned_from_body`: Q2.30 in `i32` (`_q30`);
//! * gyro rates and the bias estimate: rad/s in Q11.20 `i32` (`_rps_q20`, ±2048 rad/s,
//!   resolution 0.95 µrad/s);
//! * time step: seconds in Q0.31 `i32` (`dt_s_q31`, valid range (0, 1) s); timers are
//!   seconds in Q20 `i64`;
//! * gains β: rad/s in Q8.24 `i32`;
//! * accelerometer and magnetometer: `i32` in any consistent unit (raw counts are fine;
//!   they are normalised inside); [`crate::Config::gravity_norm`] must then be 1 g in
//!   accelerometer units;
//! * unit vectors, rotation-matrix entries, cosines and sines: Q2.30.
//!
//! All products are 32×32→64-bit (one `SMULL` on the M3), there is no division on the
//! update path: every normalisation is one integer reciprocal square root (leading-zero
//! count + 48-entry table + two Newton steps, ~2e-7 relative error). Conversions from the
//! f32 [`crate::Config`] happen once, in [`FixedConfig::from_config`].

use crate::config::{Config, UpdatePath, UpdateStatus};
use crate::Quaternion;

const ONE_Q30: i64 = 1 << 30;

/// 1/√m in Q29 at the midpoints of 48 bins of m ∈ [0.25, 1).
const RSQRT_TABLE: [u32; 48] = [
    1057347856, 1026693558, 998559613, 972618566, 948599586, 926276469, 905458609, 885984104,
    867714429, 850530263, 834328203, 819018128, 804521086, 790767575, 777696137, 765252196,
    753387102, 742057327, 731223792, 720851298, 710908045, 701365222, 692196655, 683378504,
    674889000, 666708225, 658817909, 651201261, 643842818, 636728315, 629844563, 623179354,
    616721362, 610460069, 604385689, 598489102, 592761802, 587195840, 581783781, 576518662,
    571393950, 566403514, 561541591, 556802759, 552181909, 547674226, 543275165, 538980433,
];

/// Reciprocal square root of a u64: returns (R, e) with 1/√s ≈ R·2^(e−60), R in
/// (2^29, 2^30] (Q29 of a value in (1, 2]), and m_q30 (the mantissa, Q30 in [0.25, 1)).
/// `s` must be non-zero.
fn rsqrt_parts(s: u64) -> (i64, i32, i64) {
    let len = 64 - s.leading_zeros() as i32; // 1..=64
    let e = (62 - len) >> 1; // -1..=30
    let sp = if e >= 0 { s << (2 * e) } else { s >> 2 };
    let m = (sp >> 32) as i64; // Q30 in [2^28, 2^30)
    let idx = ((m >> 24) - 16).clamp(0, 47) as usize;
    let mut y = i64::from(RSQRT_TABLE.get(idx).copied().unwrap_or(1 << 29));
    for _ in 0..2 {
        let y2 = (y * y) >> 29; // Q29
        let my2 = (m * y2) >> 30; // Q29
        y = (y * ((3 << 29) - my2)) >> 30; // Q29
    }
    (y, e, m)
}

/// Scale a vector by 1/√s, result Q30: v_i·2^30/√s.
fn scale_rsqrt<const N: usize>(v: [i64; N], s: u64) -> [i32; N] {
    let (r, e, _) = rsqrt_parts(s);
    let sh = (30 - e) as u32; // 0..=31
    v.map(|x| sat32((x.saturating_mul(r) + (1i64 << sh >> 1)) >> sh))
}

/// Integer √s (s ≥ 1), result ≈ √s with ~2e-7 relative error, as i64.
fn isqrt(s: u64) -> i64 {
    if s == 0 {
        return 0;
    }
    let (r, e, m) = rsqrt_parts(s);
    // √s = √m·2^(31−e); √m = m·(1/√m): (m_q30·R_q29)>>29 is √m in Q30.
    let sm = (m * r) >> 29;
    let sh = 30 - 31 + e; // √s = sm·2^(1−e) → shift right by (e−1)
    if sh > 0 {
        (sm + (1 << (sh - 1))) >> sh
    } else {
        sm << (-sh)
    }
}

fn sat32(x: i64) -> i32 {
    x.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

fn mul30(a: i32, b: i32) -> i64 {
    (i64::from(a) * i64::from(b)) >> 30
}

fn sumsq3(v: [i32; 3]) -> u64 {
    v.iter()
        .map(|&x| i64::from(x).unsigned_abs().pow(2))
        .fold(0u64, u64::saturating_add)
}

/// Normalise an i32 3-vector to Q30; `None` if zero. Also returns ‖v‖² (saturating).
fn unit3(v: [i32; 3]) -> Option<([i32; 3], u64)> {
    let s = sumsq3(v);
    if s == 0 {
        return None;
    }
    Some((scale_rsqrt(v.map(i64::from), s), s))
}

fn dot30(a: [i32; 3], b: [i32; 3]) -> i64 {
    (i64::from(a[0]) * i64::from(b[0]))
        .saturating_add(i64::from(a[1]) * i64::from(b[1]))
        .saturating_add(i64::from(a[2]) * i64::from(b[2]))
        >> 30
}

fn cross30(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    let c = |p: i32, q: i32, r: i32, s: i32| sat32(mul30(p, q) - mul30(r, s));
    [
        c(a[1], b[2], a[2], b[1]),
        c(a[2], b[0], a[0], b[2]),
        c(a[0], b[1], a[1], b[0]),
    ]
}

/// Convert an f32 to Q-format with `frac_bits` fractional bits (saturating; NaN → 0).
#[must_use]
pub fn float_to_q(x: f32, frac_bits: u32) -> i32 {
    let v = x * (1u64 << frac_bits.min(62)) as f32;
    if v.is_nan() {
        0
    } else {
        // `as` saturates for floats.
        libm::roundf(v) as i32
    }
}

/// rad/s (f32) to the gyro format, Q20 rad/s.
#[must_use]
pub fn rps_to_q20(rps: f32) -> i32 {
    float_to_q(rps, 20)
}

/// Seconds (f32) to the dt format, Q31 s (saturating at just under 1 s).
#[must_use]
pub fn dt_s_to_q31(dt_s: f32) -> i32 {
    float_to_q(dt_s, 31)
}

/// Microseconds to the dt format (Q31 s), saturating at just under 1 s.
#[must_use]
pub fn dt_us_to_q31(dt_us: u32) -> i32 {
    // us·2^31/1e6 = us·2147.483648 = (us·2147.483648·2^20) >> 20
    let v = (u64::from(dt_us) * 2_251_799_814 + (1 << 19)) >> 20;
    sat32(v.min(i32::MAX as u64) as i64)
}

/// The filter configuration converted to fixed point (built once, with f32).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FixedConfig {
    /// The physical configuration this was built from.
    pub cfg: Config,
    beta_q24: i32,
    beta_mag_q24: i32,
    startup_beta_q24: i32,
    startup_q20: i64,
    inv_startup_q30: i64,
    rest_gyro_sq_q40: i64,
    rest_acc_lo: u64,
    rest_acc_hi: u64,
    rest_time_q20: i64,
    inv_bias_tau_q30: i64,
    bias_max_q20: i32,
    acc_lo: u64,
    acc_hi: u64,
    cos_acc_q30: i64,
    acc_recovery_q20: i64,
    mag_lo_q16: u64,
    mag_hi_q16: u64,
    sin_dip_tol_q30: i64,
    mag_recovery_q20: i64,
    mag_min_rate_sq_q40: i64,
}

fn s_to_q20(s: f32) -> i64 {
    i64::from(float_to_q(s.min(2000.0), 20))
}

fn sq_u64(x: f32) -> u64 {
    let v = x * x;
    if v.is_finite() && v > 0.0 {
        v.min(1.8e19) as u64
    } else {
        0
    }
}

impl FixedConfig {
    /// Convert a physical [`Config`]. `cfg.gravity_norm` must be 1 g in the units the
    /// fixed filter's accelerometer input uses (e.g. counts).
    #[must_use]
    pub fn from_config(cfg: &Config) -> Self {
        let g = cfg.gravity_norm;
        let inv = |t: f32| {
            if t > 0.0 {
                i64::from(float_to_q((1.0 / t).min(1.9), 30))
            } else {
                1 << 30
            }
        };
        let f30 = |x: f32| i64::from(float_to_q(x, 30));
        let sq_q40 = |x: f32| {
            let v = i64::from(float_to_q(x, 20));
            v.saturating_mul(v)
        };
        let mr = cfg.mag_rejection;
        Self {
            cfg: *cfg,
            beta_q24: float_to_q(cfg.beta, 24),
            beta_mag_q24: float_to_q(cfg.beta_mag, 24),
            startup_beta_q24: float_to_q(cfg.startup_beta, 24),
            startup_q20: s_to_q20(cfg.startup_s.max(0.0)),
            inv_startup_q30: inv(cfg.startup_s),
            rest_gyro_sq_q40: sq_q40(cfg.bias.rest_gyro_rps),
            rest_acc_lo: sq_u64(g * (1.0 - cfg.bias.rest_accel_tol)),
            rest_acc_hi: sq_u64(g * (1.0 + cfg.bias.rest_accel_tol)),
            rest_time_q20: s_to_q20(cfg.bias.rest_time_s),
            inv_bias_tau_q30: inv(cfg.bias.tau_s),
            bias_max_q20: float_to_q(cfg.bias.max_rps, 20),
            acc_lo: sq_u64(g * (1.0 - cfg.accel_rejection.norm_tol)),
            acc_hi: sq_u64(g * (1.0 + cfg.accel_rejection.norm_tol)),
            cos_acc_q30: f30(libm::cosf(cfg.accel_rejection.angle_deg.to_radians())),
            acc_recovery_q20: s_to_q20(cfg.accel_rejection.recovery_s),
            mag_lo_q16: sq_u64((1.0 - mr.norm_tol) * 256.0),
            mag_hi_q16: sq_u64((1.0 + mr.norm_tol) * 256.0),
            sin_dip_tol_q30: f30(libm::sinf(mr.dip_tol_deg.to_radians())),
            mag_recovery_q20: s_to_q20(mr.recovery_s),
            mag_min_rate_sq_q40: sq_q40(mr.recovery_min_rate_rps),
        }
    }
}

/// Field reference: ‖m‖² with its accepted band, dip sine and its tolerance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct MagRef {
    n2: u64,
    lo: u64,
    hi: u64,
    hz_q30: i64,
    hz_tol_q30: i64,
}

/// Madgwick AHRS in fixed point (see the module docs for the Q-formats).
///
/// ```
/// use fc_ahrs::fixed::{dt_us_to_q31, FixedConfig, MadgwickFixed};
/// use fc_ahrs::{Config, UpdatePath};
/// // MPU-9250 at ±2 g: 16384 counts per g, already in FRD body axes.
/// let cfg = FixedConfig::from_config(&Config { gravity_norm: 16384.0, ..Config::DEFAULT });
/// let mut f = MadgwickFixed::from_accel_mag(cfg, [0, 0, -16384], [200, 0, 450]);
/// let st = f.update_marg([0; 3], [0, 0, -16384], [200, 0, 450], dt_us_to_q31(1000));
/// assert_eq!(st.path, UpdatePath::Marg);
/// let q = f.quaternion_q30();
/// assert!((i64::from(q[0]) - (1 << 30)).abs() < 1000);
/// ```
#[derive(Debug, Clone)]
pub struct MadgwickFixed {
    c: FixedConfig,
    q: [i32; 4],
    bias_q20: [i32; 3],
    bias_q40: [i64; 3],
    time_q20: i64,
    rest_q20: i64,
    acc_reject_q20: i64,
    acc_forced: bool,
    mag_ref: Option<MagRef>,
    cand: Option<(u64, i64)>,
    cand_q20: i64,
}

impl MadgwickFixed {
    /// New filter at the identity orientation.
    #[must_use]
    pub fn new(c: FixedConfig) -> Self {
        Self {
            c,
            q: [1 << 30, 0, 0, 0],
            bias_q20: [0; 3],
            bias_q40: [0; 3],
            time_q20: 0,
            rest_q20: 0,
            acc_reject_q20: 0,
            acc_forced: false,
            mag_ref: None,
            cand: None,
            cand_q20: 0,
        }
    }

    /// New filter initialised from one accelerometer and magnetometer sample (see
    /// [`MadgwickFixed::init_from_accel_mag`]).
    #[must_use]
    pub fn from_accel_mag(c: FixedConfig, accel: [i32; 3], mag: [i32; 3]) -> Self {
        let mut f = Self::new(c);
        f.init_from_accel_mag(accel, mag);
        f
    }

    /// Reset the orientation from an accelerometer and magnetometer sample (body frame,
    /// any units) and learn the magnetic reference; yaw 0 if the field is unusable.
    /// Returns false (state unchanged) if the accelerometer is zero.
    pub fn init_from_accel_mag(&mut self, accel: [i32; 3], mag: [i32; 3]) -> bool {
        let Some((a, _)) = unit3(accel) else {
            return false;
        };
        let d = a.map(|x| x.saturating_neg());
        let m = unit3(mag);
        let east = m.and_then(|(m, _)| unit3(cross30(d, m)));
        let e = match east {
            Some((e, _)) => e,
            None => {
                let helper = if d[0].unsigned_abs() < (0.9 * ONE_Q30 as f32) as u32 {
                    [1 << 30, 0, 0]
                } else {
                    [0, 1 << 30, 0]
                };
                unit3(cross30(d, helper)).map_or([0, 1 << 30, 0], |(e, _)| e)
            }
        };
        let n = cross30(e, d);
        self.q = quat_from_rows_q30([n, e, d]);
        self.mag_ref = None;
        if let Some((mu, n2)) = m {
            self.mag_ref = Some(self.make_ref(n2, dot30(mu, d)));
        }
        true
    }

    fn make_ref(&self, n2: u64, hz_q30: i64) -> MagRef {
        let hz = hz_q30.clamp(-ONE_Q30, ONE_Q30);
        let c2 = (ONE_Q30 * ONE_Q30 - hz * hz).max(0) as u64; // cos²(dip), Q60
        let c = isqrt(c2).max(ONE_Q30 / 20); // Q30, ≥ 0.05
        let scaled =
            |k: u64| ((u128::from(n2) * u128::from(k)) >> 16).min(u128::from(u64::MAX)) as u64;
        MagRef {
            n2,
            lo: scaled(self.c.mag_lo_q16),
            hi: scaled(self.c.mag_hi_q16),
            hz_q30: hz,
            hz_tol_q30: (self.c.sin_dip_tol_q30 * c) >> 30,
        }
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &FixedConfig {
        &self.c
    }

    /// Orientation `q_ned_from_body` as (w, x, y, z) in Q30.
    #[must_use]
    pub fn quaternion_q30(&self) -> [i32; 4] {
        self.q
    }

    /// Orientation as an f32 [`Quaternion`] (for logging and host tools).
    #[must_use]
    pub fn quaternion_f32(&self) -> Quaternion {
        let s = 1.0 / ONE_Q30 as f32;
        Quaternion::new(
            self.q[0] as f32 * s,
            self.q[1] as f32 * s,
            self.q[2] as f32 * s,
            self.q[3] as f32 * s,
        )
    }

    /// Euler angles (roll, pitch, yaw) in rad, ZYX (uses f32 maths: not for the hot path).
    #[must_use]
    pub fn euler_rad(&self) -> [f32; 3] {
        self.quaternion_f32().to_euler_rad()
    }

    /// Gyro bias estimate, rad/s in Q20.
    #[must_use]
    pub fn gyro_bias_rps_q20(&self) -> [i32; 3] {
        self.bias_q20
    }

    /// Unit gravity direction ("down") in the body frame, Q30.
    #[must_use]
    pub fn gravity_body_q30(&self) -> [i32; 3] {
        rows(self.q)[2]
    }

    /// Earth-frame (NED) linear acceleration, m/s² in Q16, from the body specific force
    /// in m/s² Q16: `a_ned = R·f + (0, 0, g)`.
    #[must_use]
    pub fn linear_accel_ned_mps2_q16(&self, accel_body_mps2_q16: [i32; 3]) -> [i32; 3] {
        let r = rows(self.q);
        let g_q16: i64 = 642_689; // 9.80665·2^16
        [
            sat32(dot30(r[0], accel_body_mps2_q16)),
            sat32(dot30(r[1], accel_body_mps2_q16)),
            sat32(dot30(r[2], accel_body_mps2_q16) + g_q16),
        ]
    }

    /// Vertical linear acceleration, up positive, m/s² in Q16 (3 multiplies).
    #[must_use]
    pub fn vertical_accel_up_mps2_q16(&self, accel_body_mps2_q16: [i32; 3]) -> i32 {
        let r = rows(self.q);
        sat32(-(dot30(r[2], accel_body_mps2_q16) + 642_689))
    }

    /// IMU update. `gyro_rps_q20` body rates (Q20 rad/s), `accel` any unit (see
    /// [`Config::gravity_norm`]), `dt_s_q31` step in Q31 s (must be > 0).
    pub fn update_imu(
        &mut self,
        gyro_rps_q20: [i32; 3],
        accel: [i32; 3],
        dt_s_q31: i32,
    ) -> UpdateStatus {
        self.update_inner(gyro_rps_q20, accel, None, dt_s_q31)
    }

    /// MARG update (magnetometer in any unit).
    pub fn update_marg(
        &mut self,
        gyro_rps_q20: [i32; 3],
        accel: [i32; 3],
        mag: [i32; 3],
        dt_s_q31: i32,
    ) -> UpdateStatus {
        self.update_inner(gyro_rps_q20, accel, Some(mag), dt_s_q31)
    }

    fn update_inner(
        &mut self,
        gyro: [i32; 3],
        accel: [i32; 3],
        mag: Option<[i32; 3]>,
        dt_q31: i32,
    ) -> UpdateStatus {
        let mut st = UpdateStatus::new();
        if dt_q31 <= 0 {
            st.gyro_invalid = true;
            return st;
        }
        let c = self.c;
        let cfg = c.cfg;
        let dt_q20 = i64::from(dt_q31 >> 11);
        let initialising = self.time_q20 < c.startup_q20;
        st.initialising = initialising;
        let acc = unit3(accel);
        st.accel_invalid = acc.is_none();

        // --- gyro bias at rest -----------------------------------------------------
        let wsub = |b: [i32; 3]| {
            [
                gyro[0].saturating_sub(b[0]),
                gyro[1].saturating_sub(b[1]),
                gyro[2].saturating_sub(b[2]),
            ]
        };
        let w_sq = |w: [i32; 3]| {
            w.iter()
                .map(|&x| i64::from(x) * i64::from(x))
                .fold(0i64, i64::saturating_add)
        };
        if cfg.bias.enabled {
            let w = wsub(self.bias_q20);
            let still = w_sq(w) < c.rest_gyro_sq_q40
                && acc.is_some_and(|(_, n2)| n2 > c.rest_acc_lo && n2 < c.rest_acc_hi);
            self.rest_q20 = if still {
                (self.rest_q20 + dt_q20).min(1 << 50)
            } else {
                0
            };
            if self.rest_q20 >= c.rest_time_q20 {
                st.at_rest = true;
                let k = ((i64::from(dt_q31) * c.inv_bias_tau_q30) >> 31).clamp(0, ONE_Q30);
                // Bias kept in Q40 so the tiny steps k·w are not lost to truncation.
                let max = i64::from(c.bias_max_q20) << 20;
                for ((acc, b), w) in self
                    .bias_q40
                    .iter_mut()
                    .zip(self.bias_q20.iter_mut())
                    .zip(w)
                {
                    *acc = (*acc + ((k * i64::from(w)) >> 10)).clamp(-max, max);
                    *b = sat32((*acc + (1 << 19)) >> 20);
                }
            }
        }
        let w = if cfg.bias.enabled {
            wsub(self.bias_q20)
        } else {
            gyro
        };

        let q = self.q;
        let [q1, q2, q3, q4] = q.map(i64::from);
        let r = rows(q);
        let down = r[2];

        // --- accelerometer: eqs. (25)-(26) -----------------------------------------
        let mut grad = [0i64; 4];
        let mut use_acc = false;
        if let Some((a, n2)) = acc {
            let d = a.map(|x| x.saturating_neg());
            let ar = cfg.accel_rejection;
            let mut reject = false;
            if ar.enabled && !initialising {
                reject = n2 < c.acc_lo || n2 > c.acc_hi || dot30(d, down) < c.cos_acc_q30;
            }
            if reject {
                self.acc_reject_q20 = (self.acc_reject_q20 + dt_q20).min(1 << 50);
                if self.acc_reject_q20 > c.acc_recovery_q20 {
                    self.acc_forced = true;
                }
                if self.acc_forced {
                    st.accel_recovering = true;
                    reject = false;
                }
            } else {
                self.acc_reject_q20 = 0;
                self.acc_forced = false;
            }
            st.accel_rejected = reject;
            if !reject {
                use_acc = true;
                // f_g = Rᵀ(0,0,1) − d (eq. 25), Q29 to keep 3-term sums in i64.
                let f1 = (i64::from(down[0]) - i64::from(d[0])) >> 1;
                let f2 = (i64::from(down[1]) - i64::from(d[1])) >> 1;
                let f3 = (i64::from(down[2]) - i64::from(d[2])) >> 1;
                // J_gᵀ f_g (eq. 26): Q30·Q29·2 → >> 28 gives Q30.
                grad[0] = (-q3 * f1 + q2 * f2) >> 28;
                grad[1] = (q4 * f1 + q1 * f2 - 2 * q2 * f3) >> 28;
                grad[2] = (-q1 * f1 + q4 * f2 - 2 * q3 * f3) >> 28;
                grad[3] = (q2 * f1 + q3 * f2) >> 28;
            }
        }

        // --- magnetometer: eqs. (29)-(30), (45)-(46) --------------------------------
        let mut grad_mag = [0i64; 4];
        let mut use_mag = false;
        if let Some(mag) = mag {
            match unit3(mag) {
                None => st.mag_invalid = true,
                Some((m, n2)) => {
                    // h = R m (eq. 45), NED.
                    let h = [dot30(r[0], m), dot30(r[1], m), dot30(r[2], m)]
                        .map(|x| x.clamp(-ONE_Q30, ONE_Q30));
                    let hz = h[2];
                    let accept = self.check_mag(n2, hz, w_sq(w), dt_q31, initialising, &mut st);
                    if accept {
                        use_mag = true;
                        // b = (√(hx²+hy²), 0, hz) (eq. 46), Q30.
                        let hs = (h[0] * h[0] + h[1] * h[1]) as u64; // Q60
                        let bx = isqrt(hs);
                        let bz = hz;
                        // f_b = Rᵀ b − m (eq. 29 with the correct 2bx, 2bz), Q29.
                        let fb = |i: usize| {
                            let col = |row: usize| {
                                r.get(row)
                                    .and_then(|rr| rr.get(i))
                                    .copied()
                                    .map_or(0, i64::from)
                            };
                            let mi = m.get(i).copied().map_or(0, i64::from);
                            ((bx * col(0) + bz * col(2)) >> 30).saturating_sub(mi) >> 1
                        };
                        let (f1, f2, f3) = (fb(0), fb(1), fb(2));
                        let bq = |b: i64, qq: i64| (b * qq) >> 30; // Q30
                        let (bx1, bx2, bx3, bx4) = (bq(bx, q1), bq(bx, q2), bq(bx, q3), bq(bx, q4));
                        let (bz1, bz2, bz3, bz4) = (bq(bz, q1), bq(bz, q2), bq(bz, q3), bq(bz, q4));
                        // J_bᵀ f_b (eq. 30), half coefficients; Q30·Q29·2 → >> 28.
                        let mut gb = [
                            (-bz3 * f1 + (-bx4 + bz2) * f2 + bx3 * f3) >> 28,
                            (bz4 * f1 + (bx3 + bz1) * f2 + (bx4 - 2 * bz2) * f3) >> 28,
                            ((-2 * bx3 - bz1) * f1 + (bx2 + bz4) * f2 + (bx1 - 2 * bz3) * f3) >> 28,
                            ((-2 * bx4 + bz2) * f1 + (-bx1 + bz3) * f2 + bx2 * f3) >> 28,
                        ];
                        if cfg.mag_heading_only {
                            gb = project_heading(q, gb, down);
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

        // --- fusion (eqs. 12, 43-44), gradients normalised separately ---------------
        let ramp = |b: i32| -> i64 {
            let b = i64::from(b);
            if initialising && c.startup_q20 > 0 {
                let frac = ((self.time_q20 * c.inv_startup_q30) >> 20).clamp(0, ONE_Q30);
                let sb = i64::from(c.startup_beta_q24);
                sb + (((b - sb) * frac) >> 30)
            } else {
                b
            }
        };
        // β·dt: Q24·Q31 → Q30.
        let beta_dt = ((ramp(c.beta_q24) * i64::from(dt_q31)) >> 25).clamp(0, ONE_Q30);
        let beta_mag_dt = ((ramp(c.beta_mag_q24) * i64::from(dt_q31)) >> 25).clamp(0, ONE_Q30);
        // ½ω·dt in Q30: Q20·Q31 = Q51 → >> 22.
        // Clamped to ±1 rad (half angle) per step, far beyond any physical rate·dt.
        let hw = w.map(|x| ((i64::from(x) * i64::from(dt_q31)) >> 22).clamp(-ONE_Q30, ONE_Q30));
        let mut nq = [
            q1 + ((-q2 * hw[0] - q3 * hw[1] - q4 * hw[2]) >> 30),
            q2 + ((q1 * hw[0] + q3 * hw[2] - q4 * hw[1]) >> 30),
            q3 + ((q1 * hw[1] - q2 * hw[2] + q4 * hw[0]) >> 30),
            q4 + ((q1 * hw[2] + q2 * hw[1] - q3 * hw[0]) >> 30),
        ];
        for (g, bdt) in [(grad, beta_dt), (grad_mag, beta_mag_dt)] {
            // Q30 gradient (|∇f| ≤ ~12) → Q26 i32 → unit Q30.
            let g26 = g.map(|x| (x >> 4).clamp(i64::from(i32::MIN), i64::from(i32::MAX)));
            let s = g26
                .iter()
                .map(|&x| x.unsigned_abs().pow(2))
                .fold(0u64, u64::saturating_add);
            if s > 0 {
                let u = scale_rsqrt(g26, s);
                for (n, ui) in nq.iter_mut().zip(u) {
                    *n -= (bdt * i64::from(ui)) >> 30;
                }
            }
        }
        let s = nq
            .iter()
            .map(|&x| x.unsigned_abs().min(1 << 31).pow(2))
            .fold(0u64, u64::saturating_add);
        if s < (1 << 40) {
            st.path = UpdatePath::Skipped;
            return st;
        }
        self.q = scale_rsqrt(nq.map(|x| x.clamp(-(1 << 31), 1 << 31)), s);
        self.time_q20 = (self.time_q20 + dt_q20).min(1 << 60);
        st
    }

    fn check_mag(
        &mut self,
        n2: u64,
        hz: i64,
        w2_q40: i64,
        dt_q31: i32,
        initialising: bool,
        st: &mut UpdateStatus,
    ) -> bool {
        let c = self.c;
        let mr = c.cfg.mag_rejection;
        let Some(re) = self.mag_ref else {
            self.mag_ref = Some(self.make_ref(n2, hz));
            return true;
        };
        if initialising {
            // Low-pass the reference (τ = 1 s): k = dt/1 s in Q31.
            let k = i128::from(dt_q31);
            let n2r = i128::from(re.n2) + ((k * (i128::from(n2) - i128::from(re.n2))) >> 31);
            let hzr = re.hz_q30 + ((i64::from(dt_q31) * (hz - re.hz_q30)) >> 31);
            self.mag_ref = Some(self.make_ref(n2r.clamp(0, i128::from(u64::MAX)) as u64, hzr));
            return true;
        }
        if !mr.enabled {
            return true;
        }
        let ok =
            |rf: &MagRef| n2 >= rf.lo && n2 <= rf.hi && (hz - rf.hz_q30).abs() <= rf.hz_tol_q30;
        if ok(&re) {
            self.cand = None;
            self.cand_q20 = 0;
            return true;
        }
        st.mag_rejected = true;
        let cand_ok = self.cand.is_some_and(|(cn2, chz)| {
            let cr = MagRef {
                hz_tol_q30: re.hz_tol_q30,
                ..self.make_ref(cn2, chz)
            };
            ok(&cr)
        });
        if cand_ok {
            if w2_q40 > c.mag_min_rate_sq_q40 {
                self.cand_q20 += i64::from(dt_q31 >> 11);
            }
            if self.cand_q20 >= c.mag_recovery_q20 {
                if let Some((cn2, chz)) = self.cand {
                    self.mag_ref = Some(self.make_ref(cn2, chz));
                }
                self.cand = None;
                self.cand_q20 = 0;
                st.mag_rejected = false;
                st.mag_reference_relearned = true;
                return true;
            }
        } else {
            self.cand = Some((n2, hz));
            self.cand_q20 = 0;
        }
        false
    }
}

/// Rows of the rotation matrix R(q) (body -> NED) in Q30; row 2 is "down" in body axes.
fn rows(q: [i32; 4]) -> [[i32; 3]; 3] {
    let [w, x, y, z] = q;
    let p = |a: i32, b: i32| mul30(a, b);
    let (xx, yy, zz) = (p(x, x), p(y, y), p(z, z));
    let (xy, xz, yz) = (p(x, y), p(x, z), p(y, z));
    let (wx, wy, wz) = (p(w, x), p(w, y), p(w, z));
    let s = |v: i64| sat32(v);
    [
        [
            s(ONE_Q30 - 2 * (yy + zz)),
            s(2 * (xy - wz)),
            s(2 * (xz + wy)),
        ],
        [
            s(2 * (xy + wz)),
            s(ONE_Q30 - 2 * (xx + zz)),
            s(2 * (yz - wx)),
        ],
        [
            s(2 * (xz - wy)),
            s(2 * (yz + wx)),
            s(ONE_Q30 - 2 * (xx + yy)),
        ],
    ]
}

/// Heading-only part of a quaternion-space gradient (see the f32 version): body rate
/// ω = 2 q* ⊗ ∇f (eq. 47), projected on the vertical, back to ½ q ⊗ (0, ω_v).
fn project_heading(q: [i32; 4], g: [i64; 4], down: [i32; 3]) -> [i64; 4] {
    // Scale g to a unit Q30 vector first so the products stay in range (direction is
    // all that matters: the result is normalised again).
    let g26 = g.map(|x| (x >> 4).clamp(i64::from(i32::MIN), i64::from(i32::MAX)));
    let s = g26
        .iter()
        .map(|&x| x.unsigned_abs().pow(2))
        .fold(0u64, u64::saturating_add);
    if s == 0 {
        return [0; 4];
    }
    let u = scale_rsqrt(g26, s).map(i64::from);
    let [w, x, y, z] = q.map(i64::from);
    // vector part of q* ⊗ u
    let vx = (w * u[1] - x * u[0] - y * u[3] + z * u[2]) >> 30;
    let vy = (w * u[2] + x * u[3] - y * u[0] - z * u[1]) >> 30;
    let vz = (w * u[3] - x * u[2] + y * u[1] - z * u[0]) >> 30;
    let d = down.map(i64::from);
    let sdot = (vx * d[0] + vy * d[1] + vz * d[2]) >> 30;
    let o = d.map(|di| (sdot * di) >> 30);
    // q ⊗ (0, o)
    [
        (-x * o[0] - y * o[1] - z * o[2]) >> 30,
        (w * o[0] + y * o[2] - z * o[1]) >> 30,
        (w * o[1] - x * o[2] + z * o[0]) >> 30,
        (w * o[2] + x * o[1] - y * o[0]) >> 30,
    ]
}

/// Quaternion (Q30) of a rotation matrix given by its rows (Q30), Shepperd's method
/// with one integer square root and one reciprocal square root.
fn quat_from_rows_q30(m: [[i32; 3]; 3]) -> [i32; 4] {
    let e = |i: usize, j: usize| {
        m.get(i)
            .and_then(|r| r.get(j))
            .copied()
            .map_or(0, i64::from)
    };
    let (m00, m11, m22) = (e(0, 0), e(1, 1), e(2, 2));
    let tr = m00 + m11 + m22;
    // t = 1 + (pivot combination) ∈ (0, 4]; pivot component = ½√t, others = pair/(2√t).
    let (case, t) = if tr > 0 {
        (0, ONE_Q30 + tr)
    } else if m00 > m11 && m00 > m22 {
        (1, ONE_Q30 + m00 - m11 - m22)
    } else if m11 > m22 {
        (2, ONE_Q30 + m11 - m00 - m22)
    } else {
        (3, ONE_Q30 + m22 - m00 - m11)
    };
    let t = t.max(1) as u64; // Q30
    let sqrt_t = isqrt(t << 30); // √t in Q30
    let half_inv = if sqrt_t > 0 {
        (ONE_Q30 * ONE_Q30 / 2) / sqrt_t
    } else {
        0
    }; // 1/(2√t), init only
    let p = sqrt_t / 2;
    let k = |a: i64| (a * half_inv) >> 30;
    let q = match case {
        0 => [
            p,
            k(e(2, 1) - e(1, 2)),
            k(e(0, 2) - e(2, 0)),
            k(e(1, 0) - e(0, 1)),
        ],
        1 => [
            k(e(2, 1) - e(1, 2)),
            p,
            k(e(0, 1) + e(1, 0)),
            k(e(0, 2) + e(2, 0)),
        ],
        2 => [
            k(e(0, 2) - e(2, 0)),
            k(e(0, 1) + e(1, 0)),
            p,
            k(e(1, 2) + e(2, 1)),
        ],
        _ => [
            k(e(1, 0) - e(0, 1)),
            k(e(0, 2) + e(2, 0)),
            k(e(1, 2) + e(2, 1)),
            p,
        ],
    };
    let s = q
        .iter()
        .map(|&x| x.unsigned_abs().min(1 << 31).pow(2))
        .fold(0u64, u64::saturating_add);
    if s == 0 {
        return [1 << 30, 0, 0, 0];
    }
    scale_rsqrt(q, s)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn rsqrt_accuracy() {
        for &s in &[
            1u64,
            2,
            3,
            7,
            1000,
            123_456_789,
            1 << 40,
            (1 << 62) + 12345,
            u64::MAX,
        ] {
            let (r, e, _) = rsqrt_parts(s);
            let approx = r as f64 * 2f64.powi(e - 60);
            let exact = 1.0 / (s as f64).sqrt();
            assert!(
                (approx / exact - 1.0).abs() < 1e-6,
                "s={s} {approx} {exact}"
            );
            let sq = isqrt(s) as f64;
            assert!(
                (sq / (s as f64).sqrt() - 1.0).abs() < 1e-6 || (sq - (s as f64).sqrt()).abs() < 1.0,
                "isqrt {s}"
            );
        }
    }

    #[test]
    fn unit_vectors() {
        let (u, _) = unit3([3, 4, 0]).unwrap();
        assert!((u[0] - (0.6 * ONE_Q30 as f64) as i32).abs() < 300);
        assert!((u[1] - (0.8 * ONE_Q30 as f64) as i32).abs() < 300);
        let (u, _) = unit3([i32::MIN, i32::MIN, i32::MIN]).unwrap();
        assert!(u.iter().all(|&x| x < 0));
        assert!(unit3([0, 0, 0]).is_none());
    }

    #[test]
    fn dt_conversions() {
        assert_eq!(dt_us_to_q31(1000), dt_s_to_q31(0.001));
        assert_eq!(dt_us_to_q31(u32::MAX), i32::MAX);
    }
}
