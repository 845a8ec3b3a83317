//! Transaction-level tests of the MPU-9250 driver against embedded-hal-mock.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use embedded_hal::i2c::ErrorKind;
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
use mpu9250::*;

mod common;

use common::{
    init_by_hand, init_for, init_result, inited_with, readback_by_hand, sample_bytes, A, NACK,
};

/// The default-config init sequence, bytes written out by hand from the register map.
fn default_init(a: u8) -> Vec<T> {
    init_by_hand(a, [0x00, 0x03, 0x10, 0x08, 0x03], [0x00, 0x01])
}

fn read_t(accel: [i16; 3], temp: i16, gyro: [i16; 3]) -> T {
    T::write_read(A, vec![0x3B], sample_bytes(accel, temp, gyro))
}

fn inited(extra: Vec<T>) -> (Mock, Mpu9250<Mock>) {
    let mut t = default_init(A);
    t.extend(extra);
    inited_with(&t, &Config::default())
}

// ---------------------------------------------------------------- init

#[test]
fn init_default_exact_bytes_and_delays() {
    let mut i2c = Mock::new(&default_init(A));
    let mut delay = CheckedDelay::new(&[D::delay_ms(10)]);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    assert_eq!(
        imu.init(&mut delay, &Config::default()),
        Ok(Variant::Mpu9250)
    );
    assert_eq!(imu.variant(), Some(Variant::Mpu9250));
    imu.release();
    i2c.done();
    delay.done();
}

#[test]
fn default_config_matches_brief() {
    let c = Config::default();
    assert_eq!(c.accel_range, AccelRange::G4);
    assert_eq!(c.gyro_range, GyroRange::Dps1000);
    assert_eq!(c.sample_rate_divider, 0);
    assert_eq!(c.gyro_bandwidth.dlpf_cfg(), 3);
    assert_eq!(c.accel_bandwidth.accel_config2_bits(), 3);
    assert_eq!(c.gyro_bandwidth.bandwidth_hz(), 41.0);
    assert_eq!(c.accel_bandwidth.bandwidth_hz(), 44.8);
    assert_eq!(c.output_data_rate_hz(), 1000.0);
}

#[test]
fn init_ad0_high_mpu9255() {
    let mut t = init_for(0x69, &Config::default(), false);
    t[0] = T::write_read(0x69, vec![0x75], vec![0x73]);
    let mut i2c = Mock::new(&t);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0High);
    assert_eq!(
        imu.init(&mut NoopDelay::new(), &Config::default()),
        Ok(Variant::Mpu9255)
    );
    i2c.done();
}

#[test]
fn init_non_default_config_exact_bytes() {
    let c = Config::new()
        .accel_range(AccelRange::G16)
        .gyro_range(GyroRange::Dps2000)
        .gyro_bandwidth(GyroBandwidth::Hz5)
        .accel_bandwidth(AccelBandwidth::Hz1046Bypass)
        .sample_rate_divider(9)
        .interrupt(
            InterruptConfig::new()
                .level(IntLevel::ActiveLow)
                .drive(IntDrive::OpenDrain)
                .latch(IntLatch::Latched)
                .clear(IntClear::OnAnyRead)
                .data_ready(false),
        );
    let t = init_by_hand(A, [0x09, 0x06, 0x18, 0x18, 0x08], [0xF0, 0x00]);
    let (mut i2c, imu) = inited_with(&t, &c);
    assert_eq!(c.output_data_rate_hz(), 100.0);
    assert_eq!(imu.scale().g_per_lsb, 1.0 / 2048.0);
    i2c.done();
}

