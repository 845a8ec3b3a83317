//! The ADC1 model against RM0008 §11 and the STM32F103x8 datasheet's ADC
//! characteristics: power-up and t_STAB, the calibration sequence and
//! t_CAL, the conversion time (sample time + 12.5 cycles; the datasheet's
//! 1 µs at 14 MHz), the code of a voltage, the sample instant, EOC/JEOC and
//! their clears, ADON and SWSTART triggers, the injected group with its
//! offsets and its priority over a regular conversion, the interrupt line,
//! and what stops the board.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use emulator::adc::{cr1, cr2, reg, sr, Adc, AdcError};

/// 72 MHz PCLK2 / 6: the usual Blue Pill ADC clock.
const ADC_12M: u32 = 12_000_000;
/// The fastest ADC clock.
const ADC_14M: u32 = 14_000_000;
/// One ADC clock cycle at 12 MHz (ns).
const CYCLE_12M: f64 = 1e3 / 12.0;
/// One LSB of VREF+ = 3.3 V.
const LSB_V: f64 = 3.3 / 4096.0;
/// Channel 1 (PA1).
const CH: usize = 1;
/// Software-triggered regular and injected groups.
const SW_TRIGGERS: u32 = cr2::EXTTRIG | cr2::EXTSEL_SWSTART | cr2::JEXTTRIG | cr2::JEXTSEL_JSWSTART;

struct Rig {
    adc: Adc,
    now: u64,
}

impl Rig {
    /// The ADC at `hz`, channel 1's pin analog, nothing written.
    fn new(hz: u32) -> Self {
        let mut adc = Adc::new(hz);
        adc.set_pin_analog(CH, true);
        Self { adc, now: 0 }
    }
    /// Powered up at 0 and calibrated (the manual's order), with the
    /// software triggers selected, at `t` ns: a ready ADC.
    fn ready(hz: u32) -> Self {
        let mut r = Self::new(hz);
        r.wr(reg::CR2, cr2::ADON | SW_TRIGGERS);
        r.at(1_000);
        r.wr(reg::CR2, cr2::ADON | SW_TRIGGERS | cr2::CAL);
        r.at(20_000);
        assert_eq!(r.rd(reg::CR2) & cr2::CAL, 0);
        r
    }
    fn try_wr(&mut self, off: u32, v: u32) -> Result<(), AdcError> {
        self.adc.write(off, v, self.now).unwrap()
    }
    fn wr(&mut self, off: u32, v: u32) {
        self.try_wr(off, v).unwrap();
    }
    fn rd(&mut self, off: u32) -> u32 {
        self.adc.read(off, self.now).unwrap()
    }
    fn at(&mut self, t: u64) {
        self.now = t;
        self.adc.advance(t);
    }
    /// A software start of the regular group.
    fn swstart(&mut self) {
        self.wr(reg::CR2, cr2::ADON | SW_TRIGGERS | cr2::SWSTART);
    }
    fn jswstart(&mut self) {
        self.wr(reg::CR2, cr2::ADON | SW_TRIGGERS | cr2::JSWSTART);
    }
    /// Regular SQ1 = `ch`, its sample time code `smp` (SMPR2).
    fn regular(&mut self, ch: usize, smp: u32) {
        self.wr(reg::SQR3, ch as u32);
        self.wr(reg::SMPR2, smp << (3 * ch));
    }
}

