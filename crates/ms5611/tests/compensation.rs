//! Compensation against the datasheet worked example and an independent
//! i128 transcription of the datasheet formulas.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use ms5611::{compensate, compensate_detailed, Channel, Prom, RawOutOfRange, ADC_LIMIT};
use proptest::prelude::*;

/// Datasheet MS5611-01BA03 "typical values" coefficients C1..C6.
const DATASHEET_C: [u16; 6] = [40127, 36924, 23317, 23282, 33464, 28312];
const DATASHEET_D1: u32 = 9_085_466;
const DATASHEET_D2: u32 = 8_569_150;

/// Straight transcription of the datasheet flow chart in i128, where
/// "x / 2^n" is floor division (`div_euclid`). Returns
/// (dT, TEMP, OFF, SENS, T2, OFF2, SENS2, TEMP final, P).
#[allow(clippy::type_complexity)]
fn reference(
    c: [u16; 6],
    d1: u32,
    d2: u32,
) -> (i128, i128, i128, i128, i128, i128, i128, i128, i128) {
    let c: [i128; 6] = c.map(i128::from);
    let (d1, d2) = (i128::from(d1), i128::from(d2));
    let pow2 = |n: u32| 2i128.pow(n);
    let dt = d2 - c[4] * pow2(8);
    let temp = 2000 + (dt * c[5]).div_euclid(pow2(23));
    let off = c[1] * pow2(16) + (c[3] * dt).div_euclid(pow2(7));
    let sens = c[0] * pow2(15) + (c[2] * dt).div_euclid(pow2(8));
    let (mut t2, mut off2, mut sens2) = (0, 0, 0);
    if temp < 2000 {
        t2 = (dt * dt).div_euclid(pow2(31));
        off2 = (5 * (temp - 2000) * (temp - 2000)).div_euclid(2);
        sens2 = (5 * (temp - 2000) * (temp - 2000)).div_euclid(4);
        if temp < -1500 {
            off2 += 7 * (temp + 1500) * (temp + 1500);
            sens2 += (11 * (temp + 1500) * (temp + 1500)).div_euclid(2);
        }
    }
    let temp_final = temp - t2;
    let p = ((d1 * (sens - sens2)).div_euclid(pow2(21)) - (off - off2)).div_euclid(pow2(15));
    (dt, temp, off, sens, t2, off2, sens2, temp_final, p)
}

fn assert_matches_reference(c: [u16; 6], d1: u32, d2: u32) {
    let prom = Prom::from_coefficients(c);
    let got = compensate_detailed(&prom, d1, d2).unwrap();
    let (dt, temp, off, sens, t2, off2, sens2, temp_final, p) = reference(c, d1, d2);
    let ctx = format!("c={c:?} d1={d1} d2={d2}");
    assert_eq!(i128::from(got.dt), dt, "dT {ctx}");
    assert_eq!(i128::from(got.temp_centi_c), temp, "TEMP {ctx}");
    assert_eq!(i128::from(got.off), off, "OFF {ctx}");
    assert_eq!(i128::from(got.sens), sens, "SENS {ctx}");
    assert_eq!(i128::from(got.t2_centi_c), t2, "T2 {ctx}");
    assert_eq!(i128::from(got.off2), off2, "OFF2 {ctx}");
    assert_eq!(i128::from(got.sens2), sens2, "SENS2 {ctx}");
    assert_eq!(
        i128::from(got.temperature_centi_c),
        temp_final,
        "TEMP-T2 {ctx}"
    );
    assert_eq!(i128::from(got.pressure_pa), p, "P {ctx}");
    assert_eq!((got.d1, got.d2), (d1, d2));
    assert_eq!(compensate(&prom, d1, d2).unwrap(), got.measurement());
}

