//! The rate loop as the firmware's controller saw it on the emulated
//! board, reconstructed on the host: the rate setpoint it used and the
//! gyro it saw at each IMU sample, for `sim::rate_loop`'s measurement
//! (`cargo fil --scenario chirp`).
//!
//! The firmware has no flash to spare for logging these, and its RTIC
//! resources have no stable address to read, so they are rebuilt from what
//! the rig knows with the code the firmware runs (the same crates):
//!
//! * **Setpoint**: the frame the firmware had at each sample — the last
//!   CRSF frame the rig sent whose bytes, plus the one idle character
//!   after which the receiver hands a burst to the parser, had arrived
//!   [`CONTROL_AFTER_SAMPLE_S`] after the sample's data-ready (when the
//!   control step runs, after the I2C read) — through `rc_input`'s
//!   parser and the default channel map (the firmware's `channel_map()`),
//!   then the flight controller's fixed-point stick shaping
//!   (`control::shapingq::StickShapingQ`) with `settings::flight_config()`.
//!   Defined in acro with the arm switch on (the sweeps), else `None`.
//! * **Gyro**: the counts the emulated MPU-9250 produced at each sample
//!   (its output registers, as the firmware's burst read returns them)
//!   through `sensor_stack`'s own pipeline configured as the firmware's
//!   boot does (`settings::pipeline_config()`, the chip's full scale from
//!   `settings::MPU`, the face-up mounting of `firmware/src/config.rs`):
//!   bias removal, mounting, the Q16 conversion and the gyro filter
//!   (`settings::GYRO_FILTER_DESIGN`). The bias is the mean of the counts
//!   over the still second before arming, as the firmware's start-up
//!   measurement takes it; the two differ by a constant within the noise,
//!   which moves only the 0 Hz bin of the spectra (Hann windows of 4 s:
//!   nothing above 0.5 Hz), so the response above 0.7 Hz is unchanged.
//!
//! What this does not see: a sample the firmware failed to read (it
//! skips it; here it would be a sample like any other) and each control
//! step's own instant ([`CONTROL_AFTER_SAMPLE_S`] is the usual one). In the
//! chirp a frame reaches the receiver 0.65 ms after a sample's data-ready,
//! after that sample's control step, so it counts from the next sample; a
//! step held off past it (the barometer's transfer on the bus) takes it
//! one sample earlier than rebuilt here: 1 ms of setpoint timing, ≤ 2.3°
//! of phase at a 6.4 Hz crossover for that frame.

use crate::crsf;
use crate::rig::{FlightRig, ImuRecord};
use control::shaping::Sticks;
use control::shapingq::StickShapingQ;
use rc_input::{ChannelMap, CrsfParser, Event};
use sensor_stack::pipeline::{ImuInput, Pipeline, PipelineConfig};
use sensor_stack::storage::CalibrationRecord;
use sensor_stack::Mounting;
use sim::rate_loop::{self, AxisReport, AxisSignals};
use sim::scenario::{Mode, Pilot, ARM_AT_S};

/// From a sample's data-ready to the control step's read of the pilot
/// state (s). Measured on the emulated board (the exception entries and
/// TIM3's CCR1, stepped by 2 µs, in the chirp's hover): the burst read
/// ends and `sample_done` starts 0.42 ms after data-ready, and the motor
/// outputs are written 0.54 ms after it; the pilot is read in between.
pub const CONTROL_AFTER_SAMPLE_S: f64 = 0.5e-3;
/// The gyro bias is taken over this window before arming (s): the
/// craft still on the ground, the chip configured.
pub const BIAS_WINDOW_S: (f64, f64) = (ARM_AT_S - 1.0, ARM_AT_S);
/// CPU cycles per IMU sample at 72 MHz and 1 kHz (the AHRS's time step;
/// the gyro path does not use it).
const CYCLES_PER_SAMPLE: u32 = 72_000;

