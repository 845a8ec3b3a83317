//! The per-sample processing the firmware runs.
//!
//! * [`Pipeline::imu_step`] (1 kHz, per MPU data-ready): raw counts → gyro
//!   bias (integer) → accelerometer offset/scale (integer, Q14 scale) →
//!   mounting (MPU frame → body FRD, signed permutation) → AHRS update →
//!   accumulate body specific force for the vertical estimator. No f32
//!   division, trigonometry or square root outside the AHRS itself.
//! * [`Pipeline::mag_step`] (100 Hz): AK8963 counts → body frame in
//!   1/16 µT with one integer affine map ([`MagCalibrationQ16`]: factory
//!   adjustment, AK8963 → MPU axes, hard/soft iron and mounting folded
//!   into one Q16 matrix when the calibration is set); kept for the AHRS's
//!   MARG updates.
//! * [`Pipeline::baro_step`] (per MS5611 pressure, ~100 Hz): pressure →
//!   height (control's cheap table form) → vertical estimator.
//! * [`Pipeline::control_step`] (100 Hz): vertical prediction with the mean
//!   earth-frame vertical acceleration of the last samples, and the Euler
//!   angles for the log. The down axis and the Euler angles come from the
//!   Q30 quaternion in integer arithmetic ([`crate::angles`], within
//!   1.2e-4 rad of the exact angles); only the vertical estimator runs in
//!   f32. The attitude, rate and altitude-hold loops that drive the motors
//!   are `flight::flightctl`'s, at the IMU rate, on
//!   [`Pipeline::quaternion`], [`Pipeline::body_rates`] and
//!   [`Pipeline::altitude_estimate`].
//!
//! The AHRS is `fc_ahrs`'s Madgwick filter; see [`AHRS_KIND`].

use calibration::{MagCalibration, MagCalibrationQ16};
use control::baro::CheapBaro;
use control::fixed::q_to_f32;
use control::vertical::{Config as VerticalConfig, VerticalEstimator};
use fc_ahrs::Quaternion;

use crate::angles;
use crate::boot::AhrsMode;
use crate::calmode::RawLogRow;
use crate::gyro_filter::{GyroFilter, GyroFilterDesign};
use crate::mounting::Mounting;
use crate::storage::{CalibrationRecord, ValidParts};

/// Standard gravity, m/s².
pub const G_MPS2: f32 = 9.806_65;
const DEG_PER_RAD: f32 = 180.0 / core::f32::consts::PI;
const RAD_PER_DEG: f32 = core::f32::consts::PI / 180.0;
/// Degrees per unit of a Q16 angle.
const DEG_PER_Q16: f32 = DEG_PER_RAD / 65_536.0;

/// Barometer readings averaged for the take-off pressure reference (height
/// 0): one MS5611 reading carries ~1.5 Pa (≈ 0.13 m) of noise, which a
/// single-reading reference would turn into a constant height offset; the
/// mean of 64 (~0.6 s at 100 Hz) cuts it eightfold.
pub const P0_AVERAGE_SAMPLES: u16 = 64;

/// Which AHRS implementation this build uses.
pub const AHRS_KIND: &str = backend::KIND;

/// One raw MPU-9250 sample as the 1 kHz step receives it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImuInput {
    /// Accelerometer, counts, MPU frame.
    pub accel: [i16; 3],
    /// Gyroscope, counts, MPU frame (bias not removed).
    pub gyro: [i16; 3],
    /// Time since the previous sample, CPU cycles (DWT CYCCNT difference).
    pub dt_cycles: u32,
}

/// Rotor drag per unit mass of the airframe (1/s: N per m/s of velocity in the
/// rotor plane, per kg), for the AHRS's multirotor mode
/// ([`fc_ahrs::Config::rotor_drag_per_s`]): the simulator's 250-class quad,
/// 0.1 N per m/s on 0.60 kg. Published small quadrotors measure 0.1–0.6/s
/// (Leishman et al. 2014); a value wrong by a fraction leaves that fraction
/// of the tilt error a filter without the drag model has while the craft
/// accelerates.
pub const ROTOR_DRAG_PER_S: f32 = 0.1 / 0.60;
/// Form drag of the airframe per unit mass (1/m: ½·ρ·C_d·A per kg), for the
/// same mode ([`fc_ahrs::Config::form_drag_per_m`]): the simulator's quad,
/// 0.006 N per (m/s)² (C_d ≈ 1 on 0.01 m²) on 0.60 kg.
pub const FORM_DRAG_PER_M: f32 = 0.006 / 0.60;

/// Fixed settings of the pipeline.
#[derive(Clone, Copy, Debug)]
pub struct PipelineConfig {
    /// CPU clock of the cycle counter, Hz.
    pub cpu_hz: u32,
    /// Gyro sensitivity, °/s per count (e.g. `mpu9250::Scale::dps_per_lsb`).
    pub gyro_dps_per_lsb: f32,
    /// Accelerometer sensitivity, g per count.
    pub accel_g_per_lsb: f32,
    /// Magnetometer µT per count per axis (AK8963 frame, factory adjustment
    /// included).
    pub mag_ut_per_lsb: [f32; 3],
    /// How the AHRS runs (from the boot probe).
    pub ahrs_mode: AhrsMode,
    /// Barometer present.
    pub altitude: bool,
    /// IMU samples per [`Pipeline::control_step`] (10 → 100 Hz).
    pub control_divider: u16,
    /// Nominal IMU sample rate, Hz.
    pub imu_rate_hz: u32,
    /// AHRS tuning: by default the multirotor mode with [`ROTOR_DRAG_PER_S`]
    /// and [`FORM_DRAG_PER_M`].
    pub ahrs: fc_ahrs::Config,
    /// Vertical estimator tuning.
    pub vertical: VerticalConfig,
    /// The rate loop's gyro filter (designed for `imu_rate_hz`), off by
    /// default; the board's is in the `settings` crate.
    pub gyro_filter: GyroFilterDesign,
}

