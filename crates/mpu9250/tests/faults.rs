//! Faults through the public API and recovery after them, and the datasheet
//! scale factors checked through `read`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use embedded_hal::i2c::ErrorKind;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
use mpu9250::*;

mod common;

use common::{init_for, inited_with, sample_bytes, A, NACK};

fn init_seq(c: &Config, bypass: bool) -> Vec<T> {
    init_for(A, c, bypass)
}

fn burst(accel: [i16; 3], temp: i16, gyro: [i16; 3]) -> T {
    T::write_read(A, vec![0x3B], sample_bytes(accel, temp, gyro))
}

#[test]
fn default_dlpf_value_3_is_41_hz_gyro_and_44_8_hz_accel() {
    let c = Config::default();
    assert_eq!(c.gyro_bandwidth.dlpf_cfg(), 3);
    assert_eq!(c.gyro_bandwidth.bandwidth_hz(), 41.0);
    assert_eq!(c.accel_bandwidth.accel_config2_bits(), 3);
    assert_eq!(c.accel_bandwidth.bandwidth_hz(), 44.8);
    // Gyro FCHOICE_B must be 0b00 for the DLPF table to apply.
    for r in [
        GyroRange::Dps250,
        GyroRange::Dps500,
        GyroRange::Dps1000,
        GyroRange::Dps2000,
    ] {
        assert_eq!(r.gyro_config_bits() & 0b11, 0);
    }
}

#[test]
fn who_am_i_table() {
    for (id, expected) in [
        (0x71, Ok(Variant::Mpu9250)),
        (0x73, Ok(Variant::Mpu9255)),
        (0x70, Err(Error::Mpu6500Detected)),
        (0x68, Err(Error::WrongChipId(0x68))),
        (0x72, Err(Error::WrongChipId(0x72))),
        (0x00, Err(Error::WrongChipId(0x00))),
        (0xFF, Err(Error::WrongChipId(0xFF))),
    ] {
        let mut i2c = Mock::new(&[T::write_read(A, vec![0x75], vec![id])]);
        let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
        assert_eq!(imu.who_am_i(), expected, "id {id:#x}");
        i2c.done();
    }
    // A wrong id stops init before the reset is written (the mock would
    // reject any further transaction).
    let mut i2c = Mock::new(&[T::write_read(A, vec![0x75], vec![0x70])]);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    assert_eq!(
        imu.init(&mut NoopDelay::new(), &Config::default()),
        Err(Error::Mpu6500Detected)
    );
    assert_eq!(imu.read(), Err(Error::NotInitialized));
    i2c.done();
}

/// A NACK at any init step, then a full init on the same driver: it works,
/// the bypass request and the gyro bias survive, and samples are read.
#[test]
fn nack_at_each_init_step_then_reinit_recovers_with_bypass_and_bias() {
    let c = Config::default();
    let full = init_seq(&c, true);
    for k in (0..full.len()).filter(|&k| k != 2) {
        let mut t = vec![
            // set_bypass(true) before the first init: USER_CTRL, INT_PIN_CFG.
            T::write(A, vec![0x6A, 0x00]),
            T::write(A, vec![0x37, 0x02]),
        ];
        t.extend(full[..k].iter().cloned());
        t.push(full[k].clone().with_error(NACK));
        t.extend(full.iter().cloned());
        // Bias [5, -5, 0] removed from the gyro.
        t.push(burst([0, 0, 8192], 0, [5 + 328, -5, 0]));
        let mut i2c = Mock::new(&t);
        let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
        imu.set_bypass(true).unwrap();
        imu.set_gyro_bias([5, -5, 0]);
        let mut d = NoopDelay::new();
        assert_eq!(imu.init(&mut d, &c), Err(Error::Bus(NACK)), "step {k}");
        assert_eq!(imu.read(), Err(Error::NotInitialized), "step {k}");
        assert!(imu.bypass());
        assert_eq!(imu.gyro_bias(), [5, -5, 0]);
        assert_eq!(imu.init(&mut d, &c), Ok(Variant::Mpu9250), "step {k}");
        let s = imu.read().unwrap();
        assert_eq!(s.accel_g, [0.0, 0.0, 1.0]);
        assert!((s.gyro_dps[0] - 10.0).abs() < 1e-4);
        assert_eq!(s.gyro_dps[1], 0.0);
        i2c.done();
    }
}

