//! Synthetic recordings for the reader and CLI tests.
#![allow(dead_code)]

/// The full BROAD header.
pub const HEADER: &str = "t_s,gyr_x_rad_s,gyr_y_rad_s,gyr_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2,mag_x_ut,mag_y_ut,mag_z_ut,ref_qw,ref_qx,ref_qy,ref_qz,moving";

/// One row at rest, level, at time `t_s`, with reference `q` (w, x, y, z).
pub fn row(t_s: f64, q: [f32; 4]) -> String {
    format!(
        "{t_s:.6},0.001,-0.002,0.0005,0.05,-0.03,9.81,20.0,0.5,-40.0,{},{},{},{},1",
        q[0], q[1], q[2], q[3]
    )
}

/// The identity reference in ENU for the rows of [`row`] (level; the
/// filter's initial heading puts magnetic north, +x here, on its own axis,
/// so this is a constant offset the test does not depend on).
pub const LEVEL: [f32; 4] = [1.0, 0.0, 0.0, 0.0];

/// `n` rows at 100 Hz from `t0_s`.
pub fn rows(n: usize, t0_s: f64) -> Vec<String> {
    (0..n).map(|i| row(t0_s + i as f64 * 0.01, LEVEL)).collect()
}

/// A file: header, then the rows, newline-terminated.
pub fn file(rows: &[String]) -> String {
    let mut s = String::from(HEADER);
    s.push('\n');
    for r in rows {
        s.push_str(r);
        s.push('\n');
    }
    s
}
