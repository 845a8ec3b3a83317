//! Replays the start of a BROAD trial and checks the error; skips if the data is absent.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use replay::{parse_csv, run, score, FilterKind, Mode, ParseError};
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
        eprintln!("BROAD data not found (set BROAD_DIR): skipping");
        return;
    };
    let text = std::fs::read_to_string(dir.join("10_undisturbed_slow_translation_A.csv")).unwrap();
    // First 25,000 rows (~87 s: 37 s rest, then motion).
    let cut: String = text.lines().take(25_001).flat_map(|l| [l, "\n"]).collect();
    let samples = parse_csv(&cut).unwrap();
    assert_eq!(samples.len(), 25_000);
    let cfg = fc_ahrs::Config::DEFAULT;
    let f = score(&samples, &run(&samples, FilterKind::F32, Mode::Marg, &cfg)).unwrap();
    let x = score(
        &samples,
        &run(&samples, FilterKind::Fixed, Mode::Marg, &cfg),
    )
    .unwrap();
    eprintln!("f32 {f:?}\nfixed {x:?}");
    assert!(f.rows > 10_000);
    assert!(f.total_deg < 2.5, "{f:?}");
    assert!((f.total_deg - x.total_deg).abs() < 0.1);
    let i = score(&samples, &run(&samples, FilterKind::F32, Mode::Imu, &cfg)).unwrap();
    assert!(i.inclination_deg < 3.0, "{i:?}");
}

#[test]
fn parse_errors_and_optional_columns() {
    assert_eq!(parse_csv(""), Err(ParseError::Empty));
    assert_eq!(
        parse_csv("t_s,gyr_x_rad_s\n"),
        Err(ParseError::MissingColumn("gyr_y_rad_s"))
    );
    let hdr = "t_s,gyr_x_rad_s,gyr_y_rad_s,gyr_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2,mag_x_ut,mag_y_ut,mag_z_ut";
    let ok = parse_csv(&format!(
        "{hdr}\n0,0,0,0,0,0,9.8,20,0,-40\n0.01,0,0,0,0,0,9.8,20,0,-40\n"
    ))
    .unwrap();
    assert_eq!(ok.len(), 2);
    assert!(ok[0].reference.is_none() && ok[0].moving);
    assert!(score(
        &ok,
        &run(&ok, FilterKind::F32, Mode::Marg, &fc_ahrs::Config::DEFAULT)
    )
    .is_none());
    assert!(matches!(
        parse_csv(&format!("{hdr}\n0,x,0,0,0,0,9.8,20,0,-40\n")),
        Err(ParseError::BadNumber { line: 2, .. })
    ));
    assert_eq!(
        parse_csv(&format!("{hdr}\n0,0\n")),
        Err(ParseError::ShortRow { line: 2 })
    );
    let with_ref = format!("{hdr},ref_qw,ref_qx,ref_qy,ref_qz,moving\n0,0,0,0,0,0,9.8,20,0,-40,nan,nan,nan,nan,1\n0,0,0,0,0,0,9.8,20,0,-40,1,0,0,0,0\n");
    let r = parse_csv(&with_ref).unwrap();
    assert!(r[0].reference.is_none() && r[0].moving);
    assert!(r[1].reference.is_some() && !r[1].moving);
}
