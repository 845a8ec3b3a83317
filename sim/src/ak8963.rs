//! Register-level model of the AKM AK8963 magnetometer (datasheet
//! MS1356-E-02): WIA, ST1 DRDY/DOR, little-endian HXL..HZH, ST2 HOFL/BITM
//! with data protection until ST2 is read, CNTL1 modes and output bit width,
//! CNTL2 soft reset, fuse-ROM ASA values readable only in fuse-ROM mode.
//!
//! Not modelled: external-trigger mode (there is no trigger pin), I2CDIS,
//! the DRDY pin, measurement-time jitter.
//!
//! The register map here is written from the datasheet independently of the
//! `ak8963` driver's on purpose: the model checks the driver.

use crate::bus::SimBusError;
use crate::device::Device;
use crate::world::World;

/// Register addresses.
#[allow(missing_docs)]
pub mod reg {
    pub const WIA: u8 = 0x00;
    pub const INFO: u8 = 0x01;
    pub const ST1: u8 = 0x02;
    pub const HXL: u8 = 0x03;
    pub const HZH: u8 = 0x08;
    pub const ST2: u8 = 0x09;
    pub const CNTL1: u8 = 0x0A;
    pub const CNTL2: u8 = 0x0B;
    pub const ASTC: u8 = 0x0C;
    pub const I2CDIS: u8 = 0x0F;
    pub const ASAX: u8 = 0x10;
    pub const ASAZ: u8 = 0x12;
}

/// Device ID.
pub const WIA_VALUE: u8 = 0x48;
/// Measurement time (typical, ns).
pub const MEASUREMENT_TIME_NS: u64 = 7_200_000;
/// Overflow threshold: |X| + |Y| + |Z| ≥ 4912 µT sets HOFL.
pub const OVERFLOW_SUM_UT: f64 = 4912.0;
/// 16-bit output sensitivity (µT/LSB).
pub const UT_PER_LSB_16: f64 = 0.15;
/// 14-bit output sensitivity (µT/LSB).
pub const UT_PER_LSB_14: f64 = 0.6;
/// Default fuse-ROM sensitivity adjustment values (ASAX, ASAY, ASAZ).
pub const DEFAULT_ASA: [u8; 3] = [176, 178, 165];

/// Operating modes (CNTL1 MODE\[3:0\]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// 0000.
    PowerDown,
    /// 0001.
    Single,
    /// 0010, 8 Hz.
    Continuous1,
    /// 0110, 100 Hz.
    Continuous2,
    /// 0100.
    ExternalTrigger,
    /// 1000.
    SelfTest,
    /// 1111.
    FuseRom,
    /// Any other code.
    Invalid,
}

impl Mode {
    fn from_bits(b: u8) -> Mode {
        match b & 0x0F {
            0x0 => Mode::PowerDown,
            0x1 => Mode::Single,
            0x2 => Mode::Continuous1,
            0x6 => Mode::Continuous2,
            0x4 => Mode::ExternalTrigger,
            0x8 => Mode::SelfTest,
            0xF => Mode::FuseRom,
            _ => Mode::Invalid,
        }
    }
}

/// The AK8963 model.
#[derive(Clone, Debug)]
pub struct Ak8963Model {
    regs: [u8; 0x13],
    ptr: u8,
    expect_reg_addr: bool,
    asa: [u8; 3],
    protected: bool,
    next_done_ns: Option<u64>,
    /// Data stops updating while DRDY keeps being set (fault).
    pub frozen: bool,
    /// WIA override (fault).
    pub who_am_i_override: Option<u8>,
    /// Every measurement overflows (fault).
    pub force_overflow: bool,
    samples: u64,
}

impl Default for Ak8963Model {
    fn default() -> Self {
        Self::new(DEFAULT_ASA)
    }
}

fn reset_registers() -> [u8; 0x13] {
    let mut r = [0u8; 0x13];
    r[reg::WIA as usize] = WIA_VALUE;
    r[reg::INFO as usize] = 0x9A;
    r
}

impl Ak8963Model {
    /// A chip with the given fuse-ROM ASA values.
    pub fn new(asa: [u8; 3]) -> Self {
        Self {
            regs: reset_registers(),
            ptr: 0,
            expect_reg_addr: false,
            asa,
            protected: false,
            next_done_ns: None,
            frozen: false,
            who_am_i_override: None,
            force_overflow: false,
            samples: 0,
        }
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        Mode::from_bits(self.regs[reg::CNTL1 as usize])
    }

    /// The fuse-ROM sensitivity adjustment values.
    pub fn asa(&self) -> [u8; 3] {
        self.asa
    }

    /// Sensitivity adjustment factor of each axis: (ASA − 128)·0.5/128 + 1.
    pub fn asa_factor(&self) -> [f64; 3] {
        self.asa.map(|a| (f64::from(a) - 128.0) * 0.5 / 128.0 + 1.0)
    }

    /// 16-bit output selected (CNTL1 BIT).
    pub fn bit16(&self) -> bool {
        self.regs[reg::CNTL1 as usize] & 0x10 != 0
    }

    /// Measurements completed so far.
    pub fn sample_count(&self) -> u64 {
        self.samples
    }

    /// Raw register value without side effects.
    pub fn register(&self, addr: u8) -> u8 {
        self.regs.get(usize::from(addr)).copied().unwrap_or(0)
    }