#[test]
fn bus_error_in_burst_then_next_read_works() {
    let c = Config::default();
    let mut t = init_seq(&c, false);
    t.push(burst([1, 2, 3], 0, [4, 5, 6]).with_error(ErrorKind::ArbitrationLoss));
    t.push(burst([0, 0, 8192], 0, [0, 0, 0]));
    t.push(burst([1, 2, 3], 0, [4, 5, 6]).with_error(NACK));
    t.push(burst([-8192, 0, 0], 0, [0, 0, 0]));
    let (mut i2c, mut imu) = inited_with(&t, &c);
    assert_eq!(imu.read(), Err(Error::Bus(ErrorKind::ArbitrationLoss)));
    assert_eq!(imu.read().unwrap().accel_g, [0.0, 0.0, 1.0]);
    assert_eq!(imu.read_raw(), Err(Error::Bus(NACK)));
    assert_eq!(imu.read_raw().unwrap().accel, [-8192, 0, 0]);
    i2c.done();
}

/// Datasheet sensitivities (accel 2048 LSB/g at ±16 g, gyro 16.4 LSB/(°/s)
/// at ±2000 °/s, temperature 333.87 LSB/°C + 21 °C) through `read`.
#[test]
fn scale_through_read_at_16g_2000dps() {
    let c = Config::new()
        .accel_range(AccelRange::G16)
        .gyro_range(GyroRange::Dps2000);
    let mut t = init_seq(&c, false);
    t.push(burst([2048, -4096, 32767], 3339, [164, -1640, -32768]));
    let (mut i2c, mut imu) = inited_with(&t, &c);
    let s = imu.read().unwrap();
    assert_eq!(s.accel_g[0], 1.0);
    assert_eq!(s.accel_g[1], -2.0);
    assert!((s.accel_g[2] - 15.9995).abs() < 1e-4);
    assert!((s.gyro_dps[0] - 10.0).abs() < 1e-4);
    assert!((s.gyro_dps[1] + 100.0).abs() < 1e-3);
    assert!((s.gyro_dps[2] + 1998.05).abs() < 1e-2);
    // 3339 / 333.87 + 21 = 31.0009 °C
    assert!((s.temp_c - 31.0009).abs() < 1e-3);
    assert_eq!(temp_centi_c(3339), 3100);
    let rps = s.gyro_rps();
    assert!((rps[0] - 10.0f32.to_radians()).abs() < 1e-6);
    i2c.done();
}

#[test]
fn integer_and_float_temperature_agree_for_every_count() {
    for raw in i16::MIN..=i16::MAX {
        let centi = temp_centi_c(raw);
        let f = f64::from(raw) / 333.87 + 21.0;
        let exact = (f * 100.0).round() as i32;
        assert!((centi - exact).abs() <= 1, "raw {raw}: {centi} vs {exact}");
        assert!((f64::from(temp_c(raw)) - f).abs() < 1e-3);
    }
}

#[test]
fn data_ready_low_then_high() {
    let c = Config::default();
    let mut t = init_seq(&c, false);
    t.push(T::write_read(A, vec![0x3A], vec![0x00]));
    t.push(T::write_read(A, vec![0x3A], vec![0x10]));
    t.push(T::write_read(A, vec![0x3A], vec![0x01]));
    t.push(T::write_read(A, vec![0x3A], vec![0x01]).with_error(NACK));
    let (mut i2c, mut imu) = inited_with(&t, &c);
    assert_eq!(imu.data_ready(), Ok(false));
    let st = imu.read_int_status().unwrap();
    assert!(st.fifo_overflow() && !st.data_ready());
    assert_eq!(imu.data_ready(), Ok(true));
    assert_eq!(imu.data_ready(), Err(Error::Bus(NACK)));
    i2c.done();
}

#[test]
fn interrupt_pin_bits_latched_open_drain_active_low() {
    let i = InterruptConfig::new()
        .level(IntLevel::ActiveLow)
        .drive(IntDrive::OpenDrain)
        .latch(IntLatch::Latched)
        .clear(IntClear::OnAnyRead);
    assert_eq!(i.int_pin_cfg(false), 0b1111_0000);
    assert_eq!(i.int_pin_cfg(true), 0b1111_0010);
    assert_eq!(i.int_enable_bits(), 0x01);
    assert_eq!(InterruptConfig::disabled().int_enable_bits(), 0x00);
}

