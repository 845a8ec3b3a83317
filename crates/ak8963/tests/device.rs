//! Transaction-level tests of the AK8963 driver against embedded-hal-mock.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use ak8963::*;
use embedded_hal::i2c::ErrorKind;
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};

mod common;
use common::*;

#[track_caller]
fn close(a: [f32; 3], b: [f32; 3]) {
    for i in 0..3 {
        assert!((a[i] - b[i]).abs() < 1e-4, "{a:?} != {b:?}");
    }
}

// ---------------------------------------------------------------- init

#[test]
fn init_default_exact_bytes_and_waits() {
    let mut i2c = Mock::new(&init_seq([0x80, 0xB0, 0x7F], 0x16));
    let mut delay = CheckedDelay::new(&[
        D::delay_us(1000), // reset poll
        D::delay_us(100),  // power-down
        D::delay_us(100),  // fuse ROM
        D::delay_us(100),  // power-down
        D::delay_us(100),  // continuous 2
    ]);
    let mut mag = Ak8963::new(i2c.clone());
    mag.init(&mut delay, &Config::default()).unwrap();
    assert_eq!(mag.asa(), [0x80, 0xB0, 0x7F]);
    assert_eq!(mag.adjustment_q8(), [256, 304, 255]);
    let u = mag.ut_per_lsb();
    assert_eq!(u[0], 0.15);
    assert!((u[1] - 0.15 * 1.1875).abs() < 1e-7);
    assert!((u[2] - 0.15 * (255.0 / 256.0)).abs() < 1e-7);
    mag.release();
    i2c.done();
    delay.done();
}

#[test]
fn default_config_is_16bit_continuous_2() {
    let c = Config::default();
    assert_eq!(
        (c.mode, c.resolution),
        (Mode::Continuous100Hz, Resolution::Bits16)
    );
    assert_eq!(c.cntl1(), 0x16);
    assert_eq!(c.mode.data_rate_hz(), Some(100));
    let modes = [
        (Mode::PowerDown, 0x0),
        (Mode::Single, 0x1),
        (Mode::Continuous8Hz, 0x2),
        (Mode::Continuous100Hz, 0x6),
        (Mode::ExternalTrigger, 0x4),
    ];
    for (m, bits) in modes {
        assert_eq!(
            Config::new().mode(m).resolution(Resolution::Bits14).cntl1(),
            bits
        );
        assert_eq!(Config::new().mode(m).cntl1(), 0x10 | bits);
    }
}

#[test]
fn init_14bit_8hz() {
    let c = Config::new()
        .mode(Mode::Continuous8Hz)
        .resolution(Resolution::Bits14);
    let mut i2c = Mock::new(&init_seq([0x80; 3], 0x02));
    let mut mag = Ak8963::new(i2c.clone());
    mag.init(&mut NoopDelay::new(), &c).unwrap();
    assert_eq!(mag.ut_per_lsb(), [0.6; 3]);
    i2c.done();
}

#[test]
fn wrong_id() {
    for id in [0x00u8, 0xFF, 0x71, 0x49] {
        let mut i2c = Mock::new(&[T::write_read(A, vec![0x00], vec![id])]);
        let mut mag = Ak8963::new(i2c.clone());
        assert_eq!(
            mag.init(&mut NoopDelay::new(), &Config::default()),
            Err(Error::WrongId(id))
        );
        i2c.done();
    }
}

#[test]
fn nack_at_every_init_step_is_a_bus_error() {
    let full = init_seq([0x80; 3], 0x16);
    for k in (0..full.len()).filter(|&k| k != 2) {
        let mut t: Vec<T> = full[..k].to_vec();
        t.push(full[k].clone().with_error(NACK));
        let mut i2c = Mock::new(&t);
        let mut mag = Ak8963::new(i2c.clone());
        assert_eq!(
            mag.init(&mut NoopDelay::new(), &Config::default()),
            Err(Error::Bus(NACK)),
            "step {k}"
        );
        assert_eq!(mag.verify_config(), Err(Error::NotInitialized));
        i2c.done();
    }
}

