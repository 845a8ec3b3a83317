//! The console's commands as a pilot types them.

// Tests may unwrap and panic (workspace rules).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use params::console::{
    execute, report_save, Line, LineBuf, LineReader, Listing, Outcome, Sink, MAX_LINE,
};
use params::ram::RamFlash;
use params::store::{load, save};
use params::{ParamId, ParamSet, COUNT, TABLE};

/// Collects the output and checks every line fits [`MAX_LINE`].
#[derive(Default)]
struct Screen(Vec<u8>);

impl Sink for Screen {
    fn put(&mut self, bytes: &[u8]) {
        self.0.extend_from_slice(bytes);
    }
}

impl Screen {
    fn lines(&self) -> Vec<String> {
        let text = String::from_utf8(self.0.clone()).unwrap();
        for l in text.split_inclusive('\n') {
            assert!(l.len() <= MAX_LINE, "line over {MAX_LINE} B: {l:?}");
        }
        text.lines().map(str::to_string).collect()
    }
}

/// Runs `line`, draining a listing one line per call (as the firmware
/// would, one per poll), each line alone in a [`LineBuf`].
fn run(line: &str, set: &mut ParamSet, armed: bool) -> (Outcome, Vec<String>) {
    let mut screen = Screen::default();
    let outcome = execute(line.as_bytes(), set, armed, &mut screen);
    if let Outcome::Listing(mut listing) = outcome {
        drain(&mut listing, set, &mut screen);
    }
    (outcome, screen.lines())
}

fn drain(listing: &mut Listing, set: &ParamSet, screen: &mut Screen) {
    let mut one = LineBuf::default();
    let mut polls = 0;
    while listing.next_line(set, &mut one) {
        assert!(
            !one.truncated(),
            "{:?}",
            String::from_utf8_lossy(one.as_bytes())
        );
        assert_eq!(one.as_bytes().iter().filter(|&&b| b == b'\n').count(), 1);
        screen.put(one.as_bytes());
        one.clear();
        polls += 1;
        assert!(polls <= COUNT + 20, "the listing never ends");
    }
    assert!(one.as_bytes().is_empty(), "the last call writes nothing");
}

#[test]
fn get_shows_value_unit_range_and_default_as_a_pasteable_line() {
    let mut set = ParamSet::defaults();
    let (outcome, lines) = run("get rate.roll.d", &mut set, true);
    assert_eq!(outcome, Outcome::Done);
    assert_eq!(
        lines,
        ["set rate.roll.d 0.0045 # s2/rad 0.0000..0.1000, default 0.0045"]
    );
    let (_, lines) = run("get batt.warn_cv", &mut set, false);
    assert_eq!(lines, ["set batt.warn_cv 350 # cV 300..400, default 350"]);
    let (_, lines) = run("get trim.roll", &mut set, false);
    assert_eq!(
        lines,
        ["set trim.roll 0.00 # deg -10.00..10.00, default 0.00"]
    );
}

#[test]
fn set_takes_exact_decimals_and_echoes_the_stored_value() {
    let mut set = ParamSet::defaults();
    let (outcome, lines) = run("set rate.roll.p 0.05", &mut set, false);
    assert_eq!(outcome, Outcome::Changed(ParamId::RateRollP));
    assert_eq!(lines, ["set rate.roll.p 0.0500"]);
    assert_eq!(set.get(ParamId::RateRollP), 500);
    let (_, lines) = run("  set   trim.pitch   -0.65 \r\n", &mut set, false);
    assert_eq!(lines, ["set trim.pitch -0.65"]);
    assert_eq!(set.get(ParamId::TrimPitch), -65);
}

#[test]
fn errors_name_the_problem_and_change_nothing() {
    let mut set = ParamSet::defaults();
    let cases = [
        (
            "set rate.roll.x 1",
            "error: unknown name: rate.roll.x (try help)",
        ),
        ("get nope", "error: unknown name: nope (try help)"),
        (
            "set rate.roll.p 2.5",
            "error: rate.roll.p: out of range: 2.5 (s/rad 0.0000..2.0000)",
        ),
        (
            "set rate.roll.p -1",
            "error: rate.roll.p: out of range: -1 (s/rad 0.0000..2.0000)",
        ),
        (
            "set rate.roll.p 0.00451",
            "error: rate.roll.p: too many decimals: 0.00451 (s/rad 0.0000..2.0000)",
        ),
        (
            "set batt.cells four",
            "error: batt.cells: not a number: four (0..8)",
        ),
        (
            "set rate.roll.p 99999999999",
            "error: rate.roll.p: out of range: 99999999999 (s/rad 0.0000..2.0000)",
        ),
        (
            "set imu.mount 0",
            "error: imu.mount: not a rotation code: 0 (0..511)",
        ),
        (
            "set imu.mount 512",
            "error: imu.mount: out of range: 512 (0..511)",
        ),
        ("fly", "error: unknown command: fly (try help)"),
        ("set rate.roll.p", "error: usage: see help"),
        ("get", "error: usage: see help"),
        ("save now", "error: usage: see help"),
        ("set a b c", "error: usage: see help"),
    ];
    for (line, want) in cases {
        let (outcome, lines) = run(line, &mut set, false);
        assert_eq!(outcome, Outcome::Done, "{line}");
        assert_eq!(lines, [want], "{line}");
    }
    assert_eq!(set, ParamSet::defaults());
}

