//! The `replay` binary as a user meets it: one test per bad input (exit
//! status and message), batches, outputs, pipes.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::{file, row, rows, HEADER, LEVEL};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// A fresh folder for one test.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("replay-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(path: &Path, text: &str) -> PathBuf {
    std::fs::write(path, text).unwrap();
    path.to_path_buf()
}

fn replay(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_replay"))
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs on one file with `text`; returns the output.
fn on(name: &str, text: &str, extra: &[&str]) -> Output {
    let d = dir(name);
    let f = write(&d.join("in.csv"), text);
    let mut args = vec![f.to_str().unwrap()];
    args.extend_from_slice(extra);
    replay(&args)
}

fn assert_fails(o: &Output, code: i32, msg: &str) {
    assert_eq!(o.status.code(), Some(code), "{}", stderr(o));
    assert!(stderr(o).contains(msg), "wanted `{msg}` in:\n{}", stderr(o));
    assert!(!stderr(o).contains("panicked"), "{}", stderr(o));
}

fn field(r: &str, col: usize, v: &str) -> String {
    let mut f: Vec<&str> = r.split(',').collect();
    f[col] = v;
    f.join(",")
}

fn corrupt(col: usize, v: &str) -> String {
    let mut r = rows(200, 0.0);
    r[50] = field(&r[50], col, v);
    file(&r)
}

#[test]
fn good_file_scores_and_exits_0() {
    let o = on("good", &file(&rows(300, 0.0)), &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("MEAN over 1 file(s)"), "{}", stdout(&o));
}

#[test]
fn non_finite_and_impossible_samples_fail_naming_line_and_column() {
    let cases = [
        (
            1,
            "nan",
            "line 52, column `gyr_x_rad_s`: not a finite number",
        ),
        (
            4,
            "inf",
            "line 52, column `acc_x_m_s2`: not a finite number",
        ),
        (7, "1e30", "line 52, column `mag_x_ut`"),
    ];
    for (col, v, msg) in cases {
        assert_fails(&on("nonfinite", &corrupt(col, v), &[]), 1, msg);
    }
    let o = on("skip", &corrupt(1, "nan"), &["--skip-invalid"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("skipped 1 invalid row(s) of 200"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_timestamps_fail() {
    assert_fails(
        &on("nant", &corrupt(0, "nan"), &[]),
        1,
        "line 52, column `t_s`: not a finite time",
    );
    let ms: Vec<String> = (0..100).map(|i| row(f64::from(i) * 10.0, LEVEL)).collect();
    assert_fails(
        &on("ms", &file(&ms), &[]),
        1,
        "timestamps look like milliseconds",
    );
    let eq: Vec<String> = (0..100).map(|_| row(1.0, LEVEL)).collect();
    assert_fails(&on("eq", &file(&eq), &[]), 1, "does not increase");
    let mut rev = rows(100, 0.0);
    rev.reverse();
    assert_fails(&on("rev", &file(&rev), &[]), 1, "does not increase");
}

#[test]
fn a_million_seconds_of_uptime_scores_like_zero() {
    let at0 = stdout(&on("t0", &file(&rows(300, 0.0)), &[]));
    let at1e6 = stdout(&on("t1e6", &file(&rows(300, 1.0e6)), &[]));
    let mean = |s: &str| s.lines().last().unwrap().to_string();
    assert_eq!(mean(&at0), mean(&at1e6));
}

#[test]
fn header_only_and_one_row_fail() {
    assert_fails(
        &on("hdr", &format!("{HEADER}\n"), &[]),
        1,
        "followed by 0 data row(s)",
    );
    assert_fails(
        &on("one", &file(&rows(1, 0.0)), &[]),
        1,
        "followed by 1 data row(s)",
    );
    assert_fails(&on("empty", "", &[]), 1, "empty file");
}

#[test]
fn bad_options_fail_before_reading() {
    let good = file(&rows(50, 0.0));
    assert_fails(&on("beta", &good, &["--beta", "-1"]), 2, "-1 is below 0");
    assert_fails(
        &on("betanan", &good, &["--beta=nan"]),
        2,
        "not a finite number",
    );
    assert_fails(
        &on("tol", &good, &["--accel-norm-tol", "2"]),
        2,
        "not in (0, 1]",
    );
    assert_fails(&on("filter", &good, &["--filter", "kalman"]), 2, "kalman");
    assert_fails(&replay(&["/nonexistent/x.csv"]), 2, "/nonexistent/x.csv");
    assert_fails(&replay(&[]), 2, "FILE.csv");
}

#[test]
fn out_never_overwrites_an_input() {
    let d = dir("outin");
    let text = file(&rows(50, 0.0));
    let f = write(&d.join("rec.csv"), &text);
    let alias = d.join(".").join("rec.csv");
    let o = replay(&[f.to_str().unwrap(), "--out", alias.to_str().unwrap()]);
    assert_fails(&o, 2, "refusing to overwrite a recording");
    assert_eq!(std::fs::read_to_string(&f).unwrap(), text);
}

#[test]
fn same_file_name_in_two_folders_gets_two_outputs() {
    let d = dir("names");
    std::fs::create_dir_all(d.join("a")).unwrap();
    std::fs::create_dir_all(d.join("b")).unwrap();
    write(&d.join("a/rec.csv"), &file(&rows(50, 0.0)));
    write(&d.join("b/rec.csv"), &file(&rows(60, 0.0)));
    let o = Command::new(env!("CARGO_BIN_EXE_replay"))
        .current_dir(&d)
        .args(["a/rec.csv", "b/rec.csv", "--out", "est/q.csv"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let a = std::fs::read_to_string(d.join("est/q_a_rec.csv")).unwrap();
    let b = std::fs::read_to_string(d.join("est/q_b_rec.csv")).unwrap();
    assert_eq!((a.lines().count(), b.lines().count()), (51, 61));
}

#[test]
fn a_bad_file_does_not_stop_the_batch() {
    let d = dir("batch");
    let good1 = write(&d.join("good1.csv"), &file(&rows(300, 0.0)));
    let bad = write(&d.join("bad.csv"), &corrupt(1, "nan"));
    let good2 = write(&d.join("good2.csv"), &file(&rows(300, 0.0)));
    let o = replay(&[
        good1.to_str().unwrap(),
        bad.to_str().unwrap(),
        good2.to_str().unwrap(),
        "--out",
        d.join("q.csv").to_str().unwrap(),
    ]);
    assert_fails(&o, 1, "1 file(s) failed");
    assert!(stdout(&o).contains("MEAN over 2 file(s)"), "{}", stdout(&o));
    assert!(d.join("q_good1.csv").exists() && d.join("q_good2.csv").exists());
    assert!(!d.join("q_bad.csv").exists());
}

/// `--out` says what it wrote (path, rows) on stderr, and each quaternion
/// is in its reference's hemisphere: a reference of −identity (the same
/// rotation as +identity) gets estimates with w < 0, +identity with w > 0.
#[test]
fn out_says_what_it_wrote_in_the_reference_hemisphere() {
    let d = dir("hemisphere");
    for (name, reference, sign) in [("plus", LEVEL, 1.0), ("minus", [-1.0, 0.0, 0.0, 0.0], -1.0)] {
        let rows: Vec<String> = (0..50).map(|i| row(i as f64 * 0.01, reference)).collect();
        let input = write(&d.join(format!("{name}.csv")), &file(&rows));
        let out = d.join(format!("{name}-q.csv"));
        let o = replay(&[input.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let said = format!("wrote {}: 50 rows", out.display());
        assert!(stderr(&o).contains(&said), "{}", stderr(&o));
        let text = std::fs::read_to_string(&out).unwrap();
        for line in text.lines().skip(1) {
            let qw: f64 = line.split(',').nth(1).unwrap().parse().unwrap();
            // The filter starts with a heading offset (see `LEVEL`): |w| is about 0.7.
            assert!(qw * sign > 0.5, "{name}: {line}");
        }
    }
}

/// A recording that fails leaves an existing `--out` byte-identical, with
/// no temporary file beside it.
#[test]
fn a_failed_replay_leaves_an_existing_out_intact() {
    let d = dir("keep");
    let bad = write(&d.join("bad.csv"), &corrupt(1, "nan"));
    let out = write(&d.join("q.csv"), "old estimates\n");
    let o = replay(&[bad.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_fails(&o, 1, "1 file(s) failed");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "old estimates\n");
    let mut names: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["bad.csv", "q.csv"]);
}

#[test]
fn board_capture_with_ctrl_c_and_repeated_header_replays() {
    let mut r = rows(200, 0.0);
    r.push(HEADER.into());
    r.extend(rows(200, 30.0));
    let mut text = file(&r);
    text.push_str("32.000000,0.001,-0.0");
    let o = on("capture", &text, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("last line cut short"), "{}", stderr(&o));
    assert!(stderr(&o).contains("2 segments"), "{}", stderr(&o));
}

#[test]
fn stdin_and_stdout() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_replay"))
        .args(["-", "--out", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let text = file(&rows(50, 0.0));
    {
        use std::io::Write;
        child
            .stdin
            .take()
            .unwrap()
            .write_all(text.as_bytes())
            .unwrap();
    }
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.starts_with("t_s,qw,qx,qy,qz\n"), "{out}");
    assert_eq!(out.lines().count(), 51);
    // The table went to stderr, keeping stdout pure data.
    assert!(stderr(&o).contains("MEAN"));
}

#[test]
fn a_closed_stdout_is_not_a_panic_and_outputs_are_written() {
    let d = dir("pipe");
    let files: Vec<String> = (0..3)
        .map(|i| {
            let p = write(&d.join(format!("r{i}.csv")), &file(&rows(3000, 0.0)));
            p.to_str().unwrap().to_string()
        })
        .collect();
    let mut args: Vec<&str> = files.iter().map(String::as_str).collect();
    let out = d.join("q.csv");
    args.extend(["--out", out.to_str().unwrap()]);
    let child = Command::new(env!("CARGO_BIN_EXE_replay"))
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Close the read end at once, as `| head -0` would.
    let mut child = child;
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"));
    for i in 0..3 {
        assert!(d.join(format!("q_r{i}.csv")).exists());
    }
}

#[test]
fn a_180_degree_error_prints_a_number() {
    // The rows' field puts the sensor's x axis at magnetic north, so the
    // filter starts level with yaw +90° in ENU; a reference at yaw −90° is
    // 180° away about the vertical.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let r: Vec<String> = (0..300)
        .map(|i| row(f64::from(i) * 0.01, [h, 0.0, 0.0, -h]))
        .collect();
    let o = on("180", &file(&r), &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = stdout(&o);
    let mean = out.lines().last().unwrap();
    let total: f64 = mean.split_whitespace().nth(5).unwrap().parse().unwrap();
    assert!((total - 180.0).abs() < 5.0, "{out}");
}
