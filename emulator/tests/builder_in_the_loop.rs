//! The STM32F103CB build's builder features on the emulated board, with
//! the release ELF built with `--features f103cb` (`FIL_ELF`; `scripts/check`
//! builds it into `cb-build/`): the battery run down to the low-battery
//! descent and landing, the CRSF telemetry frames a receiver reads off
//! PA9, and the settings console over the RTT down channel (set, save,
//! restart, kept; power cut during the save). Skipped, with a message,
//! when the firmware under test is a C8 build and `FIL_ELF` is unset.
#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use common::rigs::rig_with;
use common::*;
use emulator::rig::{FlightRig, RigOptions};
use emulator::{Board, Firmware, ResetCause};
use rc_input::telemetry::{decode_telemetry, TelemetryFrame};
use sim::scenario::Scenario;

/// The firmware under test is the CB build (its flash plan is 128 KiB);
/// otherwise skipped (or a failure when `FIL_ELF` names another build).
fn is_cb() -> bool {
    let Some(path) = elf() else {
        return false;
    };
    let fw = Firmware::load(&path).expect("ELF");
    if fw.flash.len() == 128 * 1024 {
        return true;
    }
    if std::env::var_os("FIL_ELF").is_some() {
        panic!("FIL_ELF is not the f103cb build: {}", path.display());
    }
    println!("skipped: the firmware under test is a C8 build (set FIL_ELF to the f103cb build)");
    false
}

/// The low-battery flight; at 10 s, armed and hovering, the pilot's
/// laptop types `set` and `save` into the console.
fn low_battery_flight() -> Option<FlightRig> {
    if !is_cb() {
        return None;
    }
    let mut r = rig_with(RigOptions::new(Scenario::LowBattery, 1))?;
    if let Err(e) = r.run_until_s(10.0) {
        panic!("{e}\n{}", tail(r.board(), 30));
    }
    let typed = b"set rate.roll.p 0.3\nsave\n";
    assert_eq!(r.board_mut().rtt_write_down(0, typed).unwrap(), typed.len());
    if let Err(e) = r.fly() {
        panic!("{e}\n{}", tail(r.board(), 30));
    }
    Some(r)
}

/// The simulated time (s) of the first log line containing `pat`.
fn line_s(b: &Board, pat: &str) -> f64 {
    let l = b.log_lines().iter().find(|l| l.text.contains(pat));
    let l = l.unwrap_or_else(|| panic!("no {pat:?}\n{}", tail(b, 30)));
    l.host_time_ns as f64 * 1e-9
}

/// Whether a frame is of one kind.
type FrameTest = fn(&TelemetryFrame) -> bool;

/// The CRSF frames in the bytes the USART sent, with the time each began.
fn frames(b: &mut Board) -> Vec<(f64, TelemetryFrame)> {
    let tx = b.usart1_tx_log().to_vec();
    let mut out = Vec::new();
    let mut i = 0;
    while i + 2 < tx.len() {
        let len = usize::from(tx[i + 1].byte);
        let Some(bytes) = tx.get(i..i + len + 2) else {
            break;
        };
        let raw: Vec<u8> = bytes.iter().map(|t| t.byte).collect();
        assert_eq!(
            raw[0],
            0xC8,
            "frame {} starts with {:#x}",
            out.len(),
            raw[0]
        );
        let f = decode_telemetry(&raw).unwrap_or_else(|e| panic!("{e:?}: {raw:02x?}"));
        out.push((tx[i].start_ns as f64 * 1e-9, f));
        i += len + 2;
    }
    out
}

