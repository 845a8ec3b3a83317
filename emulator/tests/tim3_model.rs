//! The general-purpose timer model against RM0008 §15.3: the time base
//! (prescaler and auto-reload preload, update events from overflow and
//! EGR.UG), PWM mode 1/2 with the CCRx preload, polarity and enable, and
//! the output level as a function of time (§15.3.9, figure 122).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod tim_support;

use emulator::tim::{cr1, ocm, reg, GpTimer};
use tim_support::{Rig, US};

// Most tests run the kernel clock at 1 MHz: one counter tick per `US` at PSC = 0.

impl Rig {
    fn tim3(hz: u32) -> Self {
        Self::new("TIM3", hz)
    }
    fn wait(&mut self, ns: u64) {
        self.now += ns;
    }
    /// Channel `ch`'s high time over one window of `window_ns`, sampled
    /// every `step_ns`.
    fn high_ns(&mut self, ch: usize, window_ns: u64, step_ns: u64) -> u64 {
        let mut high = 0;
        let end = self.now + window_ns;
        while self.now < end {
            if self.t.output_high(ch, self.now) {
                high += step_ns;
            }
            self.now += step_ns;
        }
        high
    }
    /// Channel 1 in PWM mode `mode` with preload, enabled, ARR `arr`.
    fn pwm(hz: u32, arr: u32, mode: u32) -> Self {
        let mut r = Self::tim3(hz);
        r.wr(reg::ARR, arr);
        r.wr(reg::CCMR1, (mode << 4) | (1 << 3));
        r.wr(reg::CCER, 1);
        r.update_then_start(cr1::ARPE | cr1::CEN);
        r
    }
}

#[test]
fn counter_is_blocked_while_the_auto_reload_value_is_null() {
    // ARR resets to 0 (§15.4.12): CEN alone does not count.
    let mut r = Rig::tim3(1_000_000);
    assert_eq!(r.rd(reg::ARR), 0);
    r.wr(reg::CR1, cr1::CEN);
    r.wait(100 * US);
    assert_eq!(r.rd(reg::CNT), 0);
    r.wr(reg::ARR, 1000);
    r.wait(100 * US);
    assert_eq!(r.rd(reg::CNT), 100);
}

#[test]
fn counter_frequency_is_ck_psc_over_psc_plus_one_and_wraps_at_arr() {
    // 72 MHz, PSC = 71: 1 MHz; ARR = 2499: a 2.5 ms (400 Hz) period.
    let mut r = Rig::tim3(72_000_000);
    r.wr(reg::PSC, 71);
    r.wr(reg::ARR, 2499);
    r.wr(reg::EGR, 1);
    assert_eq!(r.rd(reg::SR) & 1, 1, "UG sets UIF with URS = 0");
    r.wr(reg::SR, !1);
    assert_eq!(r.rd(reg::SR) & 1, 0, "UIF is rc_w0");
    r.wr(reg::CR1, cr1::CEN);
    r.wait(1_000 * US);
    assert_eq!(r.rd(reg::CNT), 1000);
    r.wait(1_499 * US);
    assert_eq!(r.rd(reg::CNT), 2499);
    assert_eq!(r.rd(reg::SR) & 1, 0, "no update before the overflow");
    r.wait(US);
    assert_eq!(r.rd(reg::CNT), 0, "upcounting restarts at 0 after ARR");
    assert_eq!(r.rd(reg::SR) & 1, 1, "overflow: update event");
    // A million periods later the phase is the same.
    r.wait(1_000_000 * 2_500 * US + 7 * US);
    assert_eq!(r.rd(reg::CNT), 7);
}

#[test]
fn prescaler_change_takes_effect_at_the_next_update_event() {
    // Figure 100: PSC is preloaded; the new ratio applies after the update.
    let mut r = Rig::tim3(1_000_000);
    r.wr(reg::ARR, 99);
    r.wr(reg::CR1, cr1::CEN);
    r.wait(50 * US);
    r.wr(reg::PSC, 1);
    r.wait(40 * US);
    assert_eq!(r.rd(reg::CNT), 90, "still /1 before the overflow");
    r.wait(10 * US);
    assert_eq!(r.rd(reg::CNT), 0);
    r.wait(20 * US);
    assert_eq!(r.rd(reg::CNT), 10, "/2 after the update event");
    assert_eq!(r.rd(reg::PSC), 1);
}

#[test]
fn auto_reload_is_immediate_without_arpe_and_buffered_with_it() {
    // Figures 106 and 107.
    let mut r = Rig::tim3(1_000_000);
    r.wr(reg::ARR, 0xFF);
    r.wr(reg::CR1, cr1::CEN);
    r.wait(0x30 * US);
    r.wr(reg::ARR, 0x36);
    r.wait(7 * US);
    assert_eq!(r.rd(reg::CNT), 0, "ARPE = 0: overflow at the new ARR");

    let mut r = Rig::tim3(1_000_000);
    r.wr(reg::ARR, 0xF5);
    r.wr(reg::CR1, cr1::CEN | cr1::ARPE);
    r.wait(0xF0 * US);
    r.wr(reg::ARR, 0x36);
    r.wait(6 * US);
    assert_eq!(
        r.rd(reg::CNT),
        0,
        "ARPE = 1: this period ends at the old ARR"
    );
    r.wait(0x36 * US);
    assert_eq!(r.rd(reg::CNT), 0x36);
    r.wait(US);
    assert_eq!(r.rd(reg::CNT), 0, "the next period uses the new ARR");
}