/// One sample as the controller saw it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerSample {
    /// The sample's data-ready (s).
    pub t_s: f64,
    /// When the frame the controller had was sent (s; `None` before the
    /// first): the script's time of the sticks it flew.
    pub frame_sent_s: Option<f64>,
    /// The acro rate setpoint (rad/s, body FRD roll pitch yaw); `None`
    /// outside acro or disarmed.
    pub setpoint_rps: Option<[f64; 3]>,
    /// The filtered body rates the rate loop saw (rad/s, FRD).
    pub gyro_rps: [f64; 3],
}

/// When the receiver hands a frame sent at `sent_s` to the parser (s):
/// its last byte plus one idle character.
fn handed_over_s(sent_s: f64, bytes: usize) -> f64 {
    sent_s + (bytes as f64 + 1.0) * 10.0 / f64::from(crsf::BAUD)
}

/// The acro setpoint (rad/s) of a frame the rig sent, as the firmware
/// decodes and shapes it; `None` outside acro, disarmed, or a frame the
/// parser refuses.
fn frame_setpoint(shaping: &StickShapingQ, pilot: &Pilot, bytes: &[u8]) -> Option<[f64; 3]> {
    if !pilot.arm || pilot.mode != Mode::Acro {
        return None;
    }
    let mut parser = CrsfParser::new();
    let frame = bytes.iter().find_map(|&b| match parser.push(b, 0) {
        Some(Event::Channels(f)) => Some(f),
        _ => None,
    })?;
    let s = ChannelMap::DEFAULT.sticks(&frame).ok()?;
    let sticks = Sticks {
        roll: s.roll,
        pitch: s.pitch,
        yaw: s.yaw,
        throttle: s.throttle,
    };
    Some(shaping.shape(&sticks).acro_q16.map(q16_to_f64))
}

/// A Q16 value as a float (exact).
fn q16_to_f64(q: i32) -> f64 {
    f64::from(q) / 65_536.0
}

/// A frame as the controller gets it: handover time (s), send time (s)
/// and acro setpoint.
type Handed = (f64, f64, Option<[f64; 3]>);

/// Each frame's handover, in time order.
fn frame_setpoints(frames: &[(f64, Pilot)]) -> Result<Vec<Handed>, String> {
    let shaping = StickShapingQ::new(&settings::flight_config().sticks)
        .map_err(|e| format!("stick shaping: {e:?}"))?;
    Ok(frames
        .iter()
        .map(|(sent_s, pilot)| {
            let bytes = crsf::frame_from_us(&pilot.channels_us());
            let at_s = handed_over_s(*sent_s, bytes.len());
            (at_s, *sent_s, frame_setpoint(&shaping, pilot, &bytes))
        })
        .collect())
}

/// The firmware's pipeline for the gyro path, with the start-up bias.
fn pipeline(imu: &[ImuRecord]) -> Result<Pipeline, String> {
    let range = settings::MPU.gyro_range;
    let cfg = PipelineConfig {
        gyro_dps_per_lsb: range.dps_per_lsb(),
        accel_g_per_lsb: settings::MPU.accel_range.g_per_lsb(),
        ..settings::pipeline_config()
    };
    let record = CalibrationRecord {
        mounting: Mounting::FACE_UP_X_FORWARD,
        ..CalibrationRecord::default()
    };
    let mut p = Pipeline::new(cfg, &record).map_err(|e| format!("pipeline: {e:?}"))?;
    let still: Vec<&ImuRecord> = imu
        .iter()
        .filter(|r| r.t_s >= BIAS_WINDOW_S.0 && r.t_s < BIAS_WINDOW_S.1)
        .collect();
    if still.is_empty() {
        return Err("no IMU sample in the still second before arming".into());
    }
    let mut bias = [0i16; 3];
    for (axis, b) in bias.iter_mut().enumerate() {
        let sum: f64 = still.iter().map(|r| f64::from(r.gyro[axis])).sum();
        *b = (sum / still.len() as f64).round() as i16;
    }
    p.set_gyro_bias_counts(bias);
    Ok(p)
}

/// Every IMU sample of the rig's flight as the controller saw it
/// ([`view_of`] its records).
pub fn controller_view(rig: &FlightRig) -> Result<Vec<ControllerSample>, String> {
    view_of(rig.imu_records(), rig.frames())
}