// One table per register field, as the register map lists them: the repeated
// shape is the datasheet's, not shared logic.
#[test]
fn every_bandwidth_register_value() {
    let g = [
        (GyroBandwidth::Hz250, 0, 250.0),
        (GyroBandwidth::Hz184, 1, 184.0),
        (GyroBandwidth::Hz92, 2, 92.0),
        (GyroBandwidth::Hz41, 3, 41.0),
        (GyroBandwidth::Hz20, 4, 20.0),
        (GyroBandwidth::Hz10, 5, 10.0),
        (GyroBandwidth::Hz5, 6, 5.0),
        (GyroBandwidth::Hz3600, 7, 3600.0),
    ];
    for (bw, v, hz) in g {
        assert_eq!(bw.dlpf_cfg(), v);
        assert_eq!(bw.bandwidth_hz(), hz);
    }
    let a = [
        (AccelBandwidth::Hz218_1, 1, 218.1),
        (AccelBandwidth::Hz99, 2, 99.0),
        (AccelBandwidth::Hz44_8, 3, 44.8),
        (AccelBandwidth::Hz21_2, 4, 21.2),
        (AccelBandwidth::Hz10_2, 5, 10.2),
        (AccelBandwidth::Hz5_05, 6, 5.05),
        (AccelBandwidth::Hz420, 7, 420.0),
        (AccelBandwidth::Hz1046Bypass, 0x08, 1046.0),
    ];
    for (bw, v, hz) in a {
        assert_eq!(bw.accel_config2_bits(), v);
        assert_eq!(bw.bandwidth_hz(), hz);
    }
    assert_eq!(GyroRange::Dps250.gyro_config_bits(), 0x00);
    assert_eq!(GyroRange::Dps500.gyro_config_bits(), 0x08);
    assert_eq!(GyroRange::Dps1000.gyro_config_bits(), 0x10);
    assert_eq!(GyroRange::Dps2000.gyro_config_bits(), 0x18);
    assert_eq!(AccelRange::G2.accel_config_bits(), 0x00);
    assert_eq!(AccelRange::G4.accel_config_bits(), 0x08);
    assert_eq!(AccelRange::G8.accel_config_bits(), 0x10);
    assert_eq!(AccelRange::G16.accel_config_bits(), 0x18);
}

#[test]
fn output_data_rate() {
    let c = Config::new();
    assert_eq!(c.sample_period_us(), 1000);
    assert_eq!(c.sample_rate_divider(4).output_data_rate_hz(), 200.0);
    assert_eq!(c.sample_rate_divider(255).sample_period_us(), 256_000);
    let fast = c.gyro_bandwidth(GyroBandwidth::Hz250);
    assert_eq!(fast.output_data_rate_hz(), 8000.0);
    assert_eq!(
        c.gyro_bandwidth(GyroBandwidth::Hz3600).sample_period_us(),
        125
    );
}

#[test]
fn invalid_config_no_bus_traffic() {
    let mut i2c = Mock::new(&[]);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    let c = Config::new()
        .gyro_bandwidth(GyroBandwidth::Hz3600)
        .sample_rate_divider(3);
    assert_eq!(
        imu.init(&mut NoopDelay::new(), &c),
        Err(Error::InvalidConfig(ConfigError::DividerIgnored))
    );
    i2c.done();
}

#[test]
fn wrong_chip_id() {
    for id in [0x00u8, 0xFF, 0x68, 0x48, 0x72] {
        assert_eq!(
            init_result(
                &[T::write_read(A, vec![0x75], vec![id])],
                &Config::default()
            ),
            Err(Error::WrongChipId(id))
        );
    }
}

#[test]
fn mpu6500_is_its_own_error() {
    assert_eq!(
        init_result(
            &[T::write_read(A, vec![0x75], vec![0x70])],
            &Config::default()
        ),
        Err(Error::Mpu6500Detected)
    );
}

#[test]
fn nack_at_every_init_step_is_a_bus_error() {
    let full = default_init(A);
    // Index 2 is the reset poll, which tolerates NACKs (covered separately).
    for k in (0..full.len()).filter(|&k| k != 2) {
        let mut t: Vec<T> = full[..k].to_vec();
        t.push(full[k].clone().with_error(NACK));
        let mut i2c = Mock::new(&t);
        let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
        assert_eq!(
            imu.init(&mut NoopDelay::new(), &Config::default()),
            Err(Error::Bus(NACK)),
            "step {k}"
        );
        // A failed init leaves the driver uninitialised.
        assert_eq!(imu.verify_config(), Err(Error::NotInitialized));
        i2c.done();
    }
}

