//! Second-review tests: second-order compensation at 10 °C and −20 °C with
//! independently computed expectations, ADC 0 at every OSR, recovery after
//! faults through the public API.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, missing_docs)]

use core::num::NonZeroU16;

use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
use ms5611::*;

const C: [u16; 6] = [40127, 36924, 23317, 23282, 33464, 28312];
const NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data);

fn prom() -> Prom {
    Prom::from_coefficients(C)
}

fn be24(v: u32) -> Vec<u8> {
    v.to_be_bytes()[1..].to_vec()
}

fn conversion(addr: u8, cmd: u8, value: u32) -> Vec<T> {
    vec![
        T::write(addr, vec![cmd]),
        T::write(addr, vec![0x00]),
        T::read(addr, be24(value)),
    ]
}

fn prom_reads(addr: u8, words: &[u16; 8]) -> Vec<T> {
    let mut ex = Vec::new();
    for (i, w) in words.iter().enumerate() {
        ex.push(T::write(addr, vec![0xA0 + 2 * i as u8]));
        ex.push(T::read(addr, w.to_be_bytes().to_vec()));
    }
    ex
}

// Expected values below were computed by hand-transcribing the datasheet
// formulas into a separate Python script (exact big integers, each
// "/ 2^n" as floor division, which is the crate's documented rounding), with
// the datasheet's typical coefficients. D2 was chosen as C5·2^8 + dT for
// dT = floor((T − 2000)·2^23 / C6), T = 1000 and −2000.

/// 10 °C: first-order TEMP 999, T2 = dT²/2^31 = 40, OFF2 = 5·(−1001)²/2,
/// SENS2 = 5·(−1001)²/4; final 9.59 °C, 979.81 mbar.
#[test]
fn second_order_at_10_c_computed_independently() {
    let c = compensate_detailed(&prom(), 9_085_466, 8_270_492).unwrap();
    assert_eq!(c.dt, -296_292);
    assert_eq!(c.temp_centi_c, 999);
    assert_eq!(c.t2_centi_c, 40);
    assert_eq!(c.off2, 2_505_002);
    assert_eq!(c.sens2, 1_252_501);
    assert_eq!(c.temperature_centi_c, 959);
    assert_eq!(c.pressure_pa, 97_981);
    let m = compensate(&prom(), 8_000_000, 8_270_492).unwrap();
    assert_eq!((m.pressure_pa, m.temperature_centi_c), (77_657, 959));
    assert!((m.pressure_mbar() - 776.57).abs() < 1e-3);
    assert!((m.temperature_c() - 9.59).abs() < 1e-5);
    assert_eq!(m.pressure_centi_mbar(), 77_657);
}

/// −20 °C: both second-order terms, OFF2 = 5·(−4001)²/2 + 7·(−501)²,
/// SENS2 = 5·(−4001)²/4 + 11·(−501)²/2; final −26.55 °C.
#[test]
fn second_order_at_minus_20_c_computed_independently() {
    let c = compensate_detailed(&prom(), 9_085_466, 7_381_617).unwrap();
    assert_eq!(c.dt, -1_185_167);
    assert_eq!(c.temp_centi_c, -2001);
    assert_eq!(c.t2_centi_c, 654);
    // 5 · 4001² / 2 = 40_020_002 (floor of .5), 7 · 501² = 1_757_007
    assert_eq!(c.off2, 40_020_002 + 1_757_007);
    // 5 · 4001² / 4 = 20_010_001, 11 · 501² / 2 = 1_380_505
    assert_eq!(c.sens2, 20_010_001 + 1_380_505);
    assert_eq!(c.temperature_centi_c, -2655);
    assert_eq!(c.pressure_pa, 90_747);
    let m = compensate(&prom(), 8_000_000, 7_381_617).unwrap();
    assert_eq!((m.pressure_pa, m.temperature_centi_c), (72_021, -2655));
}

/// The blocking path gives the same numbers as the pure function.
#[test]
fn measure_at_minus_20_c() {
    let mut ex = conversion(0x76, 0x42, 9_085_466);
    ex.extend(conversion(0x76, 0x52, 7_381_617));
    let mut baro = Ms5611::with_prom(Mock::new(&ex), Address::CsbHigh, prom());
    let m = baro.measure(&mut NoopDelay::new(), Osr::Osr512).unwrap();
    assert_eq!((m.pressure_pa, m.temperature_centi_c), (90_747, -2655));
    baro.release().done();
}

/// An ADC read of 0 is an error at every OSR, for D1 and for D2, and the
/// next measurement works.
#[test]
fn adc_zero_at_every_osr_for_both_channels_then_recovery() {
    for osr in Osr::ALL {
        let d1 = 0x40 | osr.command_bits();
        let d2 = 0x50 | osr.command_bits();
        let mut ex = conversion(0x77, d1, 0);
        ex.extend(conversion(0x77, d1, 9_085_466));
        ex.extend(conversion(0x77, d2, 0));
        ex.extend(conversion(0x77, d1, 9_085_466));
        ex.extend(conversion(0x77, d2, 8_569_150));
        let mut baro = Ms5611::with_prom(Mock::new(&ex), Address::CsbLow, prom());
        let mut d = NoopDelay::new();
        assert_eq!(
            baro.measure(&mut d, osr),
            Err(Error::AdcNotReady),
            "{osr:?}"
        );
        assert_eq!(
            baro.measure(&mut d, osr),
            Err(Error::AdcNotReady),
            "{osr:?}"
        );
        let m = baro.measure(&mut d, osr).unwrap();
        assert_eq!((m.pressure_pa, m.temperature_centi_c), (100_009, 2007));
        baro.release().done();
    }
}