/// The samples from the start of the bias window on, as the controller
/// saw them, from the chip's samples `imu` and the frames sent `frames`
/// (both in time order). Errors: a sample the rig did not see, or one at
/// another full scale than the firmware's.
pub fn view_of(
    imu: &[ImuRecord],
    frames: &[(f64, Pilot)],
) -> Result<Vec<ControllerSample>, String> {
    let frames = frame_setpoints(frames)?;
    let mut p = pipeline(imu)?;
    let lsb_per_dps = f64::from(settings::MPU.gyro_range.lsb_per_dps());
    let mut out = Vec::with_capacity(imu.len());
    let mut next_frame = 0;
    let mut frame: Option<&Handed> = None;
    for r in imu.iter().filter(|r| r.t_s >= BIAS_WINDOW_S.0) {
        if r.skipped > 0 || (r.gyro_lsb_per_dps - lsb_per_dps).abs() > 1e-3 {
            return Err(format!(
                "IMU sample at {:.4} s: {} skipped before it, {} LSB/(°/s)",
                r.t_s, r.skipped, r.gyro_lsb_per_dps
            ));
        }
        let control_s = r.t_s + CONTROL_AFTER_SAMPLE_S;
        while next_frame < frames.len() && frames[next_frame].0 <= control_s {
            frame = Some(&frames[next_frame]);
            next_frame += 1;
        }
        p.imu_step(&ImuInput {
            accel: r.accel,
            gyro: r.gyro,
            dt_cycles: CYCLES_PER_SAMPLE,
        });
        let g = p.body_rates_q16();
        out.push(ControllerSample {
            t_s: r.t_s,
            frame_sent_s: frame.map(|f| f.1),
            setpoint_rps: frame.and_then(|f| f.2),
            gyro_rps: g.map(q16_to_f64),
        });
    }
    Ok(out)
}

/// The chirp's three sweeps measured on the board (`sim::rate_loop`, as
/// `cargo sim --scenario chirp` measures the host's). A sweep is the
/// samples the controller flew with the sweep's frames: each sample is
/// placed in the script's time by its frame's send time, so the link's
/// latency (≈ 0.7 ms) neither cuts the sweep's first frame nor adds the
/// altitude hold's after it.
pub fn analyse_chirp(rig: &FlightRig) -> Result<Vec<AxisReport>, String> {
    let view = controller_view(rig)?;
    let fs_hz = sample_rate_hz(&view)?;
    let signals: [AxisSignals; 3] = rate_loop::chirp_signals(view.iter().map(|s| {
        (
            s.frame_sent_s.unwrap_or(s.t_s),
            s.setpoint_rps,
            Some(s.gyro_rps),
        )
    }))?;
    rate_loop::analyse_sweeps(&signals, fs_hz)
}

