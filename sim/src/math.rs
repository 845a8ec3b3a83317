//! Small f64 vector / quaternion helpers (host only, no allocation).
//!
//! In f64 and apart from `fc_ahrs`'s f32 quaternion on purpose: the truth the
//! filters are scored against does not share their arithmetic.

/// A 3-vector, frame given by the name of the variable holding it.
pub type Vec3 = [f64; 3];
/// A 3×3 matrix, row major.
pub type Mat3 = [[f64; 3]; 3];

/// The 3×3 identity matrix.
pub const IDENTITY3: Mat3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// `a + b`.
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
/// `a − b`.
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// `k·a`.
pub fn scale(a: Vec3, k: f64) -> Vec3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
/// Dot product.
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// Cross product `a × b`.
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// Euclidean norm.
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}
/// `m·v`.
pub fn mat_vec(m: &Mat3, v: Vec3) -> Vec3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}
/// `a·b`.
pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}
/// Transpose.
pub fn transpose(m: &Mat3) -> Mat3 {
    let mut r = [[0.0; 3]; 3];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = m[j][i];
        }
    }
    r
}

/// Unit quaternion (w, x, y, z), Hamilton convention. `q_a_from_b` rotates
/// vectors expressed in frame b into frame a: `v_a = q ⊗ v_b ⊗ q*`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quat {
    /// Scalar part.
    pub w: f64,
    /// Vector part, x.
    pub x: f64,
    /// Vector part, y.
    pub y: f64,
    /// Vector part, z.
    pub z: f64,
}

impl Default for Quat {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Quat {
    /// No rotation.
    pub const IDENTITY: Quat = Quat {
        w: 1.0,
        x: 0.0,
        y: 0.0,
        z: 0.0,
    };

