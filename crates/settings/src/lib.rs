//! The board's flight settings in one place: what the firmware flies and
//! what `cargo sim --scenario` and the emulated board (`cargo fil`) fly, so
//! a gain or a filter changed here can be flown on the models before the
//! real craft. Change a value, then `cargo sim --scenario chirp --bode
//! out/bode.png` measures the rate loop's margins with it, and `cargo fw` /
//! `cargo embed --release` builds it for the board.
//!
//! The receiver's channels, the mounting and the ESC protocol are the
//! board's wiring and stay in `firmware/src/config.rs`.
//!
//! | setting | what | where it acts |
//! |---|---|---|
//! | [`MPU`] | the MPU-9250's ranges, its gyro and accelerometer DLPF, 1 kHz | the chip |
//! | [`GYRO_FILTER`] | the rate loop's gyro low-pass and notch | `sensor_stack::gyro_filter` |
//! | [`flight_config`] | rates, gains, D-term low-pass, failsafe, arming | `flight::flightctl` |
//!
//! # Why these values
//!
//! The gyro path's delay costs the rate loop phase at its crossover
//! (≈ 6 Hz): every millisecond is about 2° there. The chip's DLPF_CFG 3
//! (41 Hz) alone delays the gyro 5.9 ms (datasheet), DLPF_CFG 1 (184 Hz)
//! 2.9 ms. The faster setting lets more of the frame's vibration through
//! (the rotors' imbalance at 200 Hz in the hover, 320 Hz at full throttle,
//! for the simulated 250-class quad), which the software low-pass and the
//! notch at the hover's rotor frequency take out with half the delay the
//! chip's 41 Hz filter had. The sweeps that chose each value and what each
//! does to the margins and to the motors' noise: README, "How the defaults
//! were chosen" (`cargo sim --scenario chirp --sweep NAME=LO:HI:N`).
#![no_std]
#![deny(missing_docs)]

use control::loops::{LevelConfig, RateConfig};
use flight::arming::SafetyConfig;
use flight::flightctl::FlightConfig;
use mpu9250::{GyroBandwidth, GyroRange};
use sensor_stack::gyro_filter::{GyroFilterConfig, GyroFilterDesign, GyroLowPass, GyroNotch};
use sensor_stack::pipeline::PipelineConfig;
use sensor_stack::sensors::SensorsConfig;

/// The IMU sample rate (Hz): the MPU-9250's 1 kHz internal rate with its
/// sample-rate divider at 0 (the fastest this board's 400 kHz I2C reads).
pub const IMU_RATE_HZ: f32 = 1000.0;

// The filter's design rate is the rate the chip outputs and the sample
// scheduler assumes.
const _: () = assert!(
    MPU.gyro_bandwidth.internal_rate_hz() == 1000
        && MPU.sample_rate_divider == 0
        && sensor_stack::schedule::IMU_RATE_HZ == 1000
        && IMU_RATE_HZ == 1000.0,
    "IMU_RATE_HZ must be the MPU-9250's output rate and the scheduler's"
);

/// The MPU-9250: ±4 g, ±1000 °/s, gyro DLPF_CFG 1 (184 Hz, 2.9 ms delay
/// per the register map), accelerometer A_DLPF_CFG 3 (44.8 Hz, 4.88 ms:
/// the AHRS's tilt correction is slow, the delay costs nothing), 1 kHz.
pub const MPU: mpu9250::Config = mpu9250::Config::new()
    .gyro_range(GyroRange::Dps1000)
    .gyro_bandwidth(GyroBandwidth::Hz184);

/// The rate loop's gyro filters: a PT1 low-pass at 150 Hz and a notch at
/// 200 Hz (Q 2: 100 Hz wide), the hover's rotor frequency. At 50 Hz they
/// delay the gyro ≈ 1.2 ms ([`GYRO_FILTER_DESIGN`]`.response(50.0)`).
pub const GYRO_FILTER: GyroFilterConfig = GyroFilterConfig {
    low_pass: GyroLowPass::Pt1 { cutoff_hz: 150.0 },
    notch: Some(GyroNotch {
        center_hz: 200.0,
        q: 2.0,
    }),
};