#[test]
fn a_low_pack_warns_then_descends_and_lands_on_the_board() {
    let Some(r) = low_battery_flight() else {
        return;
    };
    let b = r.board();
    let connected = line_s(b, "battery: 3S (Detected)");
    let (warn, crit) = (
        line_s(b, "battery: Warning"),
        line_s(b, "battery: CRITICAL"),
    );
    let descent = line_s(b, "battery: low-battery descent");
    let landed = line_s(b, "disarmed: landed");
    assert!(
        connected < 1.0 && connected < warn && warn < crit,
        "{connected} {warn} {crit}"
    );
    // In the same 10 Hz step as the critical level (logged just before it).
    assert!(
        (descent - crit).abs() < 0.1,
        "descent at {descent} s, critical {crit} s"
    );
    // The pack was below each threshold, loaded, for at least the 3 s
    // hold before the level was raised.
    let cells = 3.0;
    for (t, cell_v) in [(warn, 3.5), (crit, 3.3)] {
        let last_above = r
            .samples()
            .iter()
            .rfind(|s| s.t_s < t && s.quad.battery_voltage_v >= cell_v * cells)
            .map_or(0.0, |s| s.t_s);
        assert!(
            (3.0..12.0).contains(&(t - last_above)),
            "{t} s: above until {last_above} s"
        );
    }
    let height = |t: f64| {
        let s = r.samples().iter().find(|s| s.t_s >= t).unwrap();
        -s.truth.position_ned_m[2]
    };
    assert!(
        height(crit - 0.5) > 1.5,
        "held until critical: {} m",
        height(crit - 0.5)
    );
    let rate = (height(descent + 1.5) - height(descent + 3.0)) / 1.5;
    assert!((rate - 0.5).abs() < 0.15, "descent {rate} m/s");
    assert!(landed > descent);
    // The console refused both while armed: nothing saved, no restart.
    let refused = lines_after(b, 10 * S, "armed: disarm first");
    assert_eq!(refused.len(), 2, "{}", tail(b, 30));
    assert!(lines_with(b, "saved (").is_empty());
    assert_no_reset(b);
    // Never disarmed in the air: every pulse off is on the ground.
    for s in r.samples().iter().filter(|s| s.t_s > 4.0 && s.t_s < landed) {
        assert!(
            s.pulse_us.iter().any(|p| p.is_some_and(|us| us > 1010.0)) || s.quad.on_ground,
            "motors off in the air at {} s",
            s.t_s
        );
    }
}

#[test]
fn telemetry_frames_leave_pa9_at_5_hz_each_with_the_crafts_state() {
    let Some(mut r) = low_battery_flight() else {
        return;
    };
    let f = frames(r.board_mut());
    let count = |t0: f64, t1: f64, kind: FrameTest| {
        f.iter()
            .filter(|(t, x)| *t >= t0 && *t < t1 && kind(x))
            .count() as f64
            / (t1 - t0)
    };
    let kinds: [(&str, FrameTest); 4] = [
        ("battery", |x| matches!(x, TelemetryFrame::Battery { .. })),
        ("attitude", |x| matches!(x, TelemetryFrame::Attitude { .. })),
        ("baro", |x| matches!(x, TelemetryFrame::BaroAltitude { .. })),
        ("mode", |x| matches!(x, TelemetryFrame::FlightMode { .. })),
    ];
    for (name, k) in kinds {
        let hz = count(8.0, 18.0, k);
        assert!(hz >= 5.0, "{name}: {hz} Hz");
    }
    // Each frame against the truth at its time.
    let at = |t: f64| r.samples().iter().find(|s| s.t_s >= t).unwrap();
    let mut checked = [0; 3];
    for (t, x) in f.iter().filter(|(t, _)| (8.0..18.0).contains(t)) {
        let s = at(*t);
        match *x {
            TelemetryFrame::Battery { voltage_dv, .. } => {
                // The sag filter follows the lightest recent load: within
                // 0.5 V of the pack under load, never far below it.
                let v = f64::from(voltage_dv) / 10.0;
                assert!((v - s.quad.battery_voltage_v).abs() < 0.6, "{v} V at {t} s");
                checked[0] += 1;
            }
            TelemetryFrame::Attitude {
                roll_e4_rad,
                pitch_e4_rad,
                ..
            } => {
                let [roll, pitch, _] = s.truth.q_ned_from_body.to_euler();
                let e = |a: i16, b: f64| (f64::from(a) * 1e-4 - b).abs().to_degrees();
                assert!(
                    e(roll_e4_rad, roll) < 3.0 && e(pitch_e4_rad, pitch) < 3.0,
                    "at {t} s"
                );
                checked[1] += 1;
            }
            TelemetryFrame::BaroAltitude { altitude_dm, .. } => {
                let h = f64::from(altitude_dm) / 10.0;
                assert!(
                    (h + s.truth.position_ned_m[2]).abs() < 0.5,
                    "{h} m at {t} s"
                );
                checked[2] += 1;
            }
            TelemetryFrame::FlightMode { text, len } => {
                assert_eq!(&text[..len], b"ALTH", "at {t} s");
            }
        }
    }
    assert!(checked.iter().all(|&n| n >= 50), "{checked:?}");
    // The frames leave by DMA: the 1 kHz loop keeps every sample.
    let loops: Vec<_> = r
        .board()
        .log_lines()
        .iter()
        .filter(|l| (8.5e9..18e9).contains(&(l.host_time_ns as f64)) && l.text.contains("loop:"))
        .map(|l| (field(&l.text, "loop:"), l.text.clone()))
        .collect();
    assert!(loops.len() >= 8, "{} loop lines", loops.len());
    for (runs, text) in loops {
        assert!(runs >= 990, "{text}");
    }
}

