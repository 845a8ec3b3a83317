//! Faults through the public API and recovery after them: NACKs at every
//! step, bursts that die half-way, failed mode changes, ASA extremes,
//! overflow and data-ready handling.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use ak8963::*;
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};

mod common;

use common::{data, init_seq, inited, st1, A, CNTL1_CLEARED};

/// A data NACK (the chip went away mid-transfer).
const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data);

fn st2_alone(v: u8) -> T {
    T::write_read(A, vec![0x09], vec![v])
}

#[track_caller]
fn close(a: [f32; 3], b: [f32; 3], tol: f32) {
    for i in 0..3 {
        assert!((a[i] - b[i]).abs() <= tol, "{a:?} != {b:?}");
    }
}

fn driver(t: &[T], asa: [u8; 3]) -> (Mock, Ak8963<Mock>) {
    inited(asa, t.iter().cloned())
}

/// ASA 0x01 and 0xFE (the extremes that are accepted): factors
/// (1 − 128)/256 + 1 = 0.50390625 and (254 − 128)/256 + 1 = 1.4921875,
/// checked through `read` at 16 bit (0.15 µT/LSB).
#[test]
fn asa_extremes_0x01_and_0xfe_through_read() {
    assert_eq!(adjustment_factor(0x01), 0.503_906_25);
    assert_eq!(adjustment_factor(0xFE), 1.492_187_5);
    assert_eq!(adjustment_q8(0x01), 129);
    assert_eq!(adjustment_q8(0xFE), 382);
    assert!(asa_valid(0x01) && asa_valid(0xFE));
    let (mut i2c, mut mag) = driver(
        &[st1(0x01), data([1000, -1000, 2000], 0x10)],
        [0x01, 0xFE, 0x80],
    );
    assert_eq!(mag.asa(), [0x01, 0xFE, 0x80]);
    let s = mag.read().unwrap();
    // 1000 × 0.15 × 0.50390625 = 75.5859375; −1000 × 0.15 × 1.4921875 = −223.828125
    close(s.field_ut, [75.585_94, -223.828_12, 300.0], 1e-3);
    i2c.done();
}

/// A NACK at every init step, then a full init on the same driver works and
/// reads are converted with the new ASA.
#[test]
fn nack_at_each_init_step_then_reinit_recovers() {
    let full = init_seq([0xB0, 0x80, 0x80], 0x16);
    for k in (0..full.len()).filter(|&k| k != 2) {
        let mut t: Vec<T> = full[..k].to_vec();
        t.push(full[k].clone().with_error(NACK));
        t.extend(full.iter().cloned());
        t.extend([st1(0x01), data([100, 0, 0], 0x10)]);
        let mut i2c = Mock::new(&t);
        let mut mag = Ak8963::new(i2c.clone());
        let mut d = NoopDelay::new();
        assert_eq!(
            mag.init(&mut d, &Config::default()),
            Err(Error::Bus(NACK)),
            "step {k}"
        );
        assert_eq!(mag.read(), Err(Error::NotInitialized), "step {k}");
        mag.init(&mut d, &Config::default()).unwrap();
        // 100 × 0.15 × 1.1875 = 17.8125
        close(mag.read().unwrap().field_ut, [17.8125, 0.0, 0.0], 1e-4);
        i2c.done();
    }
}

/// HOFL set with data that looks perfectly valid: still an overflow, the
/// sample is dropped, and ST2 was read (it is part of the burst), so the next
/// measurement is returned normally.
#[test]
fn hofl_with_plausible_data_is_an_overflow_and_next_read_works() {
    let (mut i2c, mut mag) = driver(
        &[
            st1(0x01),
            data([100, 200, 300], 0x18), // HOFL | BITM
            st1(0x03),                   // DRDY | DOR
            data([100, 200, 300], 0x18), // overflow wins over DOR
            st1(0x01),
            data([100, 200, 300], 0x10),
        ],
        [0x80; 3],
    );
    assert_eq!(mag.read(), Err(Error::Overflow));
    assert_eq!(mag.read_raw(), Err(Error::Overflow));
    let s = mag.read().unwrap();
    close(s.field_ut, [15.0, 30.0, 45.0], 1e-4);
    assert!(!s.data_overrun);
    i2c.done();
}