/// A bus error in the middle of a gyro calibration keeps the previous bias;
/// the next calibration works.
#[test]
fn calibration_bus_error_keeps_bias_then_recovers() {
    let c = Config::default();
    let mut t = init_seq(&c, false);
    t.push(burst([0, 0, 8192], 0, [30, 30, 30]));
    t.push(burst([0, 0, 8192], 0, [30, 30, 30]).with_error(NACK));
    t.push(burst([0, 0, 8192], 0, [-7, 8, 9]));
    t.push(burst([0, 0, 8192], 0, [-7, 8, 9]));
    let (mut i2c, mut imu) = inited_with(&t, &c);
    imu.set_gyro_bias([1, 2, 3]);
    let mut d = NoopDelay::new();
    assert_eq!(imu.calibrate_gyro_bias(&mut d, 2), Err(Error::Bus(NACK)));
    assert_eq!(imu.gyro_bias(), [1, 2, 3]);
    assert_eq!(imu.calibrate_gyro_bias(&mut d, 2), Ok([-7, 8, 9]));
    assert_eq!(imu.gyro_bias(), [-7, 8, 9]);
    i2c.done();
}

/// Gyro at the i16 extremes: the mean and the bias subtraction saturate
/// instead of overflowing.
#[test]
fn calibration_and_bias_at_i16_extremes() {
    let c = Config::default();
    let mut t = init_seq(&c, false);
    for _ in 0..3 {
        t.push(burst([0, 0, 8192], 0, [i16::MIN, i16::MAX, 0]));
    }
    t.push(burst([0, 0, 8192], 0, [i16::MAX, i16::MIN, 0]));
    let (mut i2c, mut imu) = inited_with(&t, &c);
    let b = imu.calibrate_gyro_bias(&mut NoopDelay::new(), 3).unwrap();
    assert_eq!(b, [i16::MIN, i16::MAX, 0]);
    let r = imu.read_raw_unbiased().unwrap();
    assert_eq!(r.gyro, [i16::MAX, i16::MIN, 0]);
    i2c.done();
}

/// A motion error keeps the previous bias too.
#[test]
fn moved_keeps_previous_bias() {
    let c = Config::default();
    let mut t = init_seq(&c, false);
    t.push(burst([0, 0, 8192], 0, [0, 0, 0]));
    t.push(burst([0, 0, 8192], 0, [500, 0, 0]));
    let (mut i2c, mut imu) = inited_with(&t, &c);
    imu.set_gyro_bias([4, 4, 4]);
    assert!(matches!(
        imu.calibrate_gyro_bias(&mut NoopDelay::new(), 2),
        Err(Error::Moved(Motion::GyroSpread {
            axis: 0,
            peak_to_peak_counts: 500,
            ..
        }))
    ));
    assert_eq!(imu.gyro_bias(), [4, 4, 4]);
    i2c.done();
}

/// set_bypass with a NACK on either write: the error is returned, the
/// request is remembered, and verify_config reports the chip's real state.
#[test]
fn bypass_nack_is_detected_by_verify_config() {
    let c = Config::default();
    let mut t = init_seq(&c, false);
    t.push(T::write(A, vec![0x6A, 0x00]));
    t.push(T::write(A, vec![0x37, 0x02]).with_error(NACK));
    // verify_config: INT_PIN_CFG still 0x00 on the chip.
    t.push(T::write_read(
        A,
        vec![0x19],
        vec![0x00, 0x03, 0x10, 0x08, 0x03],
    ));
    t.push(T::write_read(A, vec![0x37], vec![0x00, 0x01]));
    let (mut i2c, mut imu) = inited_with(&t, &c);
    assert_eq!(imu.set_bypass(true), Err(Error::Bus(NACK)));
    assert_eq!(
        imu.verify_config(),
        Err(Error::ConfigMismatch {
            register: 0x37,
            expected: 0x02,
            found: 0x00
        })
    );
    i2c.done();
}

#[test]
fn release_returns_the_bus() {
    let imu = Mpu9250::new(Mock::new(&[]), Address::Ad0High);
    assert_eq!(imu.address(), 0x69);
    imu.release().done();
}
