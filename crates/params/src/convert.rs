//! From the table's scaled integers to the configurations the firmware's
//! crates take. The mapping (every other field stays the `base`'s):
//!
//! | parameter | field |
//! |---|---|
//! | `rate.AXIS.p/i/d` | `FlightConfig::rate.AXIS.kp/ki/kd` |
//! | `dterm.lpf` | `rate.roll/pitch.d_cutoff_hz` (yaw has no D filter) |
//! | `level.p` | `level.kp_per_s` |
//! | `level.max_rate` | `level.max_rate_rps` (°/s → rad/s) |
//! | `level.angle`, `level.expo` | `sticks.max_angle_deg`, `sticks.angle_expo` |
//! | `rates.AXIS`, `expo.AXIS` | `sticks.AXIS.max_rate_dps`, `.expo` |
//! | `sticks.deadband` | `sticks.roll/pitch/yaw.deadband` |
//! | `esc.idle` | `mixer.idle` |
//! | `esc.test` | `safety.motor_test_command` |
//! | `failsafe.hold/descent/throttle` | `safety.failsafe_hold_s/_descent_mps/_collective_max` |
//! | `gyro.lpf`, `gyro.notch`, `gyro.notch_q` | [`ParamSet::gyro_filter`] |
//! | `rc.*` | [`ParamSet::channel_map`], [`ParamSet::mode_channel`], [`ParamSet::motor_test_channel`] |
//! | `failsafe.timeout` | [`ParamSet::link_timeout_us`] (`rc_input::LinkMonitor::new`) |
//! | `imu.mount` | [`ParamSet::mounting`] |
//! | `trim.roll`, `trim.pitch` | [`ParamSet::level_trim_mpu_g`] (an accelerometer offset) |
//! | `batt.*` | [`ParamSet::battery_config`] |
//!
//! What the battery and trim values mean:
//!
//! * `batt.scale` (3 decimals): the resistor divider's ratio, pack volts
//!   per volt at the ADC pin (11.000 for 10 kΩ over 1 kΩ). From one
//!   multimeter reading: new scale = old scale × measured / shown (the
//!   board's console does it: `vbat VOLTS`).
//! * `batt.warn_cv`, `batt.crit_cv`: per-cell thresholds in 0.01 V
//!   (Betaflight's 3.50 V and 3.30 V); `batt.cells`: the cell count, 0 to
//!   detect it when the pack is connected.
//! * `trim.roll`, `trim.pitch` (2 decimals, degrees): the tilt angle mode
//!   holds with centred sticks, which cancels the accelerometer's level
//!   error (the calibration residue of a few tenths of a degree that makes
//!   the craft drift): an accelerometer offset ([`ParamSet::level_trim_mpu_g`])
//!   that makes the attitude estimate read level at that tilt.
//!
//! The f32 values are the scaled integer divided by 10^decimals, which is
//! the f32 nearest the decimal (both operands are exact), so the defaults
//! convert to the very constants they replace. The conversion runs where
//! the configuration is built (at boot, or when a value changes), never
//! on the per-sample path.

use crate::table::ParamSet;
use crate::ParamId as P;
use battery::Scale;
use flight::flightctl::FlightConfig;
use rc_input::{ChannelMap, ChannelOrder, ConfigError, SwitchPosition};
use sensor_stack::gyro_filter::{GyroFilterConfig, GyroLowPass, GyroNotch};
use sensor_stack::mounting::Mounting;

impl ParamSet {
    /// `id`'s value as an f32 (the scaled integer / 10^decimals).
    pub fn real(&self, id: P) -> f32 {
        let scale = match id.param().decimals {
            0 => 1.0,
            1 => 10.0,
            2 => 100.0,
            3 => 1000.0,
            _ => 10_000.0,
        };
        self.get(id) as f32 / scale
    }