/// `PARAMS_B`'s offset in the CB's flash (`memory-cb.x`).
const PARAMS_B: usize = 0x1_F400;

/// A board with the CB build, booted to its console.
fn console_board() -> Option<Board> {
    if !is_cb() {
        return None;
    }
    let mut b = board()?;
    b.wait_for_line("settings:", 2 * S)
        .unwrap()
        .expect("settings line");
    Some(b)
}

/// Types `line` into the console; the first log line after it with `pat`.
fn type_line(b: &mut Board, line: &str, pat: &str) -> String {
    let n = b.rtt_write_down(0, format!("{line}\n").as_bytes()).unwrap();
    assert_eq!(n, line.len() + 1, "the down channel took {n} bytes");
    let got = b.wait_for_line(pat, S).unwrap();
    got.unwrap_or_else(|| panic!("{line:?}: no {pat:?}\n{}", tail(b, 10)))
        .text
}

#[test]
fn the_console_sets_saves_and_keeps_a_value_across_a_restart() {
    let Some(mut b) = console_board() else {
        return;
    };
    let got = type_line(&mut b, "get rate.roll.p", "rate.roll.p");
    assert!(got.starts_with("set rate.roll.p 0.2500"), "{got}");
    let err = type_line(&mut b, "set rate.roll.p 9", "error");
    assert!(
        err.contains("rate.roll.p") && err.contains("2.0000"),
        "{err}"
    );
    type_line(&mut b, "set rate.roll.p 0.3", "set rate.roll.p 0.3000");
    type_line(&mut b, "save", "saved (PARAMS_A)");
    let restarted = b
        .wait_for_line("settings: loaded from PARAMS_A", 2 * S)
        .unwrap();
    assert!(restarted.is_some(), "{}", tail(&b, 10));
    assert!(b.resets().iter().any(|(_, c)| *c != ResetCause::PowerOn));
    let got = type_line(&mut b, "get rate.roll.p", "rate.roll.p");
    assert!(got.starts_with("set rate.roll.p 0.3000"), "{got}");
    let diff = type_line(&mut b, "diff", "set ");
    assert_eq!(diff, "set rate.roll.p 0.3000");
}

#[test]
fn a_power_cut_during_a_save_keeps_the_old_or_the_new_values() {
    if !is_cb() {
        return;
    }
    // A first save (0.3) so that PARAMS_A holds a record, then a second
    // (0.4, into PARAMS_B) cut at points through its erase (20-40 ms CPU
    // stall) and programming: each reboot reads one of the two values,
    // never the defaults and never garbage. (Every cut point of the
    // storage code, with undefined cells, is params' host test.)
    let mut seen = std::collections::BTreeSet::new();
    let mut partial = 0;
    // Every 4 ms over the console's poll (50 ms), the erase and the
    // programming (98 half-words).
    for cut_ms in (0..=120).step_by(4) {
        let mut b = console_board().unwrap();
        type_line(&mut b, "set rate.roll.p 0.3", "set rate.roll.p");
        type_line(&mut b, "save", "saved");
        b.wait_for_line("settings: loaded", 2 * S).unwrap().unwrap();
        type_line(&mut b, "set rate.roll.p 0.4", "set rate.roll.p");
        b.rtt_write_down(0, b"save\n").unwrap();
        let t = b.now_ns() + cut_ms * MS;
        run_until(&mut b, t);
        let page = &b.flash_image()[PARAMS_B..PARAMS_B + 1024];
        let programmed = page.chunks(2).filter(|h| h != &[0xFF, 0xFF]).count();
        println!("cut at {cut_ms} ms: PARAMS_B has {programmed} half-words programmed");
        if (1..98).contains(&programmed) {
            partial += 1;
        }
        b.reset(ResetCause::PowerOn).unwrap();
        let l = b.wait_for_line("settings:", 2 * S).unwrap().unwrap();
        assert!(
            l.text.contains("loaded from"),
            "cut at {cut_ms} ms: {}",
            l.text
        );
        let got = type_line(&mut b, "get rate.roll.p", "rate.roll.p");
        let v = got.split_whitespace().nth(2).unwrap().to_string();
        assert!(v == "0.3000" || v == "0.4000", "cut at {cut_ms} ms: {got}");
        seen.insert(v);
    }
    // The cuts span the save: some before it completed, some after, and
    // some in the middle of its programming.
    assert_eq!(seen.len(), 2, "{seen:?}");
    assert!(partial >= 1, "no cut fell inside the programming");
}

