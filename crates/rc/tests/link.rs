//! Signal-loss detection: timeouts, link quality, timer wrap, and the
//! recovery window before a link counts as up again.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use rc_input::{
    ConfigError, LinkMonitor, LinkStatus, CRSF_TIMEOUT_US, LINK_RECOVERY_US, PPM_TIMEOUT_US,
};

/// ExpressLRS' common frame period (250 Hz), µs.
const FRAME_US: u32 = 4_000;

/// Frames every [`FRAME_US`] from `from_us` while `t < until_us`, with the
/// status asked every 1 ms; returns the first time the link was up, if any.
fn frames(m: &mut LinkMonitor, from_us: u32, until_us: u32) -> Option<u32> {
    let mut up = None;
    let mut t = from_us;
    while t.wrapping_sub(from_us) < until_us.wrapping_sub(from_us) {
        if t.wrapping_sub(from_us).is_multiple_of(FRAME_US) {
            m.on_frame(t);
        }
        if up.is_none() && !m.is_lost(t) {
            up = Some(t);
        }
        t = t.wrapping_add(1_000);
    }
    up
}

/// A monitor without the recovery window: the first frame gives the link.
fn no_window() -> LinkMonitor {
    LinkMonitor::crsf().with_recovery_us(0)
}

#[test]
fn lost_until_the_first_frame() {
    let mut m = no_window();
    assert_eq!(m.status(0), LinkStatus::NeverReceived);
    assert!(m.is_lost(1_000_000));
    m.on_frame(1_000_000);
    assert!(!m.is_lost(1_000_000));
}

#[test]
fn the_first_link_up_waits_for_the_recovery_window() {
    let mut m = LinkMonitor::crsf();
    assert_eq!(m.recovery_us(), LINK_RECOVERY_US);
    m.on_frame(1_000_000);
    assert_eq!(m.status(1_000_000), LinkStatus::Recovering);
    let up = frames(&mut m, 1_000_000 + FRAME_US, 3_000_000);
    assert_eq!(up, Some(1_000_000 + LINK_RECOVERY_US));
}

#[test]
fn lost_exactly_after_the_timeout() {
    let mut m = no_window();
    m.on_frame(5_000);
    assert!(!m.is_lost(5_000 + CRSF_TIMEOUT_US));
    assert_eq!(m.status(5_001 + CRSF_TIMEOUT_US), LinkStatus::TimedOut);
    // Recovered by the next good frame (no window).
    m.on_frame(300_000);
    assert!(!m.is_lost(300_010));
    assert_eq!(m.losses(), 1);
}

#[test]
fn after_a_loss_control_comes_back_only_after_the_window() {
    let mut m = LinkMonitor::crsf();
    assert_eq!(frames(&mut m, 0, 1_000_000), Some(LINK_RECOVERY_US));
    // 150 ms without frames: lost.
    assert_eq!(m.status(1_150_000), LinkStatus::TimedOut);
    let back = 1_150_000;
    m.on_frame(back);
    assert_eq!(m.status(back), LinkStatus::Recovering);
    let up = frames(&mut m, back + FRAME_US, back + 2 * LINK_RECOVERY_US);
    assert_eq!(up, Some(back + LINK_RECOVERY_US));
    assert_eq!(m.losses(), 1);
}

#[test]
fn a_link_flapping_100_ms_on_100_ms_off_never_gives_control_back() {
    let mut m = LinkMonitor::crsf();
    let mut t = 0u32;
    let mut seen = [false; 5];
    for _ in 0..50 {
        // 100 ms of frames (25 at 250 Hz), the status asked every 1 ms ...
        assert_eq!(frames(&mut m, t, t + 100_000), None, "up at {t} µs");
        seen[m.status(t + 100_000 - 1) as usize] = true;
        // ... then 100 ms of nothing (a gap of 104 ms between frames).
        for dt in (0..100_000).step_by(1_000) {
            assert!(m.is_lost(t + 100_000 + dt));
        }
        t += 200_000;
    }
    assert!(seen[LinkStatus::Recovering as usize]);
    // Steady frames from then on: up exactly one window after the first.
    assert_eq!(frames(&mut m, t, t + 1_000_000), Some(t + LINK_RECOVERY_US));
}

