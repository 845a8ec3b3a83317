//! Flight in the loop: the release firmware ELF flies the simulator's
//! quadcopter model on the emulated board.
//!
//! ```text
//! scripted pilot (sim::scenario) ─► CRSF frames on USART1 RX (PA10), 250 Hz
//!        ▲                                         │
//!        │                                  the firmware ELF
//!        │                                         │
//! sim::quad ◄─ ESC model ◄─ TIM3 CH1–4 pulses (PA6 PA7 PB0 PB1)
//!        │
//!        └─► QuadLink ─► the simulator's MPU-9250/AK8963/MS5611 ─► I2C1
//! ```
//!
//! Every arrow is a model the rest of the project already tests: the pilot
//! scripts and the quad model are the ones `cargo sim --scenario` flies
//! with the host build of `flight` (one implementation, two rigs); the
//! pulses are read from the TIM3 model's pin waveforms
//! ([`Board::esc_pwm_ns`]), never from firmware variables.
//!
//! The rig advances in steps of [`STEP_NS`]: before each step it reads
//! the four pulse widths, lets the ESCs latch them, flies the quad over
//! the step with those commands and publishes its state to the chips, then
//! runs the board over the same step (the chips sample the motion at their
//! own instants, extrapolated from the published state by at most a step).
//!
//! # The pilot's hand
//!
//! The scripted pilot flies through the same [`AcroHand`] as `cargo sim`'s:
//! in acro (the chirp's sweeps) it holds the height and pulls the tilt
//! back to level, seeing the model's truth (by eye) and the motors' mean
//! command (by ear) at each frame; outside acro it only listens.
//!
//! # What the controller saw
//!
//! The firmware has no flash to spare for logging its rate loop, so the
//! rig keeps what it needs to reconstruct it on the host
//! ([`crate::rate_view`]): every CRSF frame it sent (time and pilot) and
//! every sample the emulated MPU-9250 produced (time and raw counts, read
//! from the chip model's output registers after each step, no side
//! effects).
//!
//! # The ESC model
//!
//! A generic PWM/OneShot125 ESC as BLHeli_S and BLHeli_32 behave: the
//! command is the pulse width's place in the protocol's range (standard
//! PWM 1000–2000 µs, OneShot125 125–250 µs: the protocol is told by the
//! frame period, ≤ 1 ms is OneShot125), linear, clamped to 0..1.
//! * **Arming**: at power-up an ESC ignores its input until it has seen
//!   pulses at or below its stop point (≤ 2 % of the range) for
//!   [`ESC_ARM_S`]; without that the motor never starts.
//! * **Signal loss**: no pulse on the pin (the pin not driven by the timer,
//!   the counter stopped) for [`ESC_SIGNAL_LOSS_S`] stops the motor and
//!   disarms the ESC (it must see the stop pulse again); within that time
//!   it keeps the last command.
//! * **Latency**: the command is taken at the rig's step, up to one step
//!   after the firmware wrote the compare register, plus up to one frame
//!   for the timer's preload — a real ESC decodes at the pulse's falling
//!   edge, 1–2 ms after the write at 400 Hz.

use crate::board::{Board, BoardConfig, BoardError};
use crate::crsf;
use crate::cycles::CycleModel;
use sim::quad::QuadState;
use sim::scenario::{AcroHand, Mode, Pilot, Scenario, Seen, FRAME_PERIOD_S};
use sim::{QuadLink, QuadParams, Quadcopter, SensorErrors, TruthSample};
use std::path::Path;

/// The ADC channel the pack's divider feeds: PA4 = ADC12_IN4 (README's
/// wiring table).
pub const BATTERY_ADC_CHANNEL: usize = 4;
/// The wiring's divider, 10 kΩ over 1 kΩ: the pin sees 1/11 of the pack.
pub const BATTERY_DIVIDER: f64 = 11.0;

/// The rig's step (ns): the ESCs are read and the quad flown in these.
pub const STEP_NS: u64 = 500_000;
/// Time an ESC must see its stop pulse before it runs its motor (s).
pub const ESC_ARM_S: f64 = 0.3;
/// Time without pulses after which an ESC stops its motor (s).
pub const ESC_SIGNAL_LOSS_S: f64 = 0.1;
/// The stop point: commands at or below it stop the motor (fraction of
/// the range).
pub const ESC_STOP_FRACTION: f64 = 0.02;

/// One ESC: its arming state and its latched command.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Esc {
    armed: bool,
    stop_seen_s: f64,
    since_pulse_s: f64,
    command: f64,
}

