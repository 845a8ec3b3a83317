//! `cargo sim --analyse FILE.csv`: the rate loop's figures ([`tuning`])
//! from a log instead of a simulated flight. The log needs a time column
//! `t_s` and, per axis, the rate setpoint the controller used and the gyro
//! it saw: `sp_roll_rate_dps` and `gyro_roll_dps` (and pitch, yaw), as the
//! scenario CSV (`cargo sim --scenario NAME --csv FILE`) has them, and
//! the STM32F103CB build's raw log at 100 Hz
//! (`sensor_stack::calmode::RATE_LOG_COLUMNS` after `RAW_LOG_HEADER`): a
//! real flight's log is analysed the same way. The C8 build's raw log
//! holds the sensors only, with no setpoint: it is recognised and refused
//! with that reason.

use super::tuning::{self, AxisReport, AxisSignals, AXES};
use std::path::Path;

/// The board's raw log's gyro column (sensor frame, rad/s).
const RAW_LOG_GYRO: &str = "gyr_x_rad_s";

/// Sample spacing may wander by this fraction of the median before the
/// log counts as unevenly sampled (gaps, dropped rows).
const DT_TOLERANCE: f64 = 0.2;

/// A log read for the analysis: the sample rate and each axis' signals.
#[derive(Clone, Debug, PartialEq)]
pub struct LogSignals {
    /// Sample rate (Hz).
    pub fs_hz: f64,
    /// Roll, pitch, yaw: setpoint and gyro (rad/s).
    pub axes: [AxisSignals; 3],
    /// Rows used.
    pub rows: usize,
}

/// Reads `path` and checks it: the columns, numbers, an even sample rate.
pub fn read(path: &Path) -> Result<LogSignals, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The column index of each name in `header`.
fn columns(header: &[&str], names: &[String]) -> Result<Vec<usize>, String> {
    names
        .iter()
        .map(|n| {
            header
                .iter()
                .position(|h| h.trim() == n)
                .ok_or_else(|| format!("no `{n}` column"))
        })
        .collect()
}

/// Parses a CSV log: the rows with a setpoint and a gyro on every axis
/// (rows without, or with NaN, as while disarmed, are left out, so the rows used must
/// be one stretch of evenly spaced samples).
pub fn parse(text: &str) -> Result<LogSignals, String> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("empty file")?.split(',').collect();
    if header.contains(&RAW_LOG_GYRO) && !header.contains(&"sp_roll_rate_dps") {
        return Err(
            "this is the C8 build's raw log: gyro, accelerometer and magnetometer at 100 Hz in the sensor frame, \
             with no rate setpoint (nor sticks, nor torque), so the loop's response cannot be measured from it; \
             the analysis needs t_s, sp_<axis>_rate_dps and gyro_<axis>_dps (the scenario CSV's columns, \
             and the STM32F103CB build's raw log)"
                .into(),
        );
    }
    let mut names = vec!["t_s".to_string()];
    for a in AXES {
        names.push(format!("sp_{a}_rate_dps"));
        names.push(format!("gyro_{a}_dps"));
    }
    let idx = columns(&header, &names)?;
    let mut t = Vec::new();
    let mut axes: [AxisSignals; 3] = Default::default();
    for (n, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        let values: Option<Vec<f64>> = idx
            .iter()
            .map(|&i| cells.get(i).and_then(|c| c.trim().parse::<f64>().ok()))
            .collect();
        let Some(v) = values else { continue };
        // NaN: no value yet (the CB raw log's first rows, before a full
        // block of the rate loop's samples), left out like an empty cell.
        if v.iter().any(|x| x.is_nan()) {
            continue;
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(format!("row {}: a value is not finite", n + 2));
        }
        t.push(v[0]);
        for (a, sig) in axes.iter_mut().enumerate() {
            sig.setpoint_rps.push(v[1 + 2 * a].to_radians());
            sig.gyro_rps.push(v[2 + 2 * a].to_radians());
        }
    }
    let fs_hz = even_rate_hz(&t)?;
    Ok(LogSignals {
        fs_hz,
        rows: t.len(),
        axes,
    })
}

/// The sample rate of times `t` (s), an error unless every spacing is
/// within [`DT_TOLERANCE`] of the median.
fn even_rate_hz(t: &[f64]) -> Result<f64, String> {
    if t.len() < 2 {
        return Err("fewer than two rows with a setpoint and a gyro on every axis".into());
    }
    let dt: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let mut sorted = dt.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    if median <= 0.0 {
        return Err("t_s does not increase".into());
    }
    if let Some(i) = dt
        .iter()
        .position(|d| (*d / median - 1.0).abs() > DT_TOLERANCE)
    {
        return Err(format!(
            "uneven sampling: {:.4} s between t = {:.4} and {:.4} s (median {median:.4} s); \
             the rows used must be one evenly spaced stretch",
            dt[i],
            t[i],
            t[i + 1]
        ));
    }
    Ok(1.0 / median)
}

