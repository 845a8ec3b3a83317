//! Register-level model of the InvenSense MPU-9250 (register map rev 1.6,
//! product specification rev 1.1): accelerometer, gyroscope, temperature,
//! sample-rate divider and DLPF configuration, data-ready interrupt, bypass,
//! the FIFO, and the internal I2C master's registers (run by
//! [`aux_master`](crate::aux_master)).
//!
//! Burst reads are coherent: the sensor registers (ACCEL_XOUT_H ..
//! GYRO_ZOUT_L) a master reads come from a user-facing copy that follows the
//! internal registers only while the serial interface is idle, so a sample
//! that lands during a read never mixes into it (InvenSense's register map
//! for the MPU-6000/6050, rev 4.2, sections 4.17-4.19: "This guarantees that
//! a burst read of sensor registers will read measurements from the same
//! sampling instant"; the MPU-9250's map, rev 1.6, keeps those registers and
//! their addresses but not the prose). Without it a read late enough to
//! straddle a sample would mix the high byte of one sample with the low
//! byte of the next: a ±256-count step whenever a value crosses a multiple
//! of 256, such as a gyro axis at rest crossing zero.
//!
//! The gyro and accelerometer DLPFs are filters with the register map's
//! 3-dB bandwidth and delay per setting ([`crate::dlpf`]: a
//! first-order low-pass and a pure delay), run at the chip's internal rate
//! (gyro 1 kHz for DLPF_CFG 1-6, 8 kHz for 0 and 7, 32 kHz with
//! FCHOICE_B; accelerometer 1 kHz, 4 kHz with ACCEL_FCHOICE_B) on the
//! signal sampled at that rate. The output registers take every
//! (1 + SMPLRT_DIV)-th filtered sample (DLPF_CFG 1-6; otherwise every
//! one) and hold it: a component above half the output rate aliases, as on
//! the chip. The sensor's white noise (the datasheet's density over the
//! internal rate's Nyquist band) is added at each internal sample and
//! passes through the filter with the signal: the output's noise has the
//! filter's shape and a variance of density² × the filter's equivalent
//! noise bandwidth (about the 3-dB bandwidth · π/2).
//!
//! Not modelled: DMP, self-test responses, wake-on-motion, start-up
//! transients (a filter starts settled on its first input).
//!
//! The register map here is written from the datasheet independently of the
//! `mpu9250` driver's on purpose: the model checks the driver, so it must not
//! share the driver's reading of the datasheet.

use crate::bus::SimBusError;
use crate::device::Device;
use crate::dlpf::{self, Dlpf};
use crate::math::Vec3;
use crate::world::{World, G_MPS2};

/// Register addresses used by the model (register map rev 1.6).
#[allow(missing_docs)]
pub mod reg {
    pub const SMPLRT_DIV: u8 = 0x19;
    pub const CONFIG: u8 = 0x1A;
    pub const GYRO_CONFIG: u8 = 0x1B;
    pub const ACCEL_CONFIG: u8 = 0x1C;
    pub const ACCEL_CONFIG2: u8 = 0x1D;
    pub const INT_PIN_CFG: u8 = 0x37;
    pub const INT_ENABLE: u8 = 0x38;
    pub const INT_STATUS: u8 = 0x3A;
    pub const ACCEL_XOUT_H: u8 = 0x3B;
    pub const TEMP_OUT_H: u8 = 0x41;
    pub const GYRO_XOUT_H: u8 = 0x43;
    pub const EXT_SENS_DATA_23: u8 = 0x60;
    pub const SIGNAL_PATH_RESET: u8 = 0x68;
    pub const USER_CTRL: u8 = 0x6A;
    pub const PWR_MGMT_1: u8 = 0x6B;
    pub const PWR_MGMT_2: u8 = 0x6C;
    pub const FIFO_COUNTH: u8 = 0x72;
    pub const FIFO_COUNTL: u8 = 0x73;
    pub const FIFO_R_W: u8 = 0x74;
    pub const FIFO_EN: u8 = 0x23;
    pub const WHO_AM_I: u8 = 0x75;
}

/// WHO_AM_I of the MPU-9250.
pub const WHO_AM_I_VALUE: u8 = 0x71;
/// Time the H_RESET bit stays set after it is written (simulated, ns).
pub const RESET_TIME_NS: u64 = 1_000_000;
/// Length of the non-latched INT pulse (register map: 50 µs).
pub const INT_PULSE_NS: u64 = 50_000;
/// Temperature sensitivity (LSB/°C), offset 0 LSB at 21 °C.
pub const TEMP_LSB_PER_C: f64 = 333.87;

