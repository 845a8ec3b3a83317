//! Property tests: the quaternion stays finite and unit-norm for any input.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use fc_ahrs::fixed::{FixedConfig, MadgwickFixed};
use fc_ahrs::{Config, Madgwick};
use proptest::prelude::*;

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -50.0f32..50.0,
        1 => Just(0.0f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::MAX),
        1 => Just(-1e30f32),
        1 => Just(1e-30f32),
    ]
}

fn any_i32() -> impl Strategy<Value = i32> {
    prop_oneof![
        4 => -100_000i32..100_000,
        1 => Just(0i32),
        1 => Just(i32::MAX),
        1 => Just(i32::MIN),
        1 => any::<i32>(),
    ]
}

fn cfgs() -> impl Strategy<Value = Config> {
    (any::<bool>(), any::<bool>(), any::<bool>()).prop_map(|(t, a, s)| {
        let mut c = Config::DEFAULT;
        c.accel_rejection.enabled = a;
        if t {
            c.algorithm = fc_ahrs::Algorithm::Textbook;
        }
        if s {
            c.startup_s = 0.0;
        }
        c
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn f32_stays_unit(cfg in cfgs(), seq in prop::collection::vec(
        (prop::array::uniform3(any_f32()), prop::array::uniform3(any_f32()),
         prop::array::uniform3(any_f32()), prop_oneof![Just(0.001f32), Just(0.0035), Just(0.0), Just(f32::NAN), Just(5.0), -1.0f32..1.0]),
        1..40),
        init in (prop::array::uniform3(any_f32()), prop::array::uniform3(any_f32()))) {
        let mut f = Madgwick::from_accel_mag(cfg, init.0, init.1);
        for (g, a, m, dt) in seq {
            f.update_marg(g, a, m, dt);
            let q = f.quaternion();
            prop_assert!(q.is_finite());
            prop_assert!((1.0 - q.norm()).abs() < 1e-3);
            f.update_imu(g, a, dt);
            prop_assert!((1.0 - f.quaternion().norm()).abs() < 1e-3);
        }
        let e = f.euler_rad();
        prop_assert!(e.iter().all(|x| x.is_finite()));
        prop_assert!(f.gravity_body().iter().all(|x| x.is_finite()));
    }

    #[test]
    fn fixed_stays_unit(cfg in cfgs(), seq in prop::collection::vec(
        (prop::array::uniform3(any_i32()), prop::array::uniform3(any_i32()),
         prop::array::uniform3(any_i32()), prop_oneof![Just(2_147_484i32), Just(7_516_193), Just(0), Just(-5), any::<i32>()]),
        1..40),
        init in (prop::array::uniform3(any_i32()), prop::array::uniform3(any_i32()))) {
        let mut f = MadgwickFixed::from_accel_mag(
            FixedConfig::from_config(&Config { gravity_norm: 16384.0, ..cfg }), init.0, init.1);
        for (g, a, m, dt) in seq {
            f.update_marg(g, a, m, dt);
            let q = f.quaternion_f32();
            prop_assert!((1.0 - q.norm()).abs() < 1e-3, "{:?}", f.quaternion_q30());
            f.update_imu(g, a, dt);
            prop_assert!((1.0 - f.quaternion_f32().norm()).abs() < 1e-3);
            let _ = f.vertical_accel_up_mps2_q16(a);
            let _ = f.linear_accel_ned_mps2_q16(a);
        }
    }
}
