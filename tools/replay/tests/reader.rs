//! The recording reader: one test per way a recording can be wrong, and a
//! property test that no input makes it panic.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::{file, row, rows, HEADER, LEVEL};
use proptest::prelude::*;
use replay::{read, ParseError, ReadOptions};

fn err(text: &str) -> ParseError {
    read(text, ReadOptions::default()).unwrap_err()
}

fn with(n: usize, line: usize, f: impl Fn(String) -> String) -> String {
    let mut r = rows(n, 0.0);
    r[line - 2] = f(r[line - 2].clone());
    file(&r)
}

fn set_field(r: String, col: usize, v: &str) -> String {
    let mut f: Vec<String> = r.split(',').map(String::from).collect();
    f[col] = v.into();
    f.join(",")
}

#[test]
fn good_file_reads_with_f64_time() {
    let rec = read(&file(&rows(50, 1.0e6)), ReadOptions::default()).unwrap();
    assert_eq!(rec.rows(), 50);
    let s = &rec.segments[0].samples;
    // f32 would round 1e6 + 0.01 to 1e6 + 0.0; f64 keeps the step.
    assert!((s[1].t_s - s[0].t_s - 0.01).abs() < 1e-9);
    assert!(rec.warnings.is_empty());
}

#[test]
fn empty_header_only_and_one_row_are_errors() {
    assert_eq!(err(""), ParseError::Empty);
    assert!(matches!(
        err(&file(&[])),
        ParseError::TooFewRows { rows: 0, .. }
    ));
    assert!(matches!(
        err(&file(&rows(1, 0.0))),
        ParseError::TooFewRows { rows: 1, .. }
    ));
    assert_eq!(
        err("t_s,gyr_x_rad_s\n0,0\n"),
        ParseError::MissingColumn("gyr_y_rad_s")
    );
}

#[test]
fn non_finite_samples_name_line_and_column() {
    for (col, name) in [(1, "gyr_x_rad_s"), (5, "acc_y_m_s2"), (9, "mag_z_ut")] {
        for v in ["nan", "inf", "-inf"] {
            let e = err(&with(10, 4, |r| set_field(r, col, v)));
            assert_eq!(
                e,
                ParseError::NonFinite {
                    line: 4,
                    column: name.into()
                },
                "{v}"
            );
            assert!(e
                .to_string()
                .starts_with(&format!("line 4, column `{name}`")));
        }
    }
}

#[test]
fn impossible_samples_are_out_of_range() {
    let e = err(&with(10, 5, |r| set_field(r, 8, "1e30")));
    assert!(
        matches!(e, ParseError::OutOfRange { line: 5, ref column, .. } if column == "mag_y_ut")
    );
    assert!(e.to_string().contains("5000 µT"), "{e}");
    let e = err(&with(10, 3, |r| set_field(r, 2, "41")));
    assert!(matches!(e, ParseError::OutOfRange { line: 3, .. }), "{e:?}");
    let e = err(&with(10, 3, |r| set_field(r, 6, "-170")));
    assert!(matches!(e, ParseError::OutOfRange { line: 3, .. }), "{e:?}");
}

#[test]
fn skip_invalid_counts_instead() {
    let text = with(10, 4, |r| set_field(r, 1, "nan"));
    let rec = read(&text, ReadOptions { skip_invalid: true }).unwrap();
    assert_eq!((rec.rows(), rec.skipped_rows), (9, 1));
}

#[test]
fn bad_time_is_an_error_with_a_hint() {
    let e = err(&with(10, 6, |r| set_field(r, 0, "nan")));
    assert_eq!(e, ParseError::BadTime { line: 6 });
    // Milliseconds.
    let ms: Vec<String> = (0..10).map(|i| row(f64::from(i) * 10.0, LEVEL)).collect();
    let e = err(&file(&ms));
    assert!(matches!(e, ParseError::DtOutOfRange { line: 3, .. }));
    assert!(
        e.to_string().contains("timestamps look like milliseconds"),
        "{e}"
    );
    // Microseconds.
    let us: Vec<String> = (0..10)
        .map(|i| row(f64::from(i) * 10_000.0, LEVEL))
        .collect();
    assert!(err(&file(&us)).to_string().contains("microseconds"));
    // All equal.
    let eq: Vec<String> = (0..10).map(|_| row(5.0, LEVEL)).collect();
    assert!(matches!(
        err(&file(&eq)),
        ParseError::TimeNotIncreasing { line: 3, .. }
    ));
    // Reversed.
    let mut rev = rows(10, 0.0);
    rev.reverse();
    assert!(matches!(
        err(&file(&rev)),
        ParseError::TimeNotIncreasing { line: 3, .. }
    ));
    // A gap.
    let mut gap = rows(10, 0.0);
    gap.extend(rows(10, 10.0));
    let e = err(&file(&gap));
    assert!(e.to_string().contains("a gap"), "{e}");
}

