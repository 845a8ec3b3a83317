//! The non-blocking schedule: exact transactions against embedded-hal-mock,
//! and randomised timing against a small timing-checking chip model.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::cell::{Cell, RefCell};
use std::num::NonZeroU16;
use std::rc::Rc;

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};
use embedded_hal_mock::eh1::i2c::{Mock, Transaction as T};
use ms5611::{
    compensate, Action, Address, Channel, Error, Measurement, Ms5611, Osr, Prom, SampleError,
    Sampler, SamplerConfig,
};
use proptest::prelude::*;

const DATASHEET_C: [u16; 6] = [40127, 36924, 23317, 23282, 33464, 28312];
const D1: u32 = 9_085_466;
const D2: u32 = 8_569_150;
const A: u8 = 0x77;

fn prom() -> Prom {
    Prom::from_coefficients(DATASHEET_C)
}

fn nack() -> ErrorKind {
    ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data)
}

fn n(v: u16) -> NonZeroU16 {
    NonZeroU16::new(v).unwrap()
}

fn start(cmd: u8) -> T {
    T::write(A, vec![cmd])
}

fn read(value: u32) -> [T; 2] {
    [
        T::write(A, vec![0x00]),
        T::read(A, value.to_be_bytes()[1..].to_vec()),
    ]
}

/// The driver with the datasheet PROM, on a bus expecting `ex`.
fn baro_on(ex: &[T]) -> Ms5611<Mock> {
    Ms5611::with_prom(Mock::new(ex), Address::CsbLow, prom())
}

/// A good D2 read, the pressure conversion it starts, a good D1 read and the
/// next pressure conversion (0x48: D1 at OSR 4096).
fn d2_then_d1() -> Vec<T> {
    let mut ex = read(D2).to_vec();
    ex.push(start(0x48));
    ex.extend(read(D1));
    ex.push(start(0x48));
    ex
}

fn expected(d1: u32, d2: u32) -> Measurement {
    compensate(&prom(), d1, d2).unwrap()
}

/// T-OSR 256 (600 µs), P-OSR 4096 (9040 µs), guard 100 µs.
fn config(n_per_t: u16) -> SamplerConfig {
    SamplerConfig::new()
        .with_temperature_osr(Osr::Osr256)
        .with_pressure_osr(Osr::Osr4096)
        .with_pressures_per_temperature(n(n_per_t))
        .with_guard_us(100)
}

const T_WAIT: u32 = 700;
const P_WAIT: u32 = 9140;

#[test]
fn d2_then_n_d1_never_early_exact_deadlines() {
    // N = 3: D2, D1, D1, D1, D2, D1.
    let mut ex = vec![start(0x50)];
    ex.extend(read(D2));
    ex.push(start(0x48));
    for k in 0..3 {
        ex.extend(read(D1 + k));
        ex.push(start(if k == 2 { 0x50 } else { 0x48 }));
    }
    ex.extend(read(D2 + 1000));
    ex.push(start(0x48));
    ex.extend(read(D1 + 10));
    ex.push(start(0x48));

    let mut baro = baro_on(&ex);
    let mut s = Sampler::new(config(3));
    assert_eq!(s.next_deadline_us(), None);
    assert_eq!(s.next_channel(), Channel::Temperature);

    let mut t = 1_000u32;
    assert_eq!(s.poll(&mut baro, t).unwrap(), None); // starts D2
    assert_eq!(s.converting(), Some(Channel::Temperature));
    assert_eq!(s.next_deadline_us(), Some(t + T_WAIT));
    // Many polls before the deadline: no bus traffic at all (the mock
    // would panic on an unexpected transaction).
    for dt in [0, 1, 350, T_WAIT - 1] {
        assert_eq!(s.poll(&mut baro, t + dt).unwrap(), None);
    }
    t += T_WAIT;
    assert_eq!(s.poll(&mut baro, t).unwrap(), None); // D2 read, D1 started
    assert_eq!(s.last_d2(), Some(D2));
    assert_eq!(s.next_deadline_us(), Some(t + P_WAIT));

    let mut got = Vec::new();
    for _ in 0..3 {
        assert_eq!(s.poll(&mut baro, t + P_WAIT - 1).unwrap(), None);
        t += P_WAIT;
        got.push(s.poll(&mut baro, t).unwrap().unwrap());
    }
    assert_eq!(
        got,
        (0..3).map(|k| expected(D1 + k, D2)).collect::<Vec<_>>()
    );
    assert_eq!(got[0].pressure_pa, 100_009);
    // Third D1 read started the D2 refresh.
    assert_eq!(s.converting(), Some(Channel::Temperature));
    t += T_WAIT;
    assert_eq!(s.poll(&mut baro, t).unwrap(), None);
    t += P_WAIT + 5_000; // a late poll is fine
    assert_eq!(
        s.poll(&mut baro, t).unwrap(),
        Some(expected(D1 + 10, D2 + 1000))
    );
    assert_eq!(s.error_count(), 0);
    baro.release().done();
}