#[test]
fn reset_poll_waits_until_bit_clears() {
    let mut t = default_init(A);
    t.splice(
        2..3,
        [
            T::write_read(A, vec![0x6B], vec![0x81]),
            T::write_read(A, vec![0x6B], vec![0x00]).with_error(NACK),
            T::write_read(A, vec![0x6B], vec![0x01]),
        ],
    );
    let mut i2c = Mock::new(&t);
    let mut delay = CheckedDelay::new(&[D::delay_ms(10), D::delay_ms(10), D::delay_ms(10)]);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    imu.init(&mut delay, &Config::default()).unwrap();
    i2c.done();
    delay.done();
}

#[test]
fn reset_timeout_when_bit_never_clears() {
    let mut t = default_init(A)[..2].to_vec();
    for _ in 0..RESET_MAX_POLLS {
        t.push(T::write_read(A, vec![0x6B], vec![0x80]));
    }
    assert_eq!(
        init_result(&t, &Config::default()),
        Err(Error::ResetTimeout)
    );
}

#[test]
fn reset_timeout_when_chip_never_answers() {
    let mut t = default_init(A)[..2].to_vec();
    for _ in 0..RESET_MAX_POLLS {
        t.push(T::write_read(A, vec![0x6B], vec![0x00]).with_error(NACK));
    }
    assert_eq!(
        init_result(&t, &Config::default()),
        Err(Error::ResetTimeout)
    );
}

#[test]
fn config_mismatch_on_every_readback_byte() {
    // (index of the readback transaction, byte offset, register, expected)
    let cases = [
        (13, 0, 0x19, 0x00),
        (13, 1, 0x1A, 0x03),
        (13, 2, 0x1B, 0x10),
        (13, 3, 0x1C, 0x08),
        (13, 4, 0x1D, 0x03),
        (14, 0, 0x37, 0x00),
        (14, 1, 0x38, 0x01),
        (15, 0, 0x6A, 0x00),
        (15, 1, 0x6B, 0x01),
        (15, 2, 0x6C, 0x00),
    ];
    for (idx, off, register, expected) in cases {
        let mut t = default_init(A);
        let mut resp: Vec<u8> = match idx {
            13 => vec![0x00, 0x03, 0x10, 0x08, 0x03],
            14 => vec![0x00, 0x01],
            _ => vec![0x00, 0x01, 0x00],
        };
        resp[off] ^= 0x40;
        let start = [0x19, 0x37, 0x6A][idx - 13];
        t[idx] = T::write_read(A, vec![start], resp);
        t.truncate(idx + 1);
        let mut i2c = Mock::new(&t);
        let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
        assert_eq!(
            imu.init(&mut NoopDelay::new(), &Config::default()),
            Err(Error::ConfigMismatch {
                register,
                expected,
                found: expected ^ 0x40
            })
        );
        i2c.done();
    }
}

#[test]
fn verify_config_detects_chip_reset_in_flight() {
    let mut extra = readback_by_hand(A, [0x00, 0x03, 0x10, 0x08, 0x03], [0x00, 0x01]);
    // Power-on defaults after a spontaneous reset: everything 0 except PWR_MGMT_1 = 0x01.
    extra.push(T::write_read(A, vec![0x19], vec![0, 0, 0, 0, 0]));
    let (mut i2c, mut imu) = inited(extra);
    assert_eq!(imu.verify_config(), Ok(()));
    assert_eq!(
        imu.verify_config(),
        Err(Error::ConfigMismatch {
            register: 0x1A,
            expected: 0x03,
            found: 0x00
        })
    );
    i2c.done();
}

#[test]
fn verify_config_before_init() {
    let mut i2c = Mock::new(&[]);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    assert_eq!(imu.verify_config(), Err(Error::NotInitialized));
    assert_eq!(imu.read(), Err(Error::NotInitialized));
    assert_eq!(
        imu.calibrate_gyro_bias(&mut NoopDelay::new(), 8),
        Err(Error::NotInitialized)
    );
    i2c.done();
}

// ---------------------------------------------------------------- reading