#[test]
fn a_conversion_takes_the_sample_time_plus_12_5_cycles() {
    // The datasheet's t_CONV: 1 µs at 14 MHz with the 1.5-cycle sample time.
    let mut r = Rig::ready(ADC_14M);
    r.regular(CH, 0);
    let t0 = r.now;
    r.swstart();
    assert_eq!(r.rd(reg::SR) & (sr::STRT | sr::EOC), sr::STRT);
    assert_eq!(r.rd(reg::CR2) & cr2::SWSTART, 0, "cleared once started");
    r.at(t0 + 999);
    assert_eq!(r.rd(reg::SR) & sr::EOC, 0);
    r.at(t0 + 1_000);
    assert_eq!(r.rd(reg::SR) & sr::EOC, sr::EOC);
    // 239.5 + 12.5 = 252 cycles at 12 MHz: 21 µs.
    let mut r = Rig::ready(ADC_12M);
    r.regular(CH, 7);
    let t0 = r.now;
    r.swstart();
    r.at(t0 + 20_990);
    assert_eq!(r.rd(reg::SR) & sr::EOC, 0);
    r.at(t0 + 21_000);
    assert_eq!(r.rd(reg::SR) & sr::EOC, sr::EOC);
}

#[test]
fn codes_are_twelve_bits_of_vref_clamped() {
    let lsb = LSB_V;
    for (v, code) in [
        (0.0, 0),
        (2048.5 * lsb, 2048),
        (100.5 * lsb, 100),
        (4094.5 * lsb, 4094),
        (3.3, 4095),
        (5.0, 4095),
        (-0.2, 0),
    ] {
        let mut r = Rig::ready(ADC_12M);
        r.regular(CH, 0);
        r.adc.set_input_v(CH, v, r.now);
        r.swstart();
        r.at(r.now + 2_000);
        assert_eq!(r.rd(reg::DR), code, "{v} V");
    }
    // Left alignment (§11.5): the code in bits 15..4.
    let mut r = Rig::ready(ADC_12M);
    r.regular(CH, 0);
    r.adc.set_input_v(CH, 2048.5 * lsb, r.now);
    r.wr(reg::CR2, cr2::ADON | SW_TRIGGERS | cr2::ALIGN);
    r.wr(
        reg::CR2,
        cr2::ADON | SW_TRIGGERS | cr2::ALIGN | cr2::SWSTART,
    );
    r.at(r.now + 2_000);
    assert_eq!(r.rd(reg::DR), 2048 << 4);
}

#[test]
fn the_input_is_sampled_at_the_end_of_the_sample_phase() {
    // 239.5 sample cycles at 12 MHz: the sample at 19.958 µs.
    let sample_ns = 239.5 * CYCLE_12M;
    for (change_at, expect) in [(sample_ns - 50.0, 4095), (sample_ns + 50.0, 0)] {
        let mut r = Rig::ready(ADC_12M);
        r.regular(CH, 7);
        let t0 = r.now;
        r.swstart();
        r.at(t0 + change_at as u64);
        r.adc.set_input_v(CH, 3.3, r.now);
        r.at(t0 + 25_000);
        assert_eq!(r.rd(reg::DR), expect, "input changed at {change_at} ns");
    }
}

#[test]
fn eoc_clears_by_a_dr_read_or_by_writing_zero() {
    let mut r = Rig::ready(ADC_12M);
    r.regular(CH, 0);
    r.swstart();
    r.at(r.now + 2_000);
    assert_ne!(r.rd(reg::SR) & sr::EOC, 0);
    r.wr(reg::SR, !0);
    assert_ne!(r.rd(reg::SR) & sr::EOC, 0, "writing 1 leaves it");
    r.rd(reg::DR);
    assert_eq!(r.rd(reg::SR) & sr::EOC, 0, "DR read");
    r.swstart();
    r.at(r.now + 2_000);
    r.wr(reg::SR, !sr::EOC);
    assert_eq!(r.rd(reg::SR) & sr::EOC, 0, "written 0");
    assert_ne!(r.rd(reg::SR) & sr::STRT, 0, "STRT left (written 1)");
    r.wr(reg::SR, 0);
    assert_eq!(r.rd(reg::SR), 0);
}

