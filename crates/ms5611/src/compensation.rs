//! Integer temperature and pressure compensation (datasheet MS5611-01BA03,
//! "Pressure and temperature calculation" and "Second order temperature
//! compensation").
//!
//! # Rounding
//!
//! Every "/ 2^n" of the datasheet is an arithmetic right shift (floor
//! division), as in the datasheet's reference implementations for 32-bit
//! MCUs; it differs from C's truncating `/` by at most 1 LSB, and only for
//! negative intermediates. No 64-bit division is used (it is a slow library
//! call on a Cortex-M3).
//!
//! # Overflow
//!
//! For any PROM (C1..C6 < 2^16) and any D1, D2 < 2^24 every intermediate
//! fits its type with margin:
//!
//! * |dT| < 2^24 (i32); |dT·C6| < 2^40 (i64); |TEMP − 2000| < 2^17.
//! * |OFF| < 2^32 + 2^33, |SENS| < 2^31 + 2^32; OFF2 < 2^38, SENS2 < 2^37
//!   (since |TEMP − 2000|, |TEMP + 1500| < 2^17).
//! * |D1·(SENS − SENS2)| < 2^24 · 2^38 = 2^62 (i64); |P| < 2^27 (i32).
//!
//! The final narrowing to i32 saturates anyway, so even a broken bound could
//! not panic or wrap. Inputs ≥ 2^24 are rejected with [`RawOutOfRange`].

use core::fmt;

use crate::{Channel, Prom};

/// Exclusive upper bound of a 24-bit ADC value.
pub const ADC_LIMIT: u32 = 1 << 24;

/// A raw ADC value was not a 24-bit number (≥ 2^24).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawOutOfRange {
    /// Which input: D1 (pressure) or D2 (temperature).
    pub channel: Channel,
    /// The rejected value.
    pub raw: u32,
}

impl fmt::Display for RawOutOfRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self.channel {
            Channel::Pressure => "D1",
            Channel::Temperature => "D2",
        };
        write!(f, "MS5611 raw {name} = {} is not a 24-bit value", self.raw)
    }
}

impl core::error::Error for RawOutOfRange {}

/// A compensated measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Measurement {
    /// Temperature-compensated pressure, Pa (= 0.01 mbar).
    pub pressure_pa: i32,
    /// Temperature, 0.01 °C (2007 = 20.07 °C).
    pub temperature_centi_c: i32,
}

impl Measurement {
    /// Pressure in mbar (hPa). Uses one f32 multiply (soft-float on a
    /// Cortex-M3); prefer [`Measurement::pressure_pa`] in hot paths.
    pub fn pressure_mbar(&self) -> f32 {
        self.pressure_pa as f32 * 0.01
    }

    /// Pressure in 0.01 mbar: numerically the same as Pa.
    pub const fn pressure_centi_mbar(&self) -> i32 {
        self.pressure_pa
    }

    /// Temperature in °C (f32).
    pub fn temperature_c(&self) -> f32 {
        self.temperature_centi_c as f32 * 0.01
    }
}

/// Every intermediate of the datasheet calculation, for verification.
///
/// Names follow the datasheet. First-order values are before the second
/// order correction is subtracted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Compensation {
    /// D1: raw pressure ADC value (< 2^24).
    pub d1: u32,
    /// D2: raw temperature ADC value (< 2^24).
    pub d2: u32,
    /// dT = D2 − C5·2^8.
    pub dt: i32,
    /// First-order TEMP = 2000 + dT·C6/2^23, 0.01 °C.
    pub temp_centi_c: i32,
    /// First-order OFF = C2·2^16 + C4·dT/2^7.
    pub off: i64,
    /// First-order SENS = C1·2^15 + C3·dT/2^8.
    pub sens: i64,
    /// Second-order T2 (0 at and above 20 °C), 0.01 °C.
    pub t2_centi_c: i32,
    /// Second-order OFF2 (0 at and above 20 °C).
    pub off2: i64,
    /// Second-order SENS2 (0 at and above 20 °C).
    pub sens2: i64,
    /// Final temperature TEMP − T2, 0.01 °C.
    pub temperature_centi_c: i32,
    /// Final P = (D1·(SENS − SENS2)/2^21 − (OFF − OFF2))/2^15, Pa.
    pub pressure_pa: i32,
}

impl Compensation {
    /// The final pressure and temperature.
    pub const fn measurement(&self) -> Measurement {
        Measurement {
            pressure_pa: self.pressure_pa,
            temperature_centi_c: self.temperature_centi_c,
        }
    }
}

/// Saturating i64 → i32 (unreachable saturation, see the module docs).
fn saturate_i32(v: i64) -> i32 {
    if v > i64::from(i32::MAX) {
        i32::MAX
    } else if v < i64::from(i32::MIN) {
        i32::MIN
    } else {
        v as i32
    }
}

