//! The CSV of a closed-loop flight (`cargo sim --scenario NAME --csv
//! FILE`): one row per logged IMU sample (1 kHz) with the model's truth,
//! the pipeline's estimate, the controller's setpoints and motor commands,
//! the link and ground state, and the events of that sample
//! ([`super::timeline`]). [`COLUMNS`] documents every column; `--help` and
//! the README print the same list.

use super::closed_loop::{FlightLog, Sample};
use super::timeline::TimedEvent;
use std::io::Write;

/// Every column, in order, with what it holds. An empty cell: no value at
/// that sample (no estimate yet, no setpoint while disarmed or in that mode).
pub const COLUMNS: [(&str, &str); 39] = [
    ("t_s", "simulated time (s)"),
    ("true_roll_deg", "true roll (°, within ±180)"),
    ("true_pitch_deg", "true pitch (°)"),
    ("true_yaw_deg", "true yaw (°, within ±180)"),
    ("true_north_m", "true position north of the take-off point (m)"),
    ("true_east_m", "true position east of the take-off point (m)"),
    ("true_height_m", "true height above the ground (m)"),
    ("true_vel_north_mps", "true velocity north (m/s)"),
    ("true_vel_east_mps", "true velocity east (m/s)"),
    ("true_vel_down_mps", "true velocity down (m/s; a climb is negative)"),
    ("true_roll_rate_dps", "true body rate about x, forward (°/s)"),
    ("true_pitch_rate_dps", "true body rate about y, right (°/s)"),
    ("true_yaw_rate_dps", "true body rate about z, down (°/s)"),
    ("est_roll_deg", "AHRS roll estimate (°)"),
    ("est_pitch_deg", "AHRS pitch estimate (°)"),
    ("est_yaw_deg", "AHRS yaw estimate (°)"),
    ("est_height_m", "vertical estimator's height (m)"),
    ("sp_roll_deg", "roll setpoint of the self-levelling modes (°)"),
    ("sp_pitch_deg", "pitch setpoint of the self-levelling modes (°)"),
    ("sp_roll_rate_dps", "roll-rate setpoint (°/s)"),
    ("sp_pitch_rate_dps", "pitch-rate setpoint (°/s)"),
    ("sp_yaw_rate_dps", "yaw-rate setpoint (°/s)"),
    ("height_target_m", "altitude-hold target (m)"),
    ("motor1", "motor 1 (rear right) command, 0..1"),
    ("motor2", "motor 2 (front right) command, 0..1"),
    ("motor3", "motor 3 (rear left) command, 0..1"),
    ("motor4", "motor 4 (front left) command, 0..1"),
    ("armed", "1 armed (also in a failsafe), 0 disarmed"),
    ("failsafe", "1 while the controller flies its failsafe"),
    ("link", "1 a radio frame was sent at this sample, 0 link lost"),
    ("on_ground", "1 the model rests on the ground"),
    ("battery_v", "battery terminal voltage (V)"),
    ("gyro_roll_dps", "the gyro the rate loop was given, about x (°/s; the pipeline's, bias removed)"),
    ("gyro_pitch_dps", "the gyro the rate loop was given, about y (°/s)"),
    ("gyro_yaw_dps", "the gyro the rate loop was given, about z (°/s)"),
    ("torque_roll", "the rate loop's roll torque command (−1..1)"),
    ("torque_pitch", "the rate loop's pitch torque command (−1..1)"),
    ("torque_yaw", "the rate loop's yaw torque command (−1..1)"),
    (
        "events",
        "the events of this sample, separated by `; `: the controller's in the words of the status lines and the board's log (ARMED, failsafe: no link: holding level and the height, failsafe: descending, disarmed: failsafe: landed, ...), injected faults (fault TIME:KIND), link lost, link back, motor N failed, lift-off, touch-down",
    ),
];

/// The header line: the column names joined by commas.
pub fn header() -> String {
    COLUMNS.map(|(name, _)| name).join(",")
}

