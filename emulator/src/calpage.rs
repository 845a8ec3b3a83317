//! The calibration page a user leaves in flash after running the
//! six-position accelerometer and the magnetometer calibrations on the
//! board: here written from the simulated board's own sensor errors, as a
//! calibration that found them exactly (the host simulator's scenarios fit
//! them from simulated samples instead and keep a residue of a few tenths
//! of a degree of level: a known difference between the two rigs).
//!
//! What is corrected is what the record can hold: per-axis accelerometer
//! offset and scale (its cross-axis terms stay, as after a six-position
//! fit), the magnetometer's hard iron and full soft-iron matrix.

use sensor_stack::storage::{self, CalibrationRecord, ValidParts};
use sim::physics::G0_MPS2;
use sim::SensorErrors;

/// Offset of the calibration page in the STM32F103C8's flash image.
pub const PAGE_OFFSET: usize = (storage::PAGE_ADDRESS - 0x0800_0000) as usize;

/// Offset of the calibration page (`CALIB_A`) in a flash image of
/// `image_len` bytes: the chip's last 1 KiB page in both flash plans
/// (`memory.x` for the C8, `memory-cb.x` for the CB).
pub fn page_offset(image_len: usize) -> usize {
    image_len.saturating_sub(storage::PAGE_SIZE)
}

type Mat3 = [[f64; 3]; 3];

/// AK8963 → MPU axes (x_mpu = y_ak, y_mpu = x_ak, z_mpu = −z_ak); its own
/// inverse.
const AK_TO_MPU: Mat3 = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, c) in row.iter_mut().enumerate() {
            *c = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// Inverse of a 3×3 matrix by cofactors (`None` if singular).
fn inverse(m: &Mat3) -> Option<Mat3> {
    let c =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let cof = [
        [c(1, 2, 1, 2), -c(1, 2, 0, 2), c(1, 2, 0, 1)],
        [-c(0, 2, 1, 2), c(0, 2, 0, 2), -c(0, 2, 0, 1)],
        [c(0, 1, 1, 2), -c(0, 1, 0, 2), c(0, 1, 0, 1)],
    ];
    let det: f64 = (0..3).map(|j| m[0][j] * cof[0][j]).sum();
    if det.abs() < 1e-12 {
        return None;
    }
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = cof[j][i] / det;
        }
    }
    Some(inv)
}

/// The record that corrects `errors` (MPU sensor frame, as stored).
pub fn record_for(errors: &SensorErrors) -> CalibrationRecord {
    let a = &errors.accel_mps2;
    let mut rec = CalibrationRecord::default();
    for i in 0..3 {
        rec.accel_offset_g[i] = (a.bias[i] / G0_MPS2) as f32;
        rec.accel_scale[i] = (1.0 / a.misalignment[i][i]) as f32;
    }
    // raw_mpu = P (S b_ak + h) = (P S P) b_mpu + P h.
    let m = &errors.mag;
    let soft_mpu = mul(&mul(&AK_TO_MPU, &m.soft_iron), &AK_TO_MPU);
    if let Some(inv) = inverse(&soft_mpu) {
        for (i, (off, row)) in rec
            .mag_offset_ut
            .iter_mut()
            .zip(rec.mag_soft_iron.iter_mut())
            .enumerate()
        {
            *off = (0..3)
                .map(|k| AK_TO_MPU[i][k] * m.hard_iron_ut[k])
                .sum::<f64>() as f32;
            *row = inv[i].map(|v| v as f32);
        }
        rec.valid.0 |= ValidParts::MAG;
    }
    rec.valid.0 |= ValidParts::ACCEL;
    rec
}

/// `image` (a whole flash image, of either chip) with `rec` written into
/// the calibration page, its last 1 KiB page.
pub fn with_record(mut image: Vec<u8>, rec: &CalibrationRecord) -> Vec<u8> {
    let bytes = storage::encode(rec);
    if image.len() < PAGE_OFFSET + storage::PAGE_SIZE {
        image.resize(PAGE_OFFSET + storage::PAGE_SIZE, 0xFF);
    }
    let at = page_offset(image.len());
    image[at..at + bytes.len()].copy_from_slice(&bytes);
    image
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_record_undoes_the_boards_errors() {
        let e = SensorErrors::datasheet(3);
        let rec = record_for(&e);
        // A true specific force of 1 g along x: what the chip reports, corrected.
        let f = [G0_MPS2, 0.0, 0.0];
        let raw_g: Vec<f64> = (0..3)
            .map(|i| {
                ((0..3)
                    .map(|k| e.accel_mps2.misalignment[i][k] * f[k])
                    .sum::<f64>()
                    + e.accel_mps2.bias[i])
                    / G0_MPS2
            })
            .collect();
        let x = (raw_g[0] - f64::from(rec.accel_offset_g[0])) * f64::from(rec.accel_scale[0]);
        assert!((x - 1.0).abs() < 1e-6, "{x}");
        // A field of (20, −5, 40) µT in the MPU frame through the AK8963's errors.
        let b_mpu = [20.0, -5.0, 40.0];
        let b_ak: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|k| AK_TO_MPU[i][k] * b_mpu[k]).sum())
            .collect();
        let meas_ak: Vec<f64> = (0..3)
            .map(|i| {
                (0..3).map(|k| e.mag.soft_iron[i][k] * b_ak[k]).sum::<f64>() + e.mag.hard_iron_ut[i]
            })
            .collect();
        let raw_mpu: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|k| AK_TO_MPU[i][k] * meas_ak[k]).sum())
            .collect();
        for (i, want) in b_mpu.iter().enumerate() {
            let c: f64 = (0..3)
                .map(|k| {
                    f64::from(rec.mag_soft_iron[i][k])
                        * (raw_mpu[k] - f64::from(rec.mag_offset_ut[k]))
                })
                .sum();
            assert!((c - want).abs() < 1e-3, "axis {i}: {c}");
        }
        assert!(rec.valid.has(ValidParts::ACCEL | ValidParts::MAG));
    }

    #[test]
    fn the_page_round_trips_through_the_firmwares_decoder() {
        let rec = record_for(&SensorErrors::datasheet(5));
        let image = with_record(vec![0xFF; 64 * 1024], &rec);
        let back = storage::decode(&image[PAGE_OFFSET..]).ok();
        assert_eq!(back, Some(rec));
    }

    #[test]
    fn the_cb_page_is_its_last_page() {
        let rec = record_for(&SensorErrors::datasheet(5));
        let image = with_record(vec![0xFF; 128 * 1024], &rec);
        let at = 0x0801_FC00 - 0x0800_0000;
        assert_eq!(storage::decode(&image[at..]).ok(), Some(rec));
        assert!(image[..at].iter().all(|b| *b == 0xFF));
    }
}
