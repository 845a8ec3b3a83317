//! Shared set-up of the firmware-in-the-loop scenarios: the release ELF (or
//! `FIL_ELF`), skipping when it is absent unless `FIL_REQUIRE_ELF=1`, and
//! readers for the firmware's log lines. `FIL_CYCLE_MODEL=pessimistic`
//! runs every scenario at the cycle model's pessimistic corner.
#![allow(dead_code, clippy::panic, clippy::expect_used, clippy::unwrap_used)]

use emulator::{Board, BoardConfig, ResetCause};

pub mod rigs;
use std::path::PathBuf;

/// One simulated second in ns.
pub const S: u64 = 1_000_000_000;
/// One simulated millisecond in ns.
pub const MS: u64 = 1_000_000;

/// The firmware under test: `FIL_ELF`, else `target/thumbv7m-none-eabi/
/// release/firmware`. `None` (test skipped) if absent, unless
/// `FIL_REQUIRE_ELF=1`, where absence fails the test.
pub fn elf() -> Option<PathBuf> {
    let path = std::env::var_os("FIL_ELF")
        .map(PathBuf::from)
        .unwrap_or_else(emulator::release_elf_path);
    if path.exists() {
        return Some(path);
    }
    if std::env::var("FIL_REQUIRE_ELF").is_ok_and(|v| v == "1") {
        panic!(
            "firmware ELF {} absent and FIL_REQUIRE_ELF=1",
            path.display()
        );
    }
    println!("skipped: firmware ELF absent (run `cargo fw`)");
    None
}

/// A board running the firmware with `config` adjusted by `f`.
pub fn board_with(f: impl FnOnce(&mut BoardConfig)) -> Option<Board> {
    let path = elf()?;
    let mut config = BoardConfig::default();
    // The RTT mode `cargo embed` sets comes from this tree's Embed.toml;
    // FIL_RTT_MODE overrides it when FIL_ELF is a firmware from another tree.
    if let Some(m) = std::env::var("FIL_RTT_MODE")
        .ok()
        .and_then(|m| emulator::RttMode::from_name(&m))
    {
        config.rtt_mode = Some(m);
    }
    if std::env::var("FIL_CYCLE_MODEL").is_ok_and(|m| m == "pessimistic") {
        config.cycle_model = emulator::CycleModel::Pessimistic;
    }
    f(&mut config);
    Some(Board::from_elf(&path, config).unwrap_or_else(|e| panic!("board: {e}")))
}

/// A board on the default world (at rest, seed 1).
pub fn board() -> Option<Board> {
    board_with(|_| {})
}

/// Runs until `t_ns` (simulated since power-on); a board error fails the
/// test with the end of the log.
pub fn run_until(b: &mut Board, t_ns: u64) {
    if let Err(e) = b.run_until_ns(t_ns) {
        panic!("board stopped at {} ns: {e}\n{}", b.now_ns(), tail(b, 40));
    }
}

/// Runs `ns` more (simulated); a board error fails the test as in [`run_until`].
pub fn run_for(b: &mut Board, ns: u64) {
    let t = b.now_ns() + ns;
    run_until(b, t);
}

/// The last `n` log lines and the board's events, for failure messages.
pub fn tail(b: &Board, n: usize) -> String {
    let lines = b.log_lines();
    let mut s: String = lines[lines.len().saturating_sub(n)..]
        .iter()
        .map(|l| format!("[{:.3}] {l}\n", l.host_time_ns as f64 * 1e-9))
        .collect();
    for e in b.events() {
        s.push_str(&format!(
            "[{:.3}] [emulator] {}\n",
            e.time_ns as f64 * 1e-9,
            e.what
        ));
    }
    s
}

/// Lines containing `pat`.
pub fn lines_with(b: &Board, pat: &str) -> Vec<String> {
    b.log_lines()
        .iter()
        .filter(|l| l.text.contains(pat))
        .map(|l| l.text.clone())
        .collect()
}

/// Lines containing `pat` read by the host after `t_ns`.
pub fn lines_after(b: &Board, t_ns: u64, pat: &str) -> Vec<String> {
    b.log_lines()
        .iter()
        .filter(|l| l.host_time_ns >= t_ns && l.text.contains(pat))
        .map(|l| l.text.clone())
        .collect()
}