    fn period_ns(&self) -> Option<u64> {
        match self.mode() {
            Mode::Continuous1 => Some(125_000_000),
            Mode::Continuous2 => Some(10_000_000),
            _ => None,
        }
    }

    fn measure(&mut self, t_ns: u64, world: &mut World) {
        self.samples += 1;
        let self_test = self.mode() == Mode::SelfTest;
        let bit16 = self.bit16();
        let (lsb_ut, limit) = if bit16 {
            (UT_PER_LSB_16, 32760.0)
        } else {
            (UT_PER_LSB_14, 8190.0)
        };
        let field = if self_test {
            // Internal self-test field (the datasheet's pass window: X, Y ±200, Z −3200..−800 LSB at 16 bit).
            [15.0, -15.0, -300.0]
        } else {
            world.mag_ak_ut(t_ns as f64 * 1e-9)
        };
        let overflow =
            self.force_overflow || field.iter().map(|v| v.abs()).sum::<f64>() >= OVERFLOW_SUM_UT;
        let adj = self.asa_factor();
        if self.protected {
            // Data being read: the new measurement is skipped.
            self.regs[reg::ST1 as usize] |= 0x02;
        } else {
            if self.regs[reg::ST1 as usize] & 0x01 != 0 {
                self.regs[reg::ST1 as usize] |= 0x02; // previous data never read
            }
            if !self.frozen {
                for i in 0..3 {
                    let counts = (field[i] / lsb_ut / adj[i]).round().clamp(-limit, limit) as i16;
                    let b = counts.to_le_bytes();
                    self.regs[usize::from(reg::HXL) + 2 * i] = b[0];
                    self.regs[usize::from(reg::HXL) + 2 * i + 1] = b[1];
                }
                self.regs[reg::ST2 as usize] =
                    (if overflow { 0x08 } else { 0 }) | (if bit16 { 0x10 } else { 0 });
            }
            self.regs[reg::ST1 as usize] |= 0x01;
        }
        if matches!(self.mode(), Mode::Single | Mode::SelfTest) {
            self.regs[reg::CNTL1 as usize] &= 0xF0; // back to power-down
            self.next_done_ns = None;
        }
    }

    fn on_register_write(&mut self, r: u8, v: u8, now_ns: u64) {
        match r {
            reg::CNTL1 => {
                self.regs[r as usize] = v & 0x1F;
                self.next_done_ns = match Mode::from_bits(v) {
                    Mode::Single | Mode::SelfTest | Mode::Continuous1 | Mode::Continuous2 => {
                        Some(now_ns + MEASUREMENT_TIME_NS)
                    }
                    _ => None,
                };
            }
            reg::CNTL2 if v & 0x01 != 0 => self.power_on_reset(now_ns),
            reg::ASTC | reg::I2CDIS => self.regs[r as usize] = v,
            _ => {} // read-only or reserved
        }
    }

    fn advance_ptr(&mut self) {
        self.ptr = match self.ptr {
            reg::ASTC => reg::WIA,
            reg::ASAZ => reg::ASAX,
            p => p.wrapping_add(1),
        };
    }
}

impl Device for Ak8963Model {
    fn update(&mut self, now_ns: u64, world: &mut World) {
        while let Some(done) = self.next_done_ns {
            if now_ns < done {
                break;
            }
            match self.period_ns() {
                Some(p) => {
                    // When far behind, every measurement but the last two is
                    // irrelevant: the last-but-one sets DRDY, the last DOR.
                    let behind = (now_ns - done) / p;
                    let t = done + behind * p;
                    self.next_done_ns = Some(t + p);
                    if behind > 0 {
                        self.measure(t - p, world);
                    }
                    self.measure(t, world);
                }
                None => self.measure(done, world),
            }
        }
    }

    fn start(&mut self, read: bool) {
        self.expect_reg_addr = !read;
    }

    fn write_byte(&mut self, byte: u8, now_ns: u64, _world: &mut World) -> Result<(), SimBusError> {
        if self.expect_reg_addr {
            self.expect_reg_addr = false;
            if usize::from(byte) >= self.regs.len() {
                return Err(SimBusError::Nack(
                    embedded_hal::i2c::NoAcknowledgeSource::Data,
                ));
            }
            self.ptr = byte;
        } else {
            self.on_register_write(self.ptr, byte, now_ns);
            self.advance_ptr();
        }
        Ok(())
    }

    fn read_byte(&mut self, _now_ns: u64, _world: &mut World) -> u8 {
        let r = self.ptr;
        let v = match r {
            reg::WIA => self.who_am_i_override.unwrap_or(WIA_VALUE),
            reg::HXL..=reg::HZH => {
                self.regs[reg::ST1 as usize] &= !0x03;
                self.protected = true;
                self.regs[r as usize]
            }
            reg::ST2 => {
                self.regs[reg::ST1 as usize] &= !0x03;
                self.protected = false;
                self.regs[r as usize]
            }
            reg::ASAX..=reg::ASAZ => {
                if self.mode() == Mode::FuseRom {
                    self.asa[usize::from(r - reg::ASAX)]
                } else {
                    0
                }
            }
            _ => self.regs.get(usize::from(r)).copied().unwrap_or(0),
        };
        self.advance_ptr();
        v
    }

    fn power_on_reset(&mut self, _now_ns: u64) {
        self.regs = reset_registers();
        self.protected = false;
        self.next_done_ns = None;
    }
}
