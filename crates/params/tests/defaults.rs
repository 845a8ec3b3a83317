//! Every default equals the compile-time value it replaces: the `settings`
//! crate's tuning, the receiver crate's timeouts and the firmware's wiring
//! constants (`firmware/src/config.rs`, read as text: the firmware is a
//! thumbv7m binary a host test cannot link).

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use flight::flightctl::FlightConfig;
use params::{ParamId, ParamSet};
use rc_input::ChannelMap;
use sensor_stack::mounting::Mounting;

#[test]
fn the_flight_tuning_is_the_settings_crates() {
    let d = ParamSet::defaults();
    assert_eq!(
        d.flight_config(FlightConfig::default()),
        settings::flight_config()
    );
    // And each parameter moves its own field (a mapping that forgot one
    // would pass the line above on defaults alone).
    for id in ParamId::ALL {
        let mut s = d;
        let p = id.param();
        let other = if p.default < p.max {
            p.default + 1
        } else {
            p.default - 1
        };
        if s.set(id, other).is_err() {
            continue; // the mounting: not every code is a rotation
        }
        let moved = s.flight_config(FlightConfig::default())
            != d.flight_config(FlightConfig::default())
            || s.gyro_filter() != d.gyro_filter()
            || s.channel_map() != d.channel_map()
            || s.mode_channel() != d.mode_channel()
            || s.motor_test_channel() != d.motor_test_channel()
            || s.link_timeout_us() != d.link_timeout_us()
            || s.mounting() != d.mounting();
        let read_raw = p.name.starts_with("batt.") || p.name.starts_with("trim.");
        assert!(moved || read_raw, "{} changes nothing", p.name);
    }
}

#[test]
fn the_gyro_filter_and_motor_test_are_the_settings_crates() {
    let d = ParamSet::defaults();
    assert_eq!(d.gyro_filter(), settings::GYRO_FILTER);
    assert_eq!(d.real(ParamId::EscTest), settings::MOTOR_TEST_COMMAND);
    assert_eq!(d.real(ParamId::LevelP), settings::LEVEL_KP_PER_S);
    assert_eq!(d.real(ParamId::RateRollD), settings::TILT_RATE_KD);
}

#[test]
fn the_link_timeout_is_the_receivers() {
    let d = ParamSet::defaults();
    assert_eq!(d.link_timeout_us(), rc_input::CRSF_TIMEOUT_US);
    assert_eq!(d.link_timeout_us(), rc_input::PPM_TIMEOUT_US);
}

/// The value of `pub const NAME: TYPE = VALUE;` in the firmware's config.
fn config_const(name: &str) -> String {
    let text = include_str!("../../../firmware/src/config.rs");
    let start = format!("pub const {name}:");
    let line = text
        .lines()
        .find(|l| l.starts_with(&start))
        .unwrap_or_else(|| panic!("{name} not in firmware/src/config.rs"));
    let value = line.split('=').nth(1).unwrap_or("");
    value.trim().trim_end_matches(';').trim().to_string()
}

#[test]
fn the_wiring_is_the_firmware_configs() {
    let d = ParamSet::defaults();
    let mode: u8 = config_const("MODE_CHANNEL").parse().unwrap();
    let test: u8 = config_const("MOTOR_TEST_CHANNEL").parse().unwrap();
    assert_eq!(d.mode_channel(), mode);
    assert_eq!(d.motor_test_channel(), test);
    assert_eq!(config_const("MOUNTING"), "Mounting::FACE_UP_X_FORWARD");
    assert_eq!(d.mounting(), Mounting::FACE_UP_X_FORWARD);
    let text = include_str!("../../../firmware/src/config.rs");
    assert!(
        text.contains("pub const fn channel_map() -> ChannelMap {\n    ChannelMap::DEFAULT\n}"),
        "firmware's channel_map() is no longer ChannelMap::DEFAULT: update rc.* defaults"
    );
    assert_eq!(d.channel_map(), Ok(ChannelMap::DEFAULT));
}