    /// `base` with the table's tuning (the module's mapping).
    pub fn flight_config(&self, base: FlightConfig) -> FlightConfig {
        let mut c = base;
        let pids = [
            (&mut c.rate.roll, [P::RateRollP, P::RateRollI, P::RateRollD]),
            (
                &mut c.rate.pitch,
                [P::RatePitchP, P::RatePitchI, P::RatePitchD],
            ),
            (&mut c.rate.yaw, [P::RateYawP, P::RateYawI, P::RateYawD]),
        ];
        for (pid, [p, i, d]) in pids {
            pid.kp = self.real(p);
            pid.ki = self.real(i);
            pid.kd = self.real(d);
        }
        c.rate.roll.d_cutoff_hz = self.real(P::DtermLpf);
        c.rate.pitch.d_cutoff_hz = self.real(P::DtermLpf);
        c.level.kp_per_s = self.real(P::LevelP);
        c.level.max_rate_rps = self.real(P::LevelMaxRate) * core::f32::consts::PI / 180.0;
        c.sticks.max_angle_deg = self.real(P::LevelAngle);
        c.sticks.angle_expo = self.real(P::LevelExpo);
        let axes = [
            (&mut c.sticks.roll, P::RatesRoll, P::ExpoRoll),
            (&mut c.sticks.pitch, P::RatesPitch, P::ExpoPitch),
            (&mut c.sticks.yaw, P::RatesYaw, P::ExpoYaw),
        ];
        for (axis, rate, expo) in axes {
            axis.max_rate_dps = self.real(rate);
            axis.expo = self.real(expo);
            axis.deadband = self.real(P::SticksDeadband);
        }
        c.mixer.idle = self.real(P::EscIdle);
        c.safety.motor_test_command = self.real(P::EscTest);
        c.safety.failsafe_hold_s = self.real(P::FailsafeHold);
        c.safety.failsafe_descent_mps = self.real(P::FailsafeDescent);
        c.safety.failsafe_collective_max = self.real(P::FailsafeThrottle);
        c
    }

    /// The rate loop's gyro filters: a PT1 low-pass and a notch, each off
    /// at 0 Hz. Designing it (`GyroFilterConfig::design`) is the caller's.
    pub fn gyro_filter(&self) -> GyroFilterConfig {
        let low_pass = match self.get(P::GyroLpf) {
            0 => GyroLowPass::Off,
            _ => GyroLowPass::Pt1 {
                cutoff_hz: self.real(P::GyroLpf),
            },
        };
        let notch = (self.get(P::GyroNotch) != 0).then(|| GyroNotch {
            center_hz: self.real(P::GyroNotch),
            q: self.real(P::GyroNotchQ),
        });
        GyroFilterConfig { low_pass, notch }
    }