/// Gyro LSB per °/s for GYRO_FS_SEL 0..3.
pub const GYRO_LSB_PER_DPS: [f64; 4] = [131.0, 65.5, 32.8, 16.4];
/// Accelerometer LSB per g for ACCEL_FS_SEL 0..3.
pub const ACCEL_LSB_PER_G: [f64; 4] = [16384.0, 8192.0, 4096.0, 2048.0];
/// Internal samples run after a clock jump before the output instant
/// (ns): enough for the slowest filter (5 Hz, 32 ms time constant) to
/// settle, so a long jump costs a bounded amount of work.
const SETTLE_NS: u64 = 300_000_000;

fn reset_registers() -> [u8; 128] {
    let mut r = [0u8; 128];
    r[reg::PWR_MGMT_1 as usize] = 0x01;
    r[reg::WHO_AM_I as usize] = WHO_AM_I_VALUE;
    // Factory self-test codes (arbitrary but typical).
    r[0x00] = 0x6A;
    r[0x01] = 0x6C;
    r[0x02] = 0x6F;
    r[0x0D] = 0x6B;
    r[0x0E] = 0x6E;
    r[0x0F] = 0x72;
    r
}

/// The sensor registers with a user-facing read copy: ACCEL_XOUT_H ..=
/// GYRO_ZOUT_L (accelerometer, temperature, gyroscope; 14 bytes).
const SENSOR_REGS: core::ops::RangeInclusive<u8> = reg::ACCEL_XOUT_H..=(reg::GYRO_XOUT_H + 5);
/// Size of [`SENSOR_REGS`].
const SENSOR_BYTES: usize = 14;

/// Saturating conversion to a 16-bit two's-complement register value.
pub fn to_i16_sat(x: f64) -> i16 {
    x.round().clamp(-32768.0, 32767.0) as i16
}

/// The MPU-9250 model.
#[derive(Clone, Debug)]
pub struct Mpu9250Model {
    regs: [u8; 128],
    ptr: u8,
    expect_reg_addr: bool,
    reset_done_ns: Option<u64>,
    next_sample_ns: u64,
    last_sample_ns: Option<u64>,
    sleeping: bool,
    /// Data registers stop updating while data-ready keeps firing (fault).
    pub frozen: bool,
    /// WHO_AM_I override (fault).
    pub who_am_i_override: Option<u8>,
    samples: u64,
    last_physical: Option<crate::world::ImuPhysical>,
    fifo: std::collections::VecDeque<u8>,
    /// The user-facing copy of [`SENSOR_REGS`] a transaction reads, taken
    /// at its (repeated) START; `None` while the serial interface is idle
    /// (reads then see the internal registers).
    read_set: Option<[u8; SENSOR_BYTES]>,
    /// Sample count the internal I2C master last ran at (see `aux_master`).
    pub(crate) master_samples_seen: u64,
    /// The DLPFs and the internal sample clock they run on.
    filters: Filters,
}

/// The gyro and accelerometer DLPFs with the internal clock that feeds
/// them: one tick per period of the faster filter, each filter stepped on
/// the ticks that fall on its own period.
#[derive(Clone, Debug)]
struct Filters {
    /// CONFIG, GYRO_CONFIG, ACCEL_CONFIG2 the filters were built for;
    /// `None` = rebuild and re-anchor the clock before the next tick.
    key: Option<(u8, u8, u8)>,
    gyro: Dlpf,
    accel: Dlpf,
    tick_ns: u64,
    next_tick_ns: u64,
    tick_index: u64,
    gyro_out: Vec3,
    accel_out: Vec3,
    temp_c: f64,
}

impl Filters {
    fn new() -> Self {
        Self {
            key: None,
            gyro: Dlpf::new(dlpf::GYRO_DLPF[0]),
            accel: Dlpf::new(dlpf::ACCEL_DLPF[0]),
            tick_ns: 1_000_000,
            next_tick_ns: 0,
            tick_index: 0,
            gyro_out: [0.0; 3],
            accel_out: [0.0; 3],
            temp_c: 21.0,
        }
    }