#[test]
fn read_raw_one_burst_big_endian() {
    let (mut i2c, mut imu) = inited(vec![T::write_read(
        A,
        vec![0x3B],
        vec![
            0x01, 0x02, 0xFF, 0xFE, 0x80, 0x00, 0x0D, 0x0B, 0x7F, 0xFF, 0x00, 0x00, 0xC0, 0x00,
        ],
    )]);
    let raw = imu.read_raw().unwrap();
    assert_eq!(raw.accel, [0x0102, -2, -32768]);
    assert_eq!(raw.temp, 0x0D0B);
    assert_eq!(raw.gyro, [32767, 0, -16384]);
    i2c.done();
}

#[test]
fn read_converts_with_configured_scale() {
    // ±4 g: 8192 LSB/g; ±1000 °/s: 32.8 LSB/(°/s); temp 3339 counts ≈ 31.0 °C.
    let (mut i2c, mut imu) = inited(vec![read_t([8192, -4096, 16384], 3339, [328, -3280, 0])]);
    let s = imu.read().unwrap();
    assert_eq!(s.accel_g, [1.0, -0.5, 2.0]);
    assert!((s.gyro_dps[0] - 10.0).abs() < 1e-4);
    assert!((s.gyro_dps[1] + 100.0).abs() < 1e-3);
    assert_eq!(s.gyro_dps[2], 0.0);
    assert!((s.temp_c - 31.0).abs() < 0.01, "{}", s.temp_c);
    let rps = s.gyro_rps();
    assert!((rps[0] - 10.0f32.to_radians()).abs() < 1e-6);
    i2c.done();
}

#[test]
fn read_nack_is_bus_error() {
    let (mut i2c, mut imu) = inited(vec![read_t([0; 3], 0, [0; 3]).with_error(NACK)]);
    assert_eq!(imu.read(), Err(Error::Bus(NACK)));
    i2c.done();
}

#[test]
fn scale_vectors_from_datasheet() {
    assert_eq!(AccelRange::G2.lsb_per_g(), 16384);
    assert_eq!(AccelRange::G4.lsb_per_g(), 8192);
    assert_eq!(AccelRange::G8.lsb_per_g(), 4096);
    assert_eq!(AccelRange::G16.lsb_per_g(), 2048);
    assert_eq!(GyroRange::Dps250.lsb_per_dps(), 131.0);
    assert_eq!(GyroRange::Dps500.lsb_per_dps(), 65.5);
    assert_eq!(GyroRange::Dps1000.lsb_per_dps(), 32.8);
    assert_eq!(GyroRange::Dps2000.lsb_per_dps(), 16.4);
    for r in [
        GyroRange::Dps250,
        GyroRange::Dps500,
        GyroRange::Dps1000,
        GyroRange::Dps2000,
    ] {
        // Datasheet factor vs exact 32768 / full scale agree within 0.1 %.
        let exact = 32768.0 / f32::from(r.full_scale_dps());
        assert!((r.lsb_per_dps() / exact - 1.0).abs() < 1e-3);
        assert_eq!(f32::from(r.lsb_per_dps_x10()) / 10.0, r.lsb_per_dps());
        assert!((r.dps_per_lsb() * r.lsb_per_dps() - 1.0).abs() < 1e-6);
    }
    for r in [
        AccelRange::G2,
        AccelRange::G4,
        AccelRange::G8,
        AccelRange::G16,
    ] {
        assert_eq!(
            u32::from(r.lsb_per_g()) * u32::from(r.full_scale_g()),
            32768
        );
    }
    // Full-scale count converts to the full-scale value.
    let s = Scale::new(AccelRange::G4, GyroRange::Dps1000);
    let out = convert(
        &RawSample {
            accel: [-32768, 0, 0],
            temp: 0,
            gyro: [-32768, 0, 0],
        },
        &s,
    );
    assert_eq!(out.accel_g[0], -4.0);
    assert!((out.gyro_dps[0] + 999.0).abs() < 1.0);
}

