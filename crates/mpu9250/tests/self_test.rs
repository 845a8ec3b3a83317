//! Factory self-test: the application note's sequence, its pass criteria on
//! responses built around the factory trim, and the configuration restored.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use common::*;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::Mock;
use mpu9250::*;

const REST_GYRO: [i16; 3] = [10, -10, 5];
const REST_ACCEL: [i16; 3] = [0, 0, 16384];

/// The whole self-test traffic: set-up, 200 samples off, self-test on, 200
/// samples on, off, the factory codes, then the configuration rewritten and
/// read back. Responses are added to the rest values in the second phase.
fn traffic(gyro_resp: [i16; 3], accel_resp: [i16; 3], codes: [u8; 6]) -> Vec<Op> {
    let mut ops = init_ops(&Config::default(), false, 0);
    ops.extend([
        Op::Write(0x19, 0),
        Op::Write(0x1A, 2),
        Op::Write(0x1B, 0),
        Op::Write(0x1D, 2),
        Op::Write(0x1C, 0),
    ]);
    ops.extend((0..200).map(|_| sample_op(REST_ACCEL, 0, REST_GYRO)));
    ops.extend([Op::Write(0x1B, 0xE0), Op::Write(0x1C, 0xE0)]);
    let on =
        |rest: [i16; 3], resp: [i16; 3]| [rest[0] + resp[0], rest[1] + resp[1], rest[2] + resp[2]];
    ops.extend(
        (0..200).map(|_| sample_op(on(REST_ACCEL, accel_resp), 0, on(REST_GYRO, gyro_resp))),
    );
    ops.extend([Op::Write(0x1B, 0), Op::Write(0x1C, 0)]);
    ops.push(Op::Read(0x00, codes[..3].to_vec()));
    ops.push(Op::Read(0x0D, codes[3..].to_vec()));
    // Restore: the configuration writes and read-backs of init, without the reset.
    let init = init_ops(&Config::default(), false, 0);
    ops.extend(init[3..].iter().cloned());
    ops
}

fn run(ops: &[Op]) -> Result<SelfTest, Error<embedded_hal::i2c::ErrorKind>> {
    let mut bus = Mock::new(&i2c(ops));
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    let r = imu.self_test(&mut NoopDelay::new());
    bus.done();
    r
}

#[test]
fn factory_trim_formula() {
    assert_eq!(factory_trim_lsb(0), 0);
    assert_eq!(factory_trim_lsb(1), 2620);
    assert_eq!(factory_trim_lsb(2), 2646); // 2620 × 1.01
                                           // 2620 × 1.01^99 = 7016.4
    assert!(factory_trim_lsb(100).abs_diff(7016) <= 1);
}

#[test]
fn responses_equal_to_the_trim_pass() {
    // Code 1: trim 2620 LSB on every axis; the chip responds exactly that.
    let r = run(&traffic([2620; 3], [2620; 3], [1; 6])).unwrap();
    assert_eq!(r.gyro_offset_lsb, [10, -10, 5]);
    assert_eq!(r.gyro_response_lsb, [2620; 3]);
    assert_eq!(r.accel_response_lsb, [2620; 3]);
    assert_eq!(r.gyro_factory_lsb, [2620; 3]);
}

#[test]
fn weak_gyro_or_strong_accel_fail_and_the_config_is_restored() {
    // Gyro x at 0.4 of its trim.
    assert_eq!(
        run(&traffic([1048, 2620, 2620], [2620; 3], [1; 6])),
        Err(Error::SelfTestFailed {
            check: SelfTestCheck::GyroResponse,
            axis: 0
        })
    );
    // Accel z at 1.6 of its trim.
    assert_eq!(
        run(&traffic([2620; 3], [2620, 2620, 4192], [1; 6])),
        Err(Error::SelfTestFailed {
            check: SelfTestCheck::AccelResponse,
            axis: 2
        })
    );
}

#[test]
fn without_factory_codes_the_absolute_limits_apply() {
    // 60 °/s = 7860 LSB and 225..675 mg = 3686..11059 LSB.
    assert!(run(&traffic([7860; 3], [4000; 3], [0; 6])).is_ok());
    assert!(run(&traffic([7859, 7860, 7860], [4000; 3], [0; 6])).is_err());
    assert!(run(&traffic([7860; 3], [3000, 4000, 4000], [0; 6])).is_err());
}

#[test]
fn a_bus_error_mid_test_still_restores_the_configuration() {
    let full = traffic([2620; 3], [2620; 3], [1; 6]);
    let init_len = init_ops(&Config::default(), false, 0).len();
    // The 10th sample read fails: nothing after it in the measurement, then
    // the restore writes and read-backs.
    let mut t = i2c(&full[..init_len + 5 + 9]);
    t.push(
        embedded_hal_mock::eh1::i2c::Transaction::write_read(A, vec![0x3B], vec![0; 14])
            .with_error(NACK),
    );
    let init = init_ops(&Config::default(), false, 0);
    t.extend(i2c(&init[3..]));
    let mut bus = Mock::new(&t);
    let mut imu = Mpu9250::new(bus.clone(), Address::Ad0Low);
    imu.init(&mut NoopDelay::new(), &Config::default()).unwrap();
    assert_eq!(imu.self_test(&mut NoopDelay::new()), Err(Error::Bus(NACK)));
    bus.done();
}
