//! The board's magnetometer calibration (`MagCalMode` in the calibration
//! build's `CalSession`) on the simulator's AK8963 with known hard and soft
//! iron, read through the real driver at the firmware's 100 Hz: what "done"
//! stores, and that an incomplete dance is never done.
//!
//! The bound under test: a fit that passes has every per-axis standard
//! error of its centre at most `EllipsoidFitConfig::MICROTESLA`'s
//! `max_offset_std_error` (1/3 µT), so the hard-iron offset it stores is
//! within three standard errors, [`OFFSET_BOUND_UT`] = 1 µT, of the truth.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use calibration::{EllipsoidFitConfig, EllipsoidFitF32, Error as CalError, MagCalibration};
use e2e::mag_samples;
use sensor_stack::calmode::{AccelCalMode, CalEvent, CalSession, MagCalMode, Press};
use sensor_stack::storage::{CalibrationRecord, ValidParts};
use sim::errors::random_soft_iron;
use sim::math::Mat3;
use sim::rng::Rng;
use sim::{SensorErrors, Trajectory};

/// The calibration build's session.
type Session = CalSession<MagCalMode, AccelCalMode>;

/// Three times the largest centre standard error a passing fit may have.
const OFFSET_BOUND_UT: f64 = 3.0 * EllipsoidFitConfig::MICROTESLA.max_offset_std_error as f64;

/// Soft-iron tolerance: `W·S` within this fraction of `k·I`. A residual
/// soft iron of ε turns a heading by at most ε rad (1 % ≈ 0.6°); the noise
/// leaves about σ/R·√(10/N) ≈ 0.1 % with N ≥ 1000 samples.
const SOFT_IRON_TOL: f64 = 0.01;

/// What a session made of `samples`: the event that ended it (if any),
/// the record, and the refusals on the way.
struct Outcome {
    done: Option<[f32; 3]>,
    record: CalibrationRecord,
    refusals: u32,
}

/// Runs a magnetometer session over `samples` (the log task polls every
/// fifth sample: 20 Hz).
fn run_session(samples: &[[f32; 3]]) -> Outcome {
    let mut s = Session::new(false);
    s.on_press(Press::Long);
    let mut record = CalibrationRecord::default();
    let mut refusals = 0;
    for (i, m) in samples.iter().enumerate() {
        s.push_mag(*m);
        if i % 5 != 4 {
            continue;
        }
        match s.poll(&mut record) {
            Some(CalEvent::MagDone { offset_ut }) => {
                return Outcome {
                    done: Some(offset_ut),
                    record,
                    refusals,
                }
            }
            Some(CalEvent::MagRefused(_)) => refusals += 1,
            Some(CalEvent::MagProgress(_)) | None => {}
            Some(e) => panic!("unexpected {e:?}"),
        }
    }
    Outcome {
        done: None,
        record,
        refusals,
    }
}

/// Hard iron (AK frame) in the MPU frame.
fn hard_iron_mpu(errors: &SensorErrors) -> [f64; 3] {
    sim::math::ak_to_mpu(errors.mag.hard_iron_ut)
}

/// Soft iron (AK frame) in the MPU frame: `P·S·P` (`P = P⁻¹`, the
/// AK→MPU axis permutation).
fn soft_iron_mpu(s: &Mat3) -> Mat3 {
    let p = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
    sim::math::mat_mul(&sim::math::mat_mul(&p, s), &p)
}

/// Asserts the stored correction recovers `errors`' hard and soft iron.
fn assert_recovers(cal: &MagCalibration, errors: &SensorErrors, what: &str) {
    let h = hard_iron_mpu(errors);
    for (k, (got, want)) in cal.offset.iter().zip(h).enumerate() {
        let e = f64::from(*got) - want;
        assert!(
            e.abs() <= OFFSET_BOUND_UT,
            "{what}: axis {k} offset error {e:.3} µT ({:?} vs {h:?})",
            cal.offset
        );
    }
    // The symmetric W undoes the symmetric S up to the scale k = R/|B|.
    let c = cal.soft_iron.map(|r| r.map(f64::from));
    let cs = sim::math::mat_mul(&c, &soft_iron_mpu(&errors.mag.soft_iron));
    let k = (cs[0][0] + cs[1][1] + cs[2][2]) / 3.0;
    for (i, row) in cs.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            let want = if i == j { k } else { 0.0 };
            assert!(
                (v - want).abs() <= SOFT_IRON_TOL * k,
                "{what}: W·S = {cs:?}"
            );
        }
    }
}

/// Hard iron (+25, −12, +8) µT and a symmetric soft iron with a few %
/// scale and cross terms (AK frame).
fn known_errors() -> SensorErrors {
    let mut e = SensorErrors::noise_only();
    e.mag.hard_iron_ut = [25.0, -12.0, 8.0];
    e.mag.soft_iron = [
        [1.04, 0.03, -0.02],
        [0.03, 0.96, 0.025],
        [-0.02, 0.025, 1.02],
    ];
    e
}

#[test]
fn the_figure_eight_stores_the_known_hard_and_soft_iron() {
    for seed in 1..=6 {
        let errors = known_errors();
        let samples = mag_samples(errors, Trajectory::FigureEight, seed, 60.0);
        let out = run_session(&samples);
        let Some(offset) = out.done else {
            panic!("seed {seed}: not done ({} refusals)", out.refusals)
        };
        let rec = out.record;
        assert!(rec.valid.has(ValidParts::MAG) && !rec.valid.has(ValidParts::ACCEL));
        assert_eq!(rec.mag_offset_ut, offset);
        let cal = MagCalibration {
            offset: rec.mag_offset_ut,
            soft_iron: rec.mag_soft_iron,
        };
        assert_recovers(&cal, &errors, &format!("seed {seed}"));
    }
}