impl PipelineConfig {
    /// Defaults for the MPU-9250 at ±1000 °/s / ±4 g, the AK8963 at 16 bit
    /// with neutral adjustment, 72 MHz, full MARG + altitude.
    pub fn new() -> Self {
        Self {
            cpu_hz: 72_000_000,
            gyro_dps_per_lsb: 1.0 / 32.8,
            accel_g_per_lsb: 1.0 / 8192.0,
            mag_ut_per_lsb: [0.15; 3],
            ahrs_mode: AhrsMode::Marg,
            altitude: true,
            control_divider: 10,
            imu_rate_hz: 1000,
            ahrs: fc_ahrs::Config::multirotor(ROTOR_DRAG_PER_S, FORM_DRAG_PER_M),
            vertical: VerticalConfig::default(),
            gyro_filter: GyroFilterDesign::PASS,
        }
    }
}

impl Default for PipelineConfig {
    fn default() -> Self {
        Self::new()
    }
}

/// Why [`Pipeline::new`] refused its configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PipelineError {
    /// A sensitivity, clock or divider is zero, negative or not finite.
    InvalidScale,
    /// A control-crate configuration was rejected.
    Control(control::Error),
}

impl From<control::Error> for PipelineError {
    fn from(e: control::Error) -> Self {
        Self::Control(e)
    }
}

/// What the pipeline produces (logged at 10–50 Hz).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Outputs {
    /// Roll, °, NED/FRD ZYX Euler.
    pub roll_deg: f32,
    /// Pitch, °.
    pub pitch_deg: f32,
    /// Yaw (heading), °, clockwise from north (magnetic, or arbitrary in IMU-only mode).
    pub yaw_deg: f32,
    /// Height above the take-off pressure, m (0 without barometer).
    pub altitude_m: f32,
    /// Vertical speed, m/s, up positive.
    pub vertical_speed_mps: f32,
    /// IMU samples processed.
    pub imu_samples: u32,
    /// Magnetometer samples used.
    pub mag_samples: u32,
    /// Barometer samples used.
    pub baro_samples: u32,
}

/// The processing chain and its state.
pub struct Pipeline {
    cfg: PipelineConfig,
    mounting: Mounting,
    /// `mounting` as source axis and sign per body axis (the hot-path form).
    mount: AxisPick,
    gyro_bias: [i32; 3],
    accel_offset: [i32; 3],
    accel_scale_q14: [i32; 3],
    /// The record in use holds a fitted accelerometer calibration.
    accel_calibrated: bool,
    mag_offset_ut: [f32; 3],
    mag_soft: [[f32; 3]; 3],
    /// AK8963 counts → body frame, 1/16 µT (everything folded together).
    mag_q16: MagCalibrationQ16,
    ahrs: backend::Ahrs,
    gyro_filter: GyroFilter,
    /// The rate loop's gyro: body FRD, bias removed, filtered, rad/s Q16.
    rates_q16: [i32; 3],
    accel_sum: [i32; 3],
    accel_n: u16,
    dt_sum_cycles: u32,
    cycle_s: f32,
    accel_mps2_per_lsb: f32,
    /// m/s² per unit of a down-axis sum of `control_divider` samples
    /// scaled by 2⁸ (see `control_step`).
    accel_mean_k: f32,
    mag_fresh: u16,
    baro: Option<CheapBaro>,
    /// Sum of the first pressures, Pa (the reference is their mean).
    p0_sum_pa: i32,
    /// Pressures summed in `p0_sum_pa`.
    p0_n: u16,
    vertical: VerticalEstimator,
    /// Gyro counts → rad/s Q16, in Q16 (`rate_q16 = counts · k >> 16`);
    /// `new` refuses a scale at or above 2·10⁹, so it fits an `i32` (and
    /// converts to f32 without the soft 64-bit conversion).
    gyro_rps_q16_per_lsb_q16: i32,
    out: Outputs,
}

fn positive(x: f32) -> bool {
    x.is_finite() && x > 0.0
}

/// Round to nearest i32, saturating.
fn round_i32(x: f32) -> i32 {
    (if x >= 0.0 { x + 0.5 } else { x - 0.5 }) as i32
}

impl Pipeline {
    /// Builds the pipeline from its configuration and the calibration
    /// record (gyro bias from the record until
    /// [`set_gyro_bias_counts`](Self::set_gyro_bias_counts) is called with
    /// the start-up measurement).
    // Not inlined into the firmware's init: built in its own frame, the
    // ~1.4 KB result is not shuffled through init's temporaries (0.7 KiB
    // less flash).
    #[inline(never)]
    pub fn new(cfg: PipelineConfig, cal: &CalibrationRecord) -> Result<Self, PipelineError> {
        let scales_ok = positive(cfg.gyro_dps_per_lsb)
            && positive(cfg.accel_g_per_lsb)
            && cfg.mag_ut_per_lsb.iter().all(|s| positive(*s))
            && cfg.cpu_hz > 0
            && cfg.control_divider > 0
            && cfg.imu_rate_hz > 0;
        if !scales_ok {
            return Err(PipelineError::InvalidScale);
        }
        let gyro_rps_per_lsb = cfg.gyro_dps_per_lsb * RAD_PER_DEG;
        let accel_mps2_per_lsb = cfg.accel_g_per_lsb * G_MPS2;
        let mag_q16 = mag_counts_to_body_q16(&cfg, cal)?;
        let gyro_k = gyro_rps_per_lsb * 4_294_967_296.0;
        if gyro_k.is_nan() || gyro_k >= 2.0e9 {
            return Err(PipelineError::InvalidScale);
        }
        let mut p = Self {
            mounting: cal.mounting,
            mount: AxisPick::new(&cal.mounting),
            // The calibration-derived fields are filled in by
            // `set_calibration` below: one copy of that code, not two.
            gyro_bias: [0; 3],
            accel_offset: [0; 3],
            accel_scale_q14: [0; 3],
            accel_calibrated: false,
            mag_offset_ut: cal.mag_offset_ut,
            mag_soft: cal.mag_soft_iron,
            mag_q16,
            ahrs: backend::Ahrs::new(cfg.ahrs, gyro_rps_per_lsb, accel_mps2_per_lsb, cfg.cpu_hz),
            gyro_filter: GyroFilter::new(&cfg.gyro_filter),
            rates_q16: [0; 3],
            accel_sum: [0; 3],
            accel_n: 0,
            dt_sum_cycles: 0,
            cycle_s: 1.0 / cfg.cpu_hz as f32,
            accel_mps2_per_lsb,
            accel_mean_k: accel_mps2_per_lsb / (256.0 * f32::from(cfg.control_divider)),
            mag_fresh: 0,
            baro: None,
            p0_sum_pa: 0,
            p0_n: 0,
            vertical: VerticalEstimator::new(cfg.vertical)?,
            gyro_rps_q16_per_lsb_q16: gyro_k as i32,
            out: Outputs::default(),
            cfg,
        };
        p.set_calibration(cal);
        Ok(p)
    }