#[test]
fn timestamps_wrap_around() {
    let mut ex = vec![start(0x50)];
    ex.extend(d2_then_d1());
    let mut baro = baro_on(&ex);
    let mut s = Sampler::new(config(10));

    let t0 = u32::MAX - 500;
    s.poll(&mut baro, t0).unwrap();
    let deadline = t0.wrapping_add(T_WAIT);
    assert_eq!(deadline, 199);
    assert_eq!(s.next_deadline_us(), Some(199));
    for t in [u32::MAX - 1, u32::MAX, 0, 198] {
        assert_eq!(s.poll(&mut baro, t).unwrap(), None);
        assert_eq!(s.converting(), Some(Channel::Temperature));
    }
    s.poll(&mut baro, 199).unwrap();
    assert_eq!(s.converting(), Some(Channel::Pressure));
    assert_eq!(
        s.poll(&mut baro, 199 + P_WAIT).unwrap(),
        Some(expected(D1, D2))
    );
    baro.release().done();
}

#[test]
fn clock_stepping_backwards_never_reads_early() {
    let ex = [start(0x50)];
    let mut baro = baro_on(&ex);
    let mut s = Sampler::new(config(10));
    s.poll(&mut baro, 5_000).unwrap();
    for t in [4_999, 0, 1_000, 5_000 + T_WAIT - 1] {
        assert_eq!(s.poll(&mut baro, t).unwrap(), None);
        assert!(matches!(s.next_action(t), Action::Wait { until_us: 5_700 }));
    }
    baro.release().done();
}

#[test]
fn not_initialised_without_prom_and_no_traffic() {
    let mut baro = Ms5611::new(Mock::new(&[]), Address::CsbLow);
    let mut s = Sampler::new(SamplerConfig::default());
    assert_eq!(s.poll(&mut baro, 0), Err(Error::NotInitialised));
    assert_eq!(s.next_deadline_us(), None);
    baro.release().done();
}

#[test]
fn nack_on_start_recovers_after_longest_conversion() {
    let recovery = 9040 + 100;
    let ex = [start(0x50).with_error(nack()), start(0x50)];
    let mut baro = baro_on(&ex);
    let mut s = Sampler::new(config(10));
    assert_eq!(s.config().recovery_us(), recovery);
    assert_eq!(s.poll(&mut baro, 100), Err(Error::Bus(nack())));
    assert_eq!(s.error_count(), 1);
    assert_eq!(s.converting(), None);
    assert_eq!(s.next_deadline_us(), Some(100 + recovery));
    assert_eq!(s.poll(&mut baro, 100 + recovery - 1).unwrap(), None);
    assert_eq!(s.poll(&mut baro, 100 + recovery).unwrap(), None);
    assert_eq!(s.converting(), Some(Channel::Temperature));
    baro.release().done();
}