#[test]
fn reset_poll_and_timeout() {
    let mut t = init_seq([0x80; 3], 0x16);
    t.splice(
        2..3,
        [
            T::write_read(A, vec![0x0B], vec![0x01]),
            T::write_read(A, vec![0x0B], vec![0x00]).with_error(NACK),
            T::write_read(A, vec![0x0B], vec![0x00]),
        ],
    );
    let mut i2c = Mock::new(&t);
    let mut mag = Ak8963::new(i2c.clone());
    mag.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    i2c.done();

    for stuck in [Some(0x01u8), None] {
        let mut t = init_seq([0x80; 3], 0x16)[..2].to_vec();
        for _ in 0..RESET_MAX_POLLS {
            t.push(match stuck {
                Some(v) => T::write_read(A, vec![0x0B], vec![v]),
                None => T::write_read(A, vec![0x0B], vec![0]).with_error(NACK),
            });
        }
        let mut i2c = Mock::new(&t);
        let mut mag = Ak8963::new(i2c.clone());
        assert_eq!(
            mag.init(&mut NoopDelay::new(), &Config::default()),
            Err(Error::ResetTimeout)
        );
        i2c.done();
    }
}

#[test]
fn bad_fuse_rom_rejected_after_power_down() {
    for asa in [
        [0x00, 0x80, 0x80],
        [0x80, 0xFF, 0x80],
        [0x80, 0x80, 0x00],
        [0xFF; 3],
    ] {
        // The chip is returned to power-down before the error is reported.
        let t = init_seq(asa, 0x16)[..7].to_vec();
        let mut i2c = Mock::new(&t);
        let mut mag = Ak8963::new(i2c.clone());
        assert_eq!(
            mag.init(&mut NoopDelay::new(), &Config::default()),
            Err(Error::BadFuseRom { asa })
        );
        assert_eq!(mag.read(), Err(Error::NotInitialized));
        i2c.done();
    }
}

#[test]
fn config_readback_mismatch() {
    let mut t = init_seq([0x80; 3], 0x16);
    *t.last_mut().unwrap() = T::write_read(A, vec![0x0A], vec![0x00]);
    let mut i2c = Mock::new(&t);
    let mut mag = Ak8963::new(i2c.clone());
    assert_eq!(
        mag.init(&mut NoopDelay::new(), &Config::default()),
        Err(CNTL1_CLEARED)
    );
    i2c.done();
}

#[test]
fn verify_config_detects_reset() {
    let (mut i2c, mut mag) = inited(
        [0x80; 3],
        vec![
            T::write_read(A, vec![0x0A], vec![0x16]),
            T::write_read(A, vec![0x0A], vec![0x00]),
            T::write_read(A, vec![0x0A], vec![0x16]).with_error(NACK),
        ],
    );
    assert_eq!(mag.verify_config(), Ok(()));
    assert_eq!(mag.verify_config(), Err(CNTL1_CLEARED));
    assert_eq!(mag.verify_config(), Err(Error::Bus(NACK)));
    i2c.done();
}

// ---------------------------------------------------------------- adjustment, scale

#[test]
fn asa_adjustment_vectors() {
    assert_eq!(adjustment_factor(0x80), 1.0);
    // (176 - 128) / 256 + 1 = 1.1875; 1.171875 is ASA 0xAC = 172.
    assert_eq!(adjustment_factor(0xB0), 1.1875);
    assert_eq!(adjustment_factor(0xAC), 1.171875);
    assert_eq!(adjustment_factor(0x00), 0.5); // no u8 underflow
    assert_eq!(adjustment_factor(0x7F), 1.0 - 1.0 / 256.0);
    assert_eq!(adjustment_factor(0xFF), 383.0 / 256.0);
    for asa in 0..=255u8 {
        assert_eq!(
            adjustment_factor(asa),
            f32::from(adjustment_q8(asa)) / 256.0
        );
        assert_eq!(asa_valid(asa), asa != 0 && asa != 0xFF);
    }
}

#[test]
fn sensitivity_vectors() {
    assert_eq!(Resolution::Bits16.ut_per_lsb(), 0.15);
    assert_eq!(Resolution::Bits14.ut_per_lsb(), 0.6);
    assert_eq!(Resolution::Bits16.nt_per_lsb(), 150);
    assert_eq!(Resolution::Bits14.nt_per_lsb(), 600);
    // Full scale: 32760 counts × 0.15 = 4914 µT, 8190 × 0.6 = 4914 µT.
    assert!((32760.0 * Resolution::Bits16.ut_per_lsb() - 4914.0f32).abs() < 1e-2);
    assert!((8190.0 * Resolution::Bits14.ut_per_lsb() - 4914.0f32).abs() < 1e-2);
}

