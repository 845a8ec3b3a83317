//! The level trim, through the sensor stack's pipeline: with the trim's
//! accelerometer offset applied, a board at rest and level reads the
//! opposite tilt, so angle mode (which holds the estimate level) holds the
//! craft at the trim's tilt. For the default mounting and one where the
//! MPU's axes are turned (the offset is in the MPU frame).
#![allow(clippy::unwrap_used)]

use params::{ParamId, ParamSet};
use sensor_stack::boot::AhrsMode;
use sensor_stack::mounting::{AxisMap, Mounting};
use sensor_stack::pipeline::{ImuInput, Pipeline, PipelineConfig};
use sensor_stack::storage::{CalibrationRecord, ValidParts};

/// Face up, x arrow to the right: forward = y_mpu, right = x_mpu.
const X_RIGHT: Mounting = match Mounting::new([
    AxisMap {
        source: 1,
        negate: false,
    },
    AxisMap {
        source: 0,
        negate: false,
    },
    AxisMap {
        source: 2,
        negate: true,
    },
]) {
    Ok(m) => m,
    Err(_) => panic!("not a rotation"),
};

/// Roll and pitch (°) the estimate settles on for a level board at rest.
fn settled_tilt(p: &ParamSet, mounting: Mounting) -> (f32, f32) {
    let mut rec = CalibrationRecord {
        valid: ValidParts(ValidParts::ACCEL),
        mounting,
        ..CalibrationRecord::default()
    };
    let trim = p.level_trim_mpu_g(&mounting);
    for (o, t) in rec.accel_offset_g.iter_mut().zip(trim) {
        *o += t;
    }
    let cfg = PipelineConfig {
        ahrs_mode: AhrsMode::ImuOnly,
        altitude: false,
        ..PipelineConfig::new()
    };
    let mut pipe = Pipeline::new(cfg, &rec).unwrap();
    pipe.set_gyro_bias_counts([0; 3]);
    // Level and face up: +1 g on the MPU's z whatever its turn.
    let level = ImuInput {
        accel: [0, 0, 8192],
        gyro: [0; 3],
        dt_cycles: 72_000,
    };
    for _ in 0..20_000 {
        if pipe.imu_step(&level) {
            pipe.control_step();
        }
    }
    let o = pipe.outputs();
    (o.roll_deg, o.pitch_deg)
}

#[test]
fn the_trim_tilts_the_level_the_estimate_reads_by_its_angles() {
    for mounting in [Mounting::FACE_UP_X_FORWARD, X_RIGHT] {
        let mut p = ParamSet::defaults();
        let (roll0, pitch0) = settled_tilt(&p, mounting);
        assert!(
            roll0.abs() < 0.01 && pitch0.abs() < 0.01,
            "{roll0} {pitch0}"
        );
        p.set(ParamId::TrimRoll, 200).unwrap(); // 2.00° right side down
        p.set(ParamId::TrimPitch, -150).unwrap(); // 1.50° nose down
        let (roll, pitch) = settled_tilt(&p, mounting);
        assert!((roll + 2.0).abs() < 0.02, "{mounting:?}: roll {roll}");
        assert!((pitch - 1.5).abs() < 0.02, "{mounting:?}: pitch {pitch}");
    }
}