    /// Applies a new calibration record (accelerometer, magnetometer,
    /// mounting; the gyro bias only if the record holds one). A
    /// magnetometer correction too large for the integer form (gains far
    /// beyond [`calibration::MAX_GAIN`]) keeps the previous one for the
    /// AHRS.
    // Out of line: shared by `new` and the firmware's save path.
    #[inline(never)]
    pub fn set_calibration(&mut self, cal: &CalibrationRecord) {
        let lsb_per_g = 1.0 / self.cfg.accel_g_per_lsb;
        let lsb_per_dps = 1.0 / self.cfg.gyro_dps_per_lsb;
        if cal.valid.has(ValidParts::GYRO) {
            self.gyro_bias = cal.gyro_bias_dps.map(|b| round_i32(b * lsb_per_dps));
        }
        self.mounting = cal.mounting;
        self.mount = AxisPick::new(&cal.mounting);
        self.accel_offset = cal.accel_offset_g.map(|o| round_i32(o * lsb_per_g));
        self.accel_scale_q14 = cal.accel_scale.map(|s| round_i32(s * 16_384.0));
        self.accel_calibrated = cal.valid.has(ValidParts::ACCEL);
        self.mag_offset_ut = cal.mag_offset_ut;
        self.mag_soft = cal.mag_soft_iron;
        if let Ok(m) = mag_counts_to_body_q16(&self.cfg, cal) {
            self.mag_q16 = m;
        }
    }

    /// Whether the craft is flying, from the flight controller: the AHRS's
    /// multirotor mode applies its drag model only then, and its tilt loop's
    /// hand-held form (ζ = ¾, the rest correction) only when not
    /// ([`fc_ahrs::Madgwick::set_in_flight`]).
    pub fn set_in_flight(&mut self, in_flight: bool) {
        self.ahrs.set_in_flight(in_flight);
    }

    /// The accelerometer correction in use was fitted (the record's
    /// [`ValidParts::ACCEL`]), not the identity default: what the flight
    /// controller's self-levelling modes need to arm.
    pub fn accel_calibrated(&self) -> bool {
        self.accel_calibrated
    }

    /// The gyro bias in use, counts (MPU frame).
    pub fn gyro_bias_counts(&self) -> [i32; 3] {
        self.gyro_bias
    }

    /// The configuration in use.
    pub fn config(&self) -> &PipelineConfig {
        &self.cfg
    }

    /// Replaces the gyro bias (counts, MPU frame), e.g. with the start-up
    /// measurement.
    pub fn set_gyro_bias_counts(&mut self, bias: [i16; 3]) {
        self.gyro_bias = bias.map(i32::from);
    }

    /// The AHRS mode in use.
    pub fn ahrs_mode(&self) -> AhrsMode {
        self.cfg.ahrs_mode
    }

    /// Degrades the pipeline at run time (a sensor failed in flight).
    pub fn set_capabilities(&mut self, ahrs_mode: AhrsMode, altitude: bool) {
        self.cfg.ahrs_mode = ahrs_mode;
        self.cfg.altitude = altitude;
    }

    /// Replaces the AK8963 scale (µT per count, factory adjustment
    /// included), for a magnetometer that was found after boot.
    pub fn set_mag_ut_per_lsb(&mut self, ut_per_lsb: [f32; 3]) {
        self.cfg.mag_ut_per_lsb = ut_per_lsb;
    }

    /// Calibrated accelerometer sample, counts, MPU frame (integer:
    /// `(raw − offset) · scale_q14 >> 14`).
    #[inline]
    pub fn calibrate_accel_counts(&self, raw: [i16; 3]) -> [i32; 3] {
        // |centred| ≤ 2^17 after saturation of a bad offset; s ≤ 2^15 (scale ≤ 2).
        let cal = |r: i16, off: i32, s: i32| {
            ((i64::from(i32::from(r).saturating_sub(off)) * i64::from(s)) >> 14) as i32
        };
        let (o, s) = (&self.accel_offset, &self.accel_scale_q14);
        [
            cal(raw[0], o[0], s[0]),
            cal(raw[1], o[1], s[1]),
            cal(raw[2], o[2], s[2]),
        ]
    }

