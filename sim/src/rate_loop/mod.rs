//! The rate loop measured from its signals, per axis: the closed loop
//! `T = gyro / setpoint` and the open loop `L = T / (1 − T)` ([`freq`]),
//! its margins, and the step response by deconvolution ([`step`]). The
//! signals are the rate setpoint the controller used and the gyro it saw,
//! at a constant sample rate: from the chirp scenario's sweeps
//! ([`chirp_signals`]) on either rig (`cargo sim`, `cargo fil`), or from
//! any log that holds them.

pub mod freq;
pub mod step;
pub mod test_signals;

use crate::scenario::{CHIRP_AXIS_PERIOD_S, CHIRP_START_S, CHIRP_SWEEP_S};
use freq::{FreqResponse, Margins};
use step::StepResponse;

/// The axes' names, roll, pitch, yaw.
pub const AXES: [&str; 3] = ["roll", "pitch", "yaw"];
/// Bands below this coherence are not used for the margins: the
/// estimate's variance there is large.
pub const MIN_COHERENCE: f64 = 0.6;
/// Frequency bands a decade.
pub const BANDS_PER_DECADE: usize = 20;
/// Lowest frequency analysed (Hz): the chirp's start.
pub const F_LO_HZ: f64 = 0.7;
/// Highest frequency analysed (Hz): the chirp's end, and at most 80 % of
/// the Nyquist frequency.
pub const F_HI_HZ: f64 = 80.0;
/// Step windows with less setpoint span than this are skipped (rad/s):
/// 20 °/s.
const STEP_MIN_SPAN_RPS: f64 = 0.35;
/// The step response's horizon (s).
const STEP_HORIZON_S: f64 = 0.5;

/// One axis' signals at a constant sample rate.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AxisSignals {
    /// The rate setpoint the controller used (rad/s).
    pub setpoint_rps: Vec<f64>,
    /// The gyro the controller saw (rad/s).
    pub gyro_rps: Vec<f64>,
}

/// One axis measured.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisReport {
    /// Roll, pitch or yaw.
    pub axis: &'static str,
    /// The closed loop, coherent bands only.
    pub closed: FreqResponse,
    /// The open loop from it.
    pub open: FreqResponse,
    /// Its margins.
    pub margins: Margins,
    /// The step response, when the setpoint moved enough.
    pub step: Option<StepResponse>,
}

/// The power of two nearest `seconds · fs_hz`, at least 64.
fn pow2_len(seconds: f64, fs_hz: f64) -> usize {
    let n = (seconds * fs_hz).max(64.0);
    1usize << n.log2().round() as u32
}

/// Measures one axis sampled at `fs_hz`: Welch segments of ≈ 4 s, steps
/// over windows of ≈ 2 s.
pub fn analyse_axis(axis: &'static str, s: &AxisSignals, fs_hz: f64) -> Result<AxisReport, String> {
    let seg = pow2_len(4.0, fs_hz);
    let spectra = freq::cross_spectra(&s.setpoint_rps, &s.gyro_rps, fs_hz, seg)
        .map_err(|e| format!("{axis}: {e}"))?;
    let f_lo = F_LO_HZ.max(2.0 * spectra.df_hz);
    let f_hi = F_HI_HZ.min(0.4 * fs_hz);
    let closed =
        FreqResponse::banded(&spectra, f_lo, f_hi, BANDS_PER_DECADE).coherent(MIN_COHERENCE);
    if closed.f_hz.len() < 3 {
        return Err(format!(
            "{axis}: fewer than 3 coherent bands between {f_lo:.1} and {f_hi:.0} Hz: the setpoint does not excite the loop"
        ));
    }
    let open = closed.open_loop_of_closed();
    let margins = freq::margins(&open);
    let window = pow2_len(2.0, fs_hz);
    let step = step::step_response(
        &s.setpoint_rps,
        &s.gyro_rps,
        fs_hz,
        window,
        STEP_HORIZON_S.min(0.45 * window as f64 / fs_hz),
        STEP_MIN_SPAN_RPS,
    );
    Ok(AxisReport {
        axis,
        closed,
        open,
        margins,
        step,
    })
}

/// The window of axis `axis`' sweep (0 roll, 1 pitch, 2 yaw) in the
/// chirp scenario: `[start, end)` (s).
pub fn chirp_window_s(axis: usize) -> (f64, f64) {
    let t0 = CHIRP_START_S + axis as f64 * CHIRP_AXIS_PERIOD_S;
    (t0, t0 + CHIRP_SWEEP_S)
}

/// One sample of a chirp flight: its time (s), the rate setpoint and the
/// gyro the controller saw (rad/s, roll pitch yaw; `None` when it had
/// none, as when not flying).
pub type ChirpSample = (f64, Option<[f64; 3]>, Option<[f64; 3]>);