    /// Builds from components (not normalised).
    pub const fn new(w: f64, x: f64, y: f64, z: f64) -> Self {
        Self { w, x, y, z }
    }
    /// Rotation of `angle_rad` about `axis` (need not be unit; zero axis gives identity).
    pub fn from_axis_angle(axis: Vec3, angle_rad: f64) -> Self {
        let n = norm(axis);
        if n == 0.0 {
            return Self::IDENTITY;
        }
        let (s, c) = (angle_rad * 0.5).sin_cos();
        let k = s / n;
        Self::new(c, axis[0] * k, axis[1] * k, axis[2] * k)
    }
    /// Aerospace Z-Y-X Euler angles: `q = Rz(yaw) ⊗ Ry(pitch) ⊗ Rx(roll)`
    /// (for `q_ned_from_body`: roll, pitch, yaw of the body in NED).
    pub fn from_euler(roll_rad: f64, pitch_rad: f64, yaw_rad: f64) -> Self {
        Self::from_axis_angle([0.0, 0.0, 1.0], yaw_rad)
            .mul(&Self::from_axis_angle([0.0, 1.0, 0.0], pitch_rad))
            .mul(&Self::from_axis_angle([1.0, 0.0, 0.0], roll_rad))
    }
    /// Inverse of [`Quat::from_euler`]: (roll, pitch, yaw) in radians.
    pub fn to_euler(&self) -> Vec3 {
        let Quat { w, x, y, z } = *self;
        let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
        let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
        let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
        [roll, pitch, yaw]
    }
    /// Hamilton product `self ⊗ o`.
    pub fn mul(&self, o: &Quat) -> Quat {
        Quat::new(
            self.w * o.w - self.x * o.x - self.y * o.y - self.z * o.z,
            self.w * o.x + self.x * o.w + self.y * o.z - self.z * o.y,
            self.w * o.y - self.x * o.z + self.y * o.w + self.z * o.x,
            self.w * o.z + self.x * o.y - self.y * o.x + self.z * o.w,
        )
    }
    /// Conjugate (inverse of a unit quaternion).
    pub fn conj(&self) -> Quat {
        Quat::new(self.w, -self.x, -self.y, -self.z)
    }
    /// Norm.
    pub fn norm(&self) -> f64 {
        (self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z).sqrt()
    }
    /// Unit quaternion in the same direction.
    pub fn normalized(&self) -> Quat {
        let n = self.norm();
        Quat::new(self.w / n, self.x / n, self.y / n, self.z / n)
    }
    /// Rotates `v` by this quaternion: `q ⊗ v ⊗ q*`.
    pub fn rotate(&self, v: Vec3) -> Vec3 {
        let m = self.to_matrix();
        mat_vec(&m, v)
    }
    /// Rotation matrix (same rotation as [`Quat::rotate`]).
    pub fn to_matrix(&self) -> Mat3 {
        let Quat { w, x, y, z } = *self;
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
    /// Spherical interpolation from `self` (`s = 0`) to `other` (`s = 1`)
    /// along the shortest rotation.
    pub fn slerp(&self, other: &Quat, s: f64) -> Quat {
        let mut rel = self.conj().mul(other);
        if rel.w < 0.0 {
            rel = Quat::new(-rel.w, -rel.x, -rel.y, -rel.z);
        }
        let angle = 2.0 * rel.w.min(1.0).acos();
        if angle < 1e-12 {
            return *other;
        }
        self.mul(&Quat::from_axis_angle([rel.x, rel.y, rel.z], angle * s))
    }
    /// Smallest rotation angle (rad, 0..π) between two orientations.
    pub fn angle_to(&self, other: &Quat) -> f64 {
        let d = (self.w * other.w + self.x * other.x + self.y * other.y + self.z * other.z).abs();
        2.0 * d.min(1.0).acos()
    }
}

/// `q_enu_from_ned`: rotates NED vectors into ENU (x_enu = y_ned, y_enu = x_ned, z_enu = −z_ned).
pub fn q_enu_from_ned() -> Quat {
    // 180° about the axis (1, 1, 0)/√2.
    Quat::from_axis_angle([1.0, 1.0, 0.0], std::f64::consts::PI)
}

/// `q_body_from_mpu` for the default mounting (MPU face up, x forward):
/// body = (x_mpu, −y_mpu, −z_mpu), a 180° rotation about x.
pub fn q_body_from_mpu() -> Quat {
    Quat::new(0.0, 1.0, 0.0, 0.0)
}

/// Body FRD vector → MPU sensor frame (default mounting).
pub fn body_to_mpu(v: Vec3) -> Vec3 {
    [v[0], -v[1], -v[2]]
}
/// MPU sensor frame vector → body FRD (default mounting).
pub fn mpu_to_body(v: Vec3) -> Vec3 {
    [v[0], -v[1], -v[2]]
}
/// MPU sensor frame → AK8963 sensor frame (MPU-9250 datasheet §9.1):
/// x_mag = y_mpu, y_mag = x_mpu, z_mag = −z_mpu.
pub fn mpu_to_ak(v: Vec3) -> Vec3 {
    [v[1], v[0], -v[2]]
}
/// AK8963 sensor frame → MPU sensor frame (the inverse, same permutation).
pub fn ak_to_mpu(v: Vec3) -> Vec3 {
    [v[1], v[0], -v[2]]
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;

    #[test]
    fn frames_compose() {
        let v = [1.0, 2.0, 3.0];
        let q = q_body_from_mpu();
        let b = q.rotate(v);
        assert!(norm(sub(b, mpu_to_body(v))) < 1e-12);
        let e = q_enu_from_ned().rotate([1.0, 2.0, 3.0]);
        assert!(norm(sub(e, [2.0, 1.0, -3.0])) < 1e-12);
        assert_eq!(ak_to_mpu(mpu_to_ak(v)), v);
    }

    #[test]
    fn euler_round_trip() {
        let q = Quat::from_euler(0.3, -0.4, 2.0);
        let e = q.to_euler();
        assert!(
            (e[0] - 0.3).abs() < 1e-12 && (e[1] + 0.4).abs() < 1e-12 && (e[2] - 2.0).abs() < 1e-12
        );
        // Yaw 90° maps body x (forward) to NED east.
        let f = Quat::from_euler(0.0, 0.0, std::f64::consts::FRAC_PI_2).rotate([1.0, 0.0, 0.0]);
        assert!(norm(sub(f, [0.0, 1.0, 0.0])) < 1e-12);
    }
}