#[test]
fn adon_written_again_starts_a_conversion_unless_another_bit_changes() {
    let mut r = Rig::ready(ADC_12M);
    r.regular(CH, 0);
    let cr = cr2::ADON | SW_TRIGGERS;
    // ADON with CONT changing at the same time: no conversion (§11.12.3).
    r.wr(reg::CR2, cr | cr2::CONT);
    r.at(r.now + 5_000);
    assert_eq!(r.rd(reg::SR) & sr::STRT, 0);
    assert_eq!(r.adc.counts().0, 0);
    r.wr(reg::CR2, cr | cr2::CONT);
    let t = r.now;
    r.at(t + 1_200);
    assert_ne!(r.rd(reg::SR) & sr::STRT, 0);
    assert_eq!(r.adc.counts().0, 1, "14 cycles: 1.167 µs");
    // Continuous: one conversion every 14 cycles at 12 MHz, back to back.
    r.at(t + 15_200);
    assert_eq!(r.adc.counts().0, 13, "⌊15.2 µs / 1.167 µs⌋");
}

#[test]
fn swstart_needs_exttrig_and_the_swstart_selection() {
    let mut r = Rig::ready(ADC_12M);
    r.regular(CH, 0);
    r.wr(reg::CR2, cr2::ADON | cr2::EXTSEL_SWSTART | cr2::SWSTART);
    r.at(r.now + 5_000);
    assert_eq!(r.adc.counts().0, 0, "EXTTRIG clear: no start");
    // A timer trigger selected is not modelled: the board stops.
    let e = r.try_wr(reg::CR2, cr2::ADON | cr2::EXTTRIG | (4 << 17));
    assert!(matches!(e, Err(AdcError::Unmodelled(_))), "{e:?}");
}

#[test]
fn power_up_waits_t_stab_and_calibration_two_cycles_then_t_cal() {
    let mut r = Rig::new(ADC_12M);
    r.regular(CH, 0);
    r.wr(reg::CR2, cr2::ADON | SW_TRIGGERS);
    r.at(500);
    let e = r.try_wr(reg::CR2, cr2::ADON | SW_TRIGGERS | cr2::SWSTART);
    assert!(
        matches!(e, Err(AdcError::Misuse(ref m)) if m.contains("t_STAB")),
        "{e:?}"
    );

    let mut r = Rig::new(ADC_12M);
    // CAL with the ADON that wakes the ADC: not two cycles powered.
    let e = r.try_wr(reg::CR2, cr2::ADON | cr2::CAL);
    assert!(matches!(e, Err(AdcError::Misuse(_))), "{e:?}");

    let mut r = Rig::new(ADC_12M);
    r.wr(reg::CR2, cr2::ADON);
    r.at((2.0 * CYCLE_12M).ceil() as u64);
    r.wr(reg::CR2, cr2::ADON | cr2::RSTCAL);
    assert_ne!(r.rd(reg::CR2) & cr2::RSTCAL, 0);
    r.at(r.now + 100);
    assert_eq!(r.rd(reg::CR2) & cr2::RSTCAL, 0, "reset by hardware");
    r.wr(reg::CR2, cr2::ADON | cr2::CAL);
    let t_cal = r.now as f64 + 83.0 * CYCLE_12M;
    r.at(t_cal as u64 - 10);
    assert_ne!(r.rd(reg::CR2) & cr2::CAL, 0, "calibrating");
    assert!(!r.adc.calibrated());
    // A conversion during calibration is refused.
    let e = r.try_wr(reg::CR2, cr2::ADON | cr2::CAL);
    assert!(
        matches!(e, Err(AdcError::Misuse(ref m)) if m.contains("calibration")),
        "{e:?}"
    );
    r.at(t_cal as u64 + 1);
    assert_eq!(r.rd(reg::CR2) & cr2::CAL, 0);
    assert!(r.adc.calibrated());
    assert_eq!(r.adc.counts().2, 1);
}

#[test]
fn calibration_removes_the_uncalibrated_offset() {
    let mut r = Rig::new(ADC_12M);
    r.adc.set_uncalibrated_offset_lsb(-7);
    r.adc.set_input_v(CH, 2048.5 * LSB_V, 0);
    r.regular(CH, 0);
    r.wr(reg::CR2, cr2::ADON | SW_TRIGGERS);
    r.at(2_000);
    r.swstart();
    r.at(4_000);
    assert_eq!(r.rd(reg::DR), 2048 - 7);
    r.wr(reg::CR2, cr2::ADON | SW_TRIGGERS | cr2::CAL);
    r.at(20_000);
    r.swstart();
    r.at(22_000);
    assert_eq!(r.rd(reg::DR), 2048);
}

