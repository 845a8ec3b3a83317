//! The `sim` binary as a user meets it: bad arguments fail before any work
//! (status 2, a message naming the option), outputs are created with their
//! folders, a closed stdout is not a panic and the files are still written;
//! a failed or interrupted run leaves the existing outputs intact.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sim-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sim"))
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Fails with status 2 and `msg`, quickly (before the calibrations run:
/// nothing on stdout).
fn refused(args: &[&str], msg: &str) {
    let o = sim(args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    assert!(
        stderr(&o).contains(msg),
        "{args:?}: wanted `{msg}` in {}",
        stderr(&o)
    );
    assert!(o.stdout.is_empty(), "{args:?} did work before failing");
}

#[test]
fn bad_values_are_refused_before_work() {
    refused(&["--duration", "0"], "out of range");
    refused(&["--duration", "1e-9"], "out of range");
    refused(&["--duration=nan"], "out of range");
    refused(&["--duration", "-5"], "out of range");
    refused(&["--duration", "100000"], "out of range");
    refused(&["--print-every", "-1"], "out of range");
    refused(&["--print-every", "inf"], "out of range");
    refused(&["--mag-dance", "0"], "out of range");
    refused(&["--seed", "-1"], "--seed");
    refused(&["--trajectory", "moon"], "moon");
    refused(&["--fault", "1:laser"], "unknown fault kind `laser`");
    refused(&["--fault=-1:magnet"], "TIME `-1`");
    refused(&["--fault", "magnet@20"], "e.g. `20:magnet`");
    refused(&["--fault", "3:nack:mpu"], "nack:CHIP:N");
    refused(&["-f", "3:busy-lockup"], "emulated board only");
    refused(&["-d", "10", "--fault", "20:magnet"], "after the end");
    refused(&["--plot", "x.jpg"], "unsupported plot format `.jpg`");
    refused(&["--plot", "noext"], "needs an extension");
    refused(&["--gyro-scale", "0.2"], "outside ±0.1");
    refused(&["--gyro-scale=-0.11"], "outside ±0.1");
    refused(&["--gyro-scale", "3%"], "not a number");
    refused(&["--fault", "3:dipole-ride:2:6800"], "5..=1000 mm");
    refused(&["--vibration", "-1"], "out of range");
    refused(&["--vibration=nan"], "out of range");
    refused(&["--spectrum", "x.jpg"], "unsupported plot format `.jpg`");
    refused(
        &["--spectrum", "x.png", "--scenario", "takeoff"],
        "cannot be used with",
    );
    refused(&["--plot", "-"], "--plot needs a file name");
}

#[test]
fn unwritable_or_clashing_outputs_are_refused_before_work() {
    let d = dir("outs");
    let blocker = d.join("file");
    std::fs::write(&blocker, "x").unwrap();
    // A folder that cannot be created (a file is in the way).
    let under_file = blocker.join("x.png");
    refused(&["--plot", under_file.to_str().unwrap()], "creating folder");
    let under_file = blocker.join("x.csv");
    refused(&["--csv", under_file.to_str().unwrap()], "creating folder");
    let a = d.join("a.png");
    let a2 = d.join(".").join("a.png");
    refused(
        &["--csv", a.to_str().unwrap(), "--plot", a2.to_str().unwrap()],
        "name the same file",
    );
}

#[test]
fn files_are_written_into_new_folders_even_when_stdout_closes() {
    let d = dir("pipe");
    let csv = d.join("new/deeper/run.csv");
    let png = d.join("new/run.png");
    let mut child = Command::new(env!("CARGO_BIN_EXE_sim"))
        .args([
            "-d",
            "3",
            "--mag-dance",
            "10",
            "--print-every",
            "0.1",
            "--fault",
            "2:vibration",
            "--csv",
            csv.to_str().unwrap(),
            "--plot",
            png.to_str().unwrap(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.lines().count() > 2500, "{}", text.lines().count());
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
}

#[test]
fn csv_to_stdout_keeps_status_lines_off_it() {
    let o = sim(&["-d", "2", "--mag-dance", "10", "--csv", "-", "-q"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let mut lines = out.lines();
    assert!(lines.next().unwrap().starts_with("t_s,"));
    assert!(lines.all(|l| l.split(',').count() == 15));
    assert!(stderr(&o).contains("== summary"));
}

#[test]
fn a_closed_loop_scenario_prints_its_figures_and_plots() {
    let d = dir("scenario");
    let plot = d.join("out/linkloss.svg");
    let o = sim(&[
        "--scenario",
        "linkloss",
        "--mag-dance",
        "10",
        "--fault",
        "12:nack:baro:20",
        "--plot",
        plot.to_str().unwrap(),
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for want in [
        "s: fault 12:nack:baro:20",
        "ARMED",
        "failsafe: no link: holding level and the height",
        "failsafe: descending",
        "disarmed: failsafe: landed",
        "hover height error RMS",
        "link lost at",
    ] {
        assert!(out.contains(want), "wanted `{want}` in {out}");
    }
    assert!(std::fs::metadata(&plot).unwrap().len() > 10_000);
    let _ = std::fs::remove_dir_all(d);
}

#[test]
fn a_scenario_refuses_the_open_loop_options() {
    refused(&["--scenario", "hover"], "invalid value");
    refused(
        &["--scenario", "steps", "--duration", "5"],
        "cannot be used with",
    );
    refused(
        &["--scenario", "steps", "--trajectory", "slow"],
        "cannot be used with",
    );
    refused(
        &["--scenario", "steps", "--gyro-scale", "0.03"],
        "cannot be used with",
    );
    refused(
        &["--scenario", "takeoff", "--fault", "30:magnet"],
        "after the end of the 20 s flight",
    );
}

/// The files in `d`, sorted.
fn names(d: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A run that fails leaves the existing plot and CSV byte-identical and no
/// temporary file beside them.
#[test]
fn a_failed_run_leaves_existing_outputs_intact() {
    let d = dir("failed");
    let (png, csv) = (d.join("keep.png"), d.join("keep.csv"));
    std::fs::write(&png, b"an old plot").unwrap();
    std::fs::write(&csv, b"an old csv").unwrap();
    let o = sim(&[
        "-d",
        "3",
        "--mag-dance",
        "10",
        "-q",
        "--fault",
        "0:scl-stuck",
        "--plot",
        png.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(std::fs::read(&png).unwrap(), b"an old plot");
    assert_eq!(std::fs::read(&csv).unwrap(), b"an old csv");
    assert_eq!(names(&d), ["keep.csv", "keep.png"]);
    let _ = std::fs::remove_dir_all(d);
}

/// SIGINT in the middle of a long run (the issue's `timeout -s INT 2 cargo
/// sim -d 3000 --plot keep.png`): status 130, the old plot byte-identical,
/// the temporary file removed.
#[test]
fn an_interrupted_run_leaves_the_existing_plot_intact() {
    let d = dir("interrupted");
    let png = d.join("keep.png");
    std::fs::write(&png, b"an old plot").unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_sim"))
        .args(["-d", "3000", "-q", "--plot", png.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for the temporary file: the outputs are open, the handler is set.
    let t0 = std::time::Instant::now();
    while names(&d).len() < 2 && t0.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert_eq!(names(&d).len(), 2, "no temporary file: {:?}", names(&d));
    std::thread::sleep(std::time::Duration::from_millis(300));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(stderr(&o).contains("interrupted"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&png).unwrap(), b"an old plot");
    assert_eq!(names(&d), ["keep.png"]);
    let _ = std::fs::remove_dir_all(d);
}

/// A scenario that fails (every IMU read fails: no sample to log or plot)
/// leaves the existing plot and CSV byte-identical, no temporary file.
#[test]
fn a_failed_scenario_leaves_existing_outputs_intact() {
    let d = dir("scenario-failed");
    let (png, csv) = (d.join("keep.png"), d.join("keep.csv"));
    std::fs::write(&png, b"an old plot").unwrap();
    std::fs::write(&csv, b"an old csv").unwrap();
    let o = sim(&[
        "--scenario",
        "takeoff",
        "--mag-dance",
        "10",
        "--fault",
        "0:scl-stuck",
        "--plot",
        png.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("no samples"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&png).unwrap(), b"an old plot");
    assert_eq!(std::fs::read(&csv).unwrap(), b"an old csv");
    assert_eq!(names(&d), ["keep.csv", "keep.png"]);
    let _ = std::fs::remove_dir_all(d);
}

/// `--scenario NAME --csv FILE` writes the documented columns (the header
/// `--help` lists), one row per sample, and replaces an old file.
#[test]
fn a_scenario_csv_has_the_documented_columns() {
    let d = dir("scenario-csv");
    let csv = d.join("out/steps.csv");
    std::fs::create_dir_all(d.join("out")).unwrap();
    std::fs::write(&csv, b"an old csv").unwrap();
    let o = sim(&[
        "--scenario",
        "steps",
        "--mag-dance",
        "10",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let help = String::from_utf8_lossy(&sim(&["--help"]).stdout).into_owned();
    let text = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(header.first(), Some(&"t_s"));
    assert_eq!(header.last(), Some(&"events"));
    for name in &header {
        assert!(
            help.contains(&format!("  {name} ")),
            "`{name}` not in --help"
        );
    }
    let out = String::from_utf8_lossy(&o.stdout);
    // The status line `N samples, M CRSF frames ...`.
    let samples: usize = out
        .lines()
        .find_map(|l| l.split_once(" samples, ").and_then(|(n, _)| n.parse().ok()))
        .unwrap();
    assert_eq!(text.lines().count(), samples + 1);
    assert!(text.lines().all(|l| l.split(',').count() == header.len()));
    let _ = std::fs::remove_dir_all(d);
}

/// The scenario CSV to a stdout that closes: no panic, status 0, the
/// status lines on stderr.
#[test]
fn a_scenario_csv_to_a_closed_stdout_is_not_a_panic() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_sim"))
        .args(["--scenario", "takeoff", "--mag-dance", "10", "--csv", "-"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    assert!(stderr(&o).contains("== figures"), "{}", stderr(&o));
}

#[test]
fn the_spectrum_is_drawn_and_its_summary_printed() {
    let d = dir("spectrum");
    let out = d.join("sub").join("spectrum.png");
    let o = sim(&["--spectrum", out.to_str().unwrap(), "--vibration", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("hover:") && text.contains("full throttle:"),
        "{text}"
    );
    assert!(std::fs::metadata(&out).unwrap().len() > 1000);
}

/// `--scenario chirp --csv --bode` measures the rate loop and writes the
/// plot; `--analyse` of that CSV measures it again; the board's raw log is
/// refused with its reason (no setpoint), and `--bode` without a
/// measurement is a usage error.
#[test]
fn the_chirp_is_measured_and_its_csv_can_be_analysed() {
    let d = dir("chirp");
    std::fs::create_dir_all(&d).unwrap();
    let (csv, bode) = (d.join("chirp.csv"), d.join("bode.png"));
    let o = sim(&[
        "--scenario",
        "chirp",
        "--mag-dance",
        "10",
        "--csv",
        csv.to_str().unwrap(),
        "--bode",
        bode.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(out.contains("== rate loop: chirp seed 1 =="), "{out}");
    assert!(std::fs::metadata(&bode).unwrap().len() > 10_000);
    let again = sim(&["--analyse", csv.to_str().unwrap()]);
    assert_eq!(again.status.code(), Some(0), "{}", stderr(&again));
    let text = String::from_utf8_lossy(&again.stdout).into_owned();
    for axis in ["roll ", "pitch ", "yaw "] {
        assert!(text.lines().any(|l| l.starts_with(axis)), "{text}");
    }
    let raw = d.join("raw.csv");
    std::fs::write(
        &raw,
        format!(
            "{}\n0.01,0,0,0,0,0,9.8,1,2,3,nan,nan,nan,nan,0\n",
            sensor_stack::calmode::RAW_LOG_HEADER
        ),
    )
    .unwrap();
    let refused = sim(&["--analyse", raw.to_str().unwrap()]);
    assert_eq!(refused.status.code(), Some(1));
    assert!(
        stderr(&refused).contains("no rate setpoint"),
        "{}",
        stderr(&refused)
    );
    let usage = sim(&["--scenario", "steps", "--bode", bode.to_str().unwrap()]);
    assert_eq!(usage.status.code(), Some(2), "{}", stderr(&usage));
    // The input is never the output.
    let same = sim(&[
        "--analyse",
        csv.to_str().unwrap(),
        "--bode",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(same.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(d);
}

#[test]
fn a_settings_file_from_the_boards_console_is_flown_and_a_bad_line_refused() {
    let d = dir("settings");
    let file = d.join("diff.txt");
    let rise = |o: &Output| -> f64 {
        let out = String::from_utf8_lossy(&o.stdout);
        let line = out
            .lines()
            .find(|l| l.starts_with("roll (estimate) step"))
            .unwrap();
        let at = line.find("rise (10-90 %) ").unwrap() + "rise (10-90 %) ".len();
        line[at..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let board = sim(&["--scenario", "steps", "-q"]);
    // Half the level loop's gain: the angle step rises about twice as slowly.
    std::fs::write(&file, "# the board's `diff`\nset level.p 6.0 # 1/s\n").unwrap();
    let slower = sim(&[
        "--scenario",
        "steps",
        "-q",
        "--settings",
        file.to_str().unwrap(),
    ]);
    assert_eq!(slower.status.code(), Some(0), "{}", stderr(&slower));
    let (r0, r1) = (rise(&board), rise(&slower));
    assert!(r1 > 1.6 * r0, "rise {r0} s → {r1} s");
    std::fs::write(&file, "set level.p 6.0\nset level.p 99\n").unwrap();
    let bad = sim(&["--scenario", "steps", "--settings", file.to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(stderr(&bad).contains("line 2: error"), "{}", stderr(&bad));
    assert!(bad.stdout.is_empty(), "flew before refusing");
    let _ = std::fs::remove_dir_all(d);
}