#[test]
fn adc_errors_recover_and_redo_the_same_channel() {
    let recovery = 9040 + 100;
    let mut ex = vec![start(0x50)];
    // 1) ADC command NACKed.
    ex.push(T::write(A, vec![0x00]).with_error(nack()));
    ex.push(start(0x50));
    // 2) ADC data NACKed.
    ex.push(T::write(A, vec![0x00]));
    ex.push(T::read(A, vec![0, 0, 0]).with_error(nack()));
    ex.push(start(0x50));
    // 3) ADC reads 0 (conversion lost).
    ex.extend(read(0));
    ex.push(start(0x50));
    // Finally a good D2 and a D1.
    ex.extend(d2_then_d1());

    let mut baro = baro_on(&ex);
    let mut s = Sampler::new(config(10));
    let mut t = 0u32;
    s.poll(&mut baro, t).unwrap();
    let expected_errors = [Error::Bus(nack()), Error::Bus(nack()), Error::AdcNotReady];
    for (i, e) in expected_errors.into_iter().enumerate() {
        t += T_WAIT;
        assert_eq!(s.poll(&mut baro, t), Err(e));
        assert_eq!(s.error_count(), i as u32 + 1);
        assert_eq!(s.next_deadline_us(), Some(t + recovery));
        assert_eq!(s.poll(&mut baro, t + recovery - 1).unwrap(), None);
        t += recovery;
        assert_eq!(s.poll(&mut baro, t).unwrap(), None); // restarted D2
        assert_eq!(s.converting(), Some(Channel::Temperature));
    }
    t += T_WAIT;
    assert_eq!(s.poll(&mut baro, t).unwrap(), None);
    t += P_WAIT;
    assert_eq!(s.poll(&mut baro, t).unwrap(), Some(expected(D1, D2)));
    baro.release().done();
}

#[test]
fn failed_start_after_a_pressure_read_keeps_the_measurement() {
    let recovery = 9040 + 100;
    let mut ex = vec![start(0x50)];
    ex.extend(read(D2));
    ex.push(start(0x48));
    ex.extend(read(D1));
    ex.push(start(0x48).with_error(nack()));
    ex.push(start(0x48)); // retried after the recovery wait
    let mut baro = baro_on(&ex);
    let mut s = Sampler::new(config(10));
    s.poll(&mut baro, 0).unwrap();
    s.poll(&mut baro, T_WAIT).unwrap();
    let t = T_WAIT + P_WAIT;
    assert_eq!(s.poll(&mut baro, t).unwrap(), Some(expected(D1, D2)));
    assert_eq!(s.error_count(), 1);
    assert_eq!(s.next_deadline_us(), Some(t + recovery));
    assert_eq!(s.poll(&mut baro, t + recovery).unwrap(), None);
    assert_eq!(s.converting(), Some(Channel::Pressure));
    baro.release().done();
}

#[test]
fn failed_start_after_a_temperature_read_is_returned() {
    let mut ex = vec![start(0x50)];
    ex.extend(read(D2));
    ex.push(start(0x48).with_error(nack()));
    let mut baro = baro_on(&ex);
    let mut s = Sampler::new(config(10));
    s.poll(&mut baro, 0).unwrap();
    assert_eq!(s.poll(&mut baro, T_WAIT), Err(Error::Bus(nack())));
    // The temperature is kept: the next start is a D1.
    assert_eq!(s.last_d2(), Some(D2));
    assert_eq!(s.next_channel(), Channel::Pressure);
    baro.release().done();
}

#[test]
fn pure_state_machine_api() {
    let p = prom();
    let mut s = Sampler::new(config(1));
    assert_eq!(
        s.on_adc_read(&p, D2, 0),
        Err(SampleError::NoConversionInFlight)
    );
    assert_eq!(s.error_count(), 0);
    assert_eq!(
        s.next_action(0),
        Action::Start {
            channel: Channel::Temperature,
            osr: Osr::Osr256
        }
    );
    s.on_conversion_started(Channel::Temperature, 0);
    assert_eq!(s.next_action(10), Action::Wait { until_us: T_WAIT });
    assert_eq!(
        s.next_action(T_WAIT),
        Action::Read {
            channel: Channel::Temperature
        }
    );
    // A 25-bit value from a broken transport is rejected.
    assert!(matches!(
        s.on_adc_read(&p, 1 << 24, T_WAIT),
        Err(SampleError::RawOutOfRange(_))
    ));
    assert_eq!(s.error_count(), 1);
    s.restart();
    s.on_conversion_started(Channel::Temperature, 0);
    assert_eq!(s.on_adc_read(&p, D2, T_WAIT), Ok(None));
    assert_eq!(
        s.next_action(T_WAIT),
        Action::Start {
            channel: Channel::Pressure,
            osr: Osr::Osr4096
        }
    );
    s.on_conversion_started(Channel::Pressure, T_WAIT);
    assert_eq!(
        s.on_adc_read(&p, D1, T_WAIT + P_WAIT),
        Ok(Some(expected(D1, D2)))
    );
    // N = 1: temperature every other conversion.
    assert_eq!(s.next_channel(), Channel::Temperature);
    // A D1 without any temperature (after restart) yields nothing.
    s.restart();
    s.on_conversion_started(Channel::Pressure, 0);
    assert_eq!(s.on_adc_read(&p, D1, P_WAIT), Ok(None));
    // After a chip reset the first conversion waits the PROM reload time.
    s.restart_after_reset(u32::MAX - 100);
    assert_eq!(s.last_d2(), None);
    assert_eq!(s.next_deadline_us(), Some(2_699));
    assert_eq!(s.next_action(2_698), Action::Wait { until_us: 2_699 });
    assert_eq!(
        s.next_action(2_699),
        Action::Start {
            channel: Channel::Temperature,
            osr: Osr::Osr256
        }
    );
    // Errors convert into the driver error.
    let e: Error<ErrorKind> = SampleError::NoConversionInFlight.into();
    assert_eq!(e, Error::NoConversionInFlight);
}

