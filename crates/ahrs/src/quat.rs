//! A small f32 quaternion (Hamilton convention, w first).

/// Unit quaternion (w, x, y, z), Hamilton convention.
///
/// As an orientation, `q_a_from_b` rotates frame-b vectors into frame a:
/// `v_a = q ⊗ (0, v_b) ⊗ q*`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Quaternion {
    /// Scalar part.
    pub w: f32,
    /// x component of the vector part.
    pub x: f32,
    /// y component of the vector part.
    pub y: f32,
    /// z component of the vector part.
    pub z: f32,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Quaternion {
    /// The identity rotation.
    pub const IDENTITY: Quaternion = Quaternion {
        w: 1.0,
        x: 0.0,
        y: 0.0,
        z: 0.0,
    };

    /// Construct from components (w, x, y, z); not normalised.
    #[must_use]
    pub const fn new(w: f32, x: f32, y: f32, z: f32) -> Self {
        Self { w, x, y, z }
    }

    /// Rotation of `angle_rad` about `axis` (any length; a zero axis gives the identity).
    #[must_use]
    pub fn from_axis_angle(axis: [f32; 3], angle_rad: f32) -> Self {
        let n = libm::sqrtf(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
        if !n.is_finite() || n <= 0.0 {
            return Self::IDENTITY;
        }
        let s = libm::sinf(0.5 * angle_rad) / n;
        Self::new(
            libm::cosf(0.5 * angle_rad),
            axis[0] * s,
            axis[1] * s,
            axis[2] * s,
        )
    }

    /// Hamilton product `self ⊗ rhs`.
    #[must_use]
    pub fn mul(&self, r: &Quaternion) -> Quaternion {
        let (a, b) = (self, r);
        Quaternion {
            w: a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
            x: a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
            y: a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            z: a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
        }
    }

    /// Conjugate (the inverse for a unit quaternion).
    #[must_use]
    pub fn conj(&self) -> Quaternion {
        Quaternion::new(self.w, -self.x, -self.y, -self.z)
    }

    /// Euclidean norm.
    #[must_use]
    pub fn norm(&self) -> f32 {
        libm::sqrtf(self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z)
    }

    /// Unit quaternion in the same direction, or `None` if the norm is zero or not finite.
    #[must_use]
    pub fn normalized(&self) -> Option<Quaternion> {
        let n2 = self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z;
        if !n2.is_finite() || n2 <= 1e-20 {
            return None;
        }
        let r = 1.0 / libm::sqrtf(n2);
        Some(Quaternion::new(
            self.w * r,
            self.x * r,
            self.y * r,
            self.z * r,
        ))
    }

    /// Rotate a vector: `q ⊗ (0, v) ⊗ q*` (for `q_a_from_b`: frame b -> frame a).
    #[must_use]
    pub fn rotate(&self, v: [f32; 3]) -> [f32; 3] {
        let m = self.to_matrix();
        mat_vec(&m, v)
    }

    /// Rotate by the inverse: `q* ⊗ (0, v) ⊗ q` (frame a -> frame b).
    #[must_use]
    pub fn rotate_inverse(&self, v: [f32; 3]) -> [f32; 3] {
        let m = self.to_matrix();
        [
            m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
            m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
            m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2],
        ]
    }

    /// Rotation matrix (row-major) of a unit quaternion.
    #[must_use]
    pub fn to_matrix(&self) -> [[f32; 3]; 3] {
        let Quaternion { w, x, y, z } = *self;
        [
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ]
    }

    /// Quaternion of a proper rotation matrix (row-major), Shepperd's method.
    #[must_use]
    pub fn from_matrix(m: &[[f32; 3]; 3]) -> Quaternion {
        let tr = m[0][0] + m[1][1] + m[2][2];
        let q = if tr > 0.0 {
            let s = 2.0 * libm::sqrtf(1.0 + tr);
            Quaternion::new(
                0.25 * s,
                (m[2][1] - m[1][2]) / s,
                (m[0][2] - m[2][0]) / s,
                (m[1][0] - m[0][1]) / s,
            )
        } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
            let s = 2.0 * libm::sqrtf(1.0 + m[0][0] - m[1][1] - m[2][2]);
            Quaternion::new(
                (m[2][1] - m[1][2]) / s,
                0.25 * s,
                (m[0][1] + m[1][0]) / s,
                (m[0][2] + m[2][0]) / s,
            )
        } else if m[1][1] > m[2][2] {
            let s = 2.0 * libm::sqrtf(1.0 + m[1][1] - m[0][0] - m[2][2]);
            Quaternion::new(
                (m[0][2] - m[2][0]) / s,
                (m[0][1] + m[1][0]) / s,
                0.25 * s,
                (m[1][2] + m[2][1]) / s,
            )
        } else {
            let s = 2.0 * libm::sqrtf(1.0 + m[2][2] - m[0][0] - m[1][1]);
            Quaternion::new(
                (m[1][0] - m[0][1]) / s,
                (m[0][2] + m[2][0]) / s,
                (m[1][2] + m[2][1]) / s,
                0.25 * s,
            )
        };
        q.normalized().unwrap_or(Quaternion::IDENTITY)
    }

    /// Euler angles (roll, pitch, yaw) in radians, ZYX (yaw-pitch-roll) sequence.
    #[must_use]
    pub fn to_euler_rad(&self) -> [f32; 3] {
        let Quaternion { w, x, y, z } = *self;
        let roll = libm::atan2f(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
        let sp = (2.0 * (w * y - x * z)).clamp(-1.0, 1.0);
        let pitch = libm::asinf(sp);
        let yaw = libm::atan2f(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
        [roll, pitch, yaw]
    }

    /// Quaternion from ZYX Euler angles (roll, pitch, yaw) in radians.
    #[must_use]
    pub fn from_euler_rad(roll: f32, pitch: f32, yaw: f32) -> Quaternion {
        let qz = Quaternion::from_axis_angle([0.0, 0.0, 1.0], yaw);
        let qy = Quaternion::from_axis_angle([0.0, 1.0, 0.0], pitch);
        let qx = Quaternion::from_axis_angle([1.0, 0.0, 0.0], roll);
        qz.mul(&qy).mul(&qx)
    }

    /// Rotation angle (radians, 0..=π) between two orientations.
    #[must_use]
    pub fn angle_to(&self, other: &Quaternion) -> f32 {
        // 2·atan2(|vec(e)|, |w(e)|) with e = self* ⊗ other: accurate for small angles.
        let e = self.conj().mul(other);
        let v = libm::sqrtf(e.x * e.x + e.y * e.y + e.z * e.z);
        2.0 * libm::atan2f(v, e.w.abs())
    }

    /// True if every component is finite.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.w.is_finite() && self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
}

pub(crate) fn mat_vec(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// sin of an angle in degrees, for configuration thresholds (0°..180°;
/// clamped to that range, NaN gives 0).
///
/// A Taylor series to x¹¹ on [−π/2, π/2] (error < 2e-7) instead of
/// `libm::sinf`, whose argument reduction (`rem_pio2f`) and f64 helpers
/// cost ~6.5 KiB of flash on a Cortex-M3 without FPU for a value computed
/// once per configuration.
pub(crate) fn sin_deg(deg: f32) -> f32 {
    // sin(x) = sin(π − x): fold [90°, 180°] onto [0°, 90°].
    let d = if deg.is_nan() {
        0.0
    } else {
        deg.clamp(0.0, 180.0)
    };
    let d = if d > 90.0 { 180.0 - d } else { d };
    let x = d * (core::f32::consts::PI / 180.0);
    let x2 = x * x;
    // Horner form of x − x³/3! + x⁵/5! − x⁷/7! + x⁹/9! − x¹¹/11!.
    x * (1.0
        - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0 * (1.0 - x2 / 110.0)))))
}

/// cos of an angle in degrees, for configuration thresholds (0°..180°;
/// clamped to that range): cos(x) = sin(90° − x), with the odd symmetry of
/// sin for x > 90°.
pub(crate) fn cos_deg(deg: f32) -> f32 {
    let d = if deg.is_nan() {
        0.0
    } else {
        deg.clamp(0.0, 180.0)
    };
    if d <= 90.0 {
        sin_deg(90.0 - d)
    } else {
        -sin_deg(d - 90.0)
    }
}

#[cfg(test)]
mod trig_tests {
    use super::{cos_deg, sin_deg};

    #[test]
    fn config_trig_matches_libm() {
        let mut d = 0.0f32;
        while d <= 180.0 {
            let r = d.to_radians();
            assert!((sin_deg(d) - libm::sinf(r)).abs() < 1e-6, "sin {d}");
            assert!((cos_deg(d) - libm::cosf(r)).abs() < 1e-6, "cos {d}");
            d += 0.25;
        }
        assert_eq!(sin_deg(f32::NAN), 0.0);
        assert!((cos_deg(-10.0) - 1.0).abs() < 1e-6);
        assert!((cos_deg(400.0) + 1.0).abs() < 1e-6);
    }
}
