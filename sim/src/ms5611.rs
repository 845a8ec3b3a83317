//! Model of the TE MS5611-01BA03 barometer (datasheet DA5611-01BA03_011)
//! and an independent transcription of its compensation (first and second
//! order), the AN520 CRC-4, and the inverse: ADC codes for a true pressure
//! and temperature.
//!
//! Commands: 0x1E reset (PROM reload 2.8 ms, the chip NACKs meanwhile),
//! 0x40..0x48 D1 / 0x50..0x58 D2 conversions per OSR (taking the datasheet's
//! maximum conversion time of the simulated clock), 0x00 ADC read (3 bytes,
//! 0 if no conversion finished, the conversion is still running — which also
//! spoils it — or the result was already read), 0xA0..0xAE PROM read (2 bytes).

use crate::bus::SimBusError;
use crate::device::Device;
use crate::world::World;
use embedded_hal::i2c::NoAcknowledgeSource;

/// The datasheet's example coefficients C1..C6 (§ "Pressure and temperature calculation").
pub const DATASHEET_C: [u16; 6] = [40127, 36924, 23317, 23282, 33464, 28312];
/// PROM reload time after reset (ns).
pub const RESET_TIME_NS: u64 = 2_800_000;
/// Maximum conversion time per OSR index (256, 512, 1024, 2048, 4096), ns.
pub const CONVERSION_TIME_NS: [u64; 5] = [600_000, 1_170_000, 2_280_000, 4_540_000, 9_040_000];
/// Pressure resolution RMS per OSR index (mbar).
pub const PRESSURE_NOISE_MBAR: [f64; 5] = [0.065, 0.042, 0.027, 0.018, 0.012];
/// Temperature resolution RMS per OSR index (°C).
pub const TEMPERATURE_NOISE_C: [f64; 5] = [0.012, 0.008, 0.005, 0.003, 0.002];

/// AN520 CRC-4 of the 8 PROM words (as in AN520, the whole low byte of word 7 is excluded).
pub fn crc4(prom: &[u16; 8]) -> u8 {
    let mut words = *prom;
    words[7] &= 0xFF00;
    let mut rem: u32 = 0;
    for cnt in 0..16 {
        let w = u32::from(words[cnt >> 1]);
        rem ^= if cnt % 2 == 1 { w & 0x00FF } else { w >> 8 };
        for _ in 0..8 {
            rem = if rem & 0x8000 != 0 {
                (rem << 1) ^ 0x3000
            } else {
                rem << 1
            };
            rem &= 0xFFFF;
        }
    }
    ((rem >> 12) & 0xF) as u8
}

/// A PROM image with coefficients `c` (C1..C6), factory word `word0`, serial
/// bits `serial12`, and a valid CRC in the low nibble of word 7.
pub fn make_prom(word0: u16, c: [u16; 6], serial12: u16) -> [u16; 8] {
    let mut p = [
        word0,
        c[0],
        c[1],
        c[2],
        c[3],
        c[4],
        c[5],
        (serial12 & 0x0FFF) << 4,
    ];
    p[7] |= u16::from(crc4(&p));
    p
}

/// Datasheet compensation in 64-bit integers, including the second-order
/// correction: returns (pressure in Pa (= 0.01 mbar), temperature in 0.01 °C).
pub fn compensate(prom: &[u16; 8], d1: u32, d2: u32) -> (i64, i64) {
    let c = |i: usize| i64::from(prom[i]);
    let d_t = i64::from(d2) - c(5) * 256;
    let mut temp = 2000 + d_t * c(6) / 8_388_608;
    let mut off = c(2) * 65_536 + (c(4) * d_t) / 128;
    let mut sens = c(1) * 32_768 + (c(3) * d_t) / 256;
    if temp < 2000 {
        let t2 = d_t * d_t / 2_147_483_648;
        let mut off2 = 5 * (temp - 2000) * (temp - 2000) / 2;
        let mut sens2 = 5 * (temp - 2000) * (temp - 2000) / 4;
        if temp < -1500 {
            off2 += 7 * (temp + 1500) * (temp + 1500);
            sens2 += 11 * (temp + 1500) * (temp + 1500) / 2;
        }
        temp -= t2;
        off -= off2;
        sens -= sens2;
    }
    let p = (i64::from(d1) * sens / 2_097_152 - off) / 32_768;
    (p, temp)
}

