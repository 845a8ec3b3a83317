//! Frame conversions: NED <-> ENU quaternions and sensor-to-body alignment.
//!
//! * Earth frames: NED (x north, y east, z down), used by the filter, and ENU
//!   (x east, y north, z up), used by the BROAD reference data.
//! * `q_enu_from_body = Q_ENU_FROM_NED ⊗ q_ned_from_body`.
//!
//! The ENU <- NED rotation swaps x and y and negates z; as a quaternion it is
//! (w, x, y, z) = (0, √½, √½, 0) (a 180° turn about the bisector of north and east).

use crate::Quaternion;

const FRAC_1_SQRT_2: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// The rotation taking NED vectors into ENU: `v_enu = R(Q_ENU_FROM_NED) v_ned`.
pub const Q_ENU_FROM_NED: Quaternion = Quaternion {
    w: 0.0,
    x: FRAC_1_SQRT_2,
    y: FRAC_1_SQRT_2,
    z: 0.0,
};

/// `q_enu_from_body = Q_ENU_FROM_NED ⊗ q_ned_from_body`.
///
/// ```
/// use fc_ahrs::{frames, Quaternion};
/// let q_enu = frames::enu_from_ned(Quaternion::IDENTITY);
/// // Body aligned with NED: body x (north) is ENU y.
/// let v = q_enu.rotate([1.0, 0.0, 0.0]);
/// assert!((v[1] - 1.0).abs() < 1e-6);
/// ```
#[must_use]
pub fn enu_from_ned(q_ned_from_body: Quaternion) -> Quaternion {
    Q_ENU_FROM_NED.mul(&q_ned_from_body)
}

/// `q_ned_from_body = conj(Q_ENU_FROM_NED) ⊗ q_enu_from_body` (the rotation is its own inverse).
#[must_use]
pub fn ned_from_enu(q_enu_from_body: Quaternion) -> Quaternion {
    Q_ENU_FROM_NED.conj().mul(&q_enu_from_body)
}

/// Convert a NED vector to ENU (and back: the map is an involution).
#[must_use]
pub fn ned_to_enu(v_ned: [f32; 3]) -> [f32; 3] {
    [v_ned[1], v_ned[0], -v_ned[2]]
}

/// A signed axis permutation mapping sensor axes to body axes:
/// `body[i] = sign[i] · sensor[axis[i]]`.
///
/// Alignment between sensors of the MPU-9250:
/// the AK8963 magnetometer frame is x_mag = y_mpu, y_mag = x_mpu, z_mag = −z_mpu.
/// [`Alignment::AK8963_TO_MPU`] maps AK8963 readings into the MPU frame
/// (x_mpu = y_mag, y_mpu = x_mag, z_mpu = −z_mag); apply it first (the `ak8963`
/// crate's `to_mpu_frame` does the same) and then the board mounting, e.g.
/// [`Alignment::MPU_TO_FRD`], to both IMU and magnetometer.
/// Compose with [`Alignment::then`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Alignment {
    /// Source (sensor) axis index for each body axis (0 = x, 1 = y, 2 = z; larger values read as z).
    pub axis: [u8; 3],
    /// True where the body axis is the negated sensor axis.
    pub negate: [bool; 3],
}

impl Alignment {
    /// Sensor axes are body axes (e.g. BROAD: the body is the IMU frame).
    pub const IDENTITY: Alignment = Alignment {
        axis: [0, 1, 2],
        negate: [false; 3],
    };
    /// AK8963 magnetometer frame -> MPU-9250 frame: (y_mag, x_mag, −z_mag).
    pub const AK8963_TO_MPU: Alignment = Alignment {
        axis: [1, 0, 2],
        negate: [false, false, true],
    };
    /// MPU frame (breakout face up, x arrow forward) -> FRD body: (x, −y, −z).
    pub const MPU_TO_FRD: Alignment = Alignment {
        axis: [0, 1, 2],
        negate: [false, true, true],
    };

