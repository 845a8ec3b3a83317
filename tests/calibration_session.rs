//! The firmware's button / mode / calibration state machine
//! (`sensor_stack::calmode::CalSession`) and the raw-log row, host-tested: the
//! button decoding into modes, a figure-eight and a six-position session
//! run to completion with the result written into the calibration record,
//! an abort, and the raw-log column order.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use sensor_stack::calmode::{
    AccelCalibrator, CalEvent, CalSession, MagCalibrator, MagMinMaxMode, Mode, NotBuilt, RawLogRow,
    LONG_PRESS_MS, RAW_LOG_HEADER,
};
use sensor_stack::storage::{CalibrationRecord, ValidParts};

type Session = CalSession<MagMinMaxMode>;

/// Holds the button for `ms` starting at `t`, sampling it every 50 ms as
/// the log task does; returns the events and the time after release.
fn press<M: MagCalibrator, A: AccelCalibrator>(
    s: &mut CalSession<M, A>,
    t: &mut u32,
    ms: u32,
) -> Vec<CalEvent> {
    let mut ev = Vec::new();
    let end = *t + ms;
    while *t < end {
        ev.extend(s.on_button(*t, true));
        *t += 50;
    }
    for _ in 0..3 {
        ev.extend(s.on_button(*t, false));
        *t += 50;
    }
    ev
}

#[test]
fn button_selects_the_modes() {
    let mut s = Session::new(false);
    let mut t = 0;
    assert_eq!(s.mode(), Mode::Normal);
    assert!(!s.wants().raw_log && !s.wants().mag_ut && !s.wants().accel_g);
    // Short press: raw log on, and off again.
    let ev = press(&mut s, &mut t, 200);
    assert_eq!(
        ev,
        [CalEvent::ModeChanged {
            from: Mode::Normal,
            to: Mode::RawLog
        }]
    );
    assert!(s.wants().raw_log);
    press(&mut s, &mut t, 200);
    assert_eq!(s.mode(), Mode::Normal);
    // Long press: magnetometer calibration (reported while still held).
    let ev = press(&mut s, &mut t, LONG_PRESS_MS + 300);
    assert_eq!(
        ev,
        [CalEvent::ModeChanged {
            from: Mode::Normal,
            to: Mode::MagCal
        }]
    );
    assert!(s.wants().mag_ut);
    // Any press aborts a calibration; nothing is written.
    let mut rec = CalibrationRecord::default();
    s.push_mag([30.0, 0.0, 0.0]);
    press(&mut s, &mut t, 200);
    assert_eq!(s.mode(), Mode::Normal);
    assert_eq!(s.poll(&mut rec), None);
    assert_eq!(rec, CalibrationRecord::default());
    // Held at boot: accelerometer calibration.
    let s = Session::new(true);
    assert_eq!(s.mode(), Mode::AccelCal);
    assert!(s.wants().accel_g);
}

/// The flight build's session ([`NotBuilt`] for both calibrations): the
/// button held at boot and a long press are refused with the mode they
/// asked for, the mode stays normal and no samples are asked for; the raw
/// log still toggles; nothing is ever written into the record.
#[test]
fn a_build_without_calibrations_refuses_them_and_keeps_the_raw_log() {
    type Flight = CalSession<NotBuilt, NotBuilt>;
    let s = Flight::new(true);
    assert!(s.refused_at_boot());
    assert_eq!(s.mode(), Mode::Normal);
    assert!(!Flight::new(false).refused_at_boot());
    let mut s = Flight::new(false);
    let mut t = 0;
    let ev = press(&mut s, &mut t, LONG_PRESS_MS + 300);
    assert_eq!(
        ev,
        [CalEvent::Unavailable {
            wanted: Mode::MagCal
        }]
    );
    assert_eq!(s.mode(), Mode::Normal);
    let w = s.wants();
    assert!(!w.mag_ut && !w.accel_g && !w.raw_log);
    let mut rec = CalibrationRecord::default();
    s.push_mag([30.0, 0.0, 0.0]);
    s.push_accel([0.0, 0.0, 1.0]);
    for _ in 0..100 {
        assert_eq!(s.poll(&mut rec), None);
    }
    assert_eq!(rec, CalibrationRecord::default());
    let ev = press(&mut s, &mut t, 200);
    assert_eq!(
        ev,
        [CalEvent::ModeChanged {
            from: Mode::Normal,
            to: Mode::RawLog
        }]
    );
    assert!(s.wants().raw_log);
}

#[test]
fn releasing_the_button_held_at_boot_keeps_the_accelerometer_calibration() {
    let mut s = Session::new(true);
    let mut t = 0;
    // Still held for a few seconds after reset (longer than a long press),
    // then let go: neither is a press.
    let mut ev = Vec::new();
    while t < 3 * LONG_PRESS_MS {
        ev.extend(s.on_button(t, true));
        t += 50;
    }
    for _ in 0..10 {
        ev.extend(s.on_button(t, false));
        t += 50;
    }
    assert_eq!(ev, []);
    assert_eq!(s.mode(), Mode::AccelCal);
    // The next press is a real one: it aborts.
    press(&mut s, &mut t, 200);
    assert_eq!(s.mode(), Mode::Normal);
}

