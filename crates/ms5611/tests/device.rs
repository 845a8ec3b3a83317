//! Bus-level tests of the driver against embedded-hal-mock transactions.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;
use common::{conversion, prom_reads};
use embedded_hal::i2c::{ErrorKind, NoAcknowledgeSource};
use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as D};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
use ms5611::{command, compensate, Address, Channel, Error, Ms5611, Osr, Prom};

const DATASHEET_C: [u16; 6] = [40127, 36924, 23317, 23282, 33464, 28312];
const D1: u32 = 9_085_466;
const D2: u32 = 8_569_150;

fn nack() -> ErrorKind {
    ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data)
}

fn datasheet_prom() -> Prom {
    Prom::from_coefficients(DATASHEET_C)
}

#[test]
fn init_resets_waits_2_8_ms_and_reads_prom_at_both_addresses() {
    for (address, addr) in [(Address::CsbHigh, 0x76), (Address::CsbLow, 0x77)] {
        let words = datasheet_prom().words();
        let mut ex = vec![T::write(addr, vec![0x1E])];
        ex.extend(prom_reads(addr, &words));
        let mut delay = CheckedDelay::new(&[D::delay_us(2800)]);
        let mut baro = Ms5611::new(Mock::new(&ex), address);
        assert_eq!(baro.address(), address);
        assert!(baro.prom().is_none());
        let prom = baro.init(&mut delay).unwrap();
        assert_eq!(prom.words(), words);
        assert_eq!(baro.prom(), Some(&prom));
        delay.done();
        baro.release().done();
    }
    assert_eq!(command::RESET_TIME_US, 2800);
}

#[test]
fn non_blocking_reset_then_prom() {
    let words = datasheet_prom().words();
    let mut ex = vec![T::write(0x77, vec![0x1E])];
    ex.extend(prom_reads(0x77, &words));
    let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
    baro.reset().unwrap();
    // ... the caller schedules RESET_TIME_US ...
    assert_eq!(baro.read_prom_words().unwrap(), words);
    baro.release().done();
}

#[test]
fn convert_each_osr_waits_its_conversion_time() {
    let expected = [
        (Osr::Osr256, 0x40, 0x50, 600),
        (Osr::Osr512, 0x42, 0x52, 1170),
        (Osr::Osr1024, 0x44, 0x54, 2280),
        (Osr::Osr2048, 0x46, 0x56, 4540),
        (Osr::Osr4096, 0x48, 0x58, 9040),
    ];
    for (osr, d1_cmd, d2_cmd, time_us) in expected {
        let mut ex = conversion(0x77, d1_cmd, 0x12_3456);
        ex.extend(conversion(0x77, d2_cmd, 0xFF_FFFF));
        let mut delay = CheckedDelay::new(&[D::delay_us(time_us), D::delay_us(time_us)]);
        let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
        assert_eq!(
            baro.convert(&mut delay, Channel::Pressure, osr).unwrap(),
            0x12_3456
        );
        assert_eq!(
            baro.convert(&mut delay, Channel::Temperature, osr).unwrap(),
            0xFF_FFFF
        );
        delay.done();
        baro.release().done();
    }
}

#[test]
fn non_blocking_conversion_and_adc_read_big_endian() {
    let ex = [
        T::write(0x76, vec![0x46]),
        T::write(0x76, vec![0x00]),
        T::read(0x76, vec![0x01, 0x02, 0x03]),
        T::write(0x76, vec![0x52]),
        T::write(0x76, vec![0x00]),
        T::read(0x76, vec![0x00, 0x00, 0x01]),
    ];
    let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbHigh);
    baro.start_conversion(Channel::Pressure, Osr::Osr2048)
        .unwrap();
    assert_eq!(baro.read_adc().unwrap(), 0x01_0203);
    baro.start_conversion(Channel::Temperature, Osr::Osr512)
        .unwrap();
    assert_eq!(baro.read_adc().unwrap(), 1);
    baro.release().done();
}

#[test]
fn measure_datasheet_example_at_every_osr() {
    for osr in Osr::ALL {
        let mut ex = conversion(0x77, 0x40 | osr.command_bits(), D1);
        ex.extend(conversion(0x77, 0x50 | osr.command_bits(), D2));
        let t = osr.conversion_time_us();
        let mut delay = CheckedDelay::new(&[D::delay_us(t), D::delay_us(t)]);
        let mut baro = Ms5611::with_prom(Mock::new(&ex), Address::CsbLow, datasheet_prom());
        let m = baro.measure(&mut delay, osr).unwrap();
        assert_eq!((m.pressure_pa, m.temperature_centi_c), (100_009, 2007));
        assert_eq!(m, compensate(&datasheet_prom(), D1, D2).unwrap());
        delay.done();
        baro.release().done();
    }
}

#[test]
fn full_blocking_sequence_from_power_up() {
    let words = datasheet_prom().words();
    let mut ex = vec![T::write(0x77, vec![0x1E])];
    ex.extend(prom_reads(0x77, &words));
    ex.extend(conversion(0x77, 0x48, D1));
    ex.extend(conversion(0x77, 0x58, D2));
    let mut baro = Ms5611::new(Mock::new(&ex), Address::default());
    baro.init(&mut NoopDelay::new()).unwrap();
    let m = baro.measure(&mut NoopDelay::new(), Osr::default()).unwrap();
    assert_eq!(m.pressure_pa, 100_009);
    baro.release().done();
}