#[test]
fn commands_that_change_or_write_are_refused_while_armed() {
    let mut set = ParamSet::defaults();
    set.set(ParamId::RateYawP, 6000).unwrap();
    let before = set;
    for line in ["set rate.roll.p 0.3", "save", "defaults"] {
        let (outcome, lines) = run(line, &mut set, true);
        assert_eq!(outcome, Outcome::Done, "{line}");
        assert_eq!(lines, ["error: armed: disarm first"], "{line}");
    }
    assert_eq!(set, before);
    // Reading is allowed.
    assert_eq!(run("get rate.roll.p", &mut set, true).1.len(), 1);
    assert_eq!(run("dump", &mut set, true).1.len(), COUNT);
    assert_eq!(run("diff", &mut set, true).1, ["set rate.yaw.p 0.6000"]);
    // Disarmed, the same commands run.
    assert_eq!(run("save", &mut set, false).0, Outcome::Save);
    let (outcome, lines) = run("defaults", &mut set, false);
    assert_eq!(outcome, Outcome::DefaultsLoaded);
    assert_eq!(lines, ["defaults loaded: save to keep them"]);
    assert_eq!(set, ParamSet::defaults());
}

#[test]
fn a_dump_pasted_back_restores_every_value() {
    let mut set = ParamSet::defaults();
    for line in [
        "set rate.pitch.i 1.25",
        "set rates.yaw 420",
        "set rc.throttle 1",
        "set rc.roll 3",
        "set batt.scale 10.87",
        "set trim.roll 0.62",
    ] {
        assert!(matches!(run(line, &mut set, false).0, Outcome::Changed(_)));
    }
    let (_, dump) = run("dump", &mut set, false);
    assert_eq!(dump.len(), COUNT);
    for (line, p) in dump.iter().zip(TABLE.iter()) {
        assert!(line.starts_with(&format!("set {} ", p.name)), "{line}");
    }
    // Into a board at its defaults, with a comment and an empty line.
    let mut other = ParamSet::defaults();
    assert_eq!(run("# from the other board", &mut other, false).1.len(), 0);
    assert_eq!(run("", &mut other, false).1.len(), 0);
    for line in &dump {
        assert!(
            matches!(run(line, &mut other, false).0, Outcome::Changed(_)),
            "{line}"
        );
    }
    assert_eq!(other, set);
    // diff holds exactly the changed ones, in table order.
    let (_, diff) = run("diff", &mut set, false);
    assert_eq!(
        diff,
        [
            "set rate.pitch.i 1.2500",
            "set rates.yaw 420",
            "set rc.roll 3",
            "set rc.throttle 1",
            "set batt.scale 10.870",
            "set trim.roll 0.62",
        ]
    );
    let mut fresh = ParamSet::defaults();
    for line in &diff {
        run(line, &mut fresh, false);
    }
    assert_eq!(fresh, set);
    assert!(run("diff", &mut ParamSet::defaults(), false).1.is_empty());
}

#[test]
fn help_lists_the_commands_and_every_parameter() {
    let mut set = ParamSet::defaults();
    let (_, lines) = run("help", &mut set, false);
    for cmd in ["get", "set", "save", "defaults", "dump", "diff", "help"] {
        assert!(lines.iter().any(|l| l.starts_with(cmd)), "{cmd}");
    }
    for p in TABLE.iter() {
        let l = lines
            .iter()
            .find(|l| l.starts_with(&format!("{} ", p.name)))
            .unwrap_or_else(|| panic!("{}", p.name));
        assert!(l.ends_with(p.help), "{l}");
    }
    assert!(lines.contains(&"rate.roll.p s/rad 0.0000..2.0000: roll rate P".to_string()));
}

#[test]
fn set_save_power_cycle_keeps_the_values() {
    let mut flash = RamFlash::default();
    let mut set = load(&mut flash).set();
    run("set rate.roll.p 0.3", &mut set, false);
    assert_eq!(run("save", &mut set, false).0, Outcome::Save);
    let result = save(&mut flash, &set);
    let mut screen = Screen::default();
    report_save(&result, &mut screen);
    assert_eq!(screen.lines(), ["saved (PARAMS_A)"]);
    let booted = load(&mut flash).set();
    assert_eq!(booted.get(ParamId::RateRollP), 3000);
    assert_eq!(booted, set);
}

#[test]
fn the_line_reader_splits_lines_and_drops_overlong_ones() {
    let mut reader = LineReader::<16>::default();
    let mut got = Vec::new();
    for &b in b"get a\r\nset b 1\nthis line is far too long\nx\n" {
        match reader.push(b) {
            Some(Line::Complete(l)) => got.push(String::from_utf8_lossy(l).into_owned()),
            Some(Line::TooLong) => got.push("<too long>".into()),
            None => {}
        }
    }
    assert_eq!(got, ["get a", "", "set b 1", "<too long>", "x"]);
}