#[test]
fn ug_reinitialises_the_counter_and_urs_hides_it_from_uif() {
    let mut r = Rig::tim3(1_000_000);
    r.wr(reg::ARR, 1000);
    r.wr(reg::CR1, cr1::CEN | cr1::URS);
    r.wait(300 * US);
    r.wr(reg::EGR, 1);
    assert_eq!(r.rd(reg::CNT), 0);
    assert_eq!(r.rd(reg::SR) & 1, 0, "URS = 1: only overflow sets UIF");
    r.wait(1001 * US);
    assert_eq!(r.rd(reg::SR) & 1, 1);
}

#[test]
fn udis_suppresses_update_events() {
    let mut r = Rig::tim3(1_000_000);
    r.wr(reg::ARR, 99);
    r.wr(reg::CR1, cr1::CEN | cr1::ARPE | cr1::UDIS);
    r.wr(reg::ARR, 9);
    r.wait(150 * US);
    assert_eq!(r.rd(reg::CNT), 50, "wrapped at the old ARR: no shadow load");
    assert_eq!(r.rd(reg::SR) & 1, 0, "no UIF");
}

#[test]
fn pwm_mode_1_follows_figure_122() {
    // ARR = 8: CCRx = 4 → high for counts 0..3; CCRx = 8 → 0..7;
    // CCRx > 8 → always high; CCRx = 0 → always low.
    for (ccr, high_ticks) in [(4, 4), (8, 8), (9, 9), (0, 0)] {
        let mut r = Rig::pwm(1_000_000, 8, ocm::PWM1);
        r.wr(reg::CCR1, ccr);
        r.wr(reg::EGR, 1);
        r.wait(3 * US);
        let high = r.high_ns(0, 9 * 10 * US, US / 2);
        assert_eq!(high, 10 * high_ticks * US, "CCR1 = {ccr}");
        assert_eq!(r.t.pwm_ns(0), Some((9 * US, high_ticks * US)));
    }
}

#[test]
fn pwm_mode_2_inverts_ocref_and_ccxp_inverts_the_output() {
    let mut r = Rig::pwm(1_000_000, 99, ocm::PWM2);
    r.wr(reg::CCR1, 30);
    r.wr(reg::EGR, 1);
    assert_eq!(r.high_ns(0, 100 * US, US), 70 * US);
    r.wr(reg::CCER, 0b11);
    assert_eq!(r.high_ns(0, 100 * US, US), 30 * US, "CC1P: active low");
    r.wr(reg::CCER, 0b10);
    assert_eq!(r.high_ns(0, 100 * US, US), 0, "CC1E = 0: output off");
    assert_eq!(r.t.pwm_ns(0), Some((100 * US, 0)));
}

#[test]
fn ccr_preload_applies_at_the_update_event_only_when_ocxpe_is_set() {
    // 400 Hz at 1 µs resolution: the ESC case.
    let mut r = Rig::tim3(72_000_000);
    r.wr(reg::PSC, 71);
    r.wr(reg::ARR, 2499);
    r.wr(reg::CCMR1, (ocm::PWM1 << 4) | (1 << 3) | (ocm::PWM1 << 12));
    r.wr(reg::CCER, 0x11);
    r.wr(reg::CCR1, 1000);
    r.wr(reg::CCR2, 1000);
    r.wr(reg::EGR, 1);
    r.wr(reg::CR1, cr1::CEN | cr1::ARPE);
    r.wait(500 * US);
    r.wr(reg::CCR1, 2000);
    r.wr(reg::CCR2, 2000);
    // Channel 1 (preloaded) finishes this period at 1000; channel 2 (no
    // preload) extends the pulse at once.
    assert!(r.t.output_high(0, r.now));
    r.wait(600 * US);
    assert!(!r.t.output_high(0, r.now), "CC1: old CCR until the update");
    assert!(r.t.output_high(1, r.now), "CC2: new CCR immediately");
    r.wait(1_400 * US); // 2.5 ms: next period
    assert_eq!(r.high_ns(0, 2_500 * US, US), 2_000 * US);
    assert_eq!(r.t.pwm_ns(0), Some((2_500 * US, 2_000 * US)));
}

#[test]
fn forced_modes_and_frozen_hold_the_reference() {
    let mut r = Rig::pwm(1_000_000, 99, ocm::FORCE_ACTIVE);
    assert_eq!(r.high_ns(0, 100 * US, US), 100 * US);
    r.wr(reg::CCMR1, ocm::FROZEN << 4);
    assert_eq!(r.high_ns(0, 100 * US, US), 100 * US, "frozen keeps high");
    r.wr(reg::CCMR1, ocm::FORCE_INACTIVE << 4);
    assert_eq!(r.high_ns(0, 100 * US, US), 0);
}

#[test]
fn features_outside_the_model_are_refused() {
    let mut t = GpTimer::new("TIM3", 1_000_000);
    assert!(
        matches!(t.write(reg::CCMR1, 2, 0), Some(Err(_))),
        "input capture on the neighbour's TIx"
    );
    assert!(matches!(t.write(reg::CCMR1, 0b001 << 4, 0), Some(Err(_))));
    assert!(matches!(t.write(reg::CR1, cr1::DIR, 0), Some(Err(_))));
    assert!(matches!(t.write(reg::SMCR, 4, 0), Some(Err(_))));
    assert!(matches!(t.write(reg::DIER, 2, 0), Some(Err(_))));
    assert_eq!(t.read(0x50, 0), None, "beyond the register map");
}

#[test]
fn update_interrupt_line_follows_uie_and_uif() {
    let mut r = Rig::tim3(1_000_000);
    r.wr(reg::ARR, 99);
    r.wr(reg::DIER, 1);
    r.wr(reg::CR1, cr1::CEN);
    assert!(!r.t.irq());
    assert_eq!(r.t.next_update_ns(), Some(100 * US));
    r.wait(100 * US);
    r.t.advance(r.now);
    assert!(r.t.irq());
    r.wr(reg::SR, 0);
    assert!(!r.t.irq());
}
