//! Correction types: plain `Copy`, `#[repr(C)]` data the firmware can store in
//! flash, each with `apply`, `identity`, `is_finite` and `validate`.

use crate::{Error, MAX_GAIN, MIN_GAIN};

/// `true` when every component is finite.
fn finite3(v: &[f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// `true` when `g` lies in the plausible gain range.
fn gain_ok(g: f32) -> bool {
    (MIN_GAIN..=MAX_GAIN).contains(&g)
}

/// Gyroscope bias measured at rest: `corrected = raw − bias`.
///
/// `bias` is in the unit of the rate samples it was estimated from (rad/s,
/// °/s or raw counts: whatever was fed to
/// [`GyroBiasEstimator`](crate::GyroBiasEstimator)).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroBias {
    /// Per-axis bias (x, y, z), input unit.
    pub bias: [f32; 3],
}

impl GyroBias {
    /// No correction (zero bias).
    pub const fn identity() -> Self {
        Self { bias: [0.0; 3] }
    }

    /// Remove the bias: `raw − bias`.
    pub fn apply(&self, raw: [f32; 3]) -> [f32; 3] {
        let [x, y, z] = raw;
        let [bx, by, bz] = self.bias;
        [x - bx, y - by, z - bz]
    }

    /// `true` when every field is finite.
    pub fn is_finite(&self) -> bool {
        finite3(&self.bias)
    }

    /// Check the record is usable: finite and each `|bias|` at most
    /// `max_abs_bias` (input unit; MPU-9250 ±5 °/s ≈ 0.09 rad/s is typical).
    pub fn validate(&self, max_abs_bias: f32) -> Result<(), Error> {
        if self.is_finite() && self.bias.iter().all(|b| b.abs() <= max_abs_bias) {
            Ok(())
        } else {
            Err(Error::OutOfRange)
        }
    }
}

impl Default for GyroBias {
    fn default() -> Self {
        Self::identity()
    }
}

/// Magnetometer hard- and soft-iron correction:
/// `corrected = soft_iron · (raw − offset)`.
///
/// `offset` (the hard-iron offset, the centre of the raw data) is in the input
/// unit (µT, gauss, counts, ...); `soft_iron` is dimensionless, row-major
/// (`soft_iron[row][col]`), and scaled so the corrected field keeps the
/// average raw field magnitude, so the output stays in the input unit.
/// [`MagMinMax`](crate::MagMinMax) produces a diagonal matrix,
/// [`EllipsoidFit`](crate::EllipsoidFit) a full symmetric positive-definite one.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagCalibration {
    /// Hard-iron offset (x, y, z), input unit.
    pub offset: [f32; 3],
    /// Soft-iron matrix, row-major, dimensionless.
    pub soft_iron: [[f32; 3]; 3],
}

impl MagCalibration {
    /// No correction: zero offset, identity matrix.
    pub const fn identity() -> Self {
        Self {
            offset: [0.0; 3],
            soft_iron: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        }
    }

    /// Correct a raw sample: `soft_iron · (raw − offset)`. 9 multiplies,
    /// 9 additions/subtractions.
    pub fn apply(&self, raw: [f32; 3]) -> [f32; 3] {
        let [x, y, z] = raw;
        let [ox, oy, oz] = self.offset;
        let (dx, dy, dz) = (x - ox, y - oy, z - oz);
        let [r0, r1, r2] = &self.soft_iron;
        [
            r0[0] * dx + r0[1] * dy + r0[2] * dz,
            r1[0] * dx + r1[1] * dy + r1[2] * dz,
            r2[0] * dx + r2[1] * dy + r2[2] * dz,
        ]
    }

    /// `true` when every field is finite.
    pub fn is_finite(&self) -> bool {
        finite3(&self.offset) && self.soft_iron.iter().all(finite3)
    }

    /// Check the record is plausible: all finite, every diagonal gain within
    /// [`MIN_GAIN`]..=[`MAX_GAIN`], and the symmetric part of `soft_iron`
    /// positive definite (the correction never flips or collapses a
    /// direction). The offset's size is not checked (its unit is unknown
    /// here).
    pub fn validate(&self) -> Result<(), Error> {
        if !self.is_finite() {
            return Err(Error::OutOfRange);
        }
        let [r0, r1, r2] = &self.soft_iron;
        if !(gain_ok(r0[0]) && gain_ok(r1[1]) && gain_ok(r2[2])) {
            return Err(Error::OutOfRange);
        }
        // Symmetric part, Sylvester's criterion on leading principal minors.
        let a = r0[0];
        let b = 0.5 * (r0[1] + r1[0]);
        let c = 0.5 * (r0[2] + r2[0]);
        let d = r1[1];
        let e = 0.5 * (r1[2] + r2[1]);
        let g = r2[2];
        let m2 = a * d - b * b;
        let m3 = a * (d * g - e * e) - b * (b * g - e * c) + c * (b * e - d * c);
        if m2 > 0.0 && m3 > 0.0 {
            Ok(())
        } else {
            Err(Error::OutOfRange)
        }
    }
}

impl Default for MagCalibration {
    fn default() -> Self {
        Self::identity()
    }
}

/// Accelerometer per-axis offset and scale:
/// `corrected = scale ⊙ (raw − offset)` (element-wise).
///
/// `offset` is in the input unit; `scale` is dimensionless and maps the raw
/// reading onto the configured gravity magnitude (1.0 when working in g,
/// 9.80665 when working in m/s², see
/// [`AccelSixPositionConfig::gravity`](crate::AccelSixPositionConfig::gravity)).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelCalibration {
    /// Per-axis offset (x, y, z), input unit.
    pub offset: [f32; 3],
    /// Per-axis scale factor, dimensionless.
    pub scale: [f32; 3],
}

impl AccelCalibration {
    /// No correction: zero offset, unit scale.
    pub const fn identity() -> Self {
        Self {
            offset: [0.0; 3],
            scale: [1.0; 3],
        }
    }

    /// Correct a raw sample: `scale ⊙ (raw − offset)`.
    pub fn apply(&self, raw: [f32; 3]) -> [f32; 3] {
        let [x, y, z] = raw;
        let [ox, oy, oz] = self.offset;
        let [sx, sy, sz] = self.scale;
        [sx * (x - ox), sy * (y - oy), sz * (z - oz)]
    }

    /// `true` when every field is finite.
    pub fn is_finite(&self) -> bool {
        finite3(&self.offset) && finite3(&self.scale)
    }

    /// Check the record is plausible: all finite and every scale within
    /// [`MIN_GAIN`]..=[`MAX_GAIN`]. The offset's size is not checked (its
    /// unit is unknown here).
    pub fn validate(&self) -> Result<(), Error> {
        if self.is_finite() && self.scale.iter().all(|&s| gain_ok(s)) {
            Ok(())
        } else {
            Err(Error::OutOfRange)
        }
    }
}

impl Default for AccelCalibration {
    fn default() -> Self {
        Self::identity()
    }
}