    /// The 1 kHz step: bias, calibration, mounting, AHRS update and the
    /// accumulation for the vertical estimator. Returns `true` when a
    /// [`control_step`](Self::control_step) is due.
    ///
    /// ```
    /// use sensor_stack::pipeline::{ImuInput, Pipeline, PipelineConfig};
    /// let mut p = Pipeline::new(PipelineConfig::new(), &Default::default()).unwrap();
    /// // Flat, face up, still: +1 g on z_mpu (8192 counts at ±4 g).
    /// let s = ImuInput { accel: [0, 0, 8192], gyro: [0; 3], dt_cycles: 72_000 };
    /// for _ in 0..2000 {
    ///     if p.imu_step(&s) { p.control_step(); }
    /// }
    /// let o = p.outputs();
    /// assert!(o.roll_deg.abs() < 1.0 && o.pitch_deg.abs() < 1.0);
    /// ```
    pub fn imu_step(&mut self, input: &ImuInput) -> bool {
        if self.cfg.ahrs_mode == AhrsMode::None {
            return false;
        }
        // Written out per axis: at opt-level "z" the iterator form does
        // not inline and costs ~300 instructions a sample.
        let (r, b) = (&input.gyro, &self.gyro_bias);
        let gyro = [
            i32::from(r[0]).saturating_sub(b[0]),
            i32::from(r[1]).saturating_sub(b[1]),
            i32::from(r[2]).saturating_sub(b[2]),
        ];
        let accel = self.calibrate_accel_counts(input.accel);
        let gyro_b = self.mount.apply(gyro);
        let accel_b = self.mount.apply(accel);
        let use_mag = self.cfg.ahrs_mode == AhrsMode::Marg && self.mag_fresh > 0;
        self.mag_fresh = self.mag_fresh.saturating_sub(1);
        self.ahrs.update(gyro_b, accel_b, use_mag, input.dt_cycles);
        self.rates_q16 = self.gyro_filter.apply(self.counts_to_q16(gyro_b));
        let s = &mut self.accel_sum;
        s[0] = s[0].saturating_add(accel_b[0]);
        s[1] = s[1].saturating_add(accel_b[1]);
        s[2] = s[2].saturating_add(accel_b[2]);
        self.accel_n = self.accel_n.saturating_add(1);
        self.dt_sum_cycles = self.dt_sum_cycles.saturating_add(input.dt_cycles);
        self.out.imu_samples = self.out.imu_samples.wrapping_add(1);
        self.accel_n >= self.cfg.control_divider
    }

    /// Converts an AK8963 reading (counts, AK8963 frame) to µT in the MPU
    /// frame, factory adjustment applied but no hard/soft-iron correction
    /// (the input of the magnetometer calibration).
    pub fn mag_counts_to_mpu_raw_ut(&self, counts: [i16; 3]) -> [f32; 3] {
        let [s0, s1, s2] = self.cfg.mag_ut_per_lsb;
        let ak = [
            f32::from(counts[0]) * s0,
            f32::from(counts[1]) * s1,
            f32::from(counts[2]) * s2,
        ];
        // AK8963 → MPU: x_mpu = y_ak, y_mpu = x_ak, z_mpu = −z_ak.
        [ak[1], ak[0], -ak[2]]
    }

    /// Converts an AK8963 reading (counts, AK8963 frame) to the calibrated
    /// field in µT, MPU frame.
    pub fn mag_counts_to_mpu_ut(&self, counts: [i16; 3]) -> [f32; 3] {
        let raw = self.mag_counts_to_mpu_raw_ut(counts);
        let c = [
            raw[0] - self.mag_offset_ut[0],
            raw[1] - self.mag_offset_ut[1],
            raw[2] - self.mag_offset_ut[2],
        ];
        let m = &self.mag_soft;
        [
            m[0][0] * c[0] + m[0][1] * c[1] + m[0][2] * c[2],
            m[1][0] * c[0] + m[1][1] * c[1] + m[1][2] * c[2],
            m[2][0] * c[0] + m[2][1] * c[1] + m[2][2] * c[2],
        ]
    }

    /// One raw-log row from a raw sample: gyro bias removed (rad/s),
    /// accelerometer calibration applied (m/s²), magnetometer corrected
    /// (µT; NaN without a fresh reading), all in the MPU frame, at `t_s`
    /// seconds since boot.
    pub fn raw_log_row(
        &self,
        t_s: f32,
        accel: [i16; 3],
        gyro: [i16; 3],
        mag_counts: Option<[i16; 3]>,
    ) -> RawLogRow {
        let k_g = self.cfg.gyro_dps_per_lsb * (core::f32::consts::PI / 180.0);
        let mut gyr_rps = [0.0; 3];
        for ((o, g), b) in gyr_rps.iter_mut().zip(gyro).zip(self.gyro_bias) {
            *o = i32::from(g).saturating_sub(b) as f32 * k_g;
        }
        let k_a = self.cfg.accel_g_per_lsb * G_MPS2;
        RawLogRow {
            t_s,
            gyr_rps,
            acc_mps2: self.calibrate_accel_counts(accel).map(|c| c as f32 * k_a),
            mag_ut: mag_counts.map_or([f32::NAN; 3], |c| self.mag_counts_to_mpu_ut(c)),
        }
    }

    /// The 100 Hz magnetometer step (counts, AK8963 frame): calibrated
    /// body-frame field in 1/16 µT, integer only.
    pub fn mag_step(&mut self, counts: [i16; 3]) {
        let body_q4 = self.mag_q16.apply(counts.map(i32::from));
        self.ahrs.set_mag_q4(body_q4);
        // A reading stays usable for 3 magnetometer periods.
        self.mag_fresh = self.cfg.control_divider.saturating_mul(3);
        self.out.mag_samples = self.out.mag_samples.wrapping_add(1);
    }

    /// A barometer pressure, Pa. The mean of the first
    /// [`P0_AVERAGE_SAMPLES`] readings sets the take-off reference (height
    /// 0); the vertical estimator starts with the last of them.
    pub fn baro_step(&mut self, pressure_pa: i32) {
        if !self.cfg.altitude {
            return;
        }
        let baro = match self.baro {
            Some(b) => b,
            None => {
                // Integer sum: 64 readings of ≤ 2^17 Pa cannot reach 2^31;
                // saturation only guards against nonsense input.
                self.p0_sum_pa = self.p0_sum_pa.saturating_add(pressure_pa);
                self.p0_n = self.p0_n.saturating_add(1);
                if self.p0_n < P0_AVERAGE_SAMPLES {
                    return;
                }
                let p0_pa = self.p0_sum_pa as f32 / f32::from(self.p0_n);
                self.p0_sum_pa = 0;
                self.p0_n = 0;
                match CheapBaro::new(p0_pa) {
                    Ok(b) => {
                        self.baro = Some(b);
                        b
                    }
                    Err(_) => return,
                }
            }
        };
        let h = baro.height_m(pressure_pa);
        if self.vertical.update_baro(h).is_ok() {
            self.out.baro_samples = self.out.baro_samples.wrapping_add(1);
        }
    }