#[test]
fn saved_settings_apply_at_boot_a_level_trim_tilts_the_estimate() {
    let Some(mut b) = console_board() else {
        return;
    };
    // 3° right side down: a level board then reads 3° left side down.
    type_line(&mut b, "set trim.roll 3", "set trim.roll 3.00");
    type_line(&mut b, "save", "saved");
    b.wait_for_line("settings: loaded", 2 * S).unwrap().unwrap();
    let t = b.now_ns();
    run_until(&mut b, t + 3 * S);
    let att = lines_after(&b, t + 2 * S, "att r=");
    let roll = attitude(att.last().expect("att line")).expect("roll")[0];
    assert!((roll + 3.0).abs() < 0.3, "roll {roll}° with the trim");
}

/// The raw log's rate columns (CB build) during the chirp's roll sweep:
/// (t_s, setpoint °/s, gyro °/s) of each row in the window.
fn raw_log_roll(b: &Board, t0: f64, t1: f64) -> Vec<(f64, f64, f64)> {
    let header = format!(
        "{},{}",
        sensor_stack::calmode::RAW_LOG_HEADER,
        sensor_stack::calmode::RATE_LOG_COLUMNS
    );
    let names: Vec<&str> = header.split(',').collect();
    let col = |n: &str| names.iter().position(|h| *h == n).unwrap();
    let (ct, csp, cg) = (col("t_s"), col("sp_roll_rate_dps"), col("gyro_roll_dps"));
    assert!(
        b.log_lines().iter().any(|l| l.text == header),
        "no raw-log header with the rate columns\n{}",
        tail(b, 20)
    );
    let rows = b.log_lines().iter().filter_map(|l| {
        let f: Vec<f64> = l
            .text
            .split(',')
            .map(|c| c.parse().unwrap_or(f64::NAN))
            .collect();
        (f.len() == names.len()).then(|| (f[ct], f[csp], f[cg]))
    });
    rows.filter(|r| r.0 >= t0 && r.0 < t1).collect()
}

#[test]
fn the_raw_log_of_a_chirp_gives_the_rate_loops_margins() {
    if !is_cb() {
        return;
    }
    let Some(mut r) = rig_with(RigOptions::new(Scenario::Chirp, 1)) else {
        return;
    };
    // In altitude hold before the sweeps: a short press, raw-log mode.
    let fly = |r: &mut FlightRig, t: f64| {
        r.run_until_s(t)
            .unwrap_or_else(|e| panic!("{e}\n{}", tail(r.board(), 30)))
    };
    fly(&mut r, 7.0);
    r.board_mut().apply(emulator::BoardFault::Button(true));
    fly(&mut r, 7.1);
    r.board_mut().apply(emulator::BoardFault::Button(false));
    let (t0, t1) = sim::rate_loop::chirp_window_s(0);
    fly(&mut r, t1 + 0.5);
    // The board's clock and the log's t_s start together at reset.
    let rows = raw_log_roll(r.board(), t0, t1);
    let fs = (rows.len() - 1) as f64 / (rows[rows.len() - 1].0 - rows[0].0);
    assert!((fs - 100.0).abs() < 1.0, "{fs} rows a second");
    let rad = |d: f64| d.to_radians();
    let signals = sim::rate_loop::AxisSignals {
        setpoint_rps: rows.iter().map(|x| rad(x.1)).collect(),
        gyro_rps: rows.iter().map(|x| rad(x.2)).collect(),
    };
    let rep = sim::rate_loop::analyse_axis("roll", &signals, fs).unwrap();
    let m = &rep.margins;
    println!("raw log, roll: {m:?}");
    // The figures of the 1 kHz analysis of the same loop (README:
    // crossover 6.5 Hz, phase margin 63°, Ms 1.79 on the board), from the
    // log a real flight leaves, at 100 Hz.
    let fc = m.crossover_hz.unwrap();
    assert!((4.5..8.5).contains(&fc), "crossover {fc} Hz");
    assert!(m.phase_margin_deg.unwrap() >= 45.0 && m.ms <= 2.0, "{m:?}");
}
