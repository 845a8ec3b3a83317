//! Input capture in the general-purpose timer model against RM0008
//! §15.3.5 ("Input capture mode") and the register descriptions §15.4.4
//! (DIER), §15.4.5 (SR), §15.4.6 (EGR), §15.4.7 (CCMRx input mode),
//! §15.4.9 (CCER) and §15.4.13–16 (CCRx): the counter latched at the edge,
//! polarity, the input prescaler, CCxIF/CCxOF and their clear sequences,
//! a counter wrap between two edges, and the interrupt line.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod tim_support;

use emulator::tim::{cr1, reg, sr, GpTimer};
use tim_support::{Rig, US};

/// Channel 3 (index 2): TIM4_CH3 on PB8, the firmware's PPM input.
const CH: usize = 2;
/// CCMR2 for channel 3: CC3S = 01 (IC3 on TI3), IC3PSC in bits 3:2,
/// IC3F = 0000.
fn ccmr2_ic3(psc: u32) -> u32 {
    0b01 | (psc << 2)
}
const CC3E: u32 = 1 << 8;
const CC3P: u32 = 1 << 9;
const CC3IE: u32 = 1 << 3;

impl Rig {
    /// TIM4 at 72 MHz with PSC = 71 (1 MHz counter), ARR = 0xFFFF,
    /// channel 3 capturing rising edges, running from t = 0.
    fn capture_1mhz() -> Self {
        let mut r = Self::new("TIM4", 72_000_000);
        r.wr(reg::PSC, 71);
        r.wr(reg::ARR, 0xFFFF);
        r.wr(reg::CCMR2, ccmr2_ic3(0));
        r.wr(reg::CCER, CC3E);
        r.update_then_start(cr1::CEN);
        r
    }
    /// The input goes to `high` at `t_ns` (the rig's time follows).
    fn edge(&mut self, high: bool, t_ns: u64) {
        self.now = t_ns;
        self.t.input(CH, high, t_ns);
    }
    /// A `width_ns` high pulse starting at `t_ns`.
    fn pulse(&mut self, t_ns: u64, width_ns: u64) {
        self.edge(true, t_ns);
        self.edge(false, t_ns + width_ns);
    }
    fn sr(&mut self) -> u32 {
        self.rd(reg::SR)
    }
}

#[test]
fn capture_latches_the_counter_at_the_edge_not_when_read() {
    let mut r = Rig::capture_1mhz();
    // 1234.5 µs after the counter started: 1234 whole ticks of 1 µs.
    r.edge(true, 1_234 * US + 500);
    assert_ne!(r.sr() & sr::ccif(CH), 0, "CC3IF set by the capture");
    r.now += 5_000 * US;
    assert_eq!(r.rd(reg::CNT), 6_234, "the counter ran on");
    assert_eq!(r.rd(reg::CCR3), 1_234, "CCR3 holds the edge's count");
    assert_eq!(r.sr() & sr::ccif(CH), 0, "reading CCR3 clears CC3IF");
    // The falling edge does not capture with CC3P = 0.
    r.edge(false, 7_000 * US);
    assert_eq!(r.sr() & sr::ccif(CH), 0);
    assert_eq!(r.rd(reg::CCR3), 1_234);
}

#[test]
fn counter_prescaler_sets_the_capture_resolution() {
    // 64 MHz (the HSI fallback) with PSC = 63 is the same 1 µs count.
    let mut r = Rig::capture_1mhz();
    r.t = GpTimer::new("TIM4", 64_000_000);
    r.wr(reg::PSC, 63);
    r.wr(reg::ARR, 0xFFFF);
    r.wr(reg::CCMR2, ccmr2_ic3(0));
    r.wr(reg::CCER, CC3E);
    r.wr(reg::EGR, 1);
    r.wr(reg::CR1, cr1::CEN);
    r.edge(true, 22_500 * US + 999);
    assert_eq!(r.rd(reg::CCR3), 22_500);
}