/// Every axis measured.
pub fn analyse(s: &LogSignals) -> Result<Vec<AxisReport>, String> {
    AXES.iter()
        .zip(&s.axes)
        .map(|(a, sig)| tuning::analyse_axis(a, sig, s.fs_hz))
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use sim::rate_loop::freq::C;
    use sim::rate_loop::test_signals::{lag, noise};
    use std::ops::{Div, Sub};

    /// A log of a first-order loop on every axis, time constant `tau_s`.
    fn log(tau_s: f64, rows: usize) -> String {
        let mut s = String::from("t_s,sp_roll_rate_dps,gyro_roll_dps,sp_pitch_rate_dps,gyro_pitch_dps,sp_yaw_rate_dps,gyro_yaw_dps,other\n");
        let x: Vec<f64> = noise(rows, 9).iter().map(|v| 100.0 * v).collect();
        let y = lag(&x, 1e-3, tau_s, 0);
        for i in 0..rows {
            let (a, b) = (x[i], y[i]);
            s.push_str(&format!(
                "{:.4},{a},{b},{a},{b},{a},{b},x\n",
                i as f64 * 1e-3
            ));
        }
        s
    }

    #[test]
    fn a_log_is_read_and_measured() {
        let s = parse(&log(0.01, 30_000)).unwrap();
        assert!((s.fs_hz - 1000.0).abs() < 1e-6);
        let r = analyse(&s).unwrap();
        // The log's loop: T = e^{−sθ} / (1 + sτ), θ = 0.5 ms (the
        // step-invariant discrete lag is the continuous one behind a
        // zero-order hold: half a sample). |L| = 1 where
        // |T| = |1 − T|, i.e. Re T = 1/2; the phase margin is
        // 180° + ∠(T / (1 − T)) there; T/(1 − T) = 1/(sτ) without the delay.
        let (tau, theta) = (0.01, 0.5e-3);
        let t_of = |f: f64| {
            let w = 2.0 * std::f64::consts::PI * f;
            C::from_phase(-w * theta).div(C::new(1.0, w * tau))
        };
        let fc = (0..100_000)
            .map(|i| 1.0 + i as f64 * 1e-3)
            .find(|&f| t_of(f).re <= 0.5)
            .unwrap();
        let t = t_of(fc);
        let pm = 180.0 + t.div(C::new(1.0, 0.0).sub(t)).arg().to_degrees();
        for a in r {
            let m = a.margins;
            assert!(
                (m.crossover_hz.unwrap() / fc - 1.0).abs() < 0.03,
                "{m:?} {fc}"
            );
            assert!((m.phase_margin_deg.unwrap() - pm).abs() < 3.0, "{m:?} {pm}");
            assert!(m.ms < 1.1, "{m:?}");
        }
    }

    #[test]
    fn a_raw_log_or_a_bad_log_is_refused_with_its_reason() {
        let raw = format!(
            "{}\n0.01,0,0,0,0,0,9.8,1,2,3,nan,nan,nan,nan,0\n",
            sensor_stack::calmode::RAW_LOG_HEADER
        );
        assert!(parse(&raw).unwrap_err().contains("no rate setpoint"));
        // The CB build's raw log carries the rate columns: read by name.
        let mut cb = format!(
            "{},{}\n",
            sensor_stack::calmode::RAW_LOG_HEADER,
            sensor_stack::calmode::RATE_LOG_COLUMNS
        );
        for i in 0..200 {
            let sp = (f64::from(i) * 0.3).sin() * 100.0;
            cb.push_str(&format!(
                "{},0,0,0,0,0,9.8,1,2,3,nan,nan,nan,nan,0,{sp},{sp},{sp},{sp},{sp},{sp}\n",
                f64::from(i) * 0.01
            ));
        }
        let l = parse(&cb).unwrap();
        assert_eq!((l.rows, l.fs_hz.round()), (200, 100.0));
        assert!((l.axes[0].gyro_rps[10] - l.axes[0].setpoint_rps[10]).abs() < 1e-12);
        assert!(parse("t_s,sp_roll_rate_dps\n0,1\n")
            .unwrap_err()
            .contains("gyro_roll_dps"));
        let mut gap = log(0.01, 1000);
        gap.push_str("5.0,1,1,1,1,1,1,x\n");
        assert!(parse(&gap).unwrap_err().contains("uneven"));
        assert!(parse("").is_err());
    }
}