// ---- randomised timing against a chip model ----

#[derive(Default)]
struct ChipState {
    /// Conversion in flight: (channel, command time, end time), absolute µs.
    conversion: Option<(Channel, u64, u64)>,
    /// Finished, unread result.
    result: Option<(Channel, u32)>,
    pending_read: Option<u32>,
    d1_next: u32,
    d2_next: u32,
    /// (channel, value) of every successful ADC read.
    reads: Vec<(Channel, u32)>,
    violations: Vec<String>,
    /// Fault injection: NACK the transfer with this index.
    fail_mask: u64,
    transfers: u32,
}

/// MS5611 timing model: a conversion takes exactly the datasheet maximum; a
/// command during a conversion or an early ADC read is a violation.
#[derive(Clone)]
struct Chip {
    now: Rc<Cell<u64>>,
    state: Rc<RefCell<ChipState>>,
}

impl ErrorType for Chip {
    type Error = ErrorKind;
}

fn osr_from_bits(bits: u8) -> Osr {
    Osr::ALL
        .into_iter()
        .find(|o| o.command_bits() == bits)
        .unwrap()
}

/// The conversion a CONVERT command (0x40 | D2 0x10 | OSR bits) starts at `now`:
/// (channel, start, end), µs.
fn conversion_for(cmd: u8, now: u64) -> (Channel, u64, u64) {
    let ch = if cmd & 0x10 == 0 {
        Channel::Pressure
    } else {
        Channel::Temperature
    };
    let end = now + u64::from(osr_from_bits(cmd & 0x0F).conversion_time_us());
    (ch, now, end)
}

impl ChipState {
    /// Finish a conversion whose time has come.
    fn finish_due_conversion(&mut self, now: u64) {
        if let Some((ch, _, end)) = self.conversion {
            if now >= end {
                self.conversion = None;
                let v = match ch {
                    Channel::Pressure => self.d1_next,
                    Channel::Temperature => self.d2_next,
                };
                self.result = Some((ch, v));
            }
        }
    }

    fn command(&mut self, cmd: u8, now: u64, fail: bool) -> Result<(), ErrorKind> {
        if let Some((ch, started, _)) = self.conversion {
            self.violations.push(format!(
                "cmd {cmd:#x} at {now} during {ch:?} from {started}"
            ));
        }
        if fail {
            // Worst case: the chip took the command anyway.
            if cmd & 0xE0 == 0x40 {
                self.conversion = Some(conversion_for(cmd, now));
            }
            return Err(nack());
        }
        match cmd {
            0x00 => self.pending_read = Some(self.result.take().map_or(0, |(_, v)| v)),
            c if c & 0xE0 == 0x40 => {
                self.conversion = Some(conversion_for(c, now));
                self.result = None;
            }
            other => panic!("unexpected command {other:#x}"),
        }
        Ok(())
    }

    fn adc_read(&mut self, buf: &mut [u8], now: u64, fail: bool) -> Result<(), ErrorKind> {
        let v = self.pending_read.take().expect("read without ADC command");
        if fail {
            return Err(nack());
        }
        if v == 0 {
            self.violations.push(format!("ADC read of 0 at {now}"));
        }
        buf.copy_from_slice(&v.to_be_bytes()[1..]);
        if v != 0 {
            let ch = if v == self.d1_next {
                Channel::Pressure
            } else {
                Channel::Temperature
            };
            self.reads.push((ch, v));
            match ch {
                Channel::Pressure => self.d1_next += 3,
                Channel::Temperature => self.d2_next += 5,
            }
        }
        Ok(())
    }
}