/// What an ESC makes of a pin's waveform `(period, high)` in ns.
pub fn pulse_to_command(waveform: (u64, u64)) -> Option<f64> {
    let (period_ns, high_ns) = waveform;
    if period_ns == 0 || high_ns == 0 || high_ns >= period_ns {
        return None;
    }
    let (lo, hi) = if period_ns <= 1_000_000 {
        (125_000.0, 250_000.0)
    } else {
        (1_000_000.0, 2_000_000.0)
    };
    Some(((high_ns as f64 - lo) / (hi - lo)).clamp(0.0, 1.0))
}

impl Esc {
    /// Takes the pin's waveform (`None`: no pulses) over `dt_s`; returns
    /// the command the motor runs at.
    pub fn update(&mut self, waveform: Option<(u64, u64)>, dt_s: f64) -> f64 {
        match waveform.and_then(pulse_to_command) {
            Some(c) => {
                self.since_pulse_s = 0.0;
                let stop = c <= ESC_STOP_FRACTION;
                if self.armed {
                    self.command = if stop { 0.0 } else { c };
                } else if stop {
                    self.stop_seen_s += dt_s;
                    self.armed = self.stop_seen_s >= ESC_ARM_S;
                } else {
                    self.stop_seen_s = 0.0;
                }
            }
            None => {
                self.since_pulse_s += dt_s;
                if self.since_pulse_s >= ESC_SIGNAL_LOSS_S {
                    *self = Self::default();
                }
            }
        }
        self.command
    }

    /// The ESC runs its motor (it saw its stop pulse long enough).
    pub fn armed(&self) -> bool {
        self.armed
    }
}

/// What to fly.
#[derive(Clone, Debug)]
pub struct RigOptions {
    /// The scripted flight (the same scripts as `cargo sim --scenario`).
    pub scenario: Scenario,
    /// Seed of all noise.
    pub seed: u64,
    /// Seed of the board's fixed sensor errors (datasheet size).
    pub board_seed: u64,
    /// The airframe.
    pub airframe: QuadParams,
    /// The sensors' errors; `None`: datasheet errors drawn from `board_seed`.
    pub errors: Option<SensorErrors>,
    /// Flash contents at power-up (e.g. with a calibration page).
    pub flash: Option<Vec<u8>>,
    /// LSI frequency (Hz).
    pub lsi_hz: Option<u32>,
    /// The HSE crystal oscillates (false: the HSI fallback).
    pub hse_works: bool,
    /// Which end of the manuals' timing ranges the CPU runs at.
    pub cycle_model: CycleModel,
}

impl RigOptions {
    /// `scenario` on its airframe (the 250-class quad, with the
    /// scenario's wiring error if it has one) with datasheet sensor errors
    /// from `seed`.
    pub fn new(scenario: Scenario, seed: u64) -> Self {
        Self {
            scenario,
            seed,
            board_seed: seed,
            airframe: scenario.airframe(),
            errors: None,
            flash: None,
            lsi_hz: None,
            hse_works: true,
            cycle_model: CycleModel::Typical,
        }
    }
}

/// One rig step's record.
#[derive(Clone, Copy, Debug)]
pub struct RigSample {
    /// Simulated time at the end of the step (s).
    pub t_s: f64,
    /// The body's true motion.
    pub truth: TruthSample,
    /// The four pins' high times (µs; `None`: no pulses).
    pub pulse_us: [Option<f64>; 4],
    /// What the four motors ran at over the step (0..1).
    pub commands: [f64; 4],
    /// The pilot's frame (`None`: link lost).
    pub pilot: Option<Pilot>,
    /// Model state (rotor speeds, battery, ground contact).
    pub quad: QuadState,
}

/// One sample the emulated MPU-9250 produced, as its output registers
/// held it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuRecord {
    /// The sample's instant (s): the chip's data-ready.
    pub t_s: f64,
    /// Accelerometer counts, MPU frame (ACCEL_XOUT..ZOUT).
    pub accel: [i16; 3],
    /// Gyroscope counts, MPU frame (GYRO_XOUT..ZOUT).
    pub gyro: [i16; 3],
    /// The gyro's sensitivity at the chip's full-scale setting then
    /// (LSB per °/s).
    pub gyro_lsb_per_dps: f64,
    /// Samples the chip produced since the previous record, minus one:
    /// samples the rig did not see (0 when none was skipped).
    pub skipped: u64,
}

/// The board, the quad and the pilot, advancing together.
pub struct FlightRig {
    board: Board,
    quad: Quadcopter,
    link: QuadLink,
    escs: [Esc; 4],
    scenario: Scenario,
    next_frame_s: f64,
    samples: Vec<RigSample>,
    frames_sent: u64,
    hand: AcroHand,
    frames: Vec<(f64, Pilot)>,
    imu: Vec<ImuRecord>,
    mpu_samples: u64,
}