/// The mean sample rate (Hz).
fn sample_rate_hz(view: &[ControllerSample]) -> Result<f64, String> {
    match (view.first(), view.last()) {
        (Some(a), Some(b)) if b.t_s > a.t_s => Ok((view.len() - 1) as f64 / (b.t_s - a.t_s)),
        _ => Err("fewer than two IMU samples".into()),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
mod tests {
    use super::*;
    use control::shaping::StickShaping;
    use sim::scenario::Sticks as PilotSticks;

    fn pilot(roll: f32, mode: Mode, arm: bool) -> Pilot {
        Pilot {
            sticks: PilotSticks {
                roll,
                pitch: -0.5,
                yaw: 0.3,
                throttle: 0.5,
            },
            arm,
            mode,
        }
    }

    fn imu_at(t_s: f64, gyro: [i16; 3]) -> ImuRecord {
        ImuRecord {
            t_s,
            accel: [0, 0, 8192],
            gyro,
            gyro_lsb_per_dps: f64::from(settings::MPU.gyro_range.lsb_per_dps()),
            skipped: 0,
        }
    }

    /// The decoded frame's fixed-point shaping is the float shaping of
    /// the script's sticks within what the receiver moves them: the
    /// channel map's 5 µs deadband (1 % of the 500 µs half range) and a
    /// CRSF tick (0.6 µs), through the expo's steepest slope (1 + 2·expo
    /// at full stick); nothing outside armed acro.
    #[test]
    fn a_frame_s_setpoint_is_the_stick_shaping_of_its_sticks() {
        let cfg = settings::flight_config().sticks;
        let q = StickShapingQ::new(&cfg).unwrap();
        let float = StickShaping::new(cfg).unwrap();
        for roll in [-1.0, -0.25, 0.0, 0.1, 0.25, 0.7, 1.0] {
            let p = pilot(roll, Mode::Acro, true);
            let bytes = crsf::frame_from_us(&p.channels_us());
            let got = frame_setpoint(&q, &p, &bytes).unwrap();
            let s = Sticks {
                roll,
                pitch: -0.5,
                yaw: 0.3,
                throttle: 0.5,
            };
            let want = float.rate_setpoint(&s).unwrap();
            let want = [want.roll_rps, want.pitch_rps, want.yaw_rps].map(f64::from);
            let axes = [cfg.roll, cfg.pitch, cfg.yaw];
            for ((g, w), a) in got.iter().zip(want).zip(axes) {
                let slope = 1.0 + 2.0 * f64::from(a.expo);
                let tol = 5.7 / 495.0 * slope * f64::from(a.max_rate_dps).to_radians();
                assert!((g - w).abs() <= tol, "{roll}: {got:?} vs {want:?}");
            }
        }
        for p in [pilot(0.3, Mode::Angle, true), pilot(0.3, Mode::Acro, false)] {
            let bytes = crsf::frame_from_us(&p.channels_us());
            assert_eq!(frame_setpoint(&q, &p, &bytes), None);
        }
    }

    /// A still gyro reads its bias away; a constant rate on x (the face-up
    /// mounting keeps x) reads counts / sensitivity through the filter's
    /// unity DC gain; a frame counts from its handover.
    #[test]
    fn the_view_scales_the_counts_and_takes_frames_when_they_arrive() {
        let (bias, rate) = (12i16, 12 + 328);
        let mut imu: Vec<ImuRecord> = (0..3000)
            .map(|i| imu_at(i as f64 * 1e-3, [bias, bias, bias]))
            .collect();
        let after = imu.len();
        imu.extend((0..500).map(|i| imu_at((after + i) as f64 * 1e-3, [rate, bias, bias])));
        let sent_s = 2.9995;
        let frames = [(sent_s, pilot(0.25, Mode::Acro, true))];
        let view = view_of(&imu, &frames).unwrap();
        assert!(view.iter().all(|s| s.t_s >= BIAS_WINDOW_S.0));
        let at = |t: f64| view.iter().find(|s| s.t_s >= t - 1e-9).unwrap();
        assert!(at(2.9).gyro_rps.iter().all(|g| g.abs() < 1e-4));
        let want = (328.0 / settings::MPU.gyro_range.lsb_per_dps() as f64).to_radians();
        assert!((at(3.4).gyro_rps[0] - want).abs() < 1e-3 * want);
        assert!(at(3.4).gyro_rps[1].abs() < 1e-4);
        // Handed over 27 byte times after it was sent: 0.64 ms.
        let handed = handed_over_s(sent_s, 26);
        assert!((handed - sent_s - 27.0 * 10.0 / 420_000.0).abs() < 1e-12);
        for s in &view {
            let has = s.t_s + CONTROL_AFTER_SAMPLE_S >= handed;
            assert_eq!(s.setpoint_rps.is_some(), has, "{}", s.t_s);
            assert_eq!(s.frame_sent_s.is_some(), has, "{}", s.t_s);
        }
    }

    #[test]
    fn a_sample_the_rig_missed_is_refused() {
        let mut imu: Vec<ImuRecord> = (0..3000).map(|i| imu_at(i as f64 * 1e-3, [0; 3])).collect();
        imu[2500].skipped = 1;
        assert!(view_of(&imu, &[]).unwrap_err().contains("1 skipped"));
    }
}