    /// Rebuilds the filters for `key`, their clock's first tick at `first_ns`.
    fn rebuild(&mut self, key: (u8, u8, u8), first_ns: u64) {
        self.gyro = Dlpf::new(dlpf::gyro_spec(key.0, key.1));
        self.accel = Dlpf::new(dlpf::accel_spec(key.2));
        self.tick_ns = self.gyro.period_ns().min(self.accel.period_ns()).max(1);
        self.next_tick_ns = first_ns;
        self.tick_index = 0;
        self.key = Some(key);
    }

    /// Runs the internal ticks up to and including `t_ns` (the last
    /// [`SETTLE_NS`] of them after a long jump).
    fn run_to(&mut self, t_ns: u64, world: &mut World) {
        if self.next_tick_ns > t_ns {
            return;
        }
        let n = (t_ns - self.next_tick_ns) / self.tick_ns + 1;
        let skip = n.saturating_sub(SETTLE_NS / self.tick_ns);
        self.next_tick_ns += skip * self.tick_ns;
        self.tick_index += skip;
        let g_every = (self.gyro.period_ns() / self.tick_ns).max(1);
        let a_every = (self.accel.period_ns() / self.tick_ns).max(1);
        // White noise over each filter's Nyquist band: the density times
        // the square root of half its rate per sample.
        let g_band = 0.5 * self.gyro.spec().rate_hz;
        let a_band = 0.5 * self.accel.spec().rate_hz;
        for _ in skip..n {
            let phys = world.imu_signal(self.next_tick_ns as f64 * 1e-9);
            let noise = world.imu_noise(g_band, a_band);
            if self.tick_index.is_multiple_of(g_every) {
                let x = crate::math::add(phys.gyro_mpu_dps, noise.gyro_mpu_dps);
                self.gyro_out = self.gyro.step(x);
            }
            if self.tick_index.is_multiple_of(a_every) {
                let x = crate::math::add(phys.accel_mpu_mps2, noise.accel_mpu_mps2);
                self.accel_out = self.accel.step(x);
            }
            self.temp_c = phys.temp_c;
            self.next_tick_ns += self.tick_ns;
            self.tick_index += 1;
        }
    }
}

/// FIFO size of the MPU-9250, bytes.
pub const FIFO_SIZE: usize = 512;
/// Samples produced at most when the clock jumps with the FIFO on (one more
/// than a full FIFO of the smallest entries, 2 bytes).
const FIFO_MAX_CATCH_UP: u64 = FIFO_SIZE as u64 / 2 + 1;

impl Default for Mpu9250Model {
    fn default() -> Self {
        Self::new()
    }
}

impl Mpu9250Model {
    /// A chip just powered on.
    pub fn new() -> Self {
        Self {
            regs: reset_registers(),
            ptr: 0,
            expect_reg_addr: false,
            reset_done_ns: None,
            next_sample_ns: 1_000_000,
            last_sample_ns: None,
            sleeping: false,
            frozen: false,
            who_am_i_override: None,
            samples: 0,
            last_physical: None,
            fifo: std::collections::VecDeque::with_capacity(FIFO_SIZE),
            read_set: None,
            master_samples_seen: 0,
            filters: Filters::new(),
        }
    }

    /// Raw register value (no side effects).
    pub fn register(&self, addr: u8) -> u8 {
        self.regs.get(usize::from(addr)).copied().unwrap_or(0)
    }

    /// Output data rate period (ns) from GYRO_CONFIG.FCHOICE_B, CONFIG.DLPF_CFG, SMPLRT_DIV.
    pub fn sample_period_ns(&self) -> u64 {
        let fchoice_b = self.regs[reg::GYRO_CONFIG as usize] & 0x03;
        let dlpf = self.regs[reg::CONFIG as usize] & 0x07;
        if fchoice_b != 0 {
            31_250
        } else if dlpf == 0 || dlpf == 7 {
            125_000
        } else {
            1_000_000 * (1 + u64::from(self.regs[reg::SMPLRT_DIV as usize]))
        }
    }

    /// Gyro equivalent noise bandwidth (Hz) = 3 dB bandwidth · π/2.
    pub fn gyro_enbw_hz(&self) -> f64 {
        let spec = dlpf::gyro_spec(
            self.regs[reg::CONFIG as usize],
            self.regs[reg::GYRO_CONFIG as usize],
        );
        spec.bandwidth_hz * std::f64::consts::FRAC_PI_2
    }

    /// Accelerometer equivalent noise bandwidth (Hz).
    pub fn accel_enbw_hz(&self) -> f64 {
        dlpf::accel_spec(self.regs[reg::ACCEL_CONFIG2 as usize]).bandwidth_hz
            * std::f64::consts::FRAC_PI_2
    }