#[test]
fn cc3p_selects_the_falling_edge() {
    let mut r = Rig::capture_1mhz();
    r.wr(reg::CCER, CC3E | CC3P);
    r.edge(true, 100 * US);
    assert_eq!(
        r.sr() & sr::ccif(CH),
        0,
        "rising edge ignored with CC3P = 1"
    );
    r.edge(false, 400 * US);
    assert_ne!(r.sr() & sr::ccif(CH), 0);
    assert_eq!(r.rd(reg::CCR3), 400);
}

#[test]
fn a_disabled_channel_does_not_capture() {
    let mut r = Rig::capture_1mhz();
    r.wr(reg::CCER, 0);
    r.pulse(100 * US, 300 * US);
    assert_eq!(r.sr() & sr::ccif(CH), 0, "CC3E = 0: no capture");
    assert_eq!(r.rd(reg::CCR3), 0);
}

#[test]
fn overcapture_sets_ccxof_which_only_a_zero_write_clears() {
    let mut r = Rig::capture_1mhz();
    r.pulse(1_000 * US, 300 * US);
    r.pulse(2_500 * US, 300 * US);
    let s = r.sr();
    assert_ne!(s & sr::ccif(CH), 0);
    assert_ne!(s & sr::ccof(CH), 0, "a capture while CC3IF was set");
    assert_eq!(r.rd(reg::CCR3), 2_500, "CCR3 holds the newer capture");
    let s = r.sr();
    assert_eq!(s & sr::ccif(CH), 0, "read cleared CC3IF");
    assert_ne!(s & sr::ccof(CH), 0, "but not CC3OF");
    r.wr(reg::SR, !sr::ccof(CH));
    assert_eq!(r.sr() & sr::ccof(CH), 0, "rc_w0");
    // CC3IF cleared by writing 0 instead of reading CCR3: the next capture
    // is not an over-capture.
    r.pulse(4_000 * US, 300 * US);
    r.wr(reg::SR, !sr::ccif(CH));
    assert_eq!(r.sr() & (sr::ccif(CH) | sr::ccof(CH)), 0);
    r.pulse(5_500 * US, 300 * US);
    assert_eq!(r.sr() & sr::ccof(CH), 0);
    // Writing 1 to a flag has no effect.
    r.wr(reg::SR, 0xFFFF);
    assert_ne!(r.sr() & sr::ccif(CH), 0);
}

#[test]
fn interval_across_a_counter_wrap_is_the_wrapping_difference() {
    let mut r = Rig::capture_1mhz();
    // 60 ms and 70 ms: the 16-bit counter wraps at 65.536 ms in between.
    r.pulse(60_000 * US, 300 * US);
    let a = r.rd(reg::CCR3) as u16;
    r.pulse(70_000 * US, 300 * US);
    let b = r.rd(reg::CCR3) as u16;
    assert_eq!(a, 60_000);
    assert_eq!(b, (70_000 - 65_536) as u16);
    assert_eq!(b.wrapping_sub(a), 10_000);
    assert_ne!(r.sr() & sr::UIF, 0, "the wrap was an update event");
}

#[test]
fn capture_interrupt_follows_ccxie_and_ccxif() {
    let mut r = Rig::capture_1mhz();
    r.pulse(100 * US, 300 * US);
    assert!(!r.t.irq(), "CC3IE = 0: flag only");
    r.rd(reg::CCR3);
    r.wr(reg::DIER, CC3IE);
    assert!(!r.t.irq());
    r.pulse(1_600 * US, 300 * US);
    assert!(r.t.irq(), "CC3IE and CC3IF");
    r.rd(reg::CCR3);
    assert!(!r.t.irq(), "the handler's CCR3 read drops the line");
    // Over-capture alone (CC3IF cleared, CC3OF left) raises no interrupt.
    r.pulse(3_100 * US, 300 * US);
    r.pulse(4_600 * US, 300 * US);
    r.wr(reg::SR, !sr::ccif(CH));
    assert_ne!(r.sr() & sr::ccof(CH), 0);
    assert!(!r.t.irq());
}

