//! The monitor's rules, reading by reading at 10 Hz: presence, the cell
//! count at connection, the sag filter's time constants, the hold times and
//! the latch.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use battery::*;

/// The ADC reading of a pack at `mv` on the default divider, rounded.
fn counts(mv: u32) -> u16 {
    ((u64::from(mv) * 4096 + 36_300 / 2) / 36_300) as u16
}

fn monitor() -> BatteryMonitor {
    BatteryMonitor::new(Config::DEFAULT).unwrap()
}

/// Feeds `n` readings of `mv`; the events in order, with the reading's index.
fn feed(m: &mut BatteryMonitor, mv: u32, n: usize) -> Vec<(usize, Event)> {
    (0..n)
        .filter_map(|i| m.update(counts(mv)).map(|e| (i, e)))
        .collect()
}

/// A monitor with a pack at `pack_mv` connected and settled.
fn connected(cfg: Config, pack_mv: u32) -> BatteryMonitor {
    let mut m = BatteryMonitor::new(cfg).unwrap();
    let events = feed(&mut m, pack_mv, usize::from(SETTLE_SAMPLES));
    assert!(
        matches!(events[..], [(4, Event::Connected { .. })]),
        "{events:?}"
    );
    m
}

#[test]
fn no_battery_means_no_warnings() {
    let mut m = monitor();
    // A board on USB: 0 V, or a little leakage below the 2.5 V threshold.
    for mv in [0, 300, 2_400] {
        assert!(feed(&mut m, mv, 600).is_empty());
        let s = m.status();
        assert_eq!(s.level, Level::NoBattery);
        assert_eq!((s.cells, s.filtered_mv, s.filtered_cell_mv), (0, 0, 0));
        assert_eq!(m.filtered_counts(), None);
    }
}

#[test]
fn cells_are_detected_for_charged_and_storage_packs() {
    for n in 1..=8u32 {
        for cell_mv in [4_200, 3_850] {
            let mut m = monitor();
            let events = feed(&mut m, n * cell_mv, 5);
            assert_eq!(events.len(), 1, "{n}S at {cell_mv} mV");
            let Event::Connected { cells, source, .. } = events[0].1 else {
                panic!("{events:?}");
            };
            assert_eq!((u32::from(cells), source), (n, CellSource::Detected));
            assert_eq!(m.status().level, Level::Ok);
        }
    }
}

#[test]
fn known_misdetections_of_the_rule() {
    // mV / 4300 + 1 is one short below 4.3·(n−1)/n a cell, one over above
    // 4.3 V a cell: why it runs at connection only, and why it can be set.
    assert_eq!(cells_from_mv(4 * 3_200, 4_300), 3); // 4S below 3.23 V a cell
    assert_eq!(cells_from_mv(6 * 3_500, 4_300), 5); // 6S below 3.58 V a cell
    assert_eq!(cells_from_mv(3 * 4_350, 4_300), 4); // 3S LiHV at 4.35 V
    assert_eq!(cells_from_mv(3 * 4_350, 4_400), 3); // ... with 4.40 V set
    assert_eq!(cells_from_mv(0, 4_300), 1);
    assert_eq!(cells_from_mv(u32::MAX, 4_300), MAX_CELLS);
}

#[test]
fn detection_is_limited_to_eight_cells() {
    // A 24:1 divider (80 V at full scale) reading 45 V: 45 / 4.3 + 1 = 11.
    let cfg = Config {
        scale: Scale::new(80_000).unwrap(),
        ..Config::DEFAULT
    };
    let mut m = BatteryMonitor::new(cfg).unwrap();
    let c = (45_000u32 * 4096 / 80_000) as u16;
    let mut last = None;
    for _ in 0..5 {
        last = m.update(c).or(last);
    }
    assert!(matches!(last, Some(Event::Connected { cells: 8, .. })));
}

#[test]
fn the_override_sets_the_cell_count() {
    let cfg = Config {
        cells_override: 4,
        ..Config::DEFAULT
    };
    let mut m = BatteryMonitor::new(cfg).unwrap();
    // A 4S pack run down to 3.0 V a cell would detect as 3S.
    let events = feed(&mut m, 12_000, 5);
    assert!(matches!(
        events[..],
        [(
            4,
            Event::Connected {
                cells: 4,
                source: CellSource::Configured,
                ..
            }
        )]
    ));
    assert_eq!(m.status().cells, 4);
}