    /// The filter settings in effect: gyro, accelerometer.
    pub fn dlpf_specs(&self) -> (dlpf::DlpfSpec, dlpf::DlpfSpec) {
        (
            dlpf::gyro_spec(
                self.regs[reg::CONFIG as usize],
                self.regs[reg::GYRO_CONFIG as usize],
            ),
            dlpf::accel_spec(self.regs[reg::ACCEL_CONFIG2 as usize]),
        )
    }

    /// Gyro sensitivity (LSB per °/s) at the configured full scale.
    pub fn gyro_lsb_per_dps(&self) -> f64 {
        GYRO_LSB_PER_DPS[usize::from((self.regs[reg::GYRO_CONFIG as usize] >> 3) & 3)]
    }

    /// Accelerometer sensitivity (LSB per g) at the configured full scale.
    pub fn accel_lsb_per_g(&self) -> f64 {
        ACCEL_LSB_PER_G[usize::from((self.regs[reg::ACCEL_CONFIG as usize] >> 3) & 3)]
    }

    /// BYPASS_EN set and I2C_MST_EN clear: the AK8963 is reachable.
    pub fn bypass_active(&self) -> bool {
        self.reset_done_ns.is_none()
            && self.regs[reg::INT_PIN_CFG as usize] & 0x02 != 0
            && self.regs[reg::USER_CTRL as usize] & 0x20 == 0
    }

    /// Number of samples produced so far.
    pub fn sample_count(&self) -> u64 {
        self.samples
    }

    /// Time of the last sample (ns).
    pub fn last_sample_ns(&self) -> Option<u64> {
        self.last_sample_ns
    }

    /// Time of the next sample (ns).
    pub fn next_sample_ns(&self) -> u64 {
        self.next_sample_ns
    }

    /// The physical values behind the latest sample (before quantisation).
    pub fn last_physical(&self) -> Option<crate::world::ImuPhysical> {
        self.last_physical
    }

    /// The INT line is asserted (logical level; see [`Mpu9250Model::int_pin_high`]).
    pub fn int_asserted(&self, now_ns: u64) -> bool {
        if self.regs[reg::INT_ENABLE as usize] & 0x01 == 0 {
            return false;
        }
        if self.regs[reg::INT_PIN_CFG as usize] & 0x20 != 0 {
            self.regs[reg::INT_STATUS as usize] & 0x01 != 0
        } else {
            self.last_sample_ns
                .is_some_and(|t| now_ns < t + INT_PULSE_NS)
        }
    }

    /// Electrical level of the INT pin (ACTL = INT_PIN_CFG bit 7 inverts it).
    pub fn int_pin_high(&self, now_ns: u64) -> bool {
        let active_low = self.regs[reg::INT_PIN_CFG as usize] & 0x80 != 0;
        self.int_asserted(now_ns) != active_low
    }

    fn clear_data(&mut self) {
        for r in reg::ACCEL_XOUT_H..=reg::EXT_SENS_DATA_23 {
            self.regs[usize::from(r)] = 0;
        }
    }

    fn put16(&mut self, at: u8, v: i16) {
        let b = v.to_be_bytes();
        self.regs[usize::from(at)] = b[0];
        self.regs[usize::from(at) + 1] = b[1];
    }

    /// The filters run up to `t_ns` (rebuilt first if their registers
    /// changed; their clock then starts at this output instant).
    fn filtered_at(&mut self, t_ns: u64, world: &mut World) -> crate::world::ImuPhysical {
        let key = (
            self.regs[reg::CONFIG as usize] & 0x07,
            self.regs[reg::GYRO_CONFIG as usize] & 0x03,
            self.regs[reg::ACCEL_CONFIG2 as usize] & 0x0F,
        );
        if self.filters.key != Some(key) {
            self.filters.rebuild(key, t_ns);
        }
        self.filters.run_to(t_ns, world);
        // The temperature is not filtered: its own noise per output sample.
        let temp_noise_c = world.imu_noise(0.0, 0.0).temp_c;
        let f = &self.filters;
        crate::world::ImuPhysical {
            gyro_mpu_dps: f.gyro_out,
            accel_mpu_mps2: f.accel_out,
            temp_c: f.temp_c + temp_noise_c,
        }
    }