/// The column list for `--help` and the README: one `name  meaning` line
/// each.
pub fn help() -> String {
    let mut s = String::from(
        "Scenario CSV (--scenario NAME --csv FILE): one row per IMU sample (1 kHz), columns:\n",
    );
    for (name, what) in COLUMNS {
        s.push_str(&format!("  {name:<20} {what}\n"));
    }
    s
}

/// Writes the header and one row per sample of `log`; each event goes on
/// the first sample at or after its time (an event after the last sample
/// on the last row).
pub fn write(out: &mut dyn Write, log: &FlightLog, events: &[TimedEvent]) -> std::io::Result<()> {
    writeln!(out, "{}", header())?;
    let mut next = 0;
    let n = log.samples.len();
    for (i, s) in log.samples.iter().enumerate() {
        let start = next;
        while events
            .get(next)
            .is_some_and(|e| e.t_s <= s.t_s || i + 1 == n)
        {
            next += 1;
        }
        let texts: Vec<&str> = events
            .get(start..next)
            .unwrap_or_default()
            .iter()
            .map(|e| e.text.as_str())
            .collect();
        writeln!(out, "{},{}", row(s), quoted(&texts.join("; ")))?;
    }
    Ok(())
}

/// A CSV field: quoted (its quotes doubled) when it holds a comma, a
/// quote or a line break.
fn quoted(field: &str) -> String {
    if field.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", field.replace('"', "\"\""))
    } else {
        field.to_string()
    }
}

fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or(String::new(), |x| format!("{x:.decimals$}"))
}