#[test]
fn datasheet_worked_example_to_the_digit() {
    let prom = Prom::from_coefficients(DATASHEET_C);
    let c = compensate_detailed(&prom, DATASHEET_D1, DATASHEET_D2).unwrap();
    assert_eq!(c.dt, 2366);
    assert_eq!(c.temp_centi_c, 2007);
    assert_eq!(c.off, 2_420_281_617);
    assert_eq!(c.sens, 1_315_097_036);
    // 20.07 °C is above 20 °C: no second-order correction.
    assert_eq!((c.t2_centi_c, c.off2, c.sens2), (0, 0, 0));
    assert_eq!(c.temperature_centi_c, 2007);
    assert_eq!(c.pressure_pa, 100_009);

    let m = c.measurement();
    assert_eq!(m.pressure_centi_mbar(), 100_009);
    assert!((m.pressure_mbar() - 1000.09).abs() < 1e-3);
    assert!((m.temperature_c() - 20.07).abs() < 1e-4);
    assert_matches_reference(DATASHEET_C, DATASHEET_D1, DATASHEET_D2);
}

/// D2 for a wanted first-order TEMP with the datasheet coefficients,
/// from TEMP = 2000 + dT·C6/2^23 solved for dT (rounded).
fn d2_for_temp_centi_c(temp: i64) -> u32 {
    let dt = ((temp - 2000) as f64 * 8_388_608.0 / f64::from(DATASHEET_C[5])).round() as i64;
    u32::try_from(i64::from(DATASHEET_C[4]) * 256 + dt).unwrap()
}

#[test]
fn second_order_below_20_c() {
    let d2 = d2_for_temp_centi_c(1000); // 10 °C
    let c = compensate_detailed(&Prom::from_coefficients(DATASHEET_C), DATASHEET_D1, d2).unwrap();
    assert!((999..=1001).contains(&c.temp_centi_c), "{}", c.temp_centi_c);
    // Independent values: T2 = dT²/2^31, OFF2 = 5·ΔT²/2, SENS2 = 5·ΔT²/4.
    let dt = i128::from(c.dt);
    let delta = i128::from(c.temp_centi_c) - 2000;
    assert_eq!(i128::from(c.t2_centi_c), (dt * dt) >> 31);
    assert_eq!(i128::from(c.off2), 5 * delta * delta / 2);
    assert_eq!(i128::from(c.sens2), 5 * delta * delta / 4);
    assert!(c.t2_centi_c > 0 && c.off2 > 0 && c.sens2 > 0);
    assert_eq!(c.temperature_centi_c, c.temp_centi_c - c.t2_centi_c);
    assert_matches_reference(DATASHEET_C, DATASHEET_D1, d2);
}

#[test]
fn second_order_below_minus_15_c() {
    for temp in [-1600, -2000, -4000] {
        let d2 = d2_for_temp_centi_c(temp);
        let c =
            compensate_detailed(&Prom::from_coefficients(DATASHEET_C), DATASHEET_D1, d2).unwrap();
        assert!((temp - 1..=temp + 1).contains(&i64::from(c.temp_centi_c)));
        let t = i128::from(c.temp_centi_c);
        let low = 5 * (t - 2000) * (t - 2000);
        let very_low = (t + 1500) * (t + 1500);
        assert_eq!(i128::from(c.off2), low / 2 + 7 * very_low, "OFF2 at {temp}");
        assert_eq!(
            i128::from(c.sens2),
            low / 4 + 11 * very_low / 2,
            "SENS2 at {temp}"
        );
        assert_matches_reference(DATASHEET_C, DATASHEET_D1, d2);
    }
}

#[test]
fn second_order_boundaries() {
    // Exactly 20.00 °C: no correction. One count colder: correction starts.
    let prom = Prom::from_coefficients(DATASHEET_C);
    let c5 = u32::from(DATASHEET_C[4]) * 256;
    let at = compensate_detailed(&prom, DATASHEET_D1, c5).unwrap();
    assert_eq!(at.temp_centi_c, 2000);
    assert_eq!((at.t2_centi_c, at.off2, at.sens2), (0, 0, 0));
    let below = compensate_detailed(&prom, DATASHEET_D1, c5 - 1).unwrap();
    assert_eq!(below.temp_centi_c, 1999); // floor(-28312 / 2^23) = -1
    assert_eq!((below.off2, below.sens2), (2, 1)); // 5/2, 5/4 floored
    assert_matches_reference(DATASHEET_C, DATASHEET_D1, c5 - 1);
}