#[test]
fn measurement_range_boundary() {
    // 32746 × 0.15 = 4911.9 µT (in range); 32747 × 0.15 = 4912.05 µT (over)
    assert!(!exceeds_range([32746, 0, 0], Resolution::Bits16));
    assert!(exceeds_range([32747, 0, 0], Resolution::Bits16));
    assert!(exceeds_range([20000, -12747, 0], Resolution::Bits16));
    assert!(!exceeds_range([-10000, 10000, -12746], Resolution::Bits16));
    assert!(!exceeds_range([8186, 0, 0], Resolution::Bits14));
    assert!(exceeds_range([8187, 0, 0], Resolution::Bits14));
    assert!(exceeds_range([i16::MIN; 3], Resolution::Bits14));
}

// ---------------------------------------------------------------- reading

#[test]
fn read_converts_with_adjustment() {
    let (mut i2c, mut mag) = inited(
        [0xB0, 0x80, 0x01],
        vec![st1(0x01), data([100, -200, 400], 0x10)],
    );
    let s = mag.read().unwrap();
    // 100 × 0.15 × 1.1875; -200 × 0.15 × 1; 400 × 0.15 × 129/256
    close(s.field_ut, [17.8125, -30.0, 30.234375]);
    assert!(!s.data_overrun);
    i2c.done();
}

#[test]
fn read_14bit_scale() {
    let c = Config::new().resolution(Resolution::Bits14);
    let mut t = init_seq([0x80; 3], 0x06);
    t.extend([
        st1(0x01),
        data([100, -8000, 0], 0x00),
        st1(0x01),
        data([100, -8190, 0], 0x00),
    ]);
    let mut i2c = Mock::new(&t);
    let mut mag = Ak8963::new(i2c.clone());
    mag.init(&mut NoopDelay::new(), &c).unwrap();
    let s = mag.read().unwrap();
    assert!((s.field_ut[0] - 60.0).abs() < 1e-4);
    assert!((s.field_ut[1] + 4800.0).abs() < 1e-2);
    // 100 + 8190 counts × 0.6 µT = 4974 µT > 4912 µT: overflow even without HOFL
    assert_eq!(mag.read(), Err(Error::Overflow));
    i2c.done();
}

#[test]
fn st2_bitm_must_match_the_configured_resolution() {
    // 16 bit configured, the chip reports 14-bit output (BITM clear): the
    // counts would be scaled 4x too small, so the sample is dropped.
    let (mut i2c, mut mag) = inited(
        [0x80; 3],
        vec![
            st1(0x01),
            data([100, 0, 0], 0x00),
            st1(0x01),
            data([100, 0, 0], 0x10),
        ],
    );
    assert_eq!(
        mag.read(),
        Err(Error::ResolutionMismatch {
            configured: Resolution::Bits16
        })
    );
    assert!((mag.read().unwrap().field_ut[0] - 15.0).abs() < 1e-4);
    i2c.done();

    // 14 bit configured, BITM set.
    let c = Config::new().resolution(Resolution::Bits14);
    let mut t = init_seq([0x80; 3], 0x06);
    t.extend([st1(0x01), data([100, 0, 0], 0x10)]);
    let mut i2c = Mock::new(&t);
    let mut mag = Ak8963::new(i2c.clone());
    mag.init(&mut NoopDelay::new(), &c).unwrap();
    assert_eq!(
        mag.read_raw(),
        Err(Error::ResolutionMismatch {
            configured: Resolution::Bits14
        })
    );
    i2c.done();
}

#[test]
fn not_ready_reads_only_st1() {
    let (mut i2c, mut mag) = inited(
        [0x80; 3],
        vec![st1(0x00), st1(0x02), st1(0x01), data([1, 2, 3], 0x10)],
    );
    assert_eq!(mag.read(), Err(Error::NotReady));
    // DOR without DRDY is still not ready
    assert_eq!(mag.read_raw(), Err(Error::NotReady));
    assert_eq!(mag.read_raw().unwrap().counts, [1, 2, 3]);
    i2c.done();
}

#[test]
fn data_overrun_is_flagged_and_data_kept() {
    let (mut i2c, mut mag) = inited([0x80; 3], vec![st1(0x03), data([1000, 0, -1000], 0x10)]);
    let s = mag.read().unwrap();
    assert!(s.data_overrun);
    close(s.field_ut, [150.0, 0.0, -150.0]);
    i2c.done();
}