/// The same compensation on real numbers (no truncation): (Pa, 0.01 °C) and
/// the (OFF, SENS) it used.
fn compensate_f(prom: &[u16; 8], d1: f64, d2: f64) -> (f64, f64) {
    let c = |i: usize| f64::from(prom[i]);
    let d_t = d2 - c(5) * 256.0;
    let mut temp = 2000.0 + d_t * c(6) / 8_388_608.0;
    let (mut off, mut sens) = off_sens_f(prom, d_t);
    if temp < 2000.0 {
        let (t2, off2, sens2) = second_order_f(temp, d_t);
        temp -= t2;
        off -= off2;
        sens -= sens2;
    }
    ((d1 * sens / 2_097_152.0 - off) / 32_768.0, temp)
}

fn off_sens_f(prom: &[u16; 8], d_t: f64) -> (f64, f64) {
    let c = |i: usize| f64::from(prom[i]);
    (
        c(2) * 65_536.0 + c(4) * d_t / 128.0,
        c(1) * 32_768.0 + c(3) * d_t / 256.0,
    )
}

fn second_order_f(temp: f64, d_t: f64) -> (f64, f64, f64) {
    let t2 = d_t * d_t / 2_147_483_648.0;
    let mut off2 = 5.0 * (temp - 2000.0).powi(2) / 2.0;
    let mut sens2 = 5.0 * (temp - 2000.0).powi(2) / 4.0;
    if temp < -1500.0 {
        off2 += 7.0 * (temp + 1500.0).powi(2);
        sens2 += 11.0 * (temp + 1500.0).powi(2) / 2.0;
    }
    (t2, off2, sens2)
}