#[test]
fn temperature_vectors() {
    assert_eq!(temp_c(0), 21.0);
    assert!((temp_c(334) - 22.0).abs() < 0.01);
    assert!((temp_c(-7011) - 0.0).abs() < 0.01);
    assert_eq!(temp_centi_c(0), 2100);
    assert_eq!(temp_centi_c(3339), 3100);
    assert_eq!(temp_centi_c(-7011), 0);
    assert_eq!(temp_centi_c(i16::MAX), 2100 + 9814); // 32767 / 333.87 = 98.143 °C
    assert_eq!(temp_centi_c(i16::MIN), 2100 - 9815); // -98.146 °C
}

// ---------------------------------------------------------------- interrupts, bypass

#[test]
fn interrupt_bits() {
    let i = InterruptConfig::new();
    assert_eq!((i.int_pin_cfg_bits(), i.int_enable_bits()), (0x00, 0x01));
    assert_eq!(i.level(IntLevel::ActiveLow).int_pin_cfg_bits(), 0x80);
    assert_eq!(i.drive(IntDrive::OpenDrain).int_pin_cfg_bits(), 0x40);
    assert_eq!(i.latch(IntLatch::Latched).int_pin_cfg_bits(), 0x20);
    assert_eq!(i.clear(IntClear::OnAnyRead).int_pin_cfg_bits(), 0x10);
    assert_eq!(InterruptConfig::disabled().int_enable_bits(), 0x00);
    assert_eq!(i.int_pin_cfg(true), 0x02);
}

#[test]
fn set_interrupts_and_status() {
    let int = InterruptConfig::new()
        .latch(IntLatch::Latched)
        .clear(IntClear::OnAnyRead);
    let (mut i2c, mut imu) = inited(vec![
        T::write(A, vec![0x37, 0x30]),
        T::write(A, vec![0x38, 0x01]),
        T::write_read(A, vec![0x3A], vec![0x01]),
        T::write_read(A, vec![0x3A], vec![0x50]),
        T::write_read(A, vec![0x3A], vec![0x00]).with_error(NACK),
        // verify_config expects the new interrupt bits
        T::write_read(A, vec![0x19], vec![0x00, 0x03, 0x10, 0x08, 0x03]),
        T::write_read(A, vec![0x37], vec![0x30, 0x01]),
        T::write_read(A, vec![0x6A], vec![0x00, 0x01, 0x00]),
    ]);
    imu.set_interrupts(int).unwrap();
    assert!(imu.data_ready().unwrap());
    let st = imu.read_int_status().unwrap();
    assert!(!st.data_ready() && st.wake_on_motion() && st.fifo_overflow() && !st.fsync());
    assert_eq!(imu.data_ready(), Err(Error::Bus(NACK)));
    imu.verify_config().unwrap();
    i2c.done();
}

#[test]
fn bypass_keeps_interrupt_bits_and_survives_init() {
    let int = InterruptConfig::new()
        .level(IntLevel::ActiveLow)
        .latch(IntLatch::Latched);
    let c = Config::new().interrupt(int);
    let mut t = init_for(A, &c, false);
    t.extend([
        T::write(A, vec![0x6A, 0x00]),
        T::write(A, vec![0x37, 0xA2]),
        // set_interrupts keeps BYPASS_EN
        T::write(A, vec![0x37, 0x02]),
        T::write(A, vec![0x38, 0x00]),
    ]);
    // re-init with the interrupt config restored: INT_PIN_CFG = 0xA2 again
    t.extend(init_for(A, &c, true));
    t.push(T::write(A, vec![0x37, 0xA0]));
    let (mut i2c, mut imu) = inited_with(&t, &c);
    imu.set_bypass(true).unwrap();
    assert!(imu.bypass());
    imu.set_interrupts(InterruptConfig::disabled()).unwrap();
    imu.init(&mut NoopDelay::new(), &c).unwrap();
    // the INT_PIN_CFG written by init held both the interrupt bits and BYPASS_EN
    assert_eq!(c.register_values(true)[8], (0x37, 0xA2));
    imu.set_bypass(false).unwrap();
    i2c.done();
}

#[test]
fn bypass_nack() {
    let (mut i2c, mut imu) = inited(vec![T::write(A, vec![0x6A, 0x00]).with_error(NACK)]);
    assert_eq!(imu.set_bypass(true), Err(Error::Bus(NACK)));
    i2c.done();
}