#[test]
fn a_flapping_link_restarts_the_window_even_when_nobody_asks_in_the_gaps() {
    let mut m = LinkMonitor::crsf();
    let mut t = 0u32;
    for _ in 0..20 {
        for k in 0..25 {
            m.on_frame(t + k * FRAME_US);
            assert!(m.is_lost(t + k * FRAME_US));
        }
        t += 200_000;
    }
    assert!(m.losses() >= 19, "{}", m.losses());
}

#[test]
fn gaps_within_the_timeout_do_not_restart_the_window() {
    let mut m = LinkMonitor::crsf();
    frames(&mut m, 0, 200_000);
    // 96 ms from the last frame to the next: within the 100 ms timeout.
    assert_eq!(frames(&mut m, 292_000, 700_000), Some(LINK_RECOVERY_US));
    assert_eq!(m.losses(), 0);
}

#[test]
fn the_ppm_monitor_has_the_same_window() {
    let mut m = LinkMonitor::ppm();
    assert_eq!(m.timeout_us(), PPM_TIMEOUT_US);
    let mut t = 0u32;
    while m.is_lost(t) {
        if t.is_multiple_of(22_500) {
            m.on_frame(t);
        }
        t += 500;
    }
    // The first frame at 0, up at the first check at or after 0.5 s.
    assert_eq!(t, LINK_RECOVERY_US);
}

#[test]
fn timeout_across_the_timer_wrap() {
    let mut m = no_window();
    let t0 = u32::MAX - 30_000;
    m.on_frame(t0);
    assert!(!m.is_lost(t0.wrapping_add(60_000)));
    assert!(m.is_lost(t0.wrapping_add(100_001)));
}

#[test]
fn the_window_runs_across_the_timer_wrap_and_stays_latched() {
    let mut m = LinkMonitor::crsf();
    let t0 = u32::MAX - 200_000;
    let up = frames(&mut m, t0, t0.wrapping_add(1_000_000));
    assert_eq!(up, Some(t0.wrapping_add(LINK_RECOVERY_US)));
    // Frames for 71.6 minutes, until the time since the run began has
    // wrapped round to less than the window: the link stays up.
    let mut t = t0.wrapping_add(1_000_000);
    for _ in 0..(u32::MAX - 900_000) / FRAME_US + 1 {
        t = t.wrapping_add(FRAME_US);
        m.on_frame(t);
    }
    assert!(t.wrapping_sub(t0) < LINK_RECOVERY_US);
    assert_eq!(m.status(t), LinkStatus::Ok);
}

#[test]
fn a_loss_stays_latched_after_the_counter_wraps_around() {
    let mut m = no_window();
    m.on_frame(0);
    assert!(m.is_lost(200_000));
    // 71.6 minutes later the raw age would look small again.
    assert!(m.is_lost(10));
}

#[test]
fn a_frame_stamped_just_after_now_is_fresh() {
    let mut m = no_window();
    m.on_frame(1_000);
    // The caller read its clock at 990, then the receive interrupt ran.
    assert!(!m.is_lost(990));
}

#[test]
fn zero_link_quality_is_a_loss_even_with_frames() {
    let mut m = no_window();
    m.on_frame(0);
    m.on_link_quality(0);
    m.on_frame(10_000); // Crossfire keeps sending failsafe channel values
    assert_eq!(m.status(10_000), LinkStatus::NoLinkQuality);
    m.on_link_quality(0);
    m.on_link_quality(70);
    m.on_frame(14_000);
    assert!(!m.is_lost(14_000));
    assert_eq!(m.losses(), 1);
}

#[test]
fn after_zero_link_quality_the_window_starts_with_the_next_frame() {
    let mut m = LinkMonitor::crsf();
    assert_eq!(frames(&mut m, 0, 600_000), Some(LINK_RECOVERY_US));
    m.on_link_quality(0);
    // Failsafe channel values keep coming for 1 s: they start no run.
    frames(&mut m, 600_000, 1_600_000);
    assert_eq!(m.status(1_600_000), LinkStatus::NoLinkQuality);
    m.on_link_quality(80);
    assert_eq!(m.status(1_600_000), LinkStatus::Recovering);
    let up = frames(&mut m, 1_600_000, 2_600_000);
    assert_eq!(up, Some(1_600_000 + LINK_RECOVERY_US));
}

#[test]
fn timeout_is_validated() {
    assert_eq!(LinkMonitor::new(0), Err(ConfigError::ZeroTimeout));
    let m = LinkMonitor::new(50_000).unwrap();
    assert_eq!(m.timeout_us(), 50_000);
    assert_eq!(m.recovery_us(), LINK_RECOVERY_US);
}