impl FlightRig {
    /// Powers the board up with the ELF at `elf` on the quad of `opts`,
    /// at rest on the ground.
    pub fn new(elf: &Path, opts: &RigOptions) -> Result<Self, BoardError> {
        let quad = Quadcopter::new(opts.airframe).map_err(|e| BoardError::Elf(e.to_string()))?;
        let link = QuadLink::new();
        link.publish(&quad);
        let mut config = BoardConfig::default();
        config.sim.trajectory = link.trajectory();
        config.sim.errors = opts
            .errors
            .unwrap_or_else(|| SensorErrors::datasheet(opts.board_seed));
        config.sim.seed = opts.seed;
        config.flash = opts.flash.clone();
        config.hse_works = opts.hse_works;
        config.cycle_model = opts.cycle_model;
        if let Some(hz) = opts.lsi_hz {
            config.lsi_hz = hz;
        }
        let board = Board::from_elf(elf, config)?;
        Ok(Self {
            board,
            quad,
            link,
            escs: [Esc::default(); 4],
            scenario: opts.scenario,
            next_frame_s: 0.0,
            samples: Vec::new(),
            frames_sent: 0,
            hand: AcroHand::default(),
            frames: Vec::new(),
            imu: Vec::new(),
            mpu_samples: 0,
        })
    }

    /// The board (its log, events, pins).
    pub fn board(&self) -> &Board {
        &self.board
    }

    /// The board, to inject faults.
    pub fn board_mut(&mut self) -> &mut Board {
        &mut self.board
    }

    /// The quad model.
    pub fn quad(&self) -> &Quadcopter {
        &self.quad
    }

    /// Every step so far.
    pub fn samples(&self) -> &[RigSample] {
        &self.samples
    }

    /// CRSF frames the pilot has sent.
    pub fn frames_sent(&self) -> u64 {
        self.frames_sent
    }

    /// Every CRSF frame sent: the time its first byte went out (s) and
    /// the pilot it carried (the hand's corrections included).
    pub fn frames(&self) -> &[(f64, Pilot)] {
        &self.frames
    }

    /// Every MPU-9250 sample the rig saw, in time order.
    pub fn imu_records(&self) -> &[ImuRecord] {
        &self.imu
    }

    /// The scenario flown.
    pub fn scenario(&self) -> Scenario {
        self.scenario
    }

    /// Simulated time (s).
    pub fn now_s(&self) -> f64 {
        self.board.now_ns() as f64 * 1e-9
    }

    /// Flies until `t_s` (simulated); stops early with the error that
    /// stopped the board.
    pub fn run_until_s(&mut self, t_s: f64) -> Result<(), BoardError> {
        while self.now_s() < t_s - 1e-9 {
            self.step()?;
        }
        Ok(())
    }

    /// The scenario's whole flight.
    pub fn fly(&mut self) -> Result<(), BoardError> {
        self.run_until_s(self.scenario.duration_s())
    }

    fn send_pilot_frames(&mut self, until_s: f64) -> Option<Pilot> {
        let mut last = None;
        while self.next_frame_s < until_s {
            let at_s = self.next_frame_s;
            self.next_frame_s += FRAME_PERIOD_S;
            let seen = self.seen();
            let Some(p) = self.hand.fly(self.scenario.pilot(at_s), &seen, at_s) else {
                continue;
            };
            let frame = crsf::frame_from_us(&p.channels_us());
            self.board
                .usart1_send_at(&frame, crsf::BAUD, (at_s * 1e9) as u64);
            self.frames_sent += 1;
            self.frames.push((at_s, p));
            last = Some(p);
        }
        last.or_else(|| {
            let script = self.scenario.pilot(until_s)?;
            // In acro the hand's corrections are in the frames, not in
            // the script.
            Some(match self.frames.last() {
                Some(&(_, sent)) if script.mode == Mode::Acro => sent,
                _ => script,
            })
        })
    }

    /// What the pilot sees now: the model's true tilt, height and climb,
    /// and the mean of the commands the motors run at.
    fn seen(&self) -> Seen {
        let t = self.quad.truth();
        let [roll, pitch, _] = t.q_ned_from_body.to_euler();
        let commands = self.samples.last().map_or([0.0; 4], |s| s.commands);
        Seen {
            tilt_rad: [roll, pitch],
            height_m: t.height_m,
            climb_mps: -t.velocity_ned_mps[2],
            mean_motor: commands.iter().sum::<f64>() / 4.0,
        }
    }

