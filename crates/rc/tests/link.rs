//! Signal-loss detection: timeouts, link quality, timer wrap.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use rc_input::{ConfigError, LinkMonitor, LinkStatus, CRSF_TIMEOUT_US};

#[test]
fn lost_until_the_first_frame() {
    let mut m = LinkMonitor::crsf();
    assert_eq!(m.status(0), LinkStatus::NeverReceived);
    assert!(m.is_lost(1_000_000));
    m.on_frame(1_000_000);
    assert!(!m.is_lost(1_000_000));
}

#[test]
fn lost_exactly_after_the_timeout() {
    let mut m = LinkMonitor::crsf();
    m.on_frame(5_000);
    assert!(!m.is_lost(5_000 + CRSF_TIMEOUT_US));
    assert_eq!(m.status(5_001 + CRSF_TIMEOUT_US), LinkStatus::TimedOut);
    // Recovered by the next good frame.
    m.on_frame(300_000);
    assert!(!m.is_lost(300_010));
    assert_eq!(m.losses(), 1);
}

#[test]
fn timeout_across_the_timer_wrap() {
    let mut m = LinkMonitor::ppm();
    let t0 = u32::MAX - 30_000;
    m.on_frame(t0);
    assert!(!m.is_lost(t0.wrapping_add(60_000)));
    assert!(m.is_lost(t0.wrapping_add(100_001)));
}

#[test]
fn a_loss_stays_latched_after_the_counter_wraps_around() {
    let mut m = LinkMonitor::crsf();
    m.on_frame(0);
    assert!(m.is_lost(200_000));
    // 71.6 minutes later the raw age would look small again.
    assert!(m.is_lost(10));
}

#[test]
fn a_frame_stamped_just_after_now_is_fresh() {
    let mut m = LinkMonitor::crsf();
    m.on_frame(1_000);
    // The caller read its clock at 990, then the receive interrupt ran.
    assert!(!m.is_lost(990));
}

#[test]
fn zero_link_quality_is_a_loss_even_with_frames() {
    let mut m = LinkMonitor::crsf();
    m.on_frame(0);
    m.on_link_quality(0);
    m.on_frame(10_000); // Crossfire keeps sending failsafe channel values
    assert_eq!(m.status(10_000), LinkStatus::NoLinkQuality);
    m.on_link_quality(0);
    m.on_link_quality(70);
    assert!(!m.is_lost(10_000));
    assert_eq!(m.losses(), 1);
}

#[test]
fn timeout_is_validated() {
    assert_eq!(LinkMonitor::new(0), Err(ConfigError::ZeroTimeout));
    let m = LinkMonitor::new(50_000).unwrap();
    assert_eq!(m.timeout_us(), 50_000);
}
