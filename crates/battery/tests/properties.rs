//! Property tests: the conversions against exact arithmetic, the sag
//! filter against its `f64` reference, and the monitor's invariants over
//! arbitrary readings.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use battery::*;
use proptest::prelude::*;

/// Runs of equal readings (steady stretches, dropouts, steps), expanded.
fn runs() -> impl Strategy<Value = Vec<u16>> {
    prop::collection::vec((0u16..4300, 1usize..40), 1..40).prop_map(|rs| {
        rs.into_iter()
            .flat_map(|(c, n)| std::iter::repeat_n(c, n))
            .collect()
    })
}

/// The sag filter's `f64` reference: k = dt/(τ + dt), τ by direction.
fn reference_step(y: f64, x: f64) -> f64 {
    let dt = f64::from(SAMPLE_PERIOD_MS);
    let tau = if x < y {
        SAG_FALL_TAU_MS
    } else {
        SAG_RISE_TAU_MS
    };
    y + dt / (f64::from(tau) + dt) * (x - y)
}

proptest! {
    #[test]
    fn counts_to_mv_is_exact_to_half_a_millivolt(
        fs in Scale::MIN_FULL_SCALE_MV..=Scale::MAX_FULL_SCALE_MV,
        c in 0u16..=4095,
    ) {
        let s = Scale::new(fs).unwrap();
        let exact = f64::from(c) * f64::from(fs) / 4096.0;
        prop_assert!((f64::from(s.counts_to_mv(c)) - exact).abs() <= 0.5);
        if c > 0 {
            prop_assert!(s.counts_to_mv(c - 1) <= s.counts_to_mv(c));
        }
    }

    #[test]
    fn a_calibrated_scale_reads_the_meter_back_within_1_mv(
        c in MIN_CALIBRATION_COUNTS..ADC_MAX_COUNT,
        fs_target in Scale::MIN_FULL_SCALE_MV..=Scale::MAX_FULL_SCALE_MV,
    ) {
        // A meter reading that some valid divider would give at `c`.
        let mv = (u64::from(c) * u64::from(fs_target) / 4096) as u32;
        match scale_from_reading(c, mv) {
            Ok(s) => prop_assert!(s.counts_to_mv(c).abs_diff(mv) <= 1),
            // Rounding may take a reading at the edge just outside.
            Err(Error::ScaleOutOfRange { full_scale_mv }) => prop_assert!(
                full_scale_mv.abs_diff(fs_target) <= 4096 / u32::from(c) + 1
            ),
            Err(e) => prop_assert!(false, "{e}"),
        }
    }

    #[test]
    fn the_sag_filter_follows_its_f64_reference(
        start in 1000u16..4095,
        readings in prop::collection::vec(400u16..=4095, 1..400),
    ) {
        let mut m = BatteryMonitor::new(Config::DEFAULT).unwrap();
        for _ in 0..SETTLE_SAMPLES {
            m.update(start);
        }
        let mut y = f64::from(start);
        for &c in &readings {
            m.update(c);
            y = reference_step(y, f64::from(c));
            let mv = y * 36_300.0 / 4096.0;
            // The Q16 state's rounding, a few LSB of a count, plus the mV rounding.
            prop_assert!((f64::from(m.status().filtered_mv) - mv).abs() <= 1.0,
                "{} vs {mv}", m.status().filtered_mv);
        }
    }

    #[test]
    fn the_monitor_keeps_its_invariants(readings in runs()) {
        let mut m = BatteryMonitor::new(Config::DEFAULT).unwrap();
        let mut level = Level::NoBattery;
        let (mut lo, mut hi) = (u32::MAX, 0);
        for &c in &readings {
            let event = m.update(c);
            let s = m.status();
            let mv = Scale::DEFAULT.counts_to_mv(c);
            if mv >= PRESENT_MV {
                lo = lo.min(mv);
                hi = hi.max(mv);
            }
            // No pack ⇔ no cells; cells within 1..=8 otherwise.
            prop_assert_eq!(s.level == Level::NoBattery, s.cells == 0);
            prop_assert!(s.cells <= MAX_CELLS);
            if s.cells > 0 {
                // The filtered voltage stays within what was read since the
                // pack was last absent.
                prop_assert!(s.filtered_mv + 1 >= lo && s.filtered_mv <= hi + 1);
                prop_assert_eq!(s.filtered_cell_mv, s.filtered_mv / u32::from(s.cells));
            }
            // The level only falls with a disconnection (the latch).
            match event {
                Some(Event::Disconnected) => {
                    prop_assert_eq!(s.level, Level::NoBattery);
                    (lo, hi) = (u32::MAX, 0);
                }
                Some(Event::Raised(l)) => prop_assert!(l > level && l == s.level),
                _ => prop_assert!(s.level >= level),
            }
            if s.level == Level::NoBattery && event.is_none() && level != Level::NoBattery {
                prop_assert!(false, "level cleared without a disconnection");
            }
            level = s.level;
        }
    }

    #[test]
    fn the_descent_happens_only_when_the_rule_allows_it(
        steps in prop::collection::vec(
            (0u8..4, any::<[bool; 4]>(), any::<[i32; 4]>()), 1..200),
    ) {
        let mut g = LowBatteryDescent::new(DescentConfig::DEFAULT).unwrap();
        for (lv, [armed, in_air, altitude_available, link_ok], s) in steps {
            let level = [Level::NoBattery, Level::Ok, Level::Warning, Level::Critical][usize::from(lv)];
            let ctx = FlightContext { armed, in_air, altitude_available, link_ok };
            let sticks = SticksQ30 { roll_q30: s[0], pitch_q30: s[1], yaw_q30: s[2], throttle_q30: s[3] };
            let was = g.phase();
            let a = g.update(level, &ctx, &sticks);
            if let BatteryAction::Descend { descent_mps_q16 } = a {
                prop_assert_eq!(descent_mps_q16, DescentConfig::DEFAULT.descent_mps_q16);
                prop_assert!(level == Level::Critical && armed && altitude_available);
                let descending = matches!(was, DescentPhase::Descending { .. });
                prop_assert!(in_air || descending);
                prop_assert!(was != DescentPhase::PilotControl);
            }
            // Below critical the action never touches the controls.
            if level < Level::Critical {
                let descends = matches!(a, BatteryAction::Descend { .. });
                prop_assert!(!descends);
            }
        }
    }
}
