//! Pure parsing, conversion, calibration and axis alignment (no bus).
//!
//! **Frames.** Raw counts, [`RawMag`], [`Sample::field_ut`] and the
//! [`HardSoftIron`] correction are in the **AK8963 sensor frame**, which
//! inside the MPU-9250 is (MPU-9250 datasheet §9.1):
//! x_mag = y_mpu, y_mag = x_mpu, z_mag = −z_mpu.
//! [`to_mpu_frame`] / [`to_mpu_frame_counts`] map a vector into the MPU
//! sensor frame shared with the accelerometer and gyroscope (a swap of x and
//! y and a sign flip of z; the map is its own inverse).

use crate::config::Resolution;
use crate::register as reg;

/// Measurement range: the datasheet guarantees correct data only while
/// |X| + |Y| + |Z| ≤ 4912 µT; beyond it the chip sets ST2 HOFL.
pub const MEASUREMENT_RANGE_UT: f32 = 4912.0;
/// [`MEASUREMENT_RANGE_UT`] in nT (exact integer).
pub const MEASUREMENT_RANGE_NT: i32 = 4_912_000;

/// Marker error: ST2 HOFL was set (or the reading exceeds the measurement
/// range); the measurement must be dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Overflow;

/// Why [`parse_measurement`] rejected a measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejected {
    /// ST1 DRDY was clear: no new measurement (only from
    /// [`parse_status_block`]; the data bytes are stale).
    NotReady,
    /// ST2 HOFL was set or the reading exceeds the measurement range.
    Overflow,
    /// ST2 BITM (the output width the chip used) differs from the configured
    /// resolution: the counts would be scaled by the wrong factor, and the
    /// chip's CNTL1 no longer holds what was written (a reset or a corrupted
    /// write). PX4 drops such samples too.
    ResolutionMismatch {
        /// The resolution the driver was configured for.
        configured: Resolution,
    },
}

impl From<Overflow> for Rejected {
    fn from(_: Overflow) -> Self {
        Rejected::Overflow
    }
}

/// One measurement in counts, AK8963 sensor frame, without factory adjustment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawMag {
    /// HX, HY, HZ counts.
    pub counts: [i16; 3],
    /// Resolution the counts are in.
    pub resolution: Resolution,
    /// ST1 DOR: at least one measurement was skipped before this one (it is
    /// still a valid, current reading). [`parse_measurement`] cannot see ST1
    /// and sets it to `false`; [`Ak8963::read_raw`](crate::Ak8963::read_raw) fills it in.
    pub data_overrun: bool,
}

/// One converted measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// Magnetic flux density in µT, AK8963 sensor frame, factory sensitivity
    /// adjustment and hard/soft-iron correction applied. Use
    /// [`Sample::field_mpu_ut`] for the MPU frame.
    pub field_ut: [f32; 3],
    /// ST1 DOR: a measurement was skipped before this one (data still valid).
    pub data_overrun: bool,
}

impl Sample {
    /// [`field_ut`](Self::field_ut) in the MPU sensor frame.
    pub fn field_mpu_ut(&self) -> [f32; 3] {
        to_mpu_frame(self.field_ut)
    }
}

/// Decoded ST1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct St1 {
    /// DRDY: a measurement is waiting.
    pub data_ready: bool,
    /// DOR: a measurement was skipped.
    pub data_overrun: bool,
}

/// Decode ST1.
pub const fn parse_st1(st1: u8) -> St1 {
    St1 {
        data_ready: st1 & reg::ST1_DRDY != 0,
        data_overrun: st1 & reg::ST1_DOR != 0,
    }
}

/// Parse the 7-byte HXL..ST2 burst (little-endian X, Y, Z, then ST2).
///
/// Returns [`Rejected::Overflow`] when ST2 HOFL is set or when |X| + |Y| + |Z|
/// exceeds the 4912 µT measurement range (see [`exceeds_range`]), and
/// [`Rejected::ResolutionMismatch`] when ST2 BITM disagrees with `resolution`.
///
/// ```
/// use ak8963::{parse_measurement, Rejected, Resolution};
/// let m = parse_measurement(&[0x10, 0x00, 0xF0, 0xFF, 0x00, 0x01, 0x10], Resolution::Bits16).unwrap();
/// assert_eq!(m.counts, [16, -16, 256]);
/// assert_eq!(parse_measurement(&[0, 0, 0, 0, 0, 0, 0x18], Resolution::Bits16), Err(Rejected::Overflow));
/// // BITM clear: the chip measured in 14 bit although 16 bit was configured.
/// assert_eq!(
///     parse_measurement(&[0x10, 0x00, 0xF0, 0xFF, 0x00, 0x01, 0x00], Resolution::Bits16),
///     Err(Rejected::ResolutionMismatch { configured: Resolution::Bits16 })
/// );
/// ```
pub const fn parse_measurement(
    bytes: &[u8; reg::MEASUREMENT_LEN],
    resolution: Resolution,
) -> Result<RawMag, Rejected> {
    let counts = [
        i16::from_le_bytes([bytes[0], bytes[1]]),
        i16::from_le_bytes([bytes[2], bytes[3]]),
        i16::from_le_bytes([bytes[4], bytes[5]]),
    ];
    let st2 = bytes[6];
    // HOFL first: an overflowing sample is dropped whatever its width.
    if st2 & reg::ST2_HOFL != 0 || exceeds_range(counts, resolution) {
        return Err(Rejected::Overflow);
    }
    let bitm_16 = st2 & reg::ST2_BITM != 0;
    if bitm_16 != matches!(resolution, Resolution::Bits16) {
        return Err(Rejected::ResolutionMismatch {
            configured: resolution,
        });
    }
    Ok(RawMag {
        counts,
        resolution,
        data_overrun: false,
    })
}

