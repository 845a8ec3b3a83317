//! ESC pulse widths and timer values for the Blue Pill's 72 MHz timer clock.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::field_reassign_with_default
)]

use control::esc::{pulse_ns, EscError, EscProtocol, EscTimer, MIN_STEPS};
use proptest::prelude::*;

const TIM_CLK_HZ: u32 = 72_000_000;

#[test]
fn pwm_400hz_at_1mhz_tick() {
    // PSC 71: 1 MHz tick, one count per µs.
    let t = EscTimer::new(EscProtocol::Pwm, 400, TIM_CLK_HZ, 71).unwrap();
    assert_eq!(t.tick_hz(), 1_000_000);
    assert_eq!(t.auto_reload(), 2_499);
    assert_eq!(t.period_ns(), 2_500_000);
    assert_eq!(t.off_compare(), 1_000);
    assert_eq!(t.compare(0.0), 1_000);
    assert_eq!(t.compare(0.5), 1_500);
    assert_eq!(t.compare(1.0), 2_000);
    assert_eq!(t.compare(2.0), 2_000);
    assert_eq!(t.compare(-1.0), 1_000);
    assert_eq!(t.compare(f32::NAN), t.off_compare());
}

#[test]
fn oneshot125_at_full_clock() {
    let t = EscTimer::for_clock(EscProtocol::OneShot125, 2_000, TIM_CLK_HZ).unwrap();
    assert_eq!(t.prescaler(), 0);
    assert_eq!(t.auto_reload(), 35_999); // 500 µs
    assert_eq!(t.off_compare(), 9_000); // 125 µs × 72 ticks/µs
    assert_eq!(t.compare(1.0), 18_000); // 250 µs
    assert_eq!(t.pulse_ns(t.compare(0.5)), 187_500);
}

#[test]
fn pwm_for_clock_picks_finest_prescaler() {
    let t = EscTimer::for_clock(EscProtocol::Pwm, 400, TIM_CLK_HZ).unwrap();
    // 180 000 ticks per frame at PSC 0 do not fit: PSC 2 gives 60 000.
    assert_eq!(t.prescaler(), 2);
    assert_eq!(u32::from(t.auto_reload()) + 1, 60_000);
    assert_eq!(t.pulse_ns(t.off_compare()), 1_000_000);
    assert_eq!(t.pulse_ns(t.compare(1.0)), 2_000_000);
}

#[test]
fn refuses_bad_setups() {
    use EscProtocol::*;
    assert_eq!(
        EscTimer::new(Pwm, 0, TIM_CLK_HZ, 71),
        Err(EscError::InvalidRate)
    );
    assert_eq!(
        EscTimer::new(Pwm, 500, TIM_CLK_HZ, 71),
        Err(EscError::InvalidRate)
    );
    assert_eq!(
        EscTimer::new(OneShot125, 4_000, TIM_CLK_HZ, 0),
        Err(EscError::InvalidRate)
    );
    assert_eq!(EscTimer::new(Pwm, 400, 0, 71), Err(EscError::InvalidClock));
    assert_eq!(
        EscTimer::new(Pwm, 400, TIM_CLK_HZ, 0),
        Err(EscError::PeriodTooLong)
    );
    // 72 MHz / 7200 = 10 kHz tick: 10 steps for OneShot125's 125 µs range.
    assert_eq!(
        EscTimer::new(OneShot125, 1_000, TIM_CLK_HZ, 7_199),
        Err(EscError::ResolutionTooLow)
    );
}

#[test]
fn off_is_the_bottom_of_the_range() {
    assert_eq!(pulse_ns(EscProtocol::Pwm, 0.0), 1_000_000);
    assert_eq!(pulse_ns(EscProtocol::Pwm, 1.0), 2_000_000);
    assert_eq!(pulse_ns(EscProtocol::OneShot125, 0.0), 125_000);
    assert_eq!(pulse_ns(EscProtocol::OneShot125, 1.0), 250_000);
    assert_eq!(pulse_ns(EscProtocol::OneShot125, f32::NAN), 125_000);
}

proptest! {
    #[test]
    fn compare_is_monotonic_and_in_range(a in 0.0f32..1.0, b in 0.0f32..1.0, rate in 50u32..490) {
        let t = EscTimer::for_clock(EscProtocol::Pwm, rate, TIM_CLK_HZ).unwrap();
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        prop_assert!(t.compare(lo) <= t.compare(hi));
        prop_assert!(t.compare(lo) >= t.off_compare());
        prop_assert!(u32::from(t.compare(hi)) < t.period_ticks());
        prop_assert!(u32::from(t.compare(1.0) - t.off_compare()) >= MIN_STEPS);
        // Within one tick of the ideal pulse.
        let ideal = pulse_ns(EscProtocol::Pwm, hi) as f64;
        let tick_ns = 1e9 / t.tick_hz() as f64;
        prop_assert!((t.pulse_ns(t.compare(hi)) as f64 - ideal).abs() <= tick_ns + 1.0);
    }
}