    fn produce_sample(&mut self, t_ns: u64, world: &mut World) {
        let phys = self.filtered_at(t_ns, world);
        let pm2 = self.regs[reg::PWR_MGMT_2 as usize];
        let a_lsb = self.accel_lsb_per_g() / G_MPS2;
        let g_lsb = self.gyro_lsb_per_dps();
        let acc: Vec3 = phys.accel_mpu_mps2;
        let gyr: Vec3 = phys.gyro_mpu_dps;
        for i in 0..3 {
            // PWR_MGMT_2: bits 5..3 disable XA, YA, ZA; bits 2..0 disable XG, YG, ZG.
            let a = if pm2 & (0x20 >> i) != 0 {
                0
            } else {
                to_i16_sat(acc[i] * a_lsb)
            };
            let g = if pm2 & (0x04 >> i) != 0 {
                0
            } else {
                to_i16_sat(gyr[i] * g_lsb)
            };
            self.put16(reg::ACCEL_XOUT_H + 2 * i as u8, a);
            self.put16(reg::GYRO_XOUT_H + 2 * i as u8, g);
        }
        self.put16(
            reg::TEMP_OUT_H,
            to_i16_sat((phys.temp_c - 21.0) * TEMP_LSB_PER_C),
        );
        self.regs[reg::INT_STATUS as usize] |= 0x01;
        self.push_fifo();
        self.last_sample_ns = Some(t_ns);
        self.last_physical = Some(phys);
        self.samples += 1;
    }

    /// Set a register without side effects (the internal master's results).
    pub(crate) fn set_register(&mut self, addr: u8, v: u8) {
        if let Some(r) = self.regs.get_mut(usize::from(addr)) {
            *r = v;
        }
    }

    /// Bytes queued in the FIFO.
    pub fn fifo_len(&self) -> usize {
        self.fifo.len()
    }

    /// Queue the enabled outputs of the sample just produced (register map,
    /// FIFO_EN: stored in register order, accel, temperature, gyro x/y/z).
    /// A full FIFO drops further bytes with CONFIG FIFO_MODE set and the
    /// oldest bytes without it; either way INT_STATUS FIFO_OFLOW_INT is set.
    fn push_fifo(&mut self) {
        if self.regs[reg::USER_CTRL as usize] & 0x40 == 0 {
            return;
        }
        let en = self.regs[reg::FIFO_EN as usize];
        let blocks: [(u8, u8, usize); 5] = [
            (0x08, reg::ACCEL_XOUT_H, 6),
            (0x80, reg::TEMP_OUT_H, 2),
            (0x40, reg::GYRO_XOUT_H, 2),
            (0x20, reg::GYRO_XOUT_H + 2, 2),
            (0x10, reg::GYRO_XOUT_H + 4, 2),
        ];
        let keep_old = self.regs[reg::CONFIG as usize] & 0x40 != 0;
        for (bit, start, len) in blocks {
            if en & bit == 0 {
                continue;
            }
            for i in 0..len {
                let b = self.regs[usize::from(start) + i];
                if self.fifo.len() == FIFO_SIZE {
                    self.regs[reg::INT_STATUS as usize] |= 0x10;
                    if keep_old {
                        continue;
                    }
                    self.fifo.pop_front();
                }
                self.fifo.push_back(b);
            }
        }
    }

    fn on_register_write(&mut self, r: u8, v: u8, now_ns: u64) {
        match r {
            reg::PWR_MGMT_1 => {
                if v & 0x80 != 0 {
                    self.power_on_reset(now_ns);
                    self.regs[reg::PWR_MGMT_1 as usize] = 0x81;
                    self.reset_done_ns = Some(now_ns + RESET_TIME_NS);
                } else {
                    self.regs[r as usize] = v;
                }
            }
            reg::SIGNAL_PATH_RESET => self.clear_data(),
            reg::USER_CTRL => {
                if v & 0x01 != 0 {
                    self.clear_data();
                }
                if v & 0x04 != 0 {
                    self.fifo.clear();
                }
                // FIFO_RST, I2C_MST_RST, SIG_COND_RST self-clear.
                self.regs[r as usize] = v & !0x07;
            }
            reg::INT_STATUS | reg::FIFO_COUNTH | reg::FIFO_COUNTL | reg::WHO_AM_I => {}
            reg::ACCEL_XOUT_H..=reg::EXT_SENS_DATA_23 => {}
            _ => {
                if let Some(c) = self.regs.get_mut(usize::from(r)) {
                    *c = v;
                }
            }
        }
    }
}

