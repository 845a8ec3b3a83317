//! Replays the start of a BROAD trial and checks the error. Needs the data
//! (`scripts/fetch-broad`, or `BROAD_DIR`); without it the test prints
//! "skipped: data absent" and passes, so a run without the data says so.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use replay::{read, run, score, FilterKind, Mode, ReadOptions};
use std::path::PathBuf;

fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("BROAD_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/broad")
        });
    dir.is_dir().then_some(dir)
}

#[test]
fn broad_excerpt_f32_and_fixed() {
    let Some(dir) = data_dir() else {
        eprintln!("skipped: data absent (BROAD; run scripts/fetch-broad or set BROAD_DIR)");
        return;
    };
    let text = std::fs::read_to_string(dir.join("10_undisturbed_slow_translation_A.csv")).unwrap();
    // First 25,000 rows (~87 s: 37 s rest, then motion).
    let cut: String = text.lines().take(25_001).flat_map(|l| [l, "\n"]).collect();
    let rec = read(&cut, ReadOptions::default()).unwrap();
    assert_eq!(rec.segments.len(), 1);
    let samples = &rec.segments[0].samples;
    assert_eq!(samples.len(), 25_000);
    let cfg = fc_ahrs::Config::DEFAULT;
    let f = score(samples, &run(samples, FilterKind::F32, Mode::Marg, &cfg)).unwrap();
    let x = score(samples, &run(samples, FilterKind::Fixed, Mode::Marg, &cfg)).unwrap();
    eprintln!("f32 {f:?}\nfixed {x:?}");
    assert!(f.rows > 10_000);
    assert!(f.total_deg < 2.5, "{f:?}");
    assert!((f.total_deg - x.total_deg).abs() < 0.1);
    let i = score(samples, &run(samples, FilterKind::F32, Mode::Imu, &cfg)).unwrap();
    assert!(i.inclination_deg < 3.0, "{i:?}");
}
