//! `cargo fil` as a user meets it: bad arguments fail before the board
//! starts (status 2, a message naming what is wrong, nothing on stdout);
//! `--scenario NAME --fault … --plot FILE` flies the release ELF with the
//! fault in the air and writes the plot with its series.

#![allow(clippy::panic, clippy::expect_used, clippy::unwrap_used)]

mod common;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fil-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn fil(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fil"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Fails with status 2 and `msg`, before the board runs (nothing on stdout).
fn refused(args: &[&str], msg: &str) {
    let o = fil(args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    assert!(
        stderr(&o).contains(msg),
        "{args:?}: wanted `{msg}` in {}",
        stderr(&o)
    );
    assert!(o.stdout.is_empty(), "{args:?} did work before failing");
}

#[test]
fn bad_arguments_are_refused_before_the_board_starts() {
    let d = dir("refused");
    refused(&["-f", "magnet@3"], "e.g. `3:magnet`");
    refused(&["-f", "3:nack:baro"], "nack:CHIP:N");
    refused(&["-f", "3:chip-reset:gps"], "unknown chip `gps`");
    refused(&["-f", "3:laser"], "unknown fault kind `laser`");
    refused(
        &["-d", "4", "-f", "5:stuck-bus"],
        "after the end of the 4 s run",
    );
    refused(
        &["--seconds", "4", "-f", "4:stuck-bus"],
        "after the end of the 4 s run",
    );
    refused(&["-f", "1:stuck-bus:mpu:junk"], "junk");
    // `-s` is the seed, as in `cargo sim`; the old seconds get a pointer.
    refused(&["-s", "4.5"], "-d/--duration SECONDS");
    refused(&["-d", "0"], "must be in (0, 3600]");
    refused(&["-t", "moon"], "possible values: rest, spin");
    refused(
        &["--sensors", "perfect"],
        "possible values: noise, datasheet",
    );
    refused(
        &["--sensors", "datasheet", "--scenario", "takeoff"],
        "cannot be used with",
    );
    refused(&["--elf", "/nonexistent/firmware"], "no such file");
    refused(&["--plot", "x.svg"], "--scenario");
    refused(&["--vibration", "2"], "--scenario");
    refused(&["--scenario", "takeoff", "--vibration=-1"], "out of range");
    refused(&["--scenario", "takeoff", "--plot", "-"], "not stdout");
    refused(
        &["--scenario", "takeoff", "--plot", "x.jpg"],
        "unsupported plot format `.jpg`",
    );
    // The ELF itself, spelled differently, with a plot extension.
    let elf_svg = d.join("firmware.svg");
    std::fs::write(&elf_svg, b"not an ELF").unwrap();
    let name = d.file_name().unwrap().to_str().unwrap();
    let other = format!("{}/../{name}/./firmware.svg", d.display());
    refused(
        &[
            "--elf",
            elf_svg.to_str().unwrap(),
            "--scenario",
            "takeoff",
            "--plot",
            &other,
        ],
        "is the firmware ELF",
    );
    assert_eq!(std::fs::read(&elf_svg).unwrap(), b"not an ELF");
    let _ = std::fs::remove_dir_all(d);
}

/// The start-up gyro bias the firmware logs, in counts, from `cargo fil`'s
/// output.
fn logged_bias(args: &[&str]) -> Option<[i64; 3]> {
    let o = fil(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    let line = out.lines().find(|l| l.contains("gyro bias: done: ["))?;
    let inside = line.split("done: [").nth(1)?.split(']').next()?;
    let v: Vec<i64> = inside
        .split(',')
        .filter_map(|x| x.trim().parse().ok())
        .collect();
    v.try_into().ok()
}

/// `--sensors`: noise only (the default) gives the board a zero gyro
/// bias, as README says to expect; the datasheet profile gives it the
/// chip's bias (an MPU-9250's ZRO is up to ±5 °/s: 164 counts at
/// ±1000 °/s, and the seeded draw is not zero).
#[test]
fn the_sensor_profile_sets_the_emulated_chips_errors() {
    if common::elf().is_none() {
        return;
    }
    let noise = logged_bias(&["-d", "2.5"]).expect("a bias line");
    assert!(noise.iter().all(|c| c.abs() <= 1), "{noise:?}");
    let ds = logged_bias(&["-d", "2.5", "--sensors", "datasheet"]).expect("a bias line");
    assert!(ds.iter().any(|c| c.abs() >= 5), "{ds:?}");
    assert!(ds.iter().all(|c| c.abs() <= 200), "{ds:?}");
}

#[test]
fn a_scenario_flies_with_a_fault_in_the_air_and_plots() {
    let Some(elf) = common::elf() else { return };
    let d = dir("plot");
    let plot = d.join("out/takeoff.svg");
    let o = fil(&[
        "--elf",
        elf.to_str().unwrap(),
        "--scenario",
        "takeoff",
        "-d",
        "4.5",
        "--fault",
        "4:nack:baro:20",
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("att r="), "no attitude line in the log");
    assert!(out.contains("[emulator] flight:"), "{out}");
    // The simulator's fault is echoed at its injection time.
    assert!(
        out.contains("[   4.000000] [emulator] fault 4:nack:baro:20 injected"),
        "{out}"
    );
    assert!(stderr(&o).contains("wrote"), "{}", stderr(&o));
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.len() > 10_000, "{} bytes", svg.len());
    for series in [
        "cargo fil: takeoff seed 1",
        "truth",
        "firmware estimate",
        "stick setpoint",
        "PA6 motor 1 (RR)",
        "PB1 motor 4 (FL)",
        "throttle",
        "arm switch",
    ] {
        assert!(svg.contains(series), "no `{series}` in the plot");
    }
    let _ = std::fs::remove_dir_all(d);
}

/// SIGINT during a scenario with `--plot` over an existing file: status
/// 130, the old plot byte-identical, the temporary file removed.
#[test]
fn an_interrupted_flight_leaves_the_existing_plot_intact() {
    let Some(elf) = common::elf() else { return };
    let d = dir("interrupted");
    let plot = d.join("keep.svg");
    std::fs::write(&plot, b"an old plot").unwrap();
    let child = Command::new(env!("CARGO_BIN_EXE_fil"))
        .args(["--elf", elf.to_str().unwrap(), "--scenario", "linkloss"])
        .args(["--plot", plot.to_str().unwrap()])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let count = || std::fs::read_dir(&d).unwrap().count();
    let t0 = std::time::Instant::now();
    while count() < 2 && t0.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert_eq!(count(), 2, "no temporary file beside the plot");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert_eq!(std::fs::read(&plot).unwrap(), b"an old plot");
    assert_eq!(count(), 1, "a temporary file was left behind");
    let _ = std::fs::remove_dir_all(d);
}