    /// Whether the board will take these values at boot, beyond each one's
    /// range: the battery levels (critical below warning), the channels
    /// (no two functions on one), the gyro filter (designable at the
    /// sample rate `imu_rate_hz`). `Err` names what it would refuse; the
    /// console's `save` checks it first, so a saved set never boots into
    /// the defaults.
    pub fn validate(&self, imu_rate_hz: f32) -> Result<(), &'static str> {
        self.battery_config()
            .map_err(|_| "batt.crit_cv must be below batt.warn_cv")?;
        self.channel_map()
            .map_err(|_| "two rc.* functions on one channel")?;
        self.gyro_filter()
            .design(imu_rate_hz)
            .map_err(|_| "the gyro filter cannot be designed at the sample rate")?;
        Ok(())
    }

    /// The 0-based channel index of a 1-based channel parameter.
    fn index(&self, id: P) -> u8 {
        u8::try_from(self.get(id).saturating_sub(1)).unwrap_or(u8::MAX)
    }

    /// Sticks and arm switch (active high), nominal ranges. Errors: two of
    /// the sticks, the arm, mode and motor-test switches on one channel
    /// ([`ConfigError::DuplicateChannel`], 0-based).
    pub fn channel_map(&self) -> Result<ChannelMap, ConfigError> {
        let order = ChannelOrder::new(
            self.index(P::RcRoll),
            self.index(P::RcPitch),
            self.index(P::RcYaw),
            self.index(P::RcThrottle),
        )?;
        let map =
            ChannelMap::new(order).with_arm_switch(self.index(P::RcArm), SwitchPosition::High)?;
        let used = [P::RcRoll, P::RcPitch, P::RcYaw, P::RcThrottle, P::RcArm];
        for switch in [P::RcMode, P::RcMotorTest] {
            let clash = used
                .iter()
                .chain([P::RcMode].iter().filter(|_| switch == P::RcMotorTest));
            if clash.map(|&u| self.get(u)).any(|c| c == self.get(switch)) {
                return Err(ConfigError::DuplicateChannel {
                    channel: self.index(switch),
                });
            }
        }
        Ok(map)
    }

    /// The flight-mode switch's 0-based channel index.
    pub fn mode_channel(&self) -> u8 {
        self.index(P::RcMode)
    }

    /// The motor-test switch's 0-based channel index.
    pub fn motor_test_channel(&self) -> u8 {
        self.index(P::RcMotorTest)
    }

    /// The receiver's link-loss timeout, µs.
    pub fn link_timeout_us(&self) -> u32 {
        u32::try_from(self.get(P::FailsafeTimeout))
            .unwrap_or(0)
            .saturating_mul(1000)
    }

    /// The MPU-9250's mounting (the set only holds rotation codes; the
    /// default mounting if that were ever broken).
    pub fn mounting(&self) -> Mounting {
        u16::try_from(self.get(P::ImuMount))
            .ok()
            .and_then(|c| Mounting::from_code(c).ok())
            .unwrap_or_default()
    }

    /// The battery monitor's settings: `batt.scale` (pack volts per pin
    /// volt, 3 decimals; × 3300 mV at the ADC's full scale), `batt.cells`
    /// (0: detect), `batt.warn_cv`, `batt.crit_cv` (0.01 V a cell); the
    /// rest `battery::Config::DEFAULT`'s. The table's ranges are the
    /// monitor's (the scale's 10–80 V at full scale, the levels' 3.00–4.00
    /// and 2.80–3.99 V, up to 8 cells); what it checks besides is the
    /// critical level below the warning.
    pub fn battery_config(&self) -> Result<battery::Config, battery::Error> {
        let v = |id: P| u32::try_from(self.get(id)).unwrap_or(0);
        let cfg = battery::Config {
            scale: Scale::new(v(P::BattScale) * 3300 / 1000)?,
            cells_override: u8::try_from(v(P::BattCells)).unwrap_or(0),
            warning_cell_mv: u16::try_from(v(P::BattWarn) * 10).unwrap_or(0),
            critical_cell_mv: u16::try_from(v(P::BattCrit) * 10).unwrap_or(0),
            ..battery::Config::DEFAULT
        };
        cfg.check().map(|()| cfg)
    }

    /// The level trim as an offset to add to the calibration's
    /// accelerometer offset (g, MPU sensor frame, `mounting` taking body
    /// FRD to it). At rest tilted by roll φ and pitch θ the accelerometer
    /// reads (g sin θ, −g sin φ cos θ, ·) in body FRD; subtracting
    /// (sin θ_t, −sin φ_t, 0) g from it makes the estimate read level at
    /// (φ_t, θ_t), so angle mode holds the craft there with centred sticks
    /// (`trim.roll` > 0: right side down; `trim.pitch` > 0: nose up). The
    /// sine by its Taylor series to the cube (within 2·10⁻⁶ at the ±10°
    /// limit): no libm on the board for two numbers at boot.
    pub fn level_trim_mpu_g(&self, mounting: &Mounting) -> [f32; 3] {
        let rad = |id: P| self.real(id) * (core::f32::consts::PI / 180.0);
        let sin = |x: f32| x - x * x * x / 6.0;
        let body = [sin(rad(P::TrimPitch)), -sin(rad(P::TrimRoll)), 0.0];
        // Body → MPU: the transpose of the signed permutation `mounting`
        // applies (MPU → body); its columns are the images of the axes.
        let col = |i: usize| {
            let mut e = [0.0f32; 3];
            if let Some(x) = e.get_mut(i) {
                *x = 1.0;
            }
            mounting.apply_f32(e)
        };
        let dot = |c: [f32; 3]| c[0] * body[0] + c[1] * body[1] + c[2] * body[2];
        [dot(col(0)), dot(col(1)), dot(col(2))]
    }
}