    /// Records the chip's latest sample if it produced one since the last
    /// call (the step is shorter than its sample period: at most one).
    fn record_imu(&mut self) {
        let state = self.board.sim().state();
        let mpu = &state.mpu;
        let count = mpu.sample_count();
        let (Some(t_ns), true) = (mpu.last_sample_ns(), count > self.mpu_samples) else {
            return;
        };
        let word = |r: u8| i16::from_be_bytes([mpu.register(r), mpu.register(r + 1)]);
        let three = |first: u8| [word(first), word(first + 2), word(first + 4)];
        let record = ImuRecord {
            t_s: t_ns as f64 * 1e-9,
            accel: three(sim::mpu9250::reg::ACCEL_XOUT_H),
            gyro: three(sim::mpu9250::reg::GYRO_XOUT_H),
            gyro_lsb_per_dps: mpu.gyro_lsb_per_dps(),
            skipped: count - self.mpu_samples - 1,
        };
        drop(state);
        self.mpu_samples = count;
        self.imu.push(record);
    }

    fn read_escs(&mut self, t_s: f64, dt_s: f64) -> ([Option<f64>; 4], [f64; 4]) {
        let mut pulse_us = [None; 4];
        let mut commands = [0.0; 4];
        for ch in 0..4 {
            let w = self.board.esc_pwm_ns(ch);
            pulse_us[ch] = w.map(|(_, high)| high as f64 * 1e-3);
            commands[ch] = self.escs[ch].update(w, dt_s);
            if self.scenario.motor_failed(ch, t_s) {
                commands[ch] = 0.0;
            }
        }
        (pulse_us, commands)
    }

    fn step(&mut self) -> Result<(), BoardError> {
        let t0_ns = self.board.now_ns();
        let t1_ns = (t0_ns / STEP_NS + 1) * STEP_NS;
        let (t0_s, t1_s) = (t0_ns as f64 * 1e-9, t1_ns as f64 * 1e-9);
        let pilot = self.send_pilot_frames(t1_s);
        let (pulse_us, commands) = self.read_escs(t0_s, t1_s - t0_s);
        self.quad.advance_to(t1_s, commands);
        self.link.publish(&self.quad);
        // The pack on PA4 (ADC12_IN4) through the wiring's divider.
        let pack_v = self.quad.state().battery_voltage_v;
        self.board
            .adc1_set_input_v(BATTERY_ADC_CHANNEL, pack_v / BATTERY_DIVIDER);
        self.board.run_until_ns(t1_ns)?;
        self.record_imu();
        self.samples.push(RigSample {
            t_s: t1_s,
            truth: self.quad.truth(),
            pulse_us,
            commands,
            pilot,
            quad: *self.quad.state(),
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PWM: u64 = 2_500_000;

    #[test]
    fn pulse_widths_map_onto_the_protocol_ranges() {
        assert_eq!(pulse_to_command((PWM, 1_000_000)), Some(0.0));
        assert_eq!(pulse_to_command((PWM, 1_500_000)), Some(0.5));
        assert_eq!(pulse_to_command((PWM, 2_100_000)), Some(1.0));
        assert_eq!(pulse_to_command((500_000, 187_500)), Some(0.5));
        assert_eq!(pulse_to_command((PWM, 0)), None);
        assert_eq!(pulse_to_command((PWM, PWM)), None);
    }

    #[test]
    fn an_esc_runs_only_after_seeing_its_stop_pulse() {
        let mut e = Esc::default();
        // Throttle from power-up: never starts.
        for _ in 0..1000 {
            assert_eq!(e.update(Some((PWM, 1_500_000)), 1e-3), 0.0);
        }
        for _ in 0..299 {
            e.update(Some((PWM, 1_000_000)), 1e-3);
        }
        assert!(!e.armed());
        e.update(Some((PWM, 1_000_000)), 1e-3);
        assert!(e.armed());
        assert_eq!(e.update(Some((PWM, 1_500_000)), 1e-3), 0.5);
    }

    #[test]
    fn an_esc_holds_through_short_gaps_and_stops_on_signal_loss() {
        let mut e = Esc::default();
        for _ in 0..400 {
            e.update(Some((PWM, 1_000_000)), 1e-3);
        }
        e.update(Some((PWM, 1_600_000)), 1e-3);
        for _ in 0..99 {
            assert!((e.update(None, 1e-3) - 0.6).abs() < 1e-12);
        }
        assert_eq!(e.update(None, 1e-3), 0.0);
        assert!(!e.armed());
        // Back: it wants the stop pulse again.
        assert_eq!(e.update(Some((PWM, 1_600_000)), 1e-3), 0.0);
    }
}
