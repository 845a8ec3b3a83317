//! `cargo sim --spectrum FILE`: the simulated gyro's spectrum at hover and
//! at full throttle, as the chip outputs it with the board's setup
//! (`settings::MPU`), before the rate loop's software filter.

use sim::plot::Series;
use sim::quad::{QuadParams, Quadcopter};
use sim::spectrum::{record_gyro, welch_psd, ChipSetup};
use std::path::Path;

/// Seconds skipped while the chip's filters and the rotors settle.
const SETTLE_S: f64 = 0.5;
/// Seconds recorded per case.
const RECORD_S: f64 = 8.0;
/// Welch segment (samples): about 2 Hz bins at 1 kHz.
const SEGMENT: usize = 512;

/// The chip's setup as the board programs it (`settings::MPU`).
fn board_setup() -> ChipSetup {
    ChipSetup {
        dlpf_cfg: settings::MPU.gyro_bandwidth.dlpf_cfg(),
        smplrt_div: settings::MPU.sample_rate_divider,
    }
}

/// One case's spectrum and its summary line.
fn case(
    name: &str,
    airframe: QuadParams,
    command: f64,
    seed: u64,
) -> Result<((String, Vec<Series>), String), String> {
    let (gyro, rate, rotor_rps) =
        record_gyro(airframe, command, board_setup(), SETTLE_S, RECORD_S, seed)?;
    let rotor_hz = rotor_rps / std::f64::consts::TAU;
    let mut series = Vec::new();
    let mut rms = [0.0; 3];
    for (axis, label) in ["x", "y", "z"].iter().enumerate() {
        let x: Vec<f64> = gyro.iter().map(|g| g[axis]).collect();
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        rms[axis] = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64).sqrt();
        series.push(Series::new(
            &format!("gyro {label}"),
            welch_psd(&x, rate, SEGMENT),
        ));
    }
    let line = format!(
        "{name}: command {command:.2}, rotors at {rotor_hz:.0} Hz on average (blade pass {:.0} Hz); gyro output RMS x {:.3} y {:.3} z {:.3} °/s",
        2.0 * rotor_hz,
        rms[0],
        rms[1],
        rms[2]
    );
    let caption = format!("{name}: gyro PSD at the chip's output, {rate:.0} samples/s");
    Ok(((caption, series), line))
}

/// Records both cases, draws them into `out` and returns the summary lines.
pub fn write(
    out: &Path,
    airframe: QuadParams,
    seed: u64,
    title: &str,
) -> Result<Vec<String>, String> {
    let q = Quadcopter::new(airframe).map_err(|e| e.to_string())?;
    let hover = q.command_for_thrust(airframe.weight_n() / 4.0);
    let (p1, l1) = case("hover", airframe, hover, seed)?;
    let (p2, l2) = case("full throttle", airframe, 1.0, seed)?;
    let mut notes = vec![
        format!(
            "MPU-9250 model as the board sets it up (settings::MPU): DLPF_CFG {} ({:.0} Hz), 1 kHz, ±1000 °/s; vibration scale {}; seed {seed}; Welch, Hann, {SEGMENT} samples, half overlap; before the rate loop's software filter",
            board_setup().dlpf_cfg,
            settings::MPU.gyro_bandwidth.bandwidth_hz(),
            airframe.vibration.scale
        ),
        l1,
        l2,
    ];
    sim::plot::write_spectrum(out, title, "(°/s)²/Hz", &notes, &[p1, p2])?;
    notes.remove(0);
    Ok(notes)
}