/// Random hard iron (±60 µT per axis) and soft iron (±15 % scale, ±7.5 %
/// cross terms), one figure eight each: always done, always within the
/// bound.
#[test]
fn random_hard_and_soft_iron_are_recovered_within_the_bound() {
    let mut rng = Rng::new(0x3A6_CA1);
    for draw in 0..12 {
        let mut errors = SensorErrors::noise_only();
        errors.mag.hard_iron_ut = [0; 3].map(|_| rng.range(-60.0, 60.0));
        errors.mag.soft_iron = random_soft_iron(&mut rng, 0.15);
        let samples = mag_samples(errors, Trajectory::FigureEight, 100 + draw, 40.0);
        let out = run_session(&samples);
        assert!(out.done.is_some(), "draw {draw}: not done {errors:?}");
        let cal = MagCalibration {
            offset: out.record.mag_offset_ut,
            soft_iron: out.record.mag_soft_iron,
        };
        assert_recovers(&cal, &errors, &format!("draw {draw}: {errors:?}"));
    }
}

/// Asserts a session over `samples` never stores anything (more than twice
/// the samples a fit needs: what stops it is not the count).
fn assert_never_done(samples: &[[f32; 3]], what: &str) {
    let need = 2 * EllipsoidFitConfig::MICROTESLA.min_samples as usize;
    assert!(
        samples.len() > need,
        "{what}: only {} samples",
        samples.len()
    );
    let out = run_session(samples);
    assert_eq!(out.done, None, "{what}: done");
    assert_eq!(out.record, CalibrationRecord::default(), "{what}");
}

#[test]
fn incomplete_dances_are_never_done() {
    let errors = known_errors();
    for seed in [1, 2] {
        // Turning about one body axis only: the field traces a circle.
        for axis in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.6, 0.0, 0.8]] {
            let rate = axis.map(|a: f64| a * 90f64.to_radians());
            let s = mag_samples(errors, Trajectory::spin(rate), seed, 60.0);
            assert_never_done(&s, &format!("seed {seed}: spin about {axis:?}"));
        }
        // The upper half of a figure eight (by the raw z reading), and
        // the first 5 s of one (not yet round all directions).
        let full = mag_samples(errors, Trajectory::FigureEight, seed, 60.0);
        let (lo, hi) = full.iter().fold((f32::MAX, f32::MIN), |(lo, hi), m| {
            (lo.min(m[2]), hi.max(m[2]))
        });
        let upper: Vec<[f32; 3]> = full
            .iter()
            .copied()
            .filter(|m| m[2] > 0.5 * (lo + hi))
            .collect();
        assert_never_done(&upper, &format!("seed {seed}: upper half"));
        // The dance starts after 3 s at rest; 4 s of turning.
        assert_never_done(&full[..700], &format!("seed {seed}: first 7 s"));
    }
}

/// Samples that leave the far side of the sphere to one reading per
/// coverage direction: with the AK8963's noise the centre's standard error
/// stays inside the limit (those fits pass, within the bound); with 2 µT
/// of noise it exceeds it and the fit is refused as `UncertainOffset`,
/// while the whole dance with that noise still passes.
#[test]
fn a_far_side_left_to_single_readings_is_refused_when_noisy() {
    for (noise_ut, refused) in [(0.4, false), (2.0, true)] {
        let mut errors = known_errors();
        errors.mag.noise_ut = noise_ut;
        let full = mag_samples(errors, Trajectory::FigureEight, 5, 60.0);
        let h = hard_iron_mpu(&errors).map(|v| v as f32);
        let (lo, hi) = full.iter().fold((f32::MAX, f32::MIN), |(lo, hi), m| {
            (lo.min(m[2]), hi.max(m[2]))
        });
        let mut sparse: Vec<[f32; 3]> = full
            .iter()
            .copied()
            .filter(|m| m[2] > hi - 0.25 * (hi - lo))
            .collect();
        // Every 150th reading (1.5 s apart) elsewhere: a few dozen.
        sparse.extend(full.iter().step_by(150));
        let board = |xs: &[[f32; 3]]| {
            let mut f = EllipsoidFitF32::new(EllipsoidFitConfig::MICROTESLA, 0.125).unwrap();
            for m in xs {
                f.push(*m).unwrap();
            }
            f.finish()
        };
        let whole = board(&full).unwrap();
        assert!(whole.offset_std_error < 0.2, "{whole:?}");
        match board(&sparse) {
            Err(CalError::UncertainOffset { std_error, limit }) => {
                assert!(refused, "noise {noise_ut}: refused, se {std_error}");
                assert!(std_error > limit);
            }
            Ok(sol) => {
                assert!(!refused, "noise {noise_ut}: passed {sol:?}");
                for (got, want) in sol.calibration.offset.iter().zip(h) {
                    assert!(f64::from((got - want).abs()) <= OFFSET_BOUND_UT, "{sol:?}");
                }
            }
            Err(e) => panic!("noise {noise_ut}: {e:?}"),
        }
    }
}
