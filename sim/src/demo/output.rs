//! CSV output in the BROAD columns (readable by `tools/replay`), streamed
//! row by row as the run produces them.

use super::run::{Record, RecordSink};
use sim::math::{q_body_from_mpu, q_enu_from_ned};
use sim::Quat;
use std::io::{ErrorKind, Write};

/// The CSV header: the columns `replay` and `../shared/data/broad` use.
pub const HEADER: &str = "t_s,gyr_x_rad_s,gyr_y_rad_s,gyr_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2,mag_x_ut,mag_y_ut,mag_z_ut,ref_qw,ref_qx,ref_qy,ref_qz,moving";

/// Writes one row per record with a magnetometer sample: sensor (MPU)
/// frame data, calibrated magnetometer, and the true orientation of the
/// sensor frame relative to ENU.
pub struct CsvWriter {
    out: std::io::BufWriter<Box<dyn Write>>,
    name: String,
    /// The reader went away (stdout closed): rows are dropped quietly.
    closed: bool,
    enu_ned: Quat,
    body_mpu: Quat,
}

impl CsvWriter {
    /// A writer on `out` (named `name` in errors); writes the header.
    pub fn new(out: Box<dyn Write>, name: &str) -> Result<Self, String> {
        let mut w = Self {
            out: std::io::BufWriter::new(out),
            name: name.to_string(),
            closed: false,
            enu_ned: q_enu_from_ned(),
            body_mpu: q_body_from_mpu(),
        };
        let res = writeln!(w.out, "{HEADER}");
        w.check(res)?;
        Ok(w)
    }

    fn check(&mut self, res: std::io::Result<()>) -> Result<(), String> {
        match res {
            Err(e) if e.kind() == ErrorKind::BrokenPipe => {
                self.closed = true;
                Ok(())
            }
            Err(e) => Err(format!("writing {}: {e}", self.name)),
            Ok(()) => Ok(()),
        }
    }

    /// Flushes the buffered rows.
    pub fn finish(mut self) -> Result<(), String> {
        if self.closed {
            return Ok(());
        }
        let res = self.out.flush();
        self.check(res)
    }
}

impl RecordSink for CsvWriter {
    fn push(&mut self, r: &Record) -> Result<(), String> {
        let Some(m) = r.mag_mpu_ut else {
            return Ok(());
        };
        if self.closed {
            return Ok(());
        }
        let mut q = self.enu_ned.mul(&r.truth).mul(&self.body_mpu);
        if q.w < 0.0 {
            q = Quat::new(-q.w, -q.x, -q.y, -q.z);
        }
        let g = r.gyro_mpu_rps;
        let a = r.accel_mpu_mps2;
        let res = writeln!(
            self.out,
            "{:.6},{:.7},{:.7},{:.7},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.7},{:.7},{:.7},{:.7},{}",
            r.t_s,
            g[0],
            g[1],
            g[2],
            a[0],
            a[1],
            a[2],
            m[0],
            m[1],
            m[2],
            q.w,
            q.x,
            q.y,
            q.z,
            u8::from(r.moving)
        );
        self.check(res)
    }
}