/// [`GYRO_FILTER`] designed at build time for [`IMU_RATE_HZ`] (a setting
/// out of range does not compile).
// Evaluated by the compiler (a `const`): a bad setting stops the build,
// and nothing of this runs, or can panic, on the board.
pub const GYRO_FILTER_DESIGN: GyroFilterDesign = match GYRO_FILTER.design(IMU_RATE_HZ) {
    Ok(d) => d,
    Err(_) => panic!("GYRO_FILTER: a frequency or Q out of range for IMU_RATE_HZ"),
};

/// Motor-test command, 0..=0.2 of the ESC range above the off pulse
/// (0.08: 1080 µs in standard PWM): enough to turn every common ESC's
/// motor over, too little to lift anything.
pub const MOTOR_TEST_COMMAND: f32 = 0.08;

/// The sensors' configuration: [`MPU`] and the `sensor_stack` defaults for
/// the rest (AK8963 at 100 Hz, MS5611 schedule, health policy).
#[must_use]
pub fn sensors_config() -> SensorsConfig {
    SensorsConfig {
        mpu: MPU,
        ..SensorsConfig::default()
    }
}

/// The processing pipeline's configuration: the `sensor_stack` defaults
/// (the AHRS's multirotor mode) with [`GYRO_FILTER_DESIGN`]. The scales
/// and the capabilities are the boot's to fill in.
#[must_use]
pub fn pipeline_config() -> PipelineConfig {
    PipelineConfig {
        gyro_filter: GYRO_FILTER_DESIGN,
        ..PipelineConfig::new()
    }
}

/// The roll and pitch rate loops' D gain (torque per rad/s²): 1.5 × the
/// `control` default of 0.003. On the 250-class model (0.60 kg) with this
/// gyro path, `cargo sim --scenario chirp --sweep rate.roll.d=0.6666667:1:2`
/// flies both: the phase margin 48° → 64°, the sensitivity peak Ms 1.97 →
/// 1.71, the rate step's overshoot 21 % → 2 %, for 0.25 → 0.35 % of torque
/// noise in the hover.
pub const TILT_RATE_KD: f32 = 0.0045;

/// The angle loop's P gain (rad/s per rad of attitude error): 2 × the
/// `control` default of 6, for an angle step's rise (10–90 %, on the
/// estimate the loop controls) of 0.11 s without overshoot in `cargo sim
/// --scenario steps` (6: 0.24 s with 6 %, 9: 0.17 s), its crossover
/// (≈ 2 Hz) still a third of the rate loop's.
pub const LEVEL_KP_PER_S: f32 = 12.0;

/// The flight controller's tuning: the `flight`/`control` defaults with
/// [`TILT_RATE_KD`] and [`MOTOR_TEST_COMMAND`].
// Inlined: the firmware's constant configuration then folds at compile
// time (out of line its soft-float conversions stay in flash).
#[inline(always)]
#[must_use]
pub fn flight_config() -> FlightConfig {
    let mut rate = RateConfig::default();
    rate.roll.kd = TILT_RATE_KD;
    rate.pitch.kd = TILT_RATE_KD;
    FlightConfig {
        rate,
        level: LevelConfig {
            kp_per_s: LEVEL_KP_PER_S,
            ..LevelConfig::default()
        },
        safety: SafetyConfig {
            motor_test_command: MOTOR_TEST_COMMAND,
            ..SafetyConfig::default()
        },
        ..FlightConfig::default()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    #[test]
    fn the_settings_are_valid() {
        assert!(flight::flightctl::FlightController::new(flight_config()).is_ok());
        assert!(MPU.gyro_bandwidth.internal_rate_hz() as f32 == IMU_RATE_HZ);
        assert_eq!(sensors_config().mpu, MPU);
    }

    #[test]
    fn the_gyro_filter_delay_at_50_hz_is_as_documented() {
        let d = GYRO_FILTER_DESIGN.response(50.0).group_delay_s;
        if d == 0.0 {
            // sensor-stack's `no-gyro-filter` (a build with the calibration
            // build's features) designs no filter.
            std::println!("skipped: sensor-stack built with no-gyro-filter");
            return;
        }
        // The discrete PT1 at 150 Hz ≈ 0.8 ms (its analog prototype's
        // RC/(1 + (ωRC)²) is 0.95 ms), the notch ≈ 0.4 ms.
        assert!((d - 0.0012).abs() < 0.0001, "{d}");
    }
}