    /// Map a sensor-frame vector to the body frame.
    ///
    /// ```
    /// use fc_ahrs::frames::Alignment;
    /// assert_eq!(Alignment::AK8963_TO_MPU.apply([1.0, 2.0, 3.0]), [2.0, 1.0, -3.0]);
    /// ```
    #[must_use]
    pub fn apply<T>(&self, v: [T; 3]) -> [T; 3]
    where
        T: Copy + core::ops::Neg<Output = T>,
    {
        let pick = |i: usize| {
            let src = match self.axis.get(i).copied().unwrap_or(2) {
                0 => v[0],
                1 => v[1],
                _ => v[2],
            };
            if self.negate.get(i).copied().unwrap_or(false) {
                -src
            } else {
                src
            }
        };
        [pick(0), pick(1), pick(2)]
    }

    /// Map an i32 vector (e.g. raw counts), saturating `-i32::MIN`.
    // `apply`'s selection again: `Neg` on i32 would overflow at `i32::MIN`.
    #[must_use]
    pub fn apply_i32(&self, v: [i32; 3]) -> [i32; 3] {
        let pick = |i: usize| {
            let src = match self.axis.get(i).copied().unwrap_or(2) {
                0 => v[0],
                1 => v[1],
                _ => v[2],
            };
            if self.negate.get(i).copied().unwrap_or(false) {
                src.saturating_neg()
            } else {
                src
            }
        };
        [pick(0), pick(1), pick(2)]
    }

    /// The alignment equal to applying `self` first and then `next`.
    #[must_use]
    pub fn then(&self, next: &Alignment) -> Alignment {
        let mut axis = [0u8; 3];
        let mut negate = [false; 3];
        for (i, (a, n)) in axis.iter_mut().zip(negate.iter_mut()).enumerate() {
            let j = match next.axis.get(i).copied().unwrap_or(2) {
                0 => 0usize,
                1 => 1,
                _ => 2,
            };
            *a = self.axis.get(j).copied().unwrap_or(2);
            *n = self.negate.get(j).copied().unwrap_or(false)
                ^ next.negate.get(i).copied().unwrap_or(false);
        }
        Alignment { axis, negate }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn enu_ned_roundtrip_and_axes() {
        let q = Quaternion::from_axis_angle([0.3, -0.5, 0.8], 1.1);
        let back = ned_from_enu(enu_from_ned(q));
        assert!((back.w - q.w).abs() < 1e-6 && (back.z - q.z).abs() < 1e-6);
        // NED down is ENU -up.
        let v = Q_ENU_FROM_NED.rotate([0.0, 0.0, 1.0]);
        assert!((v[2] + 1.0).abs() < 1e-6);
        let v = Q_ENU_FROM_NED.rotate([0.0, 1.0, 0.0]);
        assert!((v[0] - 1.0).abs() < 1e-6);
        // body vector rotated into ENU equals ned_to_enu of the NED vector
        let b = [0.2, -0.7, 0.4];
        let ned = q.rotate(b);
        let enu = enu_from_ned(q).rotate(b);
        let e2 = ned_to_enu(ned);
        for i in 0..3 {
            assert!((enu[i] - e2[i]).abs() < 1e-5);
        }
    }

    #[test]
    fn alignment_compose() {
        let v = [1.0f32, 2.0, 3.0];
        let mag_to_frd = Alignment::AK8963_TO_MPU.then(&Alignment::MPU_TO_FRD);
        assert_eq!(
            mag_to_frd.apply(v),
            Alignment::MPU_TO_FRD.apply(Alignment::AK8963_TO_MPU.apply(v))
        );
        assert_eq!(mag_to_frd.apply(v), [2.0, -1.0, 3.0]);
        assert_eq!(Alignment::IDENTITY.apply(v), v);
        assert_eq!(
            Alignment::AK8963_TO_MPU.apply_i32([1, 2, i32::MIN]),
            [2, 1, i32::MAX]
        );
    }
}
