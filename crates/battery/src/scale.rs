//! ADC counts → pack voltage, and the scale set from one multimeter reading.
//!
//! The scale is the pack voltage that would read 4096 counts, in mV
//! (`full_scale_mv`): `pack_mv = counts · full_scale_mv / 4096`. For the
//! board's divider (10 kΩ over 1 kΩ, 11:1) on ADC1's 3.3 V reference
//! (VDDA) that is 11 · 3300 = 36 300 mV, one count 8.86 mV. The
//! resistors' tolerance and VDDA's are both in it, which is why the
//! builder sets it from a multimeter reading ([`scale_from_reading`]).
//! Integer arithmetic only (64-bit products; the chip has no FPU).

use crate::error::Error;

/// ADC1's codes: 12 bits, counts 0..=4095; the scale is the voltage at
/// 4096 counts.
pub const ADC_FULL_SCALE_COUNTS: u32 = 4096;

/// The converter's last code: a reading here means the pin is at or over
/// its reference.
pub const ADC_MAX_COUNT: u16 = 4095;

/// The least ADC reading [`scale_from_reading`] accepts (one count is then
/// ≤ 0.33 % of it: 2.66 V of pack on the default divider).
pub const MIN_CALIBRATION_COUNTS: u16 = 300;

/// The scale: pack mV at 4096 ADC counts, `pack_mv = counts ·
/// full_scale_mv / 4096` (36 300 mV for the board's 11:1 divider on 3.3 V).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Scale {
    full_scale_mv: u32,
}

impl Scale {
    /// The least accepted scale, mV: a 3.03:1 divider on 3.3 V.
    pub const MIN_FULL_SCALE_MV: u32 = 10_000;
    /// The greatest accepted scale, mV: a 24.2:1 divider on 3.3 V.
    pub const MAX_FULL_SCALE_MV: u32 = 80_000;
    /// The board's divider, 10 kΩ over 1 kΩ (11:1), on a 3.3 V reference:
    /// 36 300 mV at 4096 counts, so 8S at 4.2 V (33.6 V) still reads below
    /// the converter's last code.
    pub const DEFAULT: Self = Self {
        full_scale_mv: 36_300,
    };

    /// A scale of `full_scale_mv` (pack mV at 4096 counts).
    ///
    /// # Errors
    /// [`Error::ScaleOutOfRange`] outside
    /// [`MIN_FULL_SCALE_MV`](Self::MIN_FULL_SCALE_MV)..=[`MAX_FULL_SCALE_MV`](Self::MAX_FULL_SCALE_MV).
    pub const fn new(full_scale_mv: u32) -> Result<Self, Error> {
        if full_scale_mv < Self::MIN_FULL_SCALE_MV || full_scale_mv > Self::MAX_FULL_SCALE_MV {
            return Err(Error::ScaleOutOfRange { full_scale_mv });
        }
        Ok(Self { full_scale_mv })
    }

    /// Pack mV at 4096 counts (the setting's value).
    #[must_use]
    pub const fn full_scale_mv(&self) -> u32 {
        self.full_scale_mv
    }

    /// The pack voltage of one reading, mV, rounded to nearest; a reading
    /// beyond 4095 counts is taken as 4095.
    #[must_use]
    pub fn counts_to_mv(&self, counts: u16) -> u32 {
        let c = u64::from(counts.min(ADC_MAX_COUNT));
        let mv = (c * u64::from(self.full_scale_mv) + u64::from(ADC_FULL_SCALE_COUNTS / 2))
            / u64::from(ADC_FULL_SCALE_COUNTS);
        // ≤ 4095 · 80 000 / 4096 < 2^32.
        mv as u32
    }

    /// The pack voltage of a count in Q16 (a filter's state), mV, rounded
    /// to nearest; a negative count is taken as 0, one beyond 4095 as 4095.
    #[must_use]
    pub fn counts_q16_to_mv(&self, counts_q16: i32) -> u32 {
        let c = counts_q16.clamp(0, i32::from(ADC_MAX_COUNT) << 16) as u64;
        let shift = 16 + ADC_FULL_SCALE_COUNTS.trailing_zeros();
        let mv = (c * u64::from(self.full_scale_mv) + (1 << (shift - 1))) >> shift;
        mv as u32
    }
}

impl Default for Scale {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The scale that makes `adc_counts_filtered` (a steady, averaged reading
/// of a pack at rest, e.g.
/// [`BatteryMonitor::filtered_counts`](crate::BatteryMonitor::filtered_counts))
/// read `multimeter_mv`, the pack voltage a multimeter shows at the same
/// time: `full_scale_mv = multimeter_mv · 4096 / counts`, rounded. Read
/// back through it, the reading gives `multimeter_mv` within 1 mV.
///
/// # Errors
/// [`Error::CountsTooLow`] below [`MIN_CALIBRATION_COUNTS`],
/// [`Error::CountsSaturated`] at or beyond 4095 counts,
/// [`Error::ScaleOutOfRange`] when the result is not a plausible divider.
pub fn scale_from_reading(adc_counts_filtered: u16, multimeter_mv: u32) -> Result<Scale, Error> {
    let counts = adc_counts_filtered;
    if counts >= ADC_MAX_COUNT {
        return Err(Error::CountsSaturated { counts });
    }
    if counts < MIN_CALIBRATION_COUNTS {
        return Err(Error::CountsTooLow { counts });
    }
    let c = u64::from(counts);
    let fs = (u64::from(multimeter_mv) * u64::from(ADC_FULL_SCALE_COUNTS) + c / 2) / c;
    Scale::new(u32::try_from(fs).unwrap_or(u32::MAX))
}