impl Device for Mpu9250Model {
    fn update(&mut self, now_ns: u64, world: &mut World) {
        if let Some(done) = self.reset_done_ns {
            if now_ns < done {
                return;
            }
            self.reset_done_ns = None;
            self.regs[reg::PWR_MGMT_1 as usize] &= !0x80;
            self.next_sample_ns = done + self.sample_period_ns();
            self.filters.key = None;
        }
        let asleep = self.regs[reg::PWR_MGMT_1 as usize] & 0x40 != 0;
        let period = self.sample_period_ns();
        if asleep {
            self.sleeping = true;
            return;
        }
        if self.sleeping {
            self.sleeping = false;
            self.next_sample_ns = now_ns + period;
            self.filters.key = None;
        }
        if now_ns >= self.next_sample_ns {
            let n = (now_ns - self.next_sample_ns) / period + 1;
            let t = self.next_sample_ns + (n - 1) * period;
            self.next_sample_ns += n * period;
            if self.frozen {
                // Stuck output: data-ready keeps firing, the data registers keep their old values.
                self.regs[reg::INT_STATUS as usize] |= 0x01;
                self.last_sample_ns = Some(t);
            } else if self.regs[reg::USER_CTRL as usize] & 0x40 != 0 {
                // With the FIFO on every sample of the jump is queued; more
                // than a full FIFO's worth cannot change what it holds.
                let queued = n.min(FIFO_MAX_CATCH_UP);
                for j in (n - queued)..n {
                    self.produce_sample(t - (n - 1 - j) * period, world);
                }
            } else {
                self.produce_sample(t, world);
            }
        }
    }

    fn start(&mut self, read: bool) {
        self.expect_reg_addr = !read;
        if self.read_set.is_none() {
            let mut copy = [0u8; SENSOR_BYTES];
            for (c, r) in copy.iter_mut().zip(SENSOR_REGS) {
                *c = self.regs[usize::from(r)];
            }
            self.read_set = Some(copy);
        }
    }

    fn stop(&mut self, _now_ns: u64, _world: &mut World) {
        self.read_set = None;
    }

    fn write_byte(&mut self, byte: u8, now_ns: u64, _world: &mut World) -> Result<(), SimBusError> {
        if self.expect_reg_addr {
            self.expect_reg_addr = false;
            self.ptr = byte & 0x7F;
        } else {
            self.on_register_write(self.ptr, byte, now_ns);
            self.ptr = (self.ptr + 1) & 0x7F;
        }
        Ok(())
    }

    fn read_byte(&mut self, _now_ns: u64, _world: &mut World) -> u8 {
        let r = self.ptr;
        let mut v = self.regs[usize::from(r)];
        if let Some(copy) = self.read_set.filter(|_| SENSOR_REGS.contains(&r)) {
            v = copy[usize::from(r - reg::ACCEL_XOUT_H)];
        }
        if r == reg::WHO_AM_I {
            v = self.who_am_i_override.unwrap_or(v);
        }
        let any_read_clears = self.regs[reg::INT_PIN_CFG as usize] & 0x10 != 0;
        if r == reg::INT_STATUS || any_read_clears {
            self.regs[reg::INT_STATUS as usize] &= !0x11;
        }
        match r {
            // I2C_MST_STATUS flags clear when read.
            0x36 => self.regs[0x36] = 0,
            // Counts in bytes, 13 bits; read-only views of the queue.
            reg::FIFO_COUNTH => {
                self.ptr = (self.ptr + 1) & 0x7F;
                return ((self.fifo.len() >> 8) & 0x1F) as u8;
            }
            reg::FIFO_COUNTL => {
                self.ptr = (self.ptr + 1) & 0x7F;
                return (self.fifo.len() & 0xFF) as u8;
            }
            // Bursts keep popping the FIFO: the address does not advance.
            reg::FIFO_R_W => return self.fifo.pop_front().unwrap_or(0),
            _ => {}
        }
        self.ptr = (self.ptr + 1) & 0x7F;
        v
    }

    fn power_on_reset(&mut self, now_ns: u64) {
        self.regs = reset_registers();
        self.read_set = None;
        self.fifo.clear();
        self.sleeping = false;
        self.reset_done_ns = None;
        self.next_sample_ns = now_ns + self.sample_period_ns();
        self.last_sample_ns = None;
        self.filters = Filters::new();
    }
}
