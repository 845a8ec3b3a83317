//! CSV output in the BROAD columns (readable by `tools/replay`).

use super::run::Record;
use sim::math::{q_body_from_mpu, q_enu_from_ned};
use std::io::Write;

/// Writes one row per record: sensor (MPU) frame data, calibrated
/// magnetometer, and the true orientation of the sensor frame relative to ENU.
pub fn write_csv(path: &str, records: &[Record]) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        f,
        "t_s,gyr_x_rad_s,gyr_y_rad_s,gyr_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2,mag_x_ut,mag_y_ut,mag_z_ut,ref_qw,ref_qx,ref_qy,ref_qz,moving"
    )?;
    let enu_ned = q_enu_from_ned();
    let body_mpu = q_body_from_mpu();
    for r in records {
        let Some(m) = r.mag_mpu_ut else { continue };
        let mut q = enu_ned.mul(&r.truth).mul(&body_mpu);
        if q.w < 0.0 {
            q = sim::Quat::new(-q.w, -q.x, -q.y, -q.z);
        }
        let g = r.gyro_mpu_rps;
        let a = r.accel_mpu_mps2;
        writeln!(
            f,
            "{:.6},{:.7},{:.7},{:.7},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.7},{:.7},{:.7},{:.7},{}",
            r.t_s, g[0], g[1], g[2], a[0], a[1], a[2], m[0], m[1], m[2], q.w, q.x, q.y, q.z, u8::from(r.moving)
        )?;
    }
    f.flush()
}