/// DRDY low (only ST1 is read, nothing consumed), then high.
#[test]
fn drdy_low_then_high() {
    let (mut i2c, mut mag) = driver(
        &[
            st1(0x00),
            st1(0x02), // DOR without DRDY: still not ready
            st1(0x01),
            data([-200, 0, 10], 0x10),
        ],
        [0x80; 3],
    );
    assert_eq!(mag.read(), Err(Error::NotReady));
    assert_eq!(mag.read(), Err(Error::NotReady));
    let r = mag.read_raw().unwrap();
    assert_eq!(r.counts, [-200, 0, 10]);
    assert_eq!(r.resolution, Resolution::Bits16);
    i2c.done();
}

/// A bus error in the middle of the data burst: the error is returned, ST2
/// is read on its own to end the chip's data read (otherwise the data
/// registers stay protected and DRDY never rises again), and the next
/// measurement is read normally. A failing ST2 read does not hide the burst's
/// error.
#[test]
fn bus_error_mid_burst_releases_protection_and_next_read_works() {
    let (mut i2c, mut mag) = driver(
        &[
            st1(0x01),
            data([1, 2, 3], 0x10).with_error(ErrorKind::ArbitrationLoss),
            st2_alone(0x10),
            st1(0x01),
            data([10, 20, 30], 0x10),
            st1(0x01),
            data([1, 2, 3], 0x10).with_error(ErrorKind::Bus),
            st2_alone(0x10).with_error(NACK),
            st1(0x01),
            data([-10, -20, -30], 0x10),
        ],
        [0x80; 3],
    );
    assert_eq!(mag.read(), Err(Error::Bus(ErrorKind::ArbitrationLoss)));
    close(mag.read().unwrap().field_ut, [1.5, 3.0, 4.5], 1e-4);
    assert_eq!(mag.read(), Err(Error::Bus(ErrorKind::Bus)));
    close(mag.read().unwrap().field_ut, [-1.5, -3.0, -4.5], 1e-4);
    i2c.done();
}

/// A failed mode change must not switch the driver to the new resolution's
/// scale while the chip still measures with the old one.
#[test]
fn failed_set_resolution_keeps_the_old_scale() {
    let (mut i2c, mut mag) = driver(
        &[
            // set_resolution(14 bit): the power-down write is NACKed; the
            // chip keeps measuring at 16 bit.
            T::write(A, vec![0x0A, 0x00]).with_error(NACK),
            st1(0x01),
            data([1000, 0, 0], 0x10),
            // Second attempt: power-down accepted, new mode NACKed: the chip
            // idles, verify_config reports it.
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0A, 0x06]).with_error(NACK),
            T::write_read(A, vec![0x0A], vec![0x00]),
            // Third attempt succeeds.
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0A, 0x06]),
            T::write_read(A, vec![0x0A], vec![0x06]),
            st1(0x01),
            data([1000, 0, 0], 0x00),
        ],
        [0x80; 3],
    );
    let mut d = NoopDelay::new();
    assert_eq!(
        mag.set_resolution(&mut d, Resolution::Bits14),
        Err(Error::Bus(NACK))
    );
    assert_eq!(mag.config().resolution, Resolution::Bits16);
    assert_eq!(mag.ut_per_lsb(), [0.15; 3]);
    // 16-bit data converted at 0.15 µT/LSB, not 0.6.
    close(mag.read().unwrap().field_ut, [150.0, 0.0, 0.0], 1e-3);
    assert_eq!(
        mag.set_resolution(&mut d, Resolution::Bits14),
        Err(Error::Bus(NACK))
    );
    assert_eq!(mag.verify_config(), Err(CNTL1_CLEARED));
    mag.set_resolution(&mut d, Resolution::Bits14).unwrap();
    assert_eq!(mag.config().resolution, Resolution::Bits14);
    close(mag.read().unwrap().field_ut, [600.0, 0.0, 0.0], 1e-3);
    i2c.done();
}