#[test]
fn overflow_drops_sample_and_next_read_works() {
    let (mut i2c, mut mag) = inited(
        [0x80; 3],
        vec![
            st1(0x01),
            data([30000, 2000, 1000], 0x18),
            st1(0x01),
            // HOFL clear, but |X|+|Y|+|Z| above 4912 µT: still an overflow
            data([30000, 2000, 1000], 0x10),
            st1(0x01),
            data([300, 200, 100], 0x10),
        ],
    );
    assert_eq!(mag.read(), Err(Error::Overflow));
    assert_eq!(mag.read(), Err(Error::Overflow));
    close(mag.read().unwrap().field_ut, [45.0, 30.0, 15.0]);
    i2c.done();
}

#[test]
fn read_bus_errors() {
    let (mut i2c, mut mag) = inited(
        [0x80; 3],
        vec![
            st1(0x01).with_error(NACK),
            st1(0x01),
            data([0; 3], 0x10).with_error(NACK),
            // The failed burst is followed by an ST2 read that ends the
            // chip's data read (releases the data protection).
            T::write_read(A, vec![0x09], vec![0x10]),
        ],
    );
    assert_eq!(mag.read(), Err(Error::Bus(NACK)));
    assert_eq!(mag.read(), Err(Error::Bus(NACK)));
    i2c.done();
}

#[test]
fn read_before_init() {
    let mut i2c = Mock::new(&[st1(0x01), data([10, 20, 30], 0x10)]);
    let mut mag = Ak8963::new(i2c.clone());
    assert_eq!(mag.read(), Err(Error::NotInitialized));
    assert_eq!(mag.verify_config(), Err(Error::NotInitialized));
    assert_eq!(
        mag.self_test(&mut NoopDelay::new()),
        Err(Error::NotInitialized)
    );
    // raw counts need no fuse ROM
    assert_eq!(mag.read_raw().unwrap().counts, [10, 20, 30]);
    i2c.done();
}

#[test]
fn parse_is_little_endian() {
    let m = parse_measurement(
        &[0x34, 0x12, 0xFF, 0xFF, 0x00, 0x80, 0x10],
        Resolution::Bits16,
    );
    // 0x8000 = -32768 exceeds the range
    assert_eq!(m, Err(Rejected::Overflow));
    let m = parse_measurement(
        &[0x34, 0x12, 0xFF, 0xFF, 0x00, 0xF0, 0x10],
        Resolution::Bits16,
    )
    .unwrap();
    assert_eq!(m.counts, [0x1234, -1, -4096]);
    assert_eq!(m.resolution, Resolution::Bits16);
    assert!(!m.data_overrun);
    assert_eq!(
        parse_st1(0x03),
        St1 {
            data_ready: true,
            data_overrun: true
        }
    );
    assert_eq!(
        parse_st1(0x00),
        St1 {
            data_ready: false,
            data_overrun: false
        }
    );
}

// ---------------------------------------------------------------- modes

#[test]
fn set_mode_passes_through_power_down() {
    let (mut i2c, mut mag) = inited(
        [0x80; 3],
        vec![
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0A, 0x12]),
            T::write_read(A, vec![0x0A], vec![0x12]),
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0A, 0x02]),
            T::write_read(A, vec![0x0A], vec![0x02]),
            st1(0x01),
            data([10, 0, 0], 0x00),
        ],
    );
    let mut delay = CheckedDelay::new(&vec![D::delay_us(100); 4]);
    mag.set_mode(&mut delay, Mode::Continuous8Hz).unwrap();
    mag.set_resolution(&mut delay, Resolution::Bits14).unwrap();
    assert!((mag.read().unwrap().field_ut[0] - 6.0).abs() < 1e-5);
    i2c.done();
    delay.done();
}

#[test]
fn single_measurement_mode() {
    let (mut i2c, mut mag) = inited(
        [0x80; 3],
        vec![
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0A, 0x11]),
            T::write_read(A, vec![0x0A], vec![0x11]),
            st1(0x01),
            data([1, 1, 1], 0x10),
            T::write_read(A, vec![0x0A], vec![0x10]), // back in power-down by itself
            T::write(A, vec![0x0A, 0x11]),
            T::write_read(A, vec![0x0A], vec![0x16]),
        ],
    );
    mag.set_mode(&mut NoopDelay::new(), Mode::Single).unwrap();
    mag.read().unwrap();
    mag.verify_config().unwrap();
    mag.trigger_single().unwrap();
    assert_eq!(
        mag.verify_config(),
        Err(Error::ConfigMismatch {
            register: 0x0A,
            expected: 0x11,
            found: 0x16
        })
    );
    i2c.done();
}