/// Every column of `s` but the events.
fn row(s: &Sample) -> String {
    let deg = |e: [f64; 3]| e.map(f64::to_degrees);
    let t = deg(s.truth.q_ned_from_body.to_euler());
    let e = deg(s.est_q.to_euler());
    let (p, v) = (s.truth.position_ned_m, s.truth.velocity_ned_mps);
    let w = deg(s.truth.omega_body_rps);
    let out = &s.out;
    let tilt = |i: usize| out.tilt_setpoint_rad.map(|t| f64::from(t[i]).to_degrees());
    let rate = |i: usize| out.rate_setpoint_rps.map(|r| f64::from(r[i]).to_degrees());
    let flag = |b: bool| u8::from(b).to_string();
    let cells = [
        format!("{:.4}", s.t_s),
        format!("{:.3},{:.3},{:.3}", t[0], t[1], t[2]),
        format!("{:.4},{:.4},{:.4}", p[0], p[1], s.truth.height_m),
        format!("{:.4},{:.4},{:.4}", v[0], v[1], v[2]),
        format!("{:.3},{:.3},{:.3}", w[0], w[1], w[2]),
        format!("{:.3},{:.3},{:.3}", e[0], e[1], e[2]),
        opt(s.est_height_m, 4),
        [opt(tilt(0), 3), opt(tilt(1), 3)].join(","),
        [opt(rate(0), 3), opt(rate(1), 3), opt(rate(2), 3)].join(","),
        opt(out.height_target_m.map(f64::from), 4),
        out.motors.map(|m| format!("{m:.4}")).join(","),
        [out.armed, out.failsafe, s.pilot.is_some(), s.quad.on_ground]
            .map(flag)
            .join(","),
        format!("{:.3}", s.quad.battery_voltage_v),
        (0..3)
            .map(|i| opt(out.gyro_rps.map(|g| f64::from(g[i]).to_degrees()), 3))
            .collect::<Vec<_>>()
            .join(","),
        (0..3)
            .map(|i| opt(out.torque.map(|t| f64::from(t[i])), 4))
            .collect::<Vec<_>>()
            .join(","),
    ];
    cells.join(",")
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use crate::demo::closed_loop::{fly, ClosedLoopOptions, Scenario, LINK_LOSS_S};
    use crate::demo::figures::figures;
    use crate::demo::flight_fc::FirmwareFc;
    use crate::demo::timeline::timeline;

    /// The rows of the CSV of `log`, split into cells (header first).
    fn table(log: &FlightLog) -> Vec<Vec<String>> {
        let mut out = Vec::new();
        write(&mut out, log, &timeline(log)).unwrap();
        let text = String::from_utf8(out).unwrap();
        // Split on commas is right only while no field is quoted.
        assert!(!text.contains('"'));
        text.lines()
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect()
    }

    /// The time of the first row whose events hold `what`.
    fn row_time(rows: &[Vec<String>], what: &str) -> f64 {
        let events = COLUMNS.len() - 1;
        let row = rows
            .iter()
            .skip(1)
            .find(|r| r[events].split("; ").any(|e| e.starts_with(what)))
            .unwrap_or_else(|| panic!("no `{what}` event"));
        row[0].parse().unwrap()
    }

    #[test]
    fn the_link_loss_csv_has_its_columns_and_events_where_the_figures_put_them() {
        let mut fc = FirmwareFc::new(settings::flight_config()).unwrap();
        let mut o = ClosedLoopOptions::new(Scenario::LinkLoss, 1);
        o.mag_dance_s = 20.0;
        let log = fly(&o, &mut fc).unwrap();
        let rows = table(&log);
        let names: Vec<&str> = COLUMNS.iter().map(|c| c.0).collect();
        assert_eq!(rows[0], names);
        assert_eq!(rows.len(), log.samples.len() + 1);
        assert!(rows.iter().all(|r| r.len() == names.len()));
        let l = figures(&log).link_loss.unwrap();
        let lost = row_time(&rows, "link lost");
        // The script stops its frames at LINK_LOSS_S; the next 1 kHz sample logs it.
        assert!((LINK_LOSS_S..LINK_LOSS_S + 0.002).contains(&lost), "{lost}");
        let near = |t: f64, want: f64, tol: f64| (t - want).abs() <= tol;
        let hold = row_time(&rows, "failsafe: no link: holding");
        assert!(
            near(hold, lost + l.detected_s.unwrap(), 1e-3),
            "{hold} {l:?}"
        );
        let descent = row_time(&rows, "failsafe: descending");
        assert!(descent > hold, "{descent}");
        // The figures' touch-down is the height falling below 2 cm; the
        // event is the model settling on the ground, 2 cm later at 0.5 m/s
        // plus, when the descent loop is braking at contact (thrust above
        // weight), a hop of a millimetre or so before it settles (seed 1:
        // contact 0.04 s after the 2 cm mark, settled 0.14 s later).
        let down = row_time(&rows, "touch-down");
        assert!(near(down, lost + l.landed_s.unwrap(), 0.25), "{down} {l:?}");
        let disarm = row_time(&rows, "disarmed: failsafe: landed");
        assert!(
            near(disarm, lost + l.disarmed_s.unwrap(), 1e-3),
            "{disarm} {l:?}"
        );
        // The columns agree with the events: disarmed from that row on,
        // the link column 0 from the loss on.
        let col = |name: &str| names.iter().position(|n| *n == name).unwrap();
        let (armed, link) = (col("armed"), col("link"));
        let armed_at = row_time(&rows, "ARMED");
        for r in rows.iter().skip(1) {
            let t: f64 = r[0].parse().unwrap();
            assert_eq!(r[armed] == "1", (armed_at..disarm).contains(&t), "{r:?}");
            assert_eq!(r[link] == "0", t >= lost, "{r:?}");
        }
    }

    #[test]
    fn a_field_with_a_comma_or_quote_is_quoted() {
        assert_eq!(quoted("ARMED; link lost"), "ARMED; link lost");
        assert_eq!(quoted("a,b"), "\"a,b\"");
        assert_eq!(quoted("say \"x\""), "\"say \"\"x\"\"\"");
        assert_eq!(header().split(',').count(), COLUMNS.len());
        assert!(COLUMNS.iter().all(|(name, _)| help().contains(name)));
    }
}