/// The signals of each axis' sweep in a chirp flight: the samples within
/// each sweep's window ([`chirp_window_s`]), in time order; an error when
/// one has no setpoint or gyro.
pub fn chirp_signals(
    samples: impl IntoIterator<Item = ChirpSample>,
) -> Result<[AxisSignals; 3], String> {
    let mut out: [AxisSignals; 3] = Default::default();
    for (t_s, sp, g) in samples {
        let Some(axis) = (0..3).find(|&a| {
            let (t0, t1) = chirp_window_s(a);
            t_s >= t0 && t_s < t1
        }) else {
            continue;
        };
        let (Some(sp), Some(g)) = (sp, g) else {
            return Err(format!(
                "{} sweep: no rate setpoint or gyro at {t_s:.3} s (not flying)",
                AXES[axis]
            ));
        };
        out[axis].setpoint_rps.push(sp[axis]);
        out[axis].gyro_rps.push(g[axis]);
    }
    Ok(out)
}

/// Measures the three sweeps' signals sampled at `fs_hz`.
pub fn analyse_sweeps(signals: &[AxisSignals; 3], fs_hz: f64) -> Result<Vec<AxisReport>, String> {
    AXES.iter()
        .zip(signals)
        .map(|(axis, s)| analyse_axis(axis, s, fs_hz))
        .collect()
}

/// `Some(v)` to `v` with `decimals`, `None` to "-".
fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.decimals$}"))
}

/// The table: a header and one line per axis.
pub fn table(reports: &[AxisReport]) -> Vec<String> {
    let mut out = vec![format!(
        "{:<6} {:>9} {:>7} {:>8} {:>7} {:>5} {:>6} {:>8} {:>9} {:>9}",
        "axis",
        "cross Hz",
        "PM °",
        "GM dB",
        "GM Hz",
        "Ms",
        "Ms Hz",
        "rise ms",
        "overs. %",
        "settle ms"
    )];
    for r in reports {
        let m = &r.margins;
        let s = r.step.as_ref();
        out.push(format!(
            "{:<6} {:>9} {:>7} {:>8} {:>7} {:>5.2} {:>6.1} {:>8} {:>9} {:>9}",
            r.axis,
            opt(m.crossover_hz, 1),
            opt(m.phase_margin_deg, 1),
            opt(m.gain_margin_db, 1),
            opt(m.phase_crossover_hz, 1),
            m.ms,
            m.ms_hz,
            opt(s.and_then(|s| s.rise_s).map(|v| v * 1e3), 0),
            opt(s.map(|s| s.overshoot_pct), 1),
            opt(s.and_then(|s| s.settling_s).map(|v| v * 1e3), 0),
        ));
    }
    out.push(format!(
        "(L = T/(1−T), T = gyro/setpoint by Welch H1 in {BANDS_PER_DECADE} bands a decade, bands with coherence ≥ {MIN_COHERENCE}; step by Wiener deconvolution, settling to ±{:.0} %)",
        step::SETTLING_BAND * 100.0
    ));
    out
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;

    /// A flight sampled at 1 kHz from 0 to the end of the last sweep, the
    /// setpoint `t` and the gyro `−t` on every axis.
    fn flight(missing_at_s: Option<f64>) -> Vec<ChirpSample> {
        let end_s = chirp_window_s(2).1 + 1.0;
        (0..(end_s * 1000.0) as usize)
            .map(|i| {
                let t = i as f64 * 1e-3;
                let sp = (missing_at_s.is_none_or(|m| (t - m).abs() > 1e-6)).then_some([t; 3]);
                (t, sp, Some([-t; 3]))
            })
            .collect()
    }

    #[test]
    fn each_sweep_is_its_window_of_its_own_axis() {
        let s = chirp_signals(flight(None)).unwrap();
        for (axis, sig) in s.iter().enumerate() {
            let (t0, t1) = chirp_window_s(axis);
            assert_eq!(
                sig.setpoint_rps.len(),
                ((t1 - t0) * 1000.0).round() as usize
            );
            assert!((sig.setpoint_rps[0] - t0).abs() < 1e-3, "{axis}");
            assert!(sig.setpoint_rps.last().unwrap() < &t1);
            assert!(sig
                .setpoint_rps
                .iter()
                .zip(&sig.gyro_rps)
                .all(|(a, b)| a == &-b));
        }
        // The windows are the script's: the sweep's length apart by the rest.
        assert_eq!(
            chirp_window_s(0),
            (CHIRP_START_S, CHIRP_START_S + CHIRP_SWEEP_S)
        );
        assert!(
            (chirp_window_s(1).0 - chirp_window_s(0).1 - crate::scenario::CHIRP_REST_S).abs()
                < 1e-9
        );
    }

    #[test]
    fn a_sweep_without_a_setpoint_is_refused_and_the_rest_ignored() {
        // Outside the sweeps (before the first, between two) nothing is needed.
        assert!(chirp_signals(flight(Some(1.0))).is_ok());
        assert!(chirp_signals(flight(Some(chirp_window_s(0).1 + 1.0))).is_ok());
        let e = chirp_signals(flight(Some(chirp_window_s(1).0 + 2.0))).unwrap_err();
        assert!(e.starts_with("pitch sweep"), "{e}");
    }
}