#[test]
fn self_test_pass_fail_timeout() {
    let seq = |result: Option<[i16; 3]>| {
        let mut t = vec![
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0C, 0x40]),
            T::write(A, vec![0x0A, 0x18]),
            st1(0x00),
        ];
        match result {
            Some(v) => t.extend([st1(0x01), data(v, 0x10)]),
            None => t.extend((1..SELF_TEST_MAX_POLLS).map(|_| st1(0x00))),
        }
        t.extend([
            T::write(A, vec![0x0C, 0x00]),
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0A, 0x16]),
        ]);
        t
    };
    let mut t = seq(Some([10, -30, -1500]));
    t.extend(seq(Some([10, -30, -500])));
    t.extend(seq(None));
    // ASA 0xB0 on z: -1500 × 304 / 256 = -1781
    let (mut i2c, mut mag) = inited([0x80, 0x80, 0xB0], t);
    let mut d = NoopDelay::new();
    assert_eq!(mag.self_test(&mut d), Ok([10, -30, -1781]));
    assert_eq!(
        mag.self_test(&mut d),
        Err(Error::SelfTestFailed {
            adjusted_counts: [10, -30, -593]
        })
    );
    assert_eq!(mag.self_test(&mut d), Err(Error::SelfTestTimeout));
    i2c.done();
}

// ---------------------------------------------------------------- calibration, frames

#[test]
fn hard_soft_iron() {
    assert_eq!(HardSoftIron::default(), HardSoftIron::IDENTITY);
    assert_eq!(
        HardSoftIron::IDENTITY.apply([1.0, -2.0, 3.0]),
        [1.0, -2.0, 3.0]
    );
    let c = HardSoftIron {
        offset_ut: [10.0, 20.0, 30.0],
        matrix: [[1.0, 0.5, 0.0], [0.0, 2.0, 0.0], [0.0, -1.0, 1.0]],
    };
    // d = (1, 2, 3) -> (1 + 1, 4, -2 + 3)
    assert_eq!(c.apply([11.0, 22.0, 33.0]), [2.0, 4.0, 1.0]);
    let d = HardSoftIron::diagonal([1.0, 1.0, 1.0], [2.0, 3.0, 4.0]);
    assert_eq!(d.apply([2.0, 2.0, 2.0]), [2.0, 3.0, 4.0]);
}