#[test]
fn figure_eight_session_writes_the_hard_iron_into_the_record() {
    let mut s = Session::new(false);
    s.on_press(sensor_stack::calmode::Press::Long);
    assert_eq!(s.mode(), Mode::MagCal);
    let offset = [12.0f32, -7.0, 30.0];
    let field = 48.0f32;
    let mut rec = CalibrationRecord::default();
    let mut progress = Vec::new();
    let mut done = None;
    // 100 Hz samples on a brisk tumble (min/max needs the extremes before
    // its 300 samples are in); the log task polls at 20 Hz.
    for i in 0..2_000u32 {
        let a = i as f32 * 0.37;
        let b = i as f32 * 0.113;
        let dir = [a.cos() * b.cos(), a.sin() * b.cos(), b.sin()];
        s.push_mag([0, 1, 2].map(|k| offset[k] + field * dir[k]));
        if i % 5 == 0 {
            match s.poll(&mut rec) {
                Some(CalEvent::MagProgress(p)) => progress.push(p.percent),
                Some(e @ CalEvent::MagDone { .. }) => {
                    done = Some(e);
                    break;
                }
                Some(e) => panic!("unexpected {e:?}"),
                None => {}
            }
        }
    }
    let Some(CalEvent::MagDone { offset_ut }) = done else {
        panic!("not done; progress {progress:?}")
    };
    for k in 0..3 {
        assert!((offset_ut[k] - offset[k]).abs() < 2.0, "{offset_ut:?}");
        assert_eq!(rec.mag_offset_ut[k], offset_ut[k]);
    }
    assert!(rec.valid.has(ValidParts::MAG));
    assert!(!rec.valid.has(ValidParts::ACCEL));
    // Progress was reported and only ever grew; the session is over.
    assert!(!progress.is_empty() && progress.windows(2).all(|w| w[0] <= w[1]));
    assert_eq!(s.mode(), Mode::Normal);
    assert!(!s.wants().mag_ut);
}

#[test]
fn six_position_session_writes_offset_and_scale() {
    let mut s = Session::new(true);
    let offset = [0.02f32, -0.03, 0.05];
    let scale = [1.01f32, 0.98, 1.02];
    let mut rec = CalibrationRecord::default();
    let mut done = None;
    let mut n = 0u32;
    // Raw reading = true / scale + offset, for each face down in turn.
    'faces: for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            for i in 0..400 {
                let mut g = [0.0f32; 3];
                g[axis] = sign;
                let noise = ((i % 7) as f32 - 3.0) * 0.001;
                s.push_accel([0, 1, 2].map(|k| g[k] / scale[k] + offset[k] + noise));
                n += 1;
                if n.is_multiple_of(5) {
                    match s.poll(&mut rec) {
                        Some(e @ CalEvent::AccelDone { .. }) => {
                            done = Some(e);
                            break 'faces;
                        }
                        Some(CalEvent::AccelProgress(_)) | None => {}
                        Some(e) => panic!("unexpected {e:?}"),
                    }
                }
            }
        }
    }
    let Some(CalEvent::AccelDone {
        offset_g,
        scale: got,
    }) = done
    else {
        panic!("six positions not completed")
    };
    for k in 0..3 {
        assert!((offset_g[k] - offset[k]).abs() < 2e-3, "{offset_g:?}");
        assert!((got[k] - scale[k]).abs() < 2e-3, "{got:?}");
    }
    assert_eq!(rec.accel_offset_g, offset_g);
    assert_eq!(rec.accel_scale, got);
    assert!(rec.valid.has(ValidParts::ACCEL));
    assert_eq!(s.mode(), Mode::Normal);
}

#[test]
fn raw_log_columns_follow_the_header() {
    let row = RawLogRow {
        t_s: 1.5,
        gyr_rps: [0.1, 0.2, 0.3],
        acc_mps2: [1.0, 2.0, 3.0],
        mag_ut: [10.0, f32::NAN, 30.0],
    };
    let names: Vec<&str> = RAW_LOG_HEADER.split(',').collect();
    let cols = row.columns();
    assert_eq!(names.len(), cols.len() + 5); // 4 reference columns + moving
    let expect = [
        ("t_s", 1.5),
        ("gyr_x_rad_s", 0.1),
        ("gyr_z_rad_s", 0.3),
        ("acc_y_m_s2", 2.0),
        ("mag_x_ut", 10.0),
        ("mag_z_ut", 30.0),
    ];
    for (name, v) in expect {
        let i = names.iter().position(|n| *n == name).unwrap();
        assert_eq!(cols[i], v, "{name}");
    }
    let mut csv = String::new();
    row.write_csv(&mut csv).unwrap();
    assert_eq!(csv, "1.5,0.1,0.2,0.3,1,2,3,10,nan,30,nan,nan,nan,nan,0");
    assert_eq!(csv.split(',').count(), names.len());
}

#[test]
fn min_max_calibrator_starts_with_the_firmware_thresholds() {
    let m = MagMinMaxMode::start().unwrap();
    let p = MagCalibrator::progress(&m);
    assert_eq!((p.samples, p.percent), (0, 0));
    assert!(!MagCalibrator::ready(&m));
}