#[test]
fn the_injected_channel_is_offset_and_sign_extended() {
    let mut r = Rig::ready(ADC_12M);
    // One injected conversion (JL = 0): JSQ4 = channel 1; JOFR1 = 2000.
    r.wr(reg::JSQR, (CH as u32) << 15);
    r.wr(reg::jofr(1), 2000);
    r.adc.set_input_v(CH, 2048.5 * LSB_V, r.now);
    r.jswstart();
    assert_ne!(r.rd(reg::SR) & sr::JSTRT, 0);
    r.at(r.now + 2_000);
    assert_ne!(r.rd(reg::SR) & sr::JEOC, 0);
    assert_eq!(r.rd(reg::jdr(1)), 48);
    r.rd(reg::jdr(1));
    assert_ne!(r.rd(reg::SR) & sr::JEOC, 0, "a JDR read leaves JEOC");
    r.wr(reg::SR, !sr::JEOC);
    assert_eq!(r.rd(reg::SR) & sr::JEOC, 0);
    // Below the offset: negative, sign extended into bits 15..12.
    r.adc.set_input_v(CH, 0.0, r.now);
    r.jswstart();
    r.at(r.now + 2_000);
    assert_eq!(r.rd(reg::jdr(1)), (-2000i16) as u16 as u32);
}

#[test]
fn an_injected_group_converts_jsq_in_order_into_jdr1_onwards() {
    let mut r = Rig::ready(ADC_12M);
    r.adc.set_pin_analog(4, true);
    r.adc.set_input_v(CH, 1.0, 0);
    r.adc.set_input_v(4, 2.0, 0);
    // JL = 1: JSQ3 then JSQ4.
    r.wr(reg::JSQR, (1 << 20) | ((CH as u32) << 10) | (4 << 15));
    let e = r.try_wr(reg::CR2, cr2::ADON | SW_TRIGGERS | cr2::JSWSTART);
    assert!(
        matches!(e, Err(AdcError::Unmodelled(_))),
        "group without SCAN"
    );
    r.adc.take_fault();
    r.wr(reg::CR1, cr1::SCAN);
    r.jswstart();
    r.at(r.now + 1_200);
    assert_eq!(r.rd(reg::SR) & sr::JEOC, 0, "after the first of two");
    r.at(r.now + 1_200);
    assert_ne!(r.rd(reg::SR) & sr::JEOC, 0);
    assert_eq!(r.rd(reg::jdr(1)), (1.0f64 / 3.3 * 4096.0) as u32);
    assert_eq!(r.rd(reg::jdr(2)), (2.0f64 / 3.3 * 4096.0) as u32);
}

#[test]
fn an_injected_trigger_interrupts_the_regular_conversion_which_runs_again() {
    let mut r = Rig::ready(ADC_12M);
    // Regular: channel 1, 252 cycles (21 µs); injected: channel 4, 14
    // cycles (1.167 µs). Sample times are per channel.
    r.adc.set_pin_analog(4, true);
    r.regular(CH, 7);
    r.wr(reg::JSQR, 4 << 15);
    let t0 = r.now;
    r.swstart();
    r.at(t0 + 10_000);
    r.jswstart();
    r.at(t0 + 21_000);
    assert_eq!(r.rd(reg::SR) & sr::EOC, 0, "not at the first schedule");
    let jeoc = t0 + 10_000 + (14.0 * CYCLE_12M).ceil() as u64;
    assert_ne!(r.rd(reg::SR) & sr::JEOC, 0);
    r.at(jeoc + 20_990);
    assert_eq!(r.rd(reg::SR) & sr::EOC, 0);
    r.at(jeoc + 21_001);
    assert_ne!(r.rd(reg::SR) & sr::EOC, 0, "a whole conversion after JEOC");
}