/// Inverts the compensation: 24-bit codes (D1, D2) such that
/// `compensate(prom, D1, D2)` gives `pressure_pa` and `temp_c` (to the
/// ADC's resolution). Values outside the ADC's range clamp to 0..2²⁴−1.
pub fn invert(prom: &[u16; 8], pressure_pa: f64, temp_c: f64) -> (u32, u32) {
    let target_t = temp_c * 100.0;
    // TEMP(D2) is monotonic increasing: bisection.
    let (mut lo, mut hi) = (0.0f64, 16_777_215.0f64);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if compensate_f(prom, 0.0, mid).1 < target_t {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let d2 = (0.5 * (lo + hi)).round();
    // P is linear in D1 for a fixed D2.
    let c = |i: usize| f64::from(prom[i]);
    let d_t = d2 - c(5) * 256.0;
    let temp = 2000.0 + d_t * c(6) / 8_388_608.0;
    let (mut off, mut sens) = off_sens_f(prom, d_t);
    if temp < 2000.0 {
        let (_, off2, sens2) = second_order_f(temp, d_t);
        off -= off2;
        sens -= sens2;
    }
    let d1 = if sens > 0.0 {
        (pressure_pa * 32_768.0 + off) * 2_097_152.0 / sens
    } else {
        0.0
    };
    (
        d1.round().clamp(0.0, 16_777_215.0) as u32,
        d2.clamp(0.0, 16_777_215.0) as u32,
    )
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Conversion {
    Pressure,
    Temperature,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Pending {
    None,
    Converting {
        what: Conversion,
        osr: usize,
        done_ns: u64,
        spoiled: bool,
    },
    Done {
        what: Conversion,
        osr: usize,
        done_ns: u64,
    },
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum ReadSource {
    Nothing,
    Prom(usize),
    Adc([u8; 3]),
}

/// The MS5611 model.
#[derive(Clone, Debug)]
pub struct Ms5611Model {
    prom: [u16; 8],
    pending: Pending,
    read: ReadSource,
    read_pos: usize,
    first_write: bool,
    reloading_until_ns: Option<u64>,
    last_codes: (u32, u32),
    /// XOR mask applied to PROM words when read (fault).
    pub prom_corruption: [u16; 8],
    /// Conversions return the previous codes (fault).
    pub frozen: bool,
    conversions: u64,
}

impl Default for Ms5611Model {
    fn default() -> Self {
        Self::new(make_prom(0x00A5, DATASHEET_C, 0x4E5))
    }
}

impl Ms5611Model {
    /// A chip with the given PROM image.
    pub fn new(prom: [u16; 8]) -> Self {
        Self {
            prom,
            pending: Pending::None,
            read: ReadSource::Nothing,
            read_pos: 0,
            first_write: false,
            reloading_until_ns: None,
            last_codes: (0, 0),
            prom_corruption: [0; 8],
            frozen: false,
            conversions: 0,
        }
    }

    /// The (uncorrupted) PROM image.
    pub fn prom(&self) -> [u16; 8] {
        self.prom
    }

    /// Completed conversions so far.
    pub fn conversion_count(&self) -> u64 {
        self.conversions
    }

    fn result_code(
        &mut self,
        what: Conversion,
        osr: usize,
        done_ns: u64,
        world: &mut World,
    ) -> u32 {
        self.conversions += 1;
        if self.frozen && self.last_codes != (0, 0) {
            return match what {
                Conversion::Pressure => self.last_codes.0,
                Conversion::Temperature => self.last_codes.1,
            };
        }
        let (p_pa, t_c) = world.baro(done_ns as f64 * 1e-9);
        let k = world.errors.baro.noise_scale;
        let p_noise = PRESSURE_NOISE_MBAR.get(osr).copied().unwrap_or(0.0) * 100.0 * k;
        let t_noise = TEMPERATURE_NOISE_C.get(osr).copied().unwrap_or(0.0) * k;
        let p = p_pa + p_noise * world.gauss();
        let t = t_c + t_noise * world.gauss();
        let (d1, d2) = invert(&self.prom, p, t);
        match what {
            Conversion::Pressure => {
                self.last_codes.0 = d1;
                d1
            }
            Conversion::Temperature => {
                self.last_codes.1 = d2;
                d2
            }
        }
    }

    fn command(&mut self, cmd: u8, now_ns: u64, world: &mut World) -> Result<(), SimBusError> {
        match cmd {
            0x1E => {
                self.power_on_reset(now_ns);
                self.reloading_until_ns = Some(now_ns + RESET_TIME_NS);
            }
            0x40..=0x48 | 0x50..=0x58 if cmd & 1 == 0 => {
                if !matches!(self.pending, Pending::Converting { .. }) {
                    let what = if cmd < 0x50 {
                        Conversion::Pressure
                    } else {
                        Conversion::Temperature
                    };
                    let osr = usize::from((cmd & 0x0F) >> 1);
                    let t = CONVERSION_TIME_NS.get(osr).copied().unwrap_or(0);
                    self.pending = Pending::Converting {
                        what,
                        osr,
                        done_ns: now_ns + t,
                        spoiled: false,
                    };
                }
                self.read = ReadSource::Nothing;
            }
            0x00 => {
                let code = match self.pending {
                    Pending::Done { what, osr, done_ns } => {
                        self.pending = Pending::None;
                        self.result_code(what, osr, done_ns, world)
                    }
                    Pending::Converting {
                        what, osr, done_ns, ..
                    } => {
                        // Read during conversion: 0, and the result will be wrong.
                        self.pending = Pending::Converting {
                            what,
                            osr,
                            done_ns,
                            spoiled: true,
                        };
                        0
                    }
                    Pending::None => 0,
                };
                let b = code.to_be_bytes();
                self.read = ReadSource::Adc([b[1], b[2], b[3]]);
            }
            0xA0..=0xAE if cmd & 1 == 0 => {
                self.read = ReadSource::Prom(usize::from((cmd - 0xA0) >> 1));
            }
            _ => return Err(SimBusError::Nack(NoAcknowledgeSource::Data)),
        }
        Ok(())
    }
}

impl Device for Ms5611Model {
    fn update(&mut self, now_ns: u64, _world: &mut World) {
        if let Some(until) = self.reloading_until_ns {
            if now_ns >= until {
                self.reloading_until_ns = None;
            }
        }
        if let Pending::Converting {
            what,
            osr,
            done_ns,
            spoiled,
        } = self.pending
        {
            if now_ns >= done_ns {
                self.pending = if spoiled {
                    Pending::None
                } else {
                    Pending::Done { what, osr, done_ns }
                };
            }
        }
    }

    fn acks_address(&self, now_ns: u64) -> bool {
        self.reloading_until_ns.is_none_or(|u| now_ns >= u)
    }

    fn start(&mut self, read: bool) {
        self.first_write = !read;
        self.read_pos = 0;
    }

    fn write_byte(&mut self, byte: u8, now_ns: u64, world: &mut World) -> Result<(), SimBusError> {
        if self.first_write {
            self.first_write = false;
            self.command(byte, now_ns, world)
        } else {
            // Commands are one byte; extra bytes are not acknowledged.
            Err(SimBusError::Nack(NoAcknowledgeSource::Data))
        }
    }

    fn read_byte(&mut self, _now_ns: u64, _world: &mut World) -> u8 {
        let pos = self.read_pos;
        self.read_pos += 1;
        match self.read {
            ReadSource::Prom(i) => {
                let w = self.prom.get(i).copied().unwrap_or(0)
                    ^ self.prom_corruption.get(i).copied().unwrap_or(0);
                w.to_be_bytes().get(pos).copied().unwrap_or(0)
            }
            ReadSource::Adc(b) => b.get(pos).copied().unwrap_or(0),
            ReadSource::Nothing => 0,
        }
    }

    fn stop(&mut self, _now_ns: u64, _world: &mut World) {
        // An ADC result can be read once.
        if matches!(self.read, ReadSource::Adc(_)) && self.read_pos > 0 {
            self.read = ReadSource::Adc([0; 3]);
        }
    }

    fn power_on_reset(&mut self, _now_ns: u64) {
        self.pending = Pending::None;
        self.read = ReadSource::Nothing;
        self.read_pos = 0;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;

    #[test]
    fn datasheet_worked_example() {
        let prom = make_prom(0, DATASHEET_C, 0);
        let (p, t) = compensate(&prom, 9_085_466, 8_569_150);
        assert_eq!(t, 2007);
        assert_eq!(p, 100_009);
    }

    #[test]
    fn crc_detects_a_flipped_bit() {
        let prom = make_prom(0x00A5, DATASHEET_C, 0x4E5);
        assert_eq!(crc4(&prom), (prom[7] & 0xF) as u8);
        for w in 0..8 {
            for bit in 0..16 {
                if w == 7 && bit < 8 {
                    continue;
                }
                let mut bad = prom;
                bad[w] ^= 1 << bit;
                assert_ne!(crc4(&bad), (prom[7] & 0xF) as u8, "word {w} bit {bit}");
            }
        }
    }

    #[test]
    fn inversion_round_trips_over_the_range() {
        let prom = make_prom(0x00A5, DATASHEET_C, 0x4E5);
        for &t_c in &[-35.0, -20.0, -5.0, 10.0, 19.99, 20.0, 25.3, 45.0, 80.0] {
            for &p in &[1_000.0, 30_000.0, 70_000.0, 89_874.6, 101_325.0, 120_000.0] {
                let (d1, d2) = invert(&prom, p, t_c);
                let (pc, tc) = compensate(&prom, d1, d2);
                assert!((pc as f64 - p).abs() <= 1.5, "p {p} t {t_c}: got {pc}");
                assert!((tc as f64 - t_c * 100.0).abs() <= 1.5, "t {t_c}: got {tc}");
            }
        }
    }
}