    /// The 100 Hz step: vertical prediction with the mean earth-frame
    /// vertical acceleration since the last call, and the Euler angles.
    pub fn control_step(&mut self) {
        let n = self.accel_n;
        if n == 0 {
            return;
        }
        let dt_s = self.dt_sum_cycles as f32 * self.cycle_s;
        let q = self.ahrs.quaternion_q30();
        // Σ specific force along NED down, counts · 2⁸: Q30 row · counts
        // (|Σ| ≤ 2¹⁵ · n) stays below 2⁵⁵ in i64.
        let down = angles::down_row_q30(q);
        let f_down: i64 = down
            .iter()
            .zip(self.accel_sum)
            .map(|(&d, a)| i64::from(d) * i64::from(a))
            .sum::<i64>()
            >> 22;
        let k = if n == self.cfg.control_divider {
            self.accel_mean_k
        } else {
            self.accel_mps2_per_lsb / (256.0 * f32::from(n))
        };
        self.accel_sum = [0; 3];
        self.accel_n = 0;
        self.dt_sum_cycles = 0;
        // |f_down| ≤ 3 · 2⁴⁵ · n / 2²² < 2²⁵ · n: an i32 up to n = 63 (10
        // normally); saturated beyond, and converted from i32 (`i64 as
        // f32` would link the soft-float `__aeabi_l2f`, 120 B, for this
        // one line). Up acceleration = −f_down − g.
        let f_down = f_down.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        let accel_up = -(f_down as f32 * k) - G_MPS2;
        if self.cfg.altitude && self.vertical.is_initialized() {
            let _ = self.vertical.predict(accel_up, dt_s);
        }
        let e_q16 = angles::euler_q16(q);
        if self.cfg.altitude && self.vertical.is_initialized() {
            self.out.altitude_m = self.vertical.height_m();
            self.out.vertical_speed_mps = self.vertical.velocity_mps();
        }
        let e = e_q16.map(|a| a as f32);
        self.out.roll_deg = e[0] * DEG_PER_Q16;
        self.out.pitch_deg = e[1] * DEG_PER_Q16;
        self.out.yaw_deg = e[2] * DEG_PER_Q16;
    }

    /// The latest outputs (attitude as of the last control step).
    pub fn outputs(&self) -> Outputs {
        self.out
    }

    /// The AHRS quaternion `q_ned_from_body`.
    pub fn quaternion(&self) -> Quaternion {
        self.ahrs.quaternion()
    }

    /// The AHRS quaternion `q_ned_from_body` as `[w, x, y, z]` in Q30, the
    /// form the fixed-point AHRS keeps (the flight controller's input).
    pub fn quaternion_q30(&self) -> [i32; 4] {
        self.ahrs.quaternion_q30()
    }

    /// The latest gyro sample in body FRD, bias removed, through the gyro
    /// filter ([`PipelineConfig::gyro_filter`]), rad/s: the rate loop's
    /// measurement.
    pub fn body_rates(&self) -> control::controllers::BodyRates {
        // By the bits (`q_to_f32`), not a soft-float multiply per axis.
        let g = self.body_rates_q16();
        control::controllers::BodyRates {
            roll_rps: q_to_f32(g[0], 16),
            pitch_rps: q_to_f32(g[1], 16),
            yaw_rps: q_to_f32(g[2], 16),
        }
    }

    /// [`body_rates`](Self::body_rates) in Q16 rad/s: the latest sample
    /// through the gyro filter ([`PipelineConfig::gyro_filter`]).
    pub fn body_rates_q16(&self) -> [i32; 3] {
        self.rates_q16
    }

    /// Body gyro counts to Q16 rad/s: counts · k / 2¹⁶ with `k` in Q16
    /// rad/s per count, Q16 (|counts| < 2¹⁷, k < 2²⁴: the product fits
    /// `i64`; the result, at most ±35 rad/s, fits Q16).
    fn counts_to_q16(&self, g: [i32; 3]) -> [i32; 3] {
        let k = i64::from(self.gyro_rps_q16_per_lsb_q16);
        let rate = |c: i32| ((i64::from(c) * k) >> 16) as i32;
        [rate(g[0]), rate(g[1]), rate(g[2])]
    }

    /// Height (m, up, above the take-off reference) and vertical speed
    /// (m/s, up), once the barometer has initialised the estimator; `None`
    /// without a barometer.
    pub fn altitude_estimate(&self) -> Option<(f32, f32)> {
        if self.cfg.altitude && self.vertical.is_initialized() {
            Some((self.vertical.height_m(), self.vertical.velocity_mps()))
        } else {
            None
        }
    }
}

/// A [`Mounting`] as the source MPU axis (0..=2) and sign of each body
/// axis, applied with three selects and no iterator.
#[derive(Clone, Copy, Debug)]
struct AxisPick {
    src: [u8; 3],
    neg: [bool; 3],
}

impl AxisPick {
    fn new(m: &Mounting) -> Self {
        // Each body axis receives ±(source + 1) from the probe (1, 2, 3).
        let r = m.apply_i32([1, 2, 3]);
        Self {
            src: r.map(|v| (v.unsigned_abs().clamp(1, 3) - 1) as u8),
            neg: r.map(|v| v < 0),
        }
    }

    #[inline]
    fn apply(&self, v: [i32; 3]) -> [i32; 3] {
        let (s, n) = (&self.src, &self.neg);
        [
            pick(&v, s[0], n[0]),
            pick(&v, s[1], n[1]),
            pick(&v, s[2], n[2]),
        ]
    }
}

#[inline]
fn pick(v: &[i32; 3], src: u8, neg: bool) -> i32 {
    let x = match src {
        0 => v[0],
        1 => v[1],
        _ => v[2],
    };
    if neg {
        x.saturating_neg()
    } else {
        x
    }
}