/// Parse the 8-byte ST1..ST2 block (ST1, HXL..HZH, ST2), as the MPU-9250's
/// internal I2C master copies it into EXT_SENS_DATA_00..07 every sample when
/// its slave 0 reads 8 bytes from ST1. The same checks as a direct read:
/// DRDY clear is [`Rejected::NotReady`], then HOFL / range
/// ([`Rejected::Overflow`]) and BITM ([`Rejected::ResolutionMismatch`]);
/// ST1 DOR is returned as [`RawMag::data_overrun`].
///
/// ```
/// use ak8963::{parse_status_block, Rejected, Resolution};
/// let m = parse_status_block(&[0x01, 200, 0, 0x9C, 0xFF, 0, 0, 0x10], Resolution::Bits16).unwrap();
/// assert_eq!(m.counts, [200, -100, 0]);
/// assert_eq!(parse_status_block(&[0x00, 200, 0, 0, 0, 0, 0, 0x10], Resolution::Bits16), Err(Rejected::NotReady));
/// ```
pub const fn parse_status_block(
    bytes: &[u8; reg::STATUS_BLOCK_LEN],
    resolution: Resolution,
) -> Result<RawMag, Rejected> {
    let st1 = parse_st1(bytes[0]);
    if !st1.data_ready {
        return Err(Rejected::NotReady);
    }
    let measurement = [
        bytes[1], bytes[2], bytes[3], bytes[4], bytes[5], bytes[6], bytes[7],
    ];
    match parse_measurement(&measurement, resolution) {
        Ok(mut raw) => {
            raw.data_overrun = st1.data_overrun;
            Ok(raw)
        }
        Err(e) => Err(e),
    }
}

/// Whether |X| + |Y| + |Z| (counts × sensitivity, before the factory
/// adjustment) exceeds [`MEASUREMENT_RANGE_UT`]: the datasheet's overflow
/// condition (16-bit: above 32746 counts summed; 14-bit: above 8186).
/// Integer arithmetic only.
pub const fn exceeds_range(counts: [i16; 3], resolution: Resolution) -> bool {
    let sum = (counts[0] as i32).abs() + (counts[1] as i32).abs() + (counts[2] as i32).abs();
    // sum <= 98_304, × 600 <= 58_982_400: fits i32.
    sum * resolution.nt_per_lsb() as i32 > MEASUREMENT_RANGE_NT
}

/// Factory sensitivity adjustment for one axis:
/// `Hadj = H × ((ASA − 128) × 0.5 / 128 + 1) = H × (ASA − 128) / 256 + H`.
/// Computed in i32/f32 (no u8 underflow for ASA < 128).
///
/// ```
/// assert_eq!(ak8963::adjustment_factor(0x80), 1.0);
/// assert_eq!(ak8963::adjustment_factor(0xB0), 1.1875);
/// assert_eq!(ak8963::adjustment_factor(0xAC), 1.171875);
/// assert_eq!(ak8963::adjustment_factor(0x00), 0.5);
/// ```
pub fn adjustment_factor(asa: u8) -> f32 {
    (i32::from(asa) - 128) as f32 * (1.0 / 256.0) + 1.0
}

/// The same factor in Q8 (×256), exact integer: `ASA + 128`
/// (so `Hadj = H × adjustment_q8(ASA) / 256`).
pub const fn adjustment_q8(asa: u8) -> u16 {
    asa as u16 + 128
}

/// Whether a fuse-ROM ASA value is plausible (0x00 and 0xFF are what an
/// unprogrammed, unread or stuck bus returns).
pub const fn asa_valid(asa: u8) -> bool {
    asa != 0x00 && asa != 0xFF
}

/// Per-axis conversion factor µT/count = sensitivity × factory adjustment.
pub fn ut_per_lsb(asa: [u8; 3], resolution: Resolution) -> [f32; 3] {
    let s = resolution.ut_per_lsb();
    [
        s * adjustment_factor(asa[0]),
        s * adjustment_factor(asa[1]),
        s * adjustment_factor(asa[2]),
    ]
}

/// Counts to µT with per-axis factors from [`ut_per_lsb`] (AK8963 frame, no
/// hard/soft-iron correction).
pub fn counts_to_ut(counts: [i16; 3], ut_per_lsb: &[f32; 3]) -> [f32; 3] {
    [
        f32::from(counts[0]) * ut_per_lsb[0],
        f32::from(counts[1]) * ut_per_lsb[1],
        f32::from(counts[2]) * ut_per_lsb[2],
    ]
}