fn check_raw(channel: Channel, raw: u32) -> Result<u32, RawOutOfRange> {
    if raw < ADC_LIMIT {
        Ok(raw)
    } else {
        Err(RawOutOfRange { channel, raw })
    }
}

/// Full datasheet calculation with every intermediate.
///
/// ```
/// // The datasheet's worked example.
/// let prom = ms5611::Prom::from_coefficients([40127, 36924, 23317, 23282, 33464, 28312]);
/// let c = ms5611::compensate_detailed(&prom, 9_085_466, 8_569_150).unwrap();
/// assert_eq!((c.dt, c.temp_centi_c), (2366, 2007));
/// assert_eq!((c.off, c.sens), (2_420_281_617, 1_315_097_036));
/// assert_eq!(c.pressure_pa, 100_009);
/// ```
pub fn compensate_detailed(prom: &Prom, d1: u32, d2: u32) -> Result<Compensation, RawOutOfRange> {
    let d1 = check_raw(Channel::Pressure, d1)?;
    let d2 = check_raw(Channel::Temperature, d2)?;
    // Both are < 2^24 from here on, so `as i32` below is lossless.
    let [c1, c2, c3, c4, _, c6] = prom.coefficients().map(i64::from);

    // dT = D2 - C5 * 2^8, in (-2^24, 2^24): computed in i32 so that the
    // products below are 32x32->64-bit multiplies (one SMULL on a Cortex-M3).
    let dt32: i32 = (d2 as i32) - (i32::from(prom.c5()) << 8);
    let dt = i64::from(dt32);
    // TEMP = 2000 + dT * C6 / 2^23, |dT*C6| < 2^40.
    let temp = 2000 + ((dt * c6) >> 23);
    // OFF = C2 * 2^16 + C4 * dT / 2^7.
    let off = (c2 << 16) + ((c4 * dt) >> 7);
    // SENS = C1 * 2^15 + C3 * dT / 2^8.
    let sens = (c1 << 15) + ((c3 * dt) >> 8);

    let (t2, off2, sens2) = if temp < 2000 {
        let t2 = (dt * dt) >> 31;
        let d = temp - 2000;
        let sq = d * d;
        let mut off2 = (5 * sq) >> 1;
        let mut sens2 = (5 * sq) >> 2;
        if temp < -1500 {
            let e = temp + 1500;
            let sq = e * e;
            off2 += 7 * sq;
            sens2 += (11 * sq) >> 1;
        }
        (t2, off2, sens2)
    } else {
        (0, 0, 0)
    };

    let off_total = off - off2;
    let sens_total = sens - sens2;
    // P = (D1 * SENS / 2^21 - OFF) / 2^15, |D1*SENS| < 2^62.
    let p = (((i64::from(d1) * sens_total) >> 21) - off_total) >> 15;

    Ok(Compensation {
        d1,
        d2,
        dt: dt32,
        temp_centi_c: saturate_i32(temp),
        off,
        sens,
        t2_centi_c: saturate_i32(t2),
        off2,
        sens2,
        temperature_centi_c: saturate_i32(temp - t2),
        pressure_pa: saturate_i32(p),
    })
}

/// Compensated pressure and temperature from the PROM and the raw D1
/// (pressure) and D2 (temperature) ADC values, including the datasheet's
/// second-order correction below 20 °C and −15 °C.
///
/// Fails only if D1 or D2 is not a 24-bit value. Pure integer arithmetic:
/// a handful of 64-bit multiplies and shifts, no division.
///
/// ```
/// let prom = ms5611::Prom::from_coefficients([40127, 36924, 23317, 23282, 33464, 28312]);
/// let m = ms5611::compensate(&prom, 9_085_466, 8_569_150).unwrap();
/// assert_eq!(m.pressure_pa, 100_009); // 1000.09 mbar
/// assert_eq!(m.temperature_centi_c, 2007); // 20.07 °C
/// ```
pub fn compensate(prom: &Prom, d1: u32, d2: u32) -> Result<Measurement, RawOutOfRange> {
    compensate_detailed(prom, d1, d2).map(|c| c.measurement())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_25_bit_inputs() {
        let prom = Prom::from_coefficients([1; 6]);
        assert_eq!(
            compensate(&prom, ADC_LIMIT, 0),
            Err(RawOutOfRange {
                channel: Channel::Pressure,
                raw: ADC_LIMIT
            })
        );
        assert_eq!(
            compensate(&prom, 0, u32::MAX),
            Err(RawOutOfRange {
                channel: Channel::Temperature,
                raw: u32::MAX
            })
        );
        assert!(compensate(&prom, ADC_LIMIT - 1, ADC_LIMIT - 1).is_ok());
    }

    #[test]
    fn saturate() {
        assert_eq!(saturate_i32(i64::MAX), i32::MAX);
        assert_eq!(saturate_i32(i64::MIN), i32::MIN);
        assert_eq!(saturate_i32(-5), -5);
    }
}