/// The magnetometer chain from AK8963 counts to the body frame in 1/16 µT
/// as one affine map: `16 · B · W · (P · S · counts − offset)` with `S` the
/// µT-per-count scale, `P` the AK8963 → MPU axis swap, `W`/`offset` the
/// record's soft/hard iron (MPU frame, µT) and `B` the mounting.
fn mag_counts_to_body_q16(
    cfg: &PipelineConfig,
    cal: &CalibrationRecord,
) -> Result<MagCalibrationQ16, PipelineError> {
    let [s0, s1, s2] = cfg.mag_ut_per_lsb;
    let w = MagCalibration {
        offset: cal.mag_offset_ut,
        soft_iron: cal.mag_soft_iron,
    };
    // Columns of W · P · S · 16: column j is the corrected response to one
    // count on AK8963 axis j (x_ak → y_mpu, y_ak → x_mpu, z_ak → −z_mpu);
    // the mounting then maps each column to the body frame.
    let no_offset = MagCalibration {
        offset: [0.0; 3],
        ..w
    };
    let cols = [
        cal.mounting
            .apply_f32(no_offset.apply([0.0, 16.0 * s0, 0.0])),
        cal.mounting
            .apply_f32(no_offset.apply([16.0 * s1, 0.0, 0.0])),
        cal.mounting
            .apply_f32(no_offset.apply([0.0, 0.0, -16.0 * s2])),
    ];
    let [c0, c1, c2] = cols;
    let m = [
        [c0[0], c1[0], c2[0]],
        [c0[1], c1[1], c2[1]],
        [c0[2], c1[2], c2[2]],
    ];
    // The offset in AK8963 counts: P⁻¹ S⁻¹ · offset_mpu.
    let [ox, oy, oz] = cal.mag_offset_ut;
    let offset_counts = [oy / s0, ox / s1, -oz / s2];
    MagCalibrationQ16::from_affine(m, offset_counts).map_err(|_| PipelineError::InvalidScale)
}

// The two backends have the same shape on purpose: the `f32-ahrs` feature
// swaps one for the other behind the same calls.
#[cfg(feature = "f32-ahrs")]
mod backend {
    //! f32 Madgwick (`fc_ahrs::Madgwick`), inputs converted from counts
    //! with one multiply per axis (each a soft-float call on the M3).
    use fc_ahrs::{Config, Madgwick, Quaternion};

    pub const KIND: &str = "f32 Madgwick";

    pub struct Ahrs {
        filter: Madgwick,
        gyro_k: f32,
        accel_k: f32,
        cycle_s: f32,
        mag: [f32; 3],
    }

    impl Ahrs {
        pub fn new(
            cfg: Config,
            gyro_rps_per_lsb: f32,
            accel_mps2_per_lsb: f32,
            cpu_hz: u32,
        ) -> Self {
            Self {
                filter: Madgwick::new(cfg),
                gyro_k: gyro_rps_per_lsb,
                accel_k: accel_mps2_per_lsb,
                cycle_s: 1.0 / cpu_hz as f32,
                mag: [0.0; 3],
            }
        }

        pub fn set_mag_q4(&mut self, body_q4: [i32; 3]) {
            self.mag = body_q4.map(|m| m as f32 * (1.0 / 16.0));
        }

        pub fn set_in_flight(&mut self, in_flight: bool) {
            self.filter.set_in_flight(in_flight);
        }

        #[inline]
        pub fn update(
            &mut self,
            gyro_b: [i32; 3],
            accel_b: [i32; 3],
            use_mag: bool,
            dt_cycles: u32,
        ) {
            let g = gyro_b.map(|c| c as f32 * self.gyro_k);
            let a = accel_b.map(|c| c as f32 * self.accel_k);
            let dt = dt_cycles as f32 * self.cycle_s;
            if use_mag {
                self.filter.update_marg(g, a, self.mag, dt);
            } else {
                self.filter.update_imu(g, a, dt);
            }
        }

        pub fn quaternion(&self) -> Quaternion {
            self.filter.quaternion()
        }

        pub fn quaternion_q30(&self) -> [i32; 4] {
            let q = self.filter.quaternion();
            [q.w, q.x, q.y, q.z].map(|c| (c * (1u32 << 30) as f32) as i32)
        }
    }
}

#[cfg(not(feature = "f32-ahrs"))]
mod backend {
    //! Fixed-point Madgwick (`fc_ahrs::fixed::MadgwickFixed`): gyro counts →
    //! rad/s Q20 with one 32×32→64 multiply per axis (`K` in Q36 rad/s per
    //! count, shifted right 16), accelerometer in counts (the filter's
    //! `gravity_norm` is set to 1 g in counts), magnetometer in 1/16 µT,
    //! dt in cycles → Q31 s with one multiply (`2^47 / cpu_hz`, shifted 16).
    use control::fixed::q_to_f32;
    use fc_ahrs::fixed::{FixedConfig, MadgwickFixed};
    use fc_ahrs::{Config, Quaternion};

    pub const KIND: &str = "fixed-point Madgwick (Q30)";

    pub struct Ahrs {
        filter: MadgwickFixed,
        gyro_k_q36: i64,
        dt_k: u64,
        mag: [i32; 3],
    }

    impl Ahrs {
        pub fn new(
            cfg: Config,
            gyro_rps_per_lsb: f32,
            accel_mps2_per_lsb: f32,
            cpu_hz: u32,
        ) -> Self {
            let lsb_per_g = super::G_MPS2 / accel_mps2_per_lsb;
            let fixed = FixedConfig::from_config(&Config {
                gravity_norm: lsb_per_g,
                ..cfg
            });
            let k = gyro_rps_per_lsb * 68_719_476_736.0; // 2^36
            Self {
                filter: MadgwickFixed::new(fixed),
                // k > 0: `Pipeline::new` refuses a scale that is not
                // positive before it gets here.
                gyro_k_q36: if k.is_finite() {
                    fc_ahrs::fixed::f32_to_u64(k).min(i64::MAX as u64) as i64
                } else {
                    0
                },
                // 2^47 / cpu_hz (1.95e6 at 72 MHz), computed in f32 (init only).
                dt_k: fc_ahrs::fixed::f32_to_u64(140_737_488_355_328.0f32 / cpu_hz.max(1) as f32),
                mag: [0; 3],
            }
        }

