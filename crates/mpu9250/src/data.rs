//! Pure parsing and conversion (no bus): usable from a DMA or interrupt transport.
//!
//! All vectors are in the **MPU sensor frame** (datasheet §9.1, axes printed on
//! the package): right-handed, z out of the top face. At rest, flat and face up,
//! the accelerometer reads (0, 0, +1 g) (specific force); a positive gyro
//! reading is a counter-clockwise rotation about that axis seen from its tip.

use crate::config::{AccelRange, Config, GyroRange};
use crate::register::SAMPLE_LEN;

/// One raw burst: counts as the chip reports them, MPU sensor frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawSample {
    /// Accelerometer x, y, z counts.
    pub accel: [i16; 3],
    /// Temperature counts (TEMP_OUT).
    pub temp: i16,
    /// Gyroscope x, y, z counts.
    pub gyro: [i16; 3],
}

/// One converted sample, MPU sensor frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// Specific force in g (at rest, face up: (0, 0, +1)).
    pub accel_g: [f32; 3],
    /// Angular rate in °/s (gyro bias already removed by [`Mpu9250::read`](crate::Mpu9250::read)).
    pub gyro_dps: [f32; 3],
    /// Die temperature in °C.
    pub temp_c: f32,
}

impl Sample {
    /// Angular rate in rad/s.
    pub fn gyro_rps(&self) -> [f32; 3] {
        dps_to_rps(self.gyro_dps)
    }
}

/// Room-temperature offset of TEMP_OUT, °C (register map, TEMP_OUT).
pub const TEMP_OFFSET_C: f32 = 21.0;
/// Temperature sensitivity, LSB/°C (register map, TEMP_OUT).
pub const TEMP_LSB_PER_C: f32 = 333.87;
/// Radians per degree.
pub const RAD_PER_DEG: f32 = core::f32::consts::PI / 180.0;

/// Parse the 14-byte ACCEL_XOUT_H..GYRO_ZOUT_L burst (big-endian pairs).
///
/// ```
/// let bytes = [0x20, 0x00, 0xE0, 0x00, 0x00, 0x01, 0x00, 0x00, 0x7F, 0xFF, 0x80, 0x00, 0xFF, 0xFF];
/// let raw = mpu9250::parse_sample(&bytes);
/// assert_eq!(raw.accel, [8192, -8192, 1]);
/// assert_eq!(raw.temp, 0);
/// assert_eq!(raw.gyro, [32767, -32768, -1]);
/// ```
pub const fn parse_sample(bytes: &[u8; SAMPLE_LEN]) -> RawSample {
    RawSample {
        accel: [
            i16::from_be_bytes([bytes[0], bytes[1]]),
            i16::from_be_bytes([bytes[2], bytes[3]]),
            i16::from_be_bytes([bytes[4], bytes[5]]),
        ],
        temp: i16::from_be_bytes([bytes[6], bytes[7]]),
        gyro: [
            i16::from_be_bytes([bytes[8], bytes[9]]),
            i16::from_be_bytes([bytes[10], bytes[11]]),
            i16::from_be_bytes([bytes[12], bytes[13]]),
        ],
    }
}

/// Subtract a gyro bias (counts) from a raw sample, saturating at the i16 limits.
pub const fn apply_gyro_bias(raw: RawSample, bias: [i16; 3]) -> RawSample {
    RawSample {
        accel: raw.accel,
        temp: raw.temp,
        gyro: [
            raw.gyro[0].saturating_sub(bias[0]),
            raw.gyro[1].saturating_sub(bias[1]),
            raw.gyro[2].saturating_sub(bias[2]),
        ],
    }
}

/// Precomputed conversion factors for one range setting (multiplies only, no division).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Scale {
    /// g per accelerometer count.
    pub g_per_lsb: f32,
    /// °/s per gyroscope count.
    pub dps_per_lsb: f32,
}

impl Scale {
    /// Factors for the given ranges.
    pub const fn new(accel: AccelRange, gyro: GyroRange) -> Self {
        Self {
            g_per_lsb: accel.g_per_lsb(),
            dps_per_lsb: gyro.dps_per_lsb(),
        }
    }

    /// Factors for a configuration.
    pub const fn from_config(config: &Config) -> Self {
        Self::new(config.accel_range, config.gyro_range)
    }
}

/// Convert counts to g / °/s / °C (no bias handling; see [`apply_gyro_bias`]).
pub fn convert(raw: &RawSample, scale: &Scale) -> Sample {
    Sample {
        accel_g: [
            f32::from(raw.accel[0]) * scale.g_per_lsb,
            f32::from(raw.accel[1]) * scale.g_per_lsb,
            f32::from(raw.accel[2]) * scale.g_per_lsb,
        ],
        gyro_dps: [
            f32::from(raw.gyro[0]) * scale.dps_per_lsb,
            f32::from(raw.gyro[1]) * scale.dps_per_lsb,
            f32::from(raw.gyro[2]) * scale.dps_per_lsb,
        ],
        temp_c: temp_c(raw.temp),
    }
}

/// Die temperature in °C: `TEMP_OUT / 333.87 + 21`.
pub fn temp_c(raw: i16) -> f32 {
    f32::from(raw) * (1.0 / TEMP_LSB_PER_C) + TEMP_OFFSET_C
}

/// Die temperature in 0.01 °C, integer only: `raw * 10000 / 33387 + 2100`,
/// rounded to nearest (no overflow for any i16).
pub const fn temp_centi_c(raw: i16) -> i32 {
    let n = (raw as i32) * 10_000; // |n| <= 327_680_000
    let half = if n >= 0 { 33_387 / 2 } else { -(33_387 / 2) };
    (n + half) / 33_387 + 2_100
}

/// Convert a rate vector from °/s to rad/s.
pub fn dps_to_rps(v_dps: [f32; 3]) -> [f32; 3] {
    [
        v_dps[0] * RAD_PER_DEG,
        v_dps[1] * RAD_PER_DEG,
        v_dps[2] * RAD_PER_DEG,
    ]
}

/// Re-express a gyro bias measured at range `from` in counts of range `to`.
/// Gyro sensitivities are exact powers of two apart (32768 / full scale), so
/// this is a shift; the result saturates at the i16 limits.
pub const fn rescale_gyro_bias(bias: [i16; 3], from: GyroRange, to: GyroRange) -> [i16; 3] {
    let shift = from.fs_sel() as i32 - to.fs_sel() as i32;
    [
        shift_saturating(bias[0], shift),
        shift_saturating(bias[1], shift),
        shift_saturating(bias[2], shift),
    ]
}

/// `b * 2^shift` (shift in -3..=3), saturated to i16.
const fn shift_saturating(b: i16, shift: i32) -> i16 {
    let b = b as i32;
    // |b| <= 32768 and |shift| <= 3: no i32 overflow.
    let v = if shift >= 0 { b << shift } else { b >> -shift };
    if v > i16::MAX as i32 {
        i16::MAX
    } else if v < i16::MIN as i32 {
        i16::MIN
    } else {
        v as i16
    }
}