#[test]
fn from_min_max_maps_extremes_to_a_sphere() {
    let min = [-20.0, -70.0, 5.0];
    let max = [60.0, 10.0, 45.0];
    let c = HardSoftIron::from_min_max(min, max).unwrap();
    assert_eq!(c.offset_ut, [20.0, -30.0, 25.0]);
    let mean = (40.0 + 40.0 + 20.0) / 3.0;
    for axis in 0..3 {
        let mut hi = c.offset_ut;
        hi[axis] = max[axis];
        let mut lo = c.offset_ut;
        lo[axis] = min[axis];
        assert!((c.apply(hi)[axis] - mean).abs() < 1e-4);
        assert!((c.apply(lo)[axis] + mean).abs() < 1e-4);
    }
    assert_eq!(
        HardSoftIron::from_min_max([0.0, 0.0, 0.0], [1.0, 0.0, 1.0]),
        Err(CalibrationError::ZeroSpan { axis: 1 })
    );
    assert_eq!(
        HardSoftIron::from_min_max([0.0, 0.0, f32::NAN], [1.0, 1.0, 1.0]),
        Err(CalibrationError::ZeroSpan { axis: 2 })
    );
    assert_eq!(
        HardSoftIron::from_min_max([5.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
        Err(CalibrationError::ZeroSpan { axis: 0 })
    );
}

#[test]
fn calibration_applied_and_survives_init() {
    let cal = HardSoftIron::diagonal([15.0, 0.0, 0.0], [1.0, 2.0, 1.0]);
    let mut t = init_seq([0x80; 3], 0x16);
    t.extend(init_seq([0x80; 3], 0x16));
    t.extend([st1(0x01), data([100, 100, 100], 0x10)]);
    let mut i2c = Mock::new(&t);
    let mut mag = Ak8963::new(i2c.clone());
    let mut d = NoopDelay::new();
    mag.init(&mut d, &Config::default()).unwrap();
    mag.set_calibration(cal);
    mag.init(&mut d, &Config::default()).unwrap();
    assert_eq!(mag.calibration(), &cal);
    close(mag.read().unwrap().field_ut, [0.0, 30.0, 15.0]);
    i2c.done();
}

#[test]
fn frame_alignment() {
    assert_eq!(to_mpu_frame([1.0, 2.0, 3.0]), [2.0, 1.0, -3.0]);
    assert_eq!(to_mpu_frame_counts([1, 2, 3]), [2, 1, -3]);
    assert_eq!(to_mpu_frame_counts([0, 0, i16::MIN]), [0, 0, i16::MAX]);
    // Self-inverse.
    let v = [0.5, -7.0, 42.0];
    assert_eq!(to_mpu_frame(to_mpu_frame(v)), v);
    // Handedness: a proper frame change must keep x × y = z. (x_mag, y_mag, z_mag)
    // expressed in MPU axes are (0,1,0), (1,0,0), (0,0,-1): (0,1,0) × (1,0,0) = (0,0,-1).
    let (x, y) = (to_mpu_frame([1.0, 0.0, 0.0]), to_mpu_frame([0.0, 1.0, 0.0]));
    let cross = [
        x[1] * y[2] - x[2] * y[1],
        x[2] * y[0] - x[0] * y[2],
        x[0] * y[1] - x[1] * y[0],
    ];
    assert_eq!(cross, to_mpu_frame([0.0, 0.0, 1.0]));
}

#[test]
fn errors_display() {
    let cases: [(Error<ErrorKind>, &str); 11] = [
        (Error::Bus(NACK), "bus"),
        (Error::WrongId(0x12), "0x12"),
        (Error::ResetTimeout, "reset"),
        (
            Error::BadFuseRom {
                asa: [0, 0x80, 0xFF],
            },
            "0xFF",
        ),
        (Error::NotReady, "DRDY"),
        (Error::Overflow, "4912"),
        (
            Error::ConfigMismatch {
                register: 0x0A,
                expected: 0x16,
                found: 0,
            },
            "0x0A",
        ),
        (Error::NotInitialized, "initialised"),
        (
            Error::SelfTestFailed {
                adjusted_counts: [1, 2, 3],
            },
            "self-test",
        ),
        (Error::SelfTestTimeout, "self-test"),
        (
            Error::Calibration(CalibrationError::ZeroSpan { axis: 2 }),
            "axis 2",
        ),
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
        fn parse_roundtrip(v in any::<[i16; 3]>(), st2 in any::<u8>()) {
            let bytes: [u8; 7] = le(v, st2).try_into().unwrap();
            let r = parse_measurement(&bytes, Resolution::Bits16);
            if st2 & 0x08 != 0 || exceeds_range(v, Resolution::Bits16) {
                prop_assert_eq!(r, Err(Rejected::Overflow));
            } else if st2 & 0x10 == 0 {
                prop_assert_eq!(r, Err(Rejected::ResolutionMismatch { configured: Resolution::Bits16 }));
            } else {
                prop_assert_eq!(r.unwrap().counts, v);
            }
        }

        #[test]
        fn converted_magnitude_within_range(v in any::<[i16; 3]>(), asa in 1u8..255) {
            let bytes: [u8; 7] = le(v, 0x10).try_into().unwrap();
            if let Ok(raw) = parse_measurement(&bytes, Resolution::Bits16) {
                let k = ut_per_lsb([asa; 3], Resolution::Bits16);
                let f = counts_to_ut(raw.counts, &k);
                let l1: f32 = f.iter().map(|x| x.abs()).sum();
                // factory adjustment ≤ 1.5: L1 norm ≤ 1.5 × 4912 µT
                prop_assert!(l1 <= 1.5 * MEASUREMENT_RANGE_UT * 1.0001);
            }
        }

        #[test]
        fn frame_map_preserves_norm(v in any::<[i16; 3]>()) {
            let m = to_mpu_frame_counts(v);
            let n = |a: [i16; 3]| a.iter().map(|&x| i64::from(x) * i64::from(x)).sum::<i64>();
            if v[2] != i16::MIN {
                prop_assert_eq!(n(m), n(v));
            }
        }
    }
}