// ---------------------------------------------------------------- gyro bias

fn rest(gyro: [i16; 3]) -> T {
    read_t([100, -50, 8192], 0, gyro)
}

#[test]
fn gyro_bias_averaging_rounds_and_is_applied() {
    let (mut i2c, mut imu) = inited(vec![
        rest([10, -20, 3]),
        rest([12, -21, 3]),
        rest([11, -22, 4]),
        rest([12, -21, 4]),
        read_t([0, 0, 8192], 0, [11, -21, 3]),
    ]);
    let mut delay = CheckedDelay::new(&vec![D::delay_us(1000); 4]);
    // means: 45/4 = 11.25 -> 11, -84/4 = -21, 14/4 = 3.5 -> 4
    assert_eq!(imu.calibrate_gyro_bias(&mut delay, 4), Ok([11, -21, 4]));
    assert_eq!(imu.gyro_bias(), [11, -21, 4]);
    let s = imu.read().unwrap();
    assert_eq!(s.gyro_dps[0], 0.0);
    assert_eq!(s.gyro_dps[1], 0.0);
    assert!((s.gyro_dps[2] + 1.0 / 32.8).abs() < 1e-6);
    i2c.done();
    delay.done();
}

#[test]
fn gyro_bias_moved_by_rotation() {
    // 3 °/s at 32.8 LSB/(°/s) = 98 counts; a 150-count swing on y is motion.
    let (mut i2c, mut imu) = inited(vec![rest([0, 0, 0]), rest([0, 150, 0]), rest([0, 75, 0])]);
    imu.set_gyro_bias([1, 2, 3]);
    assert_eq!(
        imu.calibrate_gyro_bias(&mut NoopDelay::new(), 3),
        Err(Error::Moved(Motion::GyroSpread {
            axis: 1,
            peak_to_peak_counts: 150,
            limit_counts: 98
        }))
    );
    assert_eq!(
        imu.gyro_bias(),
        [1, 2, 3],
        "bias unchanged after a failed calibration"
    );
    i2c.done();
}

#[test]
fn gyro_bias_moved_by_acceleration() {
    let (mut i2c, mut imu) = inited(vec![rest([0; 3]), read_t([0, 0, 16384], 0, [0; 3])]);
    assert_eq!(
        imu.calibrate_gyro_bias(&mut NoopDelay::new(), 5),
        Err(Error::Moved(Motion::AccelMagnitude { magnitude_mg: 2000 }))
    );
    i2c.done();
    // free fall
    let (mut i2c, mut imu) = inited(vec![read_t([0, 0, 0], 0, [0; 3])]);
    assert_eq!(
        imu.calibrate_gyro_bias(&mut NoopDelay::new(), 5),
        Err(Error::Moved(Motion::AccelMagnitude { magnitude_mg: 0 }))
    );
    i2c.done();
}

#[test]
fn gyro_bias_tilted_at_rest_is_fine() {
    // 1 g along a diagonal: (4730, 4730, 4730) counts -> |a| = 8192.6
    let (mut i2c, mut imu) = inited(vec![read_t([4730, 4730, 4730], 0, [5, 5, 5]); 2]);
    assert_eq!(
        imu.calibrate_gyro_bias(&mut NoopDelay::new(), 2),
        Ok([5, 5, 5])
    );
    i2c.done();
}

#[test]
fn gyro_bias_zero_samples_and_bus_error() {
    let (mut i2c, mut imu) = inited(vec![rest([0; 3]), rest([0; 3]).with_error(NACK)]);
    assert_eq!(
        imu.calibrate_gyro_bias(&mut NoopDelay::new(), 0),
        Err(Error::InvalidConfig(ConfigError::NoSamples))
    );
    assert_eq!(
        imu.calibrate_gyro_bias(&mut NoopDelay::new(), 2),
        Err(Error::Bus(NACK))
    );
    assert_eq!(imu.gyro_bias(), [0; 3]);
    i2c.done();
}