/// The number after `key` in a log line (0 if absent); a `)` closing a
/// group is not part of it.
pub fn field(line: &str, key: &str) -> u64 {
    line.split(key)
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.trim_end_matches(')').parse().ok())
        .unwrap_or(0)
}

/// The last `rc: ch1-8` receiver line read after `t_ns`; none fails the test.
pub fn last_channel_line(b: &Board, t_ns: u64) -> String {
    lines_after(b, t_ns, "rc: ch1-8")
        .pop()
        .unwrap_or_else(|| panic!("no channel line\n{}", tail(b, 40)))
}

/// Asserts the receiver reported `rc: link up` after `t_ns`.
pub fn assert_link_up_after(b: &Board, t_ns: u64) {
    assert!(
        !lines_after(b, t_ns, "rc: link up").is_empty(),
        "{}",
        tail(b, 40)
    );
}

/// Runs 200 ms with nothing sent and asserts the link was lost by timeout:
/// within the 100 ms timeout plus one 50 ms log tick.
pub fn assert_link_times_out(b: &mut Board) {
    let stop = b.now_ns();
    run_until(b, stop + 200 * MS);
    let lost = lines_after(b, stop, "rc: link lost");
    assert!(
        lost.first()
            .is_some_and(|l| l.contains("no good frame within the timeout")),
        "{lost:?}\n{}",
        tail(b, 20)
    );
}

/// Runs until the start-up gyro bias has ended (it needs 1 s of stillness
/// after the probe), 8 s after power-on at the latest. Whether it ended
/// `Done` (not `GaveUp`, nor still running).
pub fn wait_for_gyro_bias(b: &mut Board) -> bool {
    let ended = |b: &Board| {
        !lines_with(b, "gyro bias: done: [").is_empty()
            || !lines_with(b, "gyro bias: gave up").is_empty()
    };
    let mut t = b.now_ns();
    while !ended(b) && t < 8 * S {
        t += 100 * MS;
        run_until(b, t);
    }
    !lines_with(b, "gyro bias: done: [").is_empty()
}

/// Asserts a line containing `pat` was logged.
pub fn assert_logged(b: &Board, pat: &str) {
    assert!(
        !lines_with(b, pat).is_empty(),
        "no log line with `{pat}`\n{}",
        tail(b, 60)
    );
}

/// The `key=value` counter from the last health line of `chip` (`mpu`, `mag`, `baro`).
pub fn health(b: &Board, chip: &str, key: &str) -> Option<u32> {
    let line = b
        .log_lines()
        .iter()
        .rev()
        .find(|l| l.text.starts_with(&format!("{chip}: ")))?;
    let field = line
        .text
        .split_whitespace()
        .find_map(|w| w.strip_prefix(&format!("{key}=")))?;
    field.parse().ok()
}

/// (roll, pitch, yaw) in degrees from an `att r=.. p=.. y=.. deg` line.
pub fn attitude(text: &str) -> Option<[f64; 3]> {
    let mut out = [0.0; 3];
    for (i, key) in ["r=", "p=", "y="].iter().enumerate() {
        let at = text.find(key)? + key.len();
        let v = text[at..].split_whitespace().next()?;
        out[i] = v.parse().ok()?;
    }
    Some(out)
}

/// MCU resets after power-on with their causes.
pub fn resets_after_power_on(b: &Board) -> Vec<ResetCause> {
    b.resets().iter().skip(1).map(|r| r.1).collect()
}

/// Asserts the MCU did not reset since power-on.
pub fn assert_no_reset(b: &Board) {
    assert!(
        resets_after_power_on(b).is_empty(),
        "unexpected MCU reset(s): {:?}\n{}",
        b.resets(),
        tail(b, 60)
    );
}

/// EXTI9_5 (MPU data-ready) handler entries over the next `ns`.
pub fn imu_updates_during(b: &mut Board, ns: u64) -> u64 {
    let n0 = b.exception_entries(emulator::EXTI9_5);
    let t = b.now_ns() + ns;
    run_until(b, t);
    b.exception_entries(emulator::EXTI9_5) - n0
}

/// Boot with all chips and wait for the capabilities line (≤ 1 s simulated).
pub fn boot_ok(b: &mut Board) {
    let caps = b
        .wait_for_line("capabilities:", S)
        .unwrap_or_else(|e| panic!("board: {e}"));
    assert!(
        caps.is_some(),
        "no capabilities line within 1 s\n{}",
        tail(b, 40)
    );
}