#[test]
fn input_prescaler_captures_every_nth_edge_and_resets_with_ccxe() {
    let mut r = Rig::capture_1mhz();
    r.wr(reg::CCER, 0);
    r.wr(reg::CCMR2, ccmr2_ic3(0b10)); // every 4th edge
    r.wr(reg::CCER, CC3E);
    let mut captures = Vec::new();
    for i in 0..8u64 {
        r.pulse((1_000 + 1_000 * i) * US, 300 * US);
        if r.sr() & sr::ccif(CH) != 0 {
            captures.push(r.rd(reg::CCR3));
        }
    }
    assert_eq!(captures, [4_000, 8_000]);
    // Three edges, CC3E off and on: the count starts again.
    for i in 0..3u64 {
        r.pulse((10_000 + 1_000 * i) * US, 300 * US);
    }
    r.wr(reg::CCER, 0);
    r.wr(reg::CCER, CC3E);
    r.pulse(14_000 * US, 300 * US);
    assert_eq!(r.sr() & sr::ccif(CH), 0, "prescaler reset by CC3E = 0");
    for i in 1..4u64 {
        r.pulse((14_000 + 1_000 * i) * US, 300 * US);
    }
    assert_eq!(r.rd(reg::CCR3), 17_000);
}

#[test]
fn ccxg_captures_by_software_and_ccr_is_read_only_in_input_mode() {
    let mut r = Rig::capture_1mhz();
    r.now = 777 * US;
    r.wr(reg::EGR, 1 << 3); // CC3G
    assert_ne!(r.sr() & sr::ccif(CH), 0);
    r.wr(reg::CCR3, 5);
    assert_eq!(r.rd(reg::CCR3), 777, "writes to CCR3 ignored in input mode");
    r.wr(reg::EGR, 1 << 3);
    r.wr(reg::EGR, 1 << 3);
    assert_ne!(r.sr() & sr::ccof(CH), 0, "CC3G over an unread capture");
}

#[test]
fn ccxs_is_locked_while_the_channel_is_enabled() {
    let mut r = Rig::capture_1mhz();
    // Try to make channel 3 an output while CC3E = 1: CC3S stays 01.
    r.wr(reg::CCMR2, 0);
    assert_eq!(r.rd(reg::CCMR2) & 3, 1);
    r.pulse(100 * US, 300 * US);
    assert_eq!(r.rd(reg::CCR3), 100, "still capturing");
    r.wr(reg::CCER, 0);
    r.wr(reg::CCMR2, 0b110 << 4);
    assert_eq!(r.rd(reg::CCMR2) & 3, 0, "writable once CC3E = 0");
}

#[test]
fn an_input_channel_drives_no_output() {
    let mut r = Rig::capture_1mhz();
    r.now = 10 * US;
    assert!(!r.t.output_high(CH, r.now));
    assert_eq!(r.t.pwm_ns(CH), None);
}

/// CCMR2 for channel 3 with the input filter IC3F = `f`.
fn ccmr2_ic3_filtered(f: u32) -> u32 {
    ccmr2_ic3(0) | (f << 4)
}

/// TIM4 at 72 MHz, PSC = 0 (the counter at f_CK_INT, so a capture shows
/// the filter's delay tick by tick), channel 3 on rising edges through
/// the filter IC3F = `f`, CR1.CKD = `ckd`.
fn filtered_rig(f: u32, ckd: u32) -> Rig {
    let mut r = Rig::capture_1mhz();
    r.wr(reg::PSC, 0);
    r.wr(reg::CCER, 0);
    r.wr(reg::CCMR2, ccmr2_ic3_filtered(f));
    r.wr(reg::CCER, CC3E);
    r.update_then_start(cr1::CEN | (ckd << 8));
    r
}

#[test]
fn the_input_filter_delays_an_edge_by_its_n_samples() {
    // IC3F = 0011: sampled at f_CK_INT, N = 8 (§15.3.5's own example).
    // An edge between kernel ticks 1000 and 1001: first sample at 1001,
    // the eighth at 1008.
    let tick_ns = |t: u64| t * 1_000 / 72;
    let mut r = filtered_rig(0b0011, 0);
    r.edge(true, tick_ns(1_000) + 5);
    assert_eq!(r.sr() & sr::ccif(CH), 0, "not through the filter yet");
    assert_eq!(
        r.t.next_input_ns().map(|t| t / 10),
        Some(tick_ns(1_008) / 10)
    );
    r.now = tick_ns(1_100);
    assert_ne!(r.sr() & sr::ccif(CH), 0, "through after 8 samples");
    assert_eq!(r.rd(reg::CCR3), 1_008);
    assert_eq!(r.t.next_input_ns(), None);
}