#[test]
fn clashing_channels_are_refused_by_the_map() {
    let mut s = ParamSet::defaults();
    s.set(ParamId::RcMode, 5).unwrap(); // the arm switch's
    assert!(s.channel_map().is_err());
    let mut s = ParamSet::defaults();
    s.set(ParamId::RcMotorTest, 6).unwrap(); // the mode switch's
    assert!(s.channel_map().is_err());
    let mut s = ParamSet::defaults();
    s.set(ParamId::RcYaw, 1).unwrap(); // roll's
    assert!(s.channel_map().is_err());
    // TAER: throttle 1, roll 2, pitch 3, yaw 4.
    let mut s = ParamSet::defaults();
    for (id, ch) in [
        (ParamId::RcThrottle, 1),
        (ParamId::RcRoll, 2),
        (ParamId::RcPitch, 3),
        (ParamId::RcYaw, 4),
    ] {
        s.set(id, ch).unwrap();
    }
    assert_eq!(
        s.channel_map(),
        Ok(ChannelMap::new(rc_input::ChannelOrder::TAER))
    );
}

#[test]
fn a_zero_frequency_turns_a_filter_off() {
    use sensor_stack::gyro_filter::{GyroFilterConfig, GyroLowPass};
    let mut s = ParamSet::defaults();
    s.set(ParamId::GyroLpf, 0).unwrap();
    s.set(ParamId::GyroNotch, 0).unwrap();
    assert_eq!(s.gyro_filter(), GyroFilterConfig::OFF);
    s.set(ParamId::GyroLpf, 90).unwrap();
    assert_eq!(
        s.gyro_filter().low_pass,
        GyroLowPass::Pt1 { cutoff_hz: 90.0 }
    );
    // Every value the table allows designs at the board's 1 kHz.
    for lpf in [1, 449] {
        for notch in [1, 449] {
            for q in [20, 2000] {
                s.set(ParamId::GyroLpf, lpf).unwrap();
                s.set(ParamId::GyroNotch, notch).unwrap();
                s.set(ParamId::GyroNotchQ, q).unwrap();
                assert!(s.gyro_filter().design(settings::IMU_RATE_HZ).is_ok());
            }
        }
    }
}

#[test]
fn every_flight_config_within_the_table_is_accepted() {
    // Each parameter at its minimum and its maximum, the others at their
    // defaults: the flight controller takes the configuration.
    for id in ParamId::ALL {
        for v in [id.param().min, id.param().max] {
            let mut s = ParamSet::defaults();
            if s.set(id, v).is_err() {
                continue;
            }
            let cfg = s.flight_config(settings::flight_config());
            assert!(
                flight::flightctl::FlightController::new(cfg).is_ok(),
                "{} = {v}",
                id.param().name
            );
        }
    }
}

#[test]
fn the_battery_settings_default_to_the_monitors_and_refuse_a_critical_above_the_warning() {
    let mut p = ParamSet::defaults();
    assert_eq!(p.battery_config(), Ok(battery::Config::DEFAULT));
    p.set(ParamId::BattCells, 4).unwrap();
    p.set(ParamId::BattScale, 10_000).unwrap();
    let c = p.battery_config().unwrap();
    assert_eq!((c.cells_override, c.scale.full_scale_mv()), (4, 33_000));
    p.set(ParamId::BattCrit, 360).unwrap();
    assert!(
        p.battery_config().is_err(),
        "critical 3.60 V above the 3.50 V warning"
    );
}

#[test]
fn validate_names_what_the_board_would_refuse_at_boot() {
    let mut p = ParamSet::defaults();
    assert_eq!(p.validate(1000.0), Ok(()));
    p.set(ParamId::BattCrit, 360).unwrap();
    assert!(p.validate(1000.0).unwrap_err().contains("batt.crit_cv"));
    let mut p = ParamSet::defaults();
    p.set(ParamId::RcMode, 1).unwrap(); // the roll stick's channel
    assert!(p.validate(1000.0).unwrap_err().contains("rc."));
}