        pub fn set_mag_q4(&mut self, body_q4: [i32; 3]) {
            self.mag = body_q4;
        }

        pub fn set_in_flight(&mut self, in_flight: bool) {
            self.filter.set_in_flight(in_flight);
        }

        #[inline]
        pub fn update(
            &mut self,
            gyro_b: [i32; 3],
            accel_b: [i32; 3],
            use_mag: bool,
            dt_cycles: u32,
        ) {
            let k = self.gyro_k_q36;
            // |counts| ≤ 2^17, k < 2^27: the product fits i64 easily.
            let g = gyro_b.map(|c| ((i64::from(c) * k) >> 16) as i32);
            let dt = ((u64::from(dt_cycles) * self.dt_k) >> 16).min(i32::MAX as u64) as i32;
            if use_mag {
                self.filter.update_marg(g, accel_b, self.mag, dt);
            } else {
                self.filter.update_imu(g, accel_b, dt);
            }
        }

        /// By the bits (`q_to_f32`), not a soft-float multiply each.
        pub fn quaternion(&self) -> Quaternion {
            let q = self.filter.quaternion_q30();
            Quaternion::new(
                q_to_f32(q[0], 30),
                q_to_f32(q[1], 30),
                q_to_f32(q[2], 30),
                q_to_f32(q[3], 30),
            )
        }