// ---- error paths ----

#[test]
fn nack_on_reset_is_a_bus_error_and_skips_the_wait() {
    let ex = [T::write(0x77, vec![0x1E]).with_error(nack())];
    let mut delay = CheckedDelay::new(&[]);
    let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
    assert_eq!(baro.init(&mut delay), Err(Error::Bus(nack())));
    assert!(baro.prom().is_none());
    delay.done();
    baro.release().done();
}

#[test]
fn nack_on_any_prom_word_command_or_data() {
    let words = datasheet_prom().words();
    for bad in 0..8 {
        for on_read in [false, true] {
            let mut ex = prom_reads(0x77, &words);
            let idx = 2 * bad + usize::from(on_read);
            ex[idx] = ex[idx].clone().with_error(nack());
            ex.truncate(idx + 1);
            let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
            assert_eq!(baro.read_prom(), Err(Error::Bus(nack())), "word {bad}");
            assert!(baro.prom().is_none());
            baro.release().done();
        }
    }
}

#[test]
fn bad_crc_reports_both_values_and_keeps_old_prom() {
    let good = datasheet_prom();
    let mut words = good.words();
    words[3] ^= 0x0100; // C3 corrupted
    let computed = ms5611::crc4(&words);
    let ex = prom_reads(0x77, &words);
    let mut baro = Ms5611::with_prom(Mock::new(&ex), Address::CsbLow, good);
    assert_eq!(
        baro.read_prom(),
        Err(Error::PromCrc {
            expected: good.crc(),
            computed
        })
    );
    assert_ne!(computed, good.crc());
    // The previously validated PROM is not lost.
    assert_eq!(baro.prom(), Some(&good));
    baro.release().done();
}

#[test]
fn blank_prom_all_zero_or_all_ones() {
    for fill in [0x0000u16, 0xFFFF] {
        let ex = prom_reads(0x77, &[fill; 8]);
        let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
        assert_eq!(baro.read_prom(), Err(Error::PromBlank));
        assert!(baro.prom().is_none());
        baro.release().done();
    }
}

#[test]
fn adc_read_of_zero_is_not_a_reading() {
    let ex = [T::write(0x77, vec![0x00]), T::read(0x77, vec![0, 0, 0])];
    let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
    assert_eq!(baro.read_adc(), Err(Error::AdcNotReady));
    baro.release().done();

    // In a blocking measurement too (here the D2 read).
    let mut ex = conversion(0x77, 0x48, D1);
    ex.extend(conversion(0x77, 0x58, 0));
    let mut baro = Ms5611::with_prom(Mock::new(&ex), Address::CsbLow, datasheet_prom());
    assert_eq!(
        baro.measure(&mut NoopDelay::new(), Osr::Osr4096),
        Err(Error::AdcNotReady)
    );
    baro.release().done();
}

#[test]
fn nack_on_conversion_adc_command_and_adc_data() {
    // Conversion command NACKed: nothing else is sent.
    let ex = [T::write(0x77, vec![0x44]).with_error(nack())];
    let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
    let mut delay = CheckedDelay::new(&[]);
    assert_eq!(
        baro.convert(&mut delay, Channel::Pressure, Osr::Osr1024),
        Err(Error::Bus(nack()))
    );
    delay.done();
    baro.release().done();

    let ex = [T::write(0x77, vec![0x00]).with_error(nack())];
    let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
    assert_eq!(baro.read_adc(), Err(Error::Bus(nack())));
    baro.release().done();

    let ex = [
        T::write(0x77, vec![0x00]),
        T::read(0x77, vec![1, 2, 3]).with_error(ErrorKind::ArbitrationLoss),
    ];
    let mut baro = Ms5611::new(Mock::new(&ex), Address::CsbLow);
    assert_eq!(baro.read_adc(), Err(Error::Bus(ErrorKind::ArbitrationLoss)));
    baro.release().done();
}

#[test]
fn measure_without_prom_touches_nothing() {
    let mut baro = Ms5611::new(Mock::new(&[]), Address::CsbLow);
    let mut delay = CheckedDelay::new(&[]);
    assert_eq!(
        baro.measure(&mut delay, Osr::Osr256),
        Err(Error::NotInitialised)
    );
    delay.done();
    baro.release().done();
}

#[test]
fn error_display_names_the_failure() {
    let cases: [(Error<ErrorKind>, &str); 7] = [
        (Error::Bus(nack()), "bus"),
        (
            Error::PromCrc {
                expected: 1,
                computed: 2,
            },
            "CRC",
        ),
        (Error::PromBlank, "blank"),
        (Error::AdcNotReady, "returned 0"),
        (
            Error::RawOutOfRange {
                channel: Channel::Pressure,
                raw: 1 << 24,
            },
            "D1",
        ),
        (Error::NotInitialised, "init"),
        (Error::NoConversionInFlight, "no conversion"),
    ];
    for (e, needle) in cases {
        let s = e.to_string();
        assert!(s.contains(needle), "{s:?} lacks {needle:?}");
    }
}