/// A bus error while the self-test field is on: the clean-up still turns
/// ASTC SELF off, powers down and restores the mode, and the error is
/// returned.
#[test]
fn self_test_bus_error_still_turns_the_self_test_field_off() {
    let (mut i2c, mut mag) = driver(
        &[
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0C, 0x40]),
            T::write(A, vec![0x0A, 0x18]),
            st1(0x00).with_error(NACK),
            T::write(A, vec![0x0C, 0x00]),
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0A, 0x16]),
            // Next self-test works.
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0C, 0x40]),
            T::write(A, vec![0x0A, 0x18]),
            st1(0x01),
            data([0, 0, -1000], 0x10),
            T::write(A, vec![0x0C, 0x00]),
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0A, 0x16]),
        ],
        [0x80; 3],
    );
    let mut d = NoopDelay::new();
    assert_eq!(mag.self_test(&mut d), Err(Error::Bus(NACK)));
    assert_eq!(mag.self_test(&mut d), Ok([0, 0, -1000]));
    i2c.done();
}

/// If clearing ASTC SELF fails, the chip is left in power-down (never back
/// in a measuring mode with the self-test field on).
#[test]
fn self_test_failed_self_clear_leaves_power_down() {
    let (mut i2c, mut mag) = driver(
        &[
            T::write(A, vec![0x0A, 0x00]),
            T::write(A, vec![0x0C, 0x40]),
            T::write(A, vec![0x0A, 0x18]),
            st1(0x01),
            data([0, 0, -1000], 0x10),
            T::write(A, vec![0x0C, 0x00]).with_error(NACK),
            T::write(A, vec![0x0A, 0x00]),
            T::write_read(A, vec![0x0A], vec![0x00]),
        ],
        [0x80; 3],
    );
    assert_eq!(mag.self_test(&mut NoopDelay::new()), Err(Error::Bus(NACK)));
    assert!(matches!(
        mag.verify_config(),
        Err(Error::ConfigMismatch { found: 0x00, .. })
    ));
    i2c.done();
}

/// 14-bit overflow boundary: 0.6 µT/LSB, sum of |counts| above 8186 overflows.
#[test]
fn range_boundaries_14_and_16_bit() {
    assert!(!exceeds_range([8186, 0, 0], Resolution::Bits14));
    assert!(exceeds_range([8187, 0, 0], Resolution::Bits14));
    assert!(exceeds_range([-3000, 3000, -2187], Resolution::Bits14));
    assert!(!exceeds_range([32746, 0, 0], Resolution::Bits16));
    assert!(exceeds_range([-32747, 0, 0], Resolution::Bits16));
    // No overflow in the sum for the most negative counts.
    assert!(exceeds_range([i16::MIN; 3], Resolution::Bits14));
}

/// AK8963 → MPU frame: x_mpu = y_mag, y_mpu = x_mag, z_mpu = −z_mag.
#[test]
fn frame_alignment_of_a_known_field() {
    // Field along +x of the MPU is +y of the AK8963.
    assert_eq!(to_mpu_frame([0.0, 40.0, 0.0]), [40.0, 0.0, 0.0]);
    // Field along +z of the MPU (out of the top face) is −z of the AK8963.
    assert_eq!(to_mpu_frame([0.0, 0.0, -40.0]), [0.0, 0.0, 40.0]);
    assert_eq!(to_mpu_frame_counts([1, 2, i16::MIN]), [2, 1, i16::MAX]);
}

/// Hard/soft iron: offset then 3×3 matrix with off-diagonal terms.
#[test]
fn hard_soft_iron_full_matrix() {
    let c = HardSoftIron {
        offset_ut: [10.0, -20.0, 5.0],
        matrix: [[1.0, 0.5, 0.0], [0.0, 2.0, 0.0], [0.25, 0.0, 1.0]],
    };
    // d = (20, 20, -5): (20 + 10, 40, 5 - 5)
    assert_eq!(c.apply([30.0, 0.0, 0.0]), [30.0, 40.0, 0.0]);
    assert_eq!(
        HardSoftIron::from_min_max([0.0, 0.0, 0.0], [1.0, 1.0, f32::NAN]),
        Err(CalibrationError::ZeroSpan { axis: 2 })
    );
}

#[test]
fn release_returns_the_bus() {
    let mag = Ak8963::new_with_address(Mock::new(&[]), 0x0D);
    assert_eq!(mag.address(), 0x0D);
    mag.release().done();
}