#[test]
fn bad_reference_and_moving_flag() {
    let e = err(&with(10, 3, |r| set_field(r, 10, "2.0")));
    assert!(
        matches!(e, ParseError::BadReference { line: 3, .. }),
        "{e:?}"
    );
    let rec = read(
        &with(10, 3, |r| set_field(r, 10, "nan")),
        ReadOptions::default(),
    )
    .unwrap();
    assert!(rec.segments[0].samples[1].reference.is_none());
    let e = err(&with(10, 3, |r| set_field(r, 14, "2")));
    assert_eq!(e, ParseError::BadMoving { line: 3 });
    let e = err(&with(10, 3, |r| set_field(r, 3, "x")));
    assert!(e.to_string().contains("`x` is not a number"), "{e}");
}

#[test]
fn truncated_last_line_is_dropped_with_a_warning() {
    let mut text = file(&rows(10, 0.0));
    text.push_str("0.100000,0.001,-0.0");
    let rec = read(&text, ReadOptions::default()).unwrap();
    assert_eq!(rec.rows(), 10);
    assert_eq!(rec.warnings.len(), 1, "{:?}", rec.warnings);
    assert!(rec.warnings[0].contains("line 12"));
    // Cut inside the last number, no newline: also dropped.
    let mut text = file(&rows(10, 0.0));
    text.push_str(&row(0.1, LEVEL)[..row(0.1, LEVEL).len() - 2]);
    text.push('-');
    let rec = read(&text, ReadOptions::default()).unwrap();
    assert_eq!((rec.rows(), rec.warnings.len()), (10, 1));
    // A short row in the middle is an error.
    let mut r = rows(10, 0.0);
    r[3] = "0.03,1".into();
    assert!(matches!(
        err(&file(&r)),
        ParseError::ShortRow {
            line: 5,
            expected: 15,
            found: 2
        }
    ));
}

#[test]
fn repeated_header_starts_a_segment() {
    let mut r = rows(10, 0.0);
    r.push(HEADER.into());
    r.extend(rows(10, 0.0));
    r.push(HEADER.into());
    r.push(HEADER.into());
    r.extend(rows(5, 3.0));
    let rec = read(&file(&r), ReadOptions::default()).unwrap();
    assert_eq!(rec.segments.len(), 3);
    assert_eq!(rec.segments[1].header_line, 12);
    assert_eq!(rec.rows(), 25);
    // The empty segment between the two adjacent headers is reported.
    assert_eq!(rec.warnings.len(), 1, "{:?}", rec.warnings);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// Any text: an error or a recording, never a panic.
    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,400}") {
        let _ = read(&text, ReadOptions::default());
        let _ = read(&text, ReadOptions { skip_invalid: true });
    }

    /// A valid file with one field replaced by arbitrary text: never a
    /// panic, and whatever is accepted obeys the rules.
    #[test]
    fn corrupted_field_is_caught_or_valid(
        line in 2usize..12, col in 0usize..15, junk in "[-+.0-9eEinfa,]{0,12}", skip in any::<bool>()
    ) {
        let text = with(10, line, |r| set_field(r, col, &junk));
        if let Ok(rec) = read(&text, ReadOptions { skip_invalid: skip }) {
            for seg in &rec.segments {
                prop_assert!(seg.samples.len() >= 2);
                for w in seg.samples.windows(2) {
                    let dt = w[1].t_s - w[0].t_s;
                    prop_assert!((replay::csv::DT_MIN_S..=replay::csv::DT_MAX_S).contains(&dt));
                }
                for s in &seg.samples {
                    let all = s.gyr_rps.iter().chain(&s.acc_mps2).chain(&s.mag_ut);
                    for v in all {
                        prop_assert!(v.is_finite());
                    }
                }
            }
        }
    }
}