#[test]
fn detection_waits_for_five_steady_readings() {
    let mut m = monitor();
    // Contact bounce: 16.0 V, then 15.5 V (0.5 V apart) restarts the window.
    assert_eq!(m.update(counts(16_000)), None);
    assert_eq!(m.update(counts(16_000)), None);
    assert_eq!(m.update(counts(15_500)), None);
    let events = feed(&mut m, 15_600, 5);
    // The window restarted at 15.5 V: four more readings complete it.
    assert!(matches!(
        events[..],
        [(3, Event::Connected { cells: 4, pack_mv, .. })] if pack_mv.abs_diff(15_580) < 10
    ));
    // A reading below presence during settling starts again from scratch.
    let mut m = monitor();
    feed(&mut m, 16_000, 4);
    m.update(0);
    assert_eq!(feed(&mut m, 16_000, 4), vec![]);
    assert_eq!(m.status().level, Level::NoBattery);
}

#[test]
fn cells_are_not_detected_again_while_connected() {
    let mut m = connected(Config::DEFAULT, 4 * 4_100);
    // The pack runs down to 3.0 V a cell (12.0 V: 3S by the rule) and
    // recovers; it stays 4S.
    for mv in (12_000..=16_400).rev().step_by(100) {
        feed(&mut m, mv, 10);
        assert_eq!(m.status().cells, 4);
    }
    feed(&mut m, 15_000, 100);
    assert_eq!(m.status().cells, 4);
}

#[test]
fn a_short_dropout_is_skipped_and_five_readings_disconnect() {
    let mut m = connected(Config::DEFAULT, 15_200);
    let before = m.status();
    assert_eq!(feed(&mut m, 0, 4), vec![]);
    // Nothing of the dropout reached the filter or the hold counts.
    assert_eq!(m.status().filtered_mv, before.filtered_mv);
    assert_eq!(m.status().raw_mv, 0);
    assert_eq!(feed(&mut m, 15_200, 1), vec![]);
    assert_eq!(m.status().filtered_mv, before.filtered_mv);
    assert_eq!(feed(&mut m, 0, 5), vec![(4, Event::Disconnected)]);
    assert_eq!(m.status().level, Level::NoBattery);
    assert_eq!(m.status().cells, 0);
}

#[test]
fn a_pack_below_the_warning_raises_it_after_the_hold() {
    // 4S at 3.45 V a cell: below 3.50 from the first reading after settling.
    let mut m = connected(Config::DEFAULT, 4 * 3_450);
    assert!(m.status().filtered_cell_mv < 3_500);
    let events = feed(&mut m, 4 * 3_450, 100);
    // 3 s at 10 Hz: the 30th reading below (index 29).
    assert_eq!(events, vec![(29, Event::Raised(Level::Warning))]);
    assert_eq!(m.status().level, Level::Warning);
}

#[test]
fn a_pack_below_critical_raises_critical_after_its_hold() {
    let cfg = Config {
        warning_hold_ms: 2_000,
        ..Config::DEFAULT
    };
    let mut m = connected(cfg, 4 * 3_250);
    let events = feed(&mut m, 4 * 3_250, 100);
    assert_eq!(
        events,
        vec![
            (19, Event::Raised(Level::Warning)),
            (29, Event::Raised(Level::Critical))
        ]
    );
}

#[test]
fn hold_times_round_up_to_whole_readings() {
    let cfg = Config {
        warning_hold_ms: 150,
        ..Config::DEFAULT
    };
    let mut m = connected(cfg, 4 * 3_450);
    assert_eq!(
        feed(&mut m, 4 * 3_450, 10),
        vec![(1, Event::Raised(Level::Warning))]
    );
}

#[test]
fn the_hold_restarts_when_the_voltage_comes_back() {
    let mut m = connected(Config::DEFAULT, 4 * 3_450);
    // 29 readings below, one short of the hold.
    assert_eq!(feed(&mut m, 4 * 3_450, 29), vec![]);
    // Back up: the filter rises at once (0.5 s time constant).
    assert_eq!(feed(&mut m, 4 * 3_800, 1), vec![]);
    assert!(m.status().filtered_cell_mv >= 3_500);
    // Down again: the count starts over at the first reading below.
    let mut first_below = None;
    let mut raised = None;
    for i in 0..200 {
        let e = m.update(counts(4 * 3_450));
        if first_below.is_none() && m.status().filtered_cell_mv < 3_500 {
            first_below = Some(i);
        }
        if let Some(e) = e {
            raised = Some((i, e));
            break;
        }
    }
    let first = first_below.unwrap();
    assert_eq!(raised, Some((first + 29, Event::Raised(Level::Warning))));
}