#[test]
fn the_input_filter_swallows_a_pulse_shorter_than_n_samples() {
    let tick_ns = |t: u64| t * 1_000 / 72;
    // N = 8 at f_CK_INT: a 50 ns (3.6 tick) spike never reaches the edge
    // detector, a 200 ns (14 tick) pulse does.
    let mut r = filtered_rig(0b0011, 0);
    r.pulse(tick_ns(500), 50);
    r.now = tick_ns(2_000);
    assert_eq!(r.sr() & sr::ccif(CH), 0, "50 ns spike filtered out");
    r.pulse(tick_ns(3_000), 200);
    r.now = tick_ns(4_000);
    assert_ne!(r.sr() & sr::ccif(CH), 0, "200 ns pulse passes");
    // IC3F = 1111 with CKD = 10: f_DTS = f_CK_INT / 4, sampled at
    // f_DTS / 32 (every 128 ticks), N = 8: a level held for less than
    // 7 × 128 = 896 ticks never reaches the eighth sample.
    let mut r = filtered_rig(0b1111, 0b10);
    r.pulse(tick_ns(1_000), tick_ns(890));
    r.now = tick_ns(10_000);
    assert_eq!(r.sr() & sr::ccif(CH), 0, "890-tick pulse filtered out");
    r.pulse(tick_ns(20_000), tick_ns(1_200));
    r.now = tick_ns(30_000);
    assert_ne!(r.sr() & sr::ccif(CH), 0, "1200-tick pulse passes");
    // First sample at tick 20 096 (the next multiple of 128), the eighth
    // 7 × 128 later.
    assert_eq!(r.rd(reg::CCR3), 20_096 + 7 * 128);
}

#[test]
fn filtered_intervals_equal_the_unfiltered_ones() {
    // Every edge is delayed alike: a PPM-like train of rising edges at
    // 1 MHz counting gives the same intervals with IC3F = 0011.
    let mut plain = Rig::capture_1mhz();
    let mut filt = Rig::capture_1mhz();
    filt.wr(reg::CCER, 0);
    filt.wr(reg::CCMR2, ccmr2_ic3_filtered(0b0011));
    filt.wr(reg::CCER, CC3E);
    let mut got = [Vec::new(), Vec::new()];
    let mut t = 1_000 * US + 321;
    for width_us in [1_100, 1_500, 1_900, 1_000, 9_000, 1_200] {
        for (r, g) in [&mut plain, &mut filt].into_iter().zip(got.iter_mut()) {
            r.pulse(t, 300 * US);
            r.now = t + 400 * US;
            g.push(r.rd(reg::CCR3));
        }
        t += width_us * US;
    }
    let intervals = |g: &[u32]| {
        g.windows(2)
            .map(|w| w[1].wrapping_sub(w[0]) & 0xFFFF)
            .collect::<Vec<_>>()
    };
    assert_eq!(intervals(&got[0]), [1_100, 1_500, 1_900, 1_000, 9_000]);
    assert_eq!(intervals(&got[1]), intervals(&got[0]));
}

#[test]
fn unmodelled_input_features_are_refused() {
    let mut t = GpTimer::new("TIM4", 72_000_000);
    let refused = |t: &mut GpTimer, off, v| matches!(t.write(off, v, 0), Some(Err(_)));
    assert!(refused(&mut t, reg::CCMR2, 0b10), "IC3 on TI4");
    assert!(refused(&mut t, reg::CCMR2, 0b11), "IC3 on TRC");
    assert!(
        refused(&mut t, reg::DIER, 1 << 1),
        "CC1IE on an output channel"
    );
    assert!(refused(&mut t, reg::DIER, 1 << 11), "CC3DE (DMA)");
    assert!(
        refused(&mut t, reg::EGR, 1 << 1),
        "CC1G on an output channel"
    );
    // Modelled: input capture with IC3PSC, and CC3IE on it.
    assert!(!refused(&mut t, reg::CCMR2, ccmr2_ic3(3)));
    assert!(!refused(&mut t, reg::DIER, CC3IE | 1));
}