/// A NACK at any step of init (reset, each PROM command, each PROM read),
/// then a full init on the same driver works.
#[test]
fn nack_at_each_init_step_then_reinit_recovers() {
    let words = prom().words();
    let mut full = vec![T::write(0x77, vec![0x1E])];
    full.extend(prom_reads(0x77, &words));
    for k in 0..full.len() {
        let mut t: Vec<T> = full[..k].to_vec();
        t.push(full[k].clone().with_error(NACK));
        t.extend(full.iter().cloned());
        let mut baro = Ms5611::new(Mock::new(&t), Address::CsbLow);
        let mut d = NoopDelay::new();
        assert_eq!(baro.init(&mut d), Err(Error::Bus(NACK)), "step {k}");
        assert!(baro.prom().is_none());
        assert_eq!(
            baro.measure(&mut d, Osr::Osr256),
            Err(Error::NotInitialised)
        );
        assert_eq!(baro.init(&mut d), Ok(prom()), "step {k}");
        baro.release().done();
    }
}

/// A corrupted PROM word (one bit flipped on the bus) is a CRC error, the
/// next clean read is accepted.
#[test]
fn prom_bit_flip_then_clean_read() {
    let words = prom().words();
    let mut bad = words;
    bad[3] ^= 0x0100;
    let mut t = prom_reads(0x77, &bad);
    t.extend(prom_reads(0x77, &words));
    let mut baro = Ms5611::new(Mock::new(&t), Address::CsbLow);
    assert!(matches!(baro.read_prom(), Err(Error::PromCrc { .. })));
    assert!(baro.prom().is_none());
    assert_eq!(baro.read_prom(), Ok(prom()));
    baro.release().done();
}

/// A PROM whose CRC and blank checks pass only by accident of the check
/// order: all-zero except a valid CRC nibble of 0 is still blank; one
/// non-zero word makes it non-blank and the CRC decides.
#[test]
fn blank_detection_edges() {
    assert_eq!(Prom::from_words(&[0; 8]), Err(PromError::Blank));
    assert_eq!(Prom::from_words(&[0xFFFF; 8]), Err(PromError::Blank));
    let mut w = [0xFFFF; 8];
    w[0] = 0xFFFE;
    assert!(matches!(Prom::from_words(&w), Err(PromError::Crc { .. })));
    let sealed = with_valid_crc(&w);
    assert!(Prom::from_words(&sealed).is_ok());
}

/// The sampler after a NACK in the middle of a run: the error is returned,
/// nothing is read early, and the schedule resumes with a temperature
/// conversion followed by pressures.
#[test]
fn sampler_recovers_after_adc_read_nack() {
    let config = SamplerConfig::new()
        .with_pressure_osr(Osr::Osr256)
        .with_temperature_osr(Osr::Osr256)
        .with_pressures_per_temperature(NonZeroU16::new(2).unwrap())
        .with_guard_us(0);
    let a = 0x77;
    let t = vec![
        T::write(a, vec![0x50]), // D2 at t = 0
        T::write(a, vec![0x00]), // read at 600
        T::read(a, be24(8_569_150)),
        T::write(a, vec![0x40]),                  // D1
        T::write(a, vec![0x00]).with_error(NACK), // read at 1200: NACK
        T::write(a, vec![0x40]),                  // after recovery (600): D1 again
        T::write(a, vec![0x00]),
        T::read(a, be24(9_085_466)),
        T::write(a, vec![0x40]),
    ];
    let mut baro = Ms5611::with_prom(Mock::new(&t), Address::CsbLow, prom());
    let mut s = Sampler::new(config);
    assert_eq!(s.poll(&mut baro, 0), Ok(None));
    assert_eq!(s.poll(&mut baro, 599), Ok(None)); // not before 600 µs
    assert_eq!(s.poll(&mut baro, 600), Ok(None));
    assert_eq!(s.poll(&mut baro, 1200), Err(Error::Bus(NACK)));
    assert_eq!(s.error_count(), 1);
    assert_eq!(s.converting(), None);
    assert_eq!(s.poll(&mut baro, 1799), Ok(None)); // recovery wait
    assert_eq!(s.poll(&mut baro, 1800), Ok(None)); // D1 restarted
    let m = s.poll(&mut baro, 2400).unwrap().unwrap();
    assert_eq!((m.pressure_pa, m.temperature_centi_c), (100_009, 2007));
    baro.release().done();
}

/// Every OSR's conversion time is the datasheet maximum and the blocking
/// conversion never reads before it.
#[test]
fn conversion_times_and_commands_per_osr() {
    let expected = [
        (Osr::Osr256, 0x40, 600),
        (Osr::Osr512, 0x42, 1170),
        (Osr::Osr1024, 0x44, 2280),
        (Osr::Osr2048, 0x46, 4540),
        (Osr::Osr4096, 0x48, 9040),
    ];
    for (osr, cmd, us) in expected {
        assert_eq!(Channel::Pressure.convert_command(osr), cmd);
        assert_eq!(Channel::Temperature.convert_command(osr), cmd | 0x10);
        assert_eq!(osr.conversion_time_us(), us);
    }
    assert_eq!(RESET_TIME_US, 2800);
}