#[test]
fn against_float_datasheet_formula() {
    // The float version of the first-order formulas agrees within rounding.
    let prom = Prom::from_coefficients(DATASHEET_C);
    for d2 in [8_000_000u32, 8_400_000, 8_569_150, 8_800_000, 9_000_000] {
        for d1 in [6_000_000u32, 8_000_000, 9_085_466, 10_000_000] {
            let c = compensate_detailed(&prom, d1, d2).unwrap();
            if c.temp_centi_c < 2000 {
                continue;
            }
            let [c1, c2, c3, c4, c5, c6] = DATASHEET_C.map(f64::from);
            let dt = f64::from(d2) - c5 * 256.0;
            let temp = 2000.0 + dt * c6 / 8_388_608.0;
            let off = c2 * 65_536.0 + c4 * dt / 128.0;
            let sens = c1 * 32_768.0 + c3 * dt / 256.0;
            let p = (f64::from(d1) * sens / 2_097_152.0 - off) / 32_768.0;
            assert!((f64::from(c.temp_centi_c) - temp).abs() <= 1.0);
            assert!(
                (f64::from(c.pressure_pa) - p).abs() <= 1.0,
                "{} vs {p}",
                c.pressure_pa
            );
        }
    }
}

#[test]
fn pressure_and_temperature_are_monotonic() {
    // Physical truth with real coefficients: more counts, more pressure and
    // more heat.
    let prom = Prom::from_coefficients(DATASHEET_C);
    let mut last = i32::MIN;
    for d1 in (4_000_000u32..12_000_000).step_by(250_000) {
        let p = compensate(&prom, d1, DATASHEET_D2).unwrap().pressure_pa;
        assert!(p > last);
        last = p;
    }
    let mut last = i32::MIN;
    for d2 in (6_000_000u32..10_000_000).step_by(100_000) {
        let t = compensate(&prom, DATASHEET_D1, d2)
            .unwrap()
            .temperature_centi_c;
        assert!(t > last);
        last = t;
    }
}

#[test]
fn extreme_corners_do_not_overflow() {
    // Every coefficient at 0 or 0xFFFF, D1/D2 at the ends of their range:
    // the maxima of every product (the test profile has overflow checks).
    let ds = [0u32, 1, 1 << 23, ADC_LIMIT - 1];
    for mask in 0u32..64 {
        let c: [u16; 6] = core::array::from_fn(|i| if mask & (1 << i) != 0 { 0xFFFF } else { 0 });
        for &d1 in &ds {
            for &d2 in &ds {
                assert_matches_reference(c, d1, d2);
            }
        }
    }
}

#[test]
fn rejects_values_above_24_bits() {
    let prom = Prom::from_coefficients(DATASHEET_C);
    assert_eq!(
        compensate(&prom, ADC_LIMIT, DATASHEET_D2),
        Err(RawOutOfRange {
            channel: Channel::Pressure,
            raw: ADC_LIMIT
        })
    );
    assert_eq!(
        compensate_detailed(&prom, DATASHEET_D1, 0x0100_0001),
        Err(RawOutOfRange {
            channel: Channel::Temperature,
            raw: 0x0100_0001
        })
    );
}

#[test]
fn overflow_checks_are_on_in_this_profile() {
    // The no-overflow tests above and below only mean something if
    // arithmetic overflow panics here.
    let overflowed = std::panic::catch_unwind(|| std::hint::black_box(i64::MAX) + 1).is_err();
    assert!(overflowed, "tests must run with overflow checks");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    /// Any PROM, any 24-bit inputs: no panic (overflow checks are on in the
    /// test profile) and every intermediate equals the i128 transcription.
    #[test]
    fn any_prom_any_raw_matches_reference(
        c in prop::array::uniform6(any::<u16>()),
        d1 in 0u32..ADC_LIMIT,
        d2 in 0u32..ADC_LIMIT,
    ) {
        assert_matches_reference(c, d1, d2);
    }

    /// Any u32 input: either a measurement or a typed range error.
    #[test]
    fn any_u32_never_panics(c in prop::array::uniform6(any::<u16>()), d1: u32, d2: u32) {
        let r = compensate(&Prom::from_coefficients(c), d1, d2);
        prop_assert_eq!(r.is_ok(), d1 < ADC_LIMIT && d2 < ADC_LIMIT);
    }
}