#[test]
fn levels_stay_latched_until_the_pack_is_disconnected() {
    let mut m = connected(Config::DEFAULT, 4 * 3_250);
    feed(&mut m, 4 * 3_250, 30);
    assert_eq!(m.status().level, Level::Critical);
    // The pack rests and recovers to 3.7 V a cell: still critical.
    assert_eq!(feed(&mut m, 4 * 3_700, 600), vec![]);
    assert_eq!(m.status().level, Level::Critical);
    assert!(m.status().filtered_cell_mv > 3_690);
    // A new pack: disconnected, then a charged one connected.
    feed(&mut m, 0, 5);
    let events = feed(&mut m, 4 * 4_150, 100);
    assert!(matches!(
        events[..],
        [(4, Event::Connected { cells: 4, .. })]
    ));
    assert_eq!(m.status().level, Level::Ok);
}

#[test]
fn the_filter_falls_with_4_s_and_rises_with_half_a_second() {
    let mut m = connected(Config::DEFAULT, 16_000);
    // A step down of 2 V: after 4 s (40 readings) 1 − 1/e of it (63 %).
    feed(&mut m, 14_000, 40);
    let fell = 16_000.0 - f64::from(m.status().filtered_mv);
    assert!((fell / 2_000.0 - 0.632).abs() < 0.02, "{fell}");
    // Settled, then a step up of 2 V: 63 % of it after 0.5 s.
    feed(&mut m, 14_000, 400);
    assert!(m.status().filtered_mv.abs_diff(14_000) <= 10);
    feed(&mut m, 16_000, 5);
    let rose = f64::from(m.status().filtered_mv) - 14_000.0;
    assert!((rose / 2_000.0 - 0.632).abs() < 0.04, "{rose}");
    // Held, the input is reached (no deadband to the count).
    feed(&mut m, 16_000, 200);
    assert_eq!(m.filtered_counts(), Some(counts(16_000)));
    assert_eq!(
        m.status().raw_mv,
        Scale::DEFAULT.counts_to_mv(counts(16_000))
    );
}

#[test]
fn new_settings_restart_the_detection() {
    let mut m = connected(Config::DEFAULT, 4 * 3_250);
    feed(&mut m, 4 * 3_250, 30);
    assert_eq!(m.status().level, Level::Critical);
    let counts_now = m.filtered_counts().unwrap();
    // Calibrated: the meter says 13.10 V where the board read 13.0.
    let scale = scale_from_reading(counts_now, 13_100).unwrap();
    m.set_config(Config {
        scale,
        ..Config::DEFAULT
    })
    .unwrap();
    assert_eq!(m.status().level, Level::NoBattery);
    let events = feed(&mut m, 4 * 3_250, 5);
    assert!(matches!(
        events[..],
        [(4, Event::Connected { cells: 4, pack_mv, .. })] if pack_mv.abs_diff(13_100) <= 1
    ));
    // A refused setting leaves the monitor as it was.
    let before = m.clone();
    let bad = Config {
        critical_cell_mv: 3_600,
        ..Config::DEFAULT
    };
    assert_eq!(
        m.set_config(bad),
        Err(Error::Setting(Setting::CriticalCellVoltage))
    );
    assert_eq!(m, before);
}

#[test]
fn settings_out_of_range_are_refused() {
    type Change = fn(&mut Config);
    let cases: [(Change, Setting); 10] = [
        (|c| c.cells_override = 9, Setting::CellsOverride),
        (|c| c.max_cell_mv = 3_999, Setting::MaxCellVoltage),
        (|c| c.max_cell_mv = 4_501, Setting::MaxCellVoltage),
        (|c| c.warning_cell_mv = 2_999, Setting::WarningCellVoltage),
        (|c| c.warning_cell_mv = 4_001, Setting::WarningCellVoltage),
        (|c| c.critical_cell_mv = 2_799, Setting::CriticalCellVoltage),
        (|c| c.critical_cell_mv = 3_500, Setting::CriticalCellVoltage),
        (|c| c.warning_hold_ms = 99, Setting::WarningHold),
        (|c| c.warning_hold_ms = 30_001, Setting::WarningHold),
        (|c| c.critical_hold_ms = 0, Setting::CriticalHold),
    ];
    for (change, setting) in cases {
        let mut cfg = Config::DEFAULT;
        change(&mut cfg);
        assert_eq!(
            BatteryMonitor::new(cfg).unwrap_err(),
            Error::Setting(setting)
        );
        assert!(!Error::Setting(setting).to_string().is_empty());
    }
    assert!(BatteryMonitor::new(Config::DEFAULT).is_ok());
    assert_eq!(Config::default(), Config::DEFAULT);
}