        pub fn quaternion_q30(&self) -> [i32; 4] {
            self.filter.quaternion_q30()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(accel: [i16; 3], gyro: [i16; 3]) -> ImuInput {
        ImuInput {
            accel,
            gyro,
            dt_cycles: 72_000,
        }
    }

    #[test]
    fn accel_calibration_integer() {
        let mut rec = CalibrationRecord::default();
        rec.accel_offset_g = [0.01, 0.0, -0.02];
        rec.accel_scale = [1.0, 0.5, 1.25];
        let p = Pipeline::new(PipelineConfig::new(), &rec).unwrap();
        // offset 0.01 g = 82 counts; −0.02 g = −164 counts.
        assert_eq!(
            p.calibrate_accel_counts([1082, 1000, 8028]),
            [1000, 500, 10240]
        );
        assert_eq!(p.calibrate_accel_counts([i16::MIN, i16::MAX, 0])[1], 16383);
    }

    /// A pipeline with the IMU-only AHRS and default calibration.
    fn imu_only() -> Pipeline {
        Pipeline::new(
            PipelineConfig {
                ahrs_mode: AhrsMode::ImuOnly,
                ..PipelineConfig::new()
            },
            &Default::default(),
        )
        .unwrap()
    }

    /// Feeds `n` identical 1 kHz samples, with the control step as the
    /// firmware schedules it.
    fn run(p: &mut Pipeline, accel: [i16; 3], gyro: [i16; 3], n: usize) {
        for _ in 0..n {
            if p.imu_step(&sample(accel, gyro)) {
                p.control_step();
            }
        }
    }

    #[test]
    fn tilt_and_yaw_rate_come_out_in_body_frd() {
        let mut p = imu_only();
        // Rolled right wing down by 30°: in FRD gravity (down) appears on +y_body
        // and the specific force (up) on −y_body, i.e. +y_mpu (y_body = −y_mpu).
        let (s, c) = (0.5f32, 0.866_025_4f32);
        let acc = [0i16, (8192.0 * s) as i16, (8192.0 * c) as i16];
        run(&mut p, acc, [0; 3], 4000);
        let o = p.outputs();
        assert!((o.roll_deg - 30.0).abs() < 1.0, "{o:?}");
        assert!(o.pitch_deg.abs() < 1.0, "{o:?}");
        // Yaw rate about body z (down) = −z_mpu: 32.8 counts = 1 °/s on −z_mpu.
        let mut p = imu_only();
        run(&mut p, [0, 0, 8192], [0, 0, -328], 1000);
        let yaw = p.outputs().yaw_deg;
        assert!(
            (yaw - 10.0).abs() < 0.5,
            "yaw after 1 s at 10 °/s clockwise: {yaw}"
        );
    }

    #[test]
    fn gyro_bias_is_removed() {
        let mut p = imu_only();
        p.set_gyro_bias_counts([0, 0, 100]);
        run(&mut p, [0, 0, 8192], [0, 0, 100], 1000);
        assert!(p.outputs().yaw_deg.abs() < 0.05);
    }

    #[test]
    fn mag_frames() {
        let p = Pipeline::new(
            PipelineConfig {
                mag_ut_per_lsb: [0.125, 0.25, 0.5],
                ..PipelineConfig::new()
            },
            &Default::default(),
        )
        .unwrap();
        // 100 counts on x_ak = 12.5 µT on y_mpu; z_ak = −z_mpu.
        assert_eq!(p.mag_counts_to_mpu_ut([100, 0, 0]), [0.0, 12.5, 0.0]);
        assert_eq!(p.mag_counts_to_mpu_ut([0, 100, 0]), [25.0, 0.0, 0.0]);
        assert_eq!(p.mag_counts_to_mpu_ut([0, 0, 100]), [0.0, 0.0, -50.0]);
        // Hard iron then soft iron, in the MPU frame.
        let mut rec = CalibrationRecord::default();
        rec.mag_offset_ut = [10.0, 0.0, 0.0];
        rec.mag_soft_iron = [[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let p = Pipeline::new(
            PipelineConfig {
                mag_ut_per_lsb: [0.125, 0.25, 0.5],
                ..PipelineConfig::new()
            },
            &rec,
        )
        .unwrap();
        assert_eq!(p.mag_counts_to_mpu_ut([0, 100, 0]), [30.0, 0.0, 0.0]);
        assert_eq!(p.mag_counts_to_mpu_raw_ut([0, 100, 0]), [25.0, 0.0, 0.0]);
        let mut q = Pipeline::new(
            PipelineConfig {
                mag_ut_per_lsb: [0.125, 0.25, 0.5],
                ..PipelineConfig::new()
            },
            &Default::default(),
        )
        .unwrap();
        q.set_calibration(&rec);
        assert_eq!(q.mag_counts_to_mpu_ut([0, 100, 0]), [30.0, 0.0, 0.0]);
    }

    #[test]
    fn altitude_from_baro_and_still_accel() {
        let mut p = Pipeline::new(PipelineConfig::new(), &Default::default()).unwrap();
        // 1 s of still samples, baro at reference, then the pressure of +10 m.
        let p0 = 100_000;
        let p10 = control::baro::pressure_pa(10.0, p0 as f32).unwrap() as i32;
        for i in 0..20_000 {
            if p.imu_step(&sample([0, 0, 8192], [0; 3])) {
                p.control_step();
            }
            if i % 10 == 0 {
                p.baro_step(if i < 1000 { p0 } else { p10 });
            }
        }
        let o = p.outputs();
        assert!((o.altitude_m - 10.0).abs() < 0.3, "{o:?}");
        assert!(o.vertical_speed_mps.abs() < 0.3, "{o:?}");
    }

    #[test]
    fn take_off_reference_is_the_mean_of_the_first_readings() {
        let mut p = Pipeline::new(PipelineConfig::new(), &Default::default()).unwrap();
        let p0 = 100_000;
        // Reading noise of ±12 Pa (±1 m): the first reading alone is 12 Pa
        // high, which a single-reading reference turns into a 1 m offset.
        let noisy = |i: u16| p0 + if i.is_multiple_of(2) { 12 } else { -12 };
        for i in 0..P0_AVERAGE_SAMPLES - 1 {
            p.baro_step(noisy(i));
        }
        assert_eq!(p.outputs().baro_samples, 0, "no height before the mean");
        p.baro_step(noisy(P0_AVERAGE_SAMPLES - 1));
        assert_eq!(p.outputs().baro_samples, 1);
        // Then the true pressure, still: the height must settle at 0, not
        // at the −1 m the first reading would have given.
        for i in 0..3000 {
            if p.imu_step(&sample([0, 0, 8192], [0; 3])) {
                p.control_step();
            }
            if i % 10 == 0 {
                p.baro_step(p0);
            }
        }
        let h = p.outputs().altitude_m;
        assert!(h.abs() < 0.05, "height above the mean reference: {h} m");
    }

    #[test]
    fn take_off_reference_ignores_a_rejected_mean() {
        let mut p = Pipeline::new(PipelineConfig::new(), &Default::default()).unwrap();
        // Nonsense pressures (negative): no reference, no height, no panic.
        for _ in 0..2 * P0_AVERAGE_SAMPLES {
            p.baro_step(-5);
        }
        assert_eq!(p.outputs().baro_samples, 0);
        for _ in 0..P0_AVERAGE_SAMPLES {
            p.baro_step(i32::MAX);
        }
        // Then real readings start a fresh mean.
        for _ in 0..P0_AVERAGE_SAMPLES {
            p.baro_step(100_000);
        }
        assert_eq!(p.outputs().baro_samples, 1);
    }

    #[test]
    fn integer_mag_chain_matches_the_f32_chain() {
        let mut rec = CalibrationRecord::default();
        rec.mag_offset_ut = [12.5, -30.0, 4.0];
        rec.mag_soft_iron = [[1.1, 0.05, -0.02], [0.05, 0.9, 0.01], [-0.02, 0.01, 1.02]];
        rec.mounting = Mounting::default();
        let cfg = PipelineConfig {
            mag_ut_per_lsb: [0.15, 0.16, 0.14],
            ..PipelineConfig::new()
        };
        let p = Pipeline::new(cfg, &rec).unwrap();
        for counts in [
            [0i16, 0, 0],
            [300, -200, 100],
            [-2000, 1500, 3000],
            [32_000, -32_000, 5],
        ] {
            let want = rec.mounting.apply_f32(p.mag_counts_to_mpu_ut(counts));
            let got = p.mag_q16.apply(counts.map(i32::from));
            for i in 0..3 {
                // 2.25 LSB of 1/16 µT plus the f32 chain's own rounding.
                let err = (got[i] as f32 / 16.0 - want[i]).abs();
                assert!(
                    err < 0.15 + 1e-5 * want[i].abs(),
                    "{counts:?}: {got:?} vs {want:?}"
                );
            }
        }
    }

    #[test]
    fn hot_path_mounting_equals_mounting() {
        let mut seen = 0;
        for code in 0..=u16::MAX {
            let Ok(m) = Mounting::from_code(code) else {
                continue;
            };
            seen += 1;
            let pick = AxisPick::new(&m);
            for v in [[1, -20, 300], [i32::MIN, 7, i32::MAX]] {
                assert_eq!(pick.apply(v), m.apply_i32(v), "{code}");
            }
        }
        assert_eq!(seen, 24, "every axis-aligned rotation");
    }

    #[test]
    fn control_step_angles_match_the_quaternion() {
        let mut p = imu_only();
        // Tilted 20° about x_mpu and 10° about y_mpu, still.
        let acc = [-1423i16, 2726, 7586];
        run(&mut p, acc, [0; 3], 3000);
        let o = p.outputs();
        let e = p.quaternion().to_euler_rad().map(|a| a.to_degrees());
        assert!((o.roll_deg - e[0]).abs() < 0.01, "{o:?} {e:?}");
        assert!((o.pitch_deg - e[1]).abs() < 0.01, "{o:?} {e:?}");
        assert!((o.yaw_deg - e[2]).abs() < 0.01, "{o:?} {e:?}");
        assert!(o.roll_deg.abs() > 5.0 && o.pitch_deg.abs() > 5.0, "{o:?}");
    }

    #[test]
    fn rejects_bad_scales() {
        let cfg = PipelineConfig {
            gyro_dps_per_lsb: 0.0,
            ..PipelineConfig::new()
        };
        assert_eq!(
            Pipeline::new(cfg, &Default::default()).err(),
            Some(PipelineError::InvalidScale)
        );
    }
}