#[test]
fn eoc_and_jeoc_raise_the_interrupt_line_with_their_enables() {
    let mut r = Rig::ready(ADC_12M);
    r.regular(CH, 0);
    r.wr(reg::JSQR, (CH as u32) << 15);
    r.swstart();
    r.at(r.now + 2_000);
    assert!(!r.adc.irq(), "EOCIE clear");
    r.wr(reg::CR1, cr1::EOCIE);
    assert!(r.adc.irq());
    r.rd(reg::DR);
    assert!(!r.adc.irq());
    r.wr(reg::CR1, cr1::JEOCIE);
    r.jswstart();
    r.at(r.now + 2_000);
    assert!(r.adc.irq());
    r.wr(reg::SR, !sr::JEOC);
    assert!(!r.adc.irq());
}

#[test]
fn a_pin_not_in_analog_mode_stops_the_board_at_the_sample() {
    let mut r = Rig::ready(ADC_12M);
    r.regular(2, 0);
    r.swstart();
    r.at(r.now + 2_000);
    let e = r.adc.take_fault();
    assert!(
        matches!(e, Some(AdcError::Misuse(ref m)) if m.contains("analog")),
        "{e:?}"
    );
}

#[test]
fn unmodelled_features_and_a_fast_clock_stop_the_board() {
    let mut r = Rig::ready(ADC_12M);
    for (off, v) in [
        (reg::CR2, cr2::ADON | cr2::DMA),
        (reg::CR2, cr2::ADON | cr2::TSVREFE),
        (reg::CR1, 1 << 23),
        (reg::CR1, 1 << 10),
    ] {
        let e = r.try_wr(off, v);
        assert!(
            matches!(e, Err(AdcError::Unmodelled(_))),
            "{off:#x} {v:#x}: {e:?}"
        );
    }
    r.wr(reg::CR1, cr1::SCAN);
    r.wr(reg::SQR1, 1 << 20);
    let e = r.try_wr(reg::CR2, cr2::ADON | SW_TRIGGERS | cr2::SWSTART);
    assert!(
        matches!(e, Err(AdcError::Unmodelled(_))),
        "regular scan: {e:?}"
    );
    // 72 MHz / 2 = 36 MHz on a powered ADC.
    let mut r = Rig::ready(ADC_12M);
    r.adc.set_clock_hz(36_000_000, r.now);
    assert!(matches!(r.adc.take_fault(), Some(AdcError::Clock(_))));
    // Powered down, the clock may be anything.
    let mut r = Rig::new(36_000_000);
    r.wr(reg::SQR3, 0);
    assert_eq!(r.adc.take_fault(), None);
}

/// The scheduler is woken for the ends that raise the interrupt line (and
/// for the injected end that restarts an interrupted regular conversion).
#[test]
fn the_next_event_is_the_end_that_raises_the_line() {
    let mut r = Rig::ready(ADC_12M);
    r.adc.set_pin_analog(4, true);
    r.regular(CH, 7);
    r.wr(reg::JSQR, 4 << 15);
    let t0 = r.now;
    r.swstart();
    assert_eq!(r.adc.next_event_ns(), None, "EOCIE clear");
    r.wr(reg::CR1, cr1::EOCIE);
    let end = t0 as f64 + 252.0 * CYCLE_12M;
    assert_eq!(r.adc.next_event_ns(), Some(end.ceil() as u64));
    r.at(t0 + 1_000);
    r.jswstart();
    let jend = (t0 + 1_000) as f64 + 14.0 * CYCLE_12M;
    assert_eq!(r.adc.next_event_ns(), Some(jend.ceil() as u64));
    r.at(jend.ceil() as u64);
    let restart_end = jend + 252.0 * CYCLE_12M;
    assert_eq!(r.adc.next_event_ns(), Some(restart_end.ceil() as u64));
}