impl I2c for Chip {
    fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
        assert_eq!(address, A);
        let now = self.now.get();
        let mut st = self.state.borrow_mut();
        let index = st.transfers;
        st.transfers += 1;
        let fail = index < 64 && st.fail_mask & (1 << index) != 0;
        st.finish_due_conversion(now);
        for op in ops.iter_mut() {
            match op {
                Operation::Write(bytes) => st.command(bytes[0], now, fail)?,
                Operation::Read(buf) => st.adc_read(buf, now, fail)?,
            }
        }
        Ok(())
    }
}

fn osr_strategy() -> impl Strategy<Value = Osr> {
    prop::sample::select(Osr::ALL.to_vec())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random configs, start times (around the u32 wrap too) and poll
    /// intervals: no early read, no command during a conversion, D2 exactly
    /// every N+1 conversions, every measurement is the compensation of the
    /// chip's latest D1 and D2, and the schedule keeps up.
    #[test]
    fn random_polling_respects_chip_timing(
        p_osr in osr_strategy(),
        t_osr in osr_strategy(),
        n_per_t in 1u16..6,
        guard in 0u32..300,
        start in prop_oneof![any::<u32>(), (u32::MAX - 100_000)..=u32::MAX],
        gaps in prop::collection::vec(1u32..3_000, 300),
        fail_mask in prop_oneof![Just(0u64), any::<u64>()],
    ) {
        let cfg = SamplerConfig::new()
            .with_pressure_osr(p_osr)
            .with_temperature_osr(t_osr)
            .with_pressures_per_temperature(n(n_per_t))
            .with_guard_us(guard);
        let now = Rc::new(Cell::new(u64::from(start)));
        let state = Rc::new(RefCell::new(ChipState {
            d1_next: D1,
            d2_next: D2 - 50_000,
            fail_mask,
            ..ChipState::default()
        }));
        let chip = Chip { now: now.clone(), state: state.clone() };
        let mut baro = Ms5611::with_prom(chip, Address::CsbLow, prom());
        let mut s = Sampler::new(cfg);
        let mut measurements = 0usize;
        let mut errors = 0u32;
        for gap in &gaps {
            let t = now.get() as u32; // the wrapping µs clock
            match s.poll(&mut baro, t) {
                Ok(Some(m)) => {
                    measurements += 1;
                    let st = state.borrow();
                    let last_d1 = st.reads.iter().rev().find(|r| r.0 == Channel::Pressure).unwrap().1;
                    let last_d2 = st.reads.iter().rev().find(|r| r.0 == Channel::Temperature).unwrap().1;
                    prop_assert_eq!(m, compensate(&prom(), last_d1, last_d2).unwrap());
                }
                Ok(None) => {}
                Err(_) => errors += 1,
            }
            now.set(now.get() + u64::from(*gap));
        }
        let st = state.borrow();
        prop_assert!(st.violations.is_empty(), "{:?}", st.violations);
        prop_assert!(errors <= s.error_count());
        if fail_mask == 0 {
            prop_assert_eq!(s.error_count(), 0);
            // Sequence: D2, then N x D1, repeating.
            for (i, (ch, _)) in st.reads.iter().enumerate() {
                let want = if i % (usize::from(n_per_t) + 1) == 0 {
                    Channel::Temperature
                } else {
                    Channel::Pressure
                };
                prop_assert_eq!(*ch, want, "read {}", i);
            }
            // Liveness: each conversion costs at most wait + one poll gap.
            let total: u64 = gaps.iter().map(|&g| u64::from(g)).sum();
            let worst = u64::from(p_osr.conversion_time_us().max(t_osr.conversion_time_us()) + guard + 3_000);
            prop_assert!(st.reads.len() as u64 + 2 >= total / worst,
                "{} reads in {} us", st.reads.len(), total);
            prop_assert_eq!(measurements, st.reads.iter().filter(|r| r.0 == Channel::Pressure).count());
        }
    }
}