#[test]
fn reinit_keeps_bias_and_rescales_on_range_change() {
    let c2000 = Config::new().gyro_range(GyroRange::Dps2000);
    let mut t = default_init(A);
    t.extend(default_init(A));
    t.extend(init_for(A, &c2000, false));
    t.push(read_t([0, 0, 8192], 0, [50, -50, 0]));
    let mut i2c = Mock::new(&t);
    let mut imu = Mpu9250::new(i2c.clone(), Address::Ad0Low);
    let mut d = NoopDelay::new();
    imu.init(&mut d, &Config::default()).unwrap();
    imu.set_gyro_bias([100, -100, 7]);
    imu.init(&mut d, &Config::default()).unwrap();
    assert_eq!(imu.gyro_bias(), [100, -100, 7]);
    let before = imu.gyro_bias_dps();
    imu.init(&mut d, &c2000).unwrap();
    assert_eq!(imu.gyro_bias(), [50, -50, 3]);
    let after = imu.gyro_bias_dps();
    assert!((before[0] - after[0]).abs() < 0.01, "{before:?} {after:?}");
    let s = imu.read().unwrap();
    assert_eq!(&s.gyro_dps[..2], &[0.0, 0.0]);
    assert!((s.gyro_dps[2] + 3.0 / 16.4).abs() < 1e-6);
    i2c.done();
}

#[test]
fn rescale_saturates() {
    assert_eq!(
        rescale_gyro_bias([20000, -20000, 1], GyroRange::Dps2000, GyroRange::Dps500),
        [i16::MAX, i16::MIN, 4]
    );
}

#[test]
fn errors_display() {
    let cases: [(Error<ErrorKind>, &str); 8] = [
        (Error::Bus(NACK), "bus"),
        (Error::WrongChipId(0x12), "0x12"),
        (Error::Mpu6500Detected, "MPU-6500"),
        (Error::ResetTimeout, "reset"),
        (
            Error::ConfigMismatch {
                register: 0x1B,
                expected: 0x10,
                found: 0,
            },
            "0x1B",
        ),
        (
            Error::Moved(Motion::AccelMagnitude { magnitude_mg: 1500 }),
            "1500",
        ),
        (Error::NotInitialized, "initialised"),
        (Error::InvalidConfig(ConfigError::DividerIgnored), "divider"),
    ];
    for (e, needle) in cases {
        let s = e.to_string();
        assert!(s.contains(needle), "{s}");
    }
}

mod props {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn parse_roundtrip(a in any::<[i16; 3]>(), t in any::<i16>(), g in any::<[i16; 3]>()) {
            let bytes: [u8; 14] = sample_bytes(a, t, g).try_into().unwrap();
            prop_assert_eq!(parse_sample(&bytes), RawSample { accel: a, temp: t, gyro: g });
        }

        #[test]
        fn integer_temp_matches_float(raw in any::<i16>()) {
            let f = temp_c(raw) * 100.0;
            prop_assert!((f - temp_centi_c(raw) as f32).abs() <= 0.51, "{} {}", f, temp_centi_c(raw));
        }

        #[test]
        fn bias_rescale_preserves_rate(b in -4000i16..4000, from in 0u8..4, to in 0u8..4) {
            let r = [GyroRange::Dps250, GyroRange::Dps500, GyroRange::Dps1000, GyroRange::Dps2000];
            let (f, t) = (r[from as usize], r[to as usize]);
            let out = rescale_gyro_bias([b; 3], f, t)[0];
            let rate_in = f32::from(b) * f32::from(f.full_scale_dps()) / 32768.0;
            let rate_out = f32::from(out) * f32::from(t.full_scale_dps()) / 32768.0;
            // within one output count
            prop_assert!((rate_in - rate_out).abs() <= f32::from(t.full_scale_dps()) / 32768.0 + 1e-6);
        }

        #[test]
        fn bias_subtraction_saturates(g in any::<i16>(), b in any::<i16>()) {
            let raw = RawSample { accel: [0; 3], temp: 0, gyro: [g; 3] };
            let out = apply_gyro_bias(raw, [b; 3]);
            let exact = i32::from(g) - i32::from(b);
            prop_assert_eq!(i32::from(out.gyro[0]), exact.clamp(-32768, 32767));
        }
    }
}