/// AK8963 frame → MPU sensor frame: `[v[1], v[0], -v[2]]`.
///
/// ```
/// assert_eq!(ak8963::to_mpu_frame([1.0, 2.0, 3.0]), [2.0, 1.0, -3.0]);
/// ```
pub fn to_mpu_frame(v: [f32; 3]) -> [f32; 3] {
    [v[1], v[0], -v[2]]
}

/// [`to_mpu_frame`] for raw counts (z negation saturates: −32768 → 32767,
/// which the chip never outputs).
pub const fn to_mpu_frame_counts(v: [i16; 3]) -> [i16; 3] {
    [v[1], v[0], v[2].saturating_neg()]
}

/// Why a hard/soft-iron calibration could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationError {
    /// max ≤ min (or not finite) on this axis (0 = x, 1 = y, 2 = z).
    ZeroSpan {
        /// Axis index.
        axis: u8,
    },
}

/// Hard- and soft-iron correction in the AK8963 frame, µT:
/// `corrected = matrix · (field − offset_ut)`.
///
/// The default is no correction (zero offset, identity matrix). A per-axis
/// scale is the diagonal case ([`HardSoftIron::diagonal`],
/// [`HardSoftIron::from_min_max`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HardSoftIron {
    /// Hard-iron offset, µT.
    pub offset_ut: [f32; 3],
    /// Soft-iron matrix, row-major, dimensionless.
    pub matrix: [[f32; 3]; 3],
}

impl Default for HardSoftIron {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl HardSoftIron {
    /// No correction.
    pub const IDENTITY: Self = Self {
        offset_ut: [0.0; 3],
        matrix: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    /// Offset plus per-axis scale (diagonal matrix).
    pub const fn diagonal(offset_ut: [f32; 3], scale: [f32; 3]) -> Self {
        Self {
            offset_ut,
            matrix: [
                [scale[0], 0.0, 0.0],
                [0.0, scale[1], 0.0],
                [0.0, 0.0, scale[2]],
            ],
        }
    }

    /// Diagonal calibration from per-axis extremes seen while rotating the
    /// sensor through all orientations: offset = (max + min) / 2, each axis
    /// scaled so its half-span equals the mean half-span of the three axes.
    ///
    /// ```
    /// use ak8963::HardSoftIron;
    /// let c = HardSoftIron::from_min_max([-30.0, -50.0, -40.0], [50.0, 30.0, 60.0]).unwrap();
    /// assert_eq!(c.offset_ut, [10.0, -10.0, 10.0]);
    /// // half-spans 40, 40, 50 -> mean 43.33: a reading at the x maximum maps to 43.33
    /// let v = c.apply([50.0, -10.0, 10.0]);
    /// assert!((v[0] - 43.333).abs() < 1e-3 && v[1] == 0.0 && v[2] == 0.0);
    /// ```
    pub fn from_min_max(min_ut: [f32; 3], max_ut: [f32; 3]) -> Result<Self, CalibrationError> {
        let mut offset = [0.0f32; 3];
        let mut half = [0.0f32; 3];
        for axis in 0..3u8 {
            let i = usize::from(axis);
            let (lo, hi) = (min_ut[i], max_ut[i]);
            let h = (hi - lo) * 0.5;
            // NaN fails `h > 0`; infinities fail `is_finite`.
            let valid = h > 0.0 && h.is_finite();
            if !valid {
                return Err(CalibrationError::ZeroSpan { axis });
            }
            offset[i] = (hi + lo) * 0.5;
            half[i] = h;
        }
        let mean = (half[0] + half[1] + half[2]) * (1.0 / 3.0);
        Ok(Self::diagonal(
            offset,
            [mean / half[0], mean / half[1], mean / half[2]],
        ))
    }

    /// Apply the correction: `matrix · (field_ut − offset_ut)`.
    pub fn apply(&self, field_ut: [f32; 3]) -> [f32; 3] {
        let d = [
            field_ut[0] - self.offset_ut[0],
            field_ut[1] - self.offset_ut[1],
            field_ut[2] - self.offset_ut[2],
        ];
        let m = &self.matrix;
        [
            m[0][0] * d[0] + m[0][1] * d[1] + m[0][2] * d[2],
            m[1][0] * d[0] + m[1][1] * d[1] + m[1][2] * d[2],
            m[2][0] * d[0] + m[2][1] * d[1] + m[2][2] * d[2],
        ]
    }
}

/// Convert a raw measurement: counts × (sensitivity × factory adjustment),
/// then the hard/soft-iron correction. AK8963 frame.
pub fn convert(raw: &RawMag, ut_per_lsb: &[f32; 3], calibration: &HardSoftIron) -> Sample {
    Sample {
        field_ut: calibration.apply(counts_to_ut(raw.counts, ut_per_lsb)),
        data_overrun: raw.data_overrun,
    }
}
