//! A flight controller assembled from `control`'s loops for the closed
//! loop: stick shaping → self-level (quaternion P) → body-rate PIDs on the
//! gyro → quad-X mixer with desaturation; altitude hold (height P →
//! vertical-speed PID) on the throttle. Arming: arm switch with the
//! throttle low and the start-up gyro bias done. Link loss: level, hold the
//! height for [`LINK_LOSS_HOLD_S`], descend at [`LINK_LOSS_DESCENT_MPS`],
//! disarm once landed ([`LANDED_S`] of no vertical motion at low throttle).
//!
//! The gains are tuned for [`sim::QuadParams::class_250`].

use super::closed_loop::{ControlInput, ControlOutput, FlightControl, Mode};
use control::controllers::{AltitudeHold, AltitudeHoldConfig, BodyRates, TorqueCommand};
use control::loops::{LevelConfig, LevelController, Quat, RateConfig, RateController};
use control::mixer::{Mixer, MixerConfig};
use control::pid::PidConfig;
use control::shaping::{StickShaping, Sticks, SticksConfig};

/// Hold time after the link is lost before descending (s).
pub const LINK_LOSS_HOLD_S: f64 = 2.0;
/// Descent speed once the hold is over (m/s).
pub const LINK_LOSS_DESCENT_MPS: f32 = 0.7;
/// Stationary this long at low collective: landed (s).
pub const LANDED_S: f64 = 1.0;
/// Throttle stick band around the centre that holds the height in altitude hold.
const HOLD_BAND: f32 = 0.1;

/// The controller.
pub struct LoopsFc {
    shaping: StickShaping,
    level: LevelController,
    rate: RateController,
    mixer: Mixer,
    alt: AltitudeHold,
    alt_cfg: AltitudeHoldConfig,
    armed: bool,
    height_target_m: Option<f32>,
    link_lost_at_s: Option<f64>,
    still_since_s: Option<f64>,
    last_throttle: f32,
}

fn err(e: control::Error) -> String {
    format!("control: {e:?}")
}

impl LoopsFc {
    /// With the tuning for the 250-class model.
    pub fn new() -> Result<Self, String> {
        let tilt = PidConfig::new(0.06, 0.15, 0.0012)
            .with_d_cutoff_hz(60.0)
            .with_integral_limits(-0.3, 0.3);
        let rate_cfg = RateConfig {
            roll: tilt,
            pitch: tilt,
            yaw: PidConfig::new(0.15, 0.15, 0.0).with_integral_limits(-0.3, 0.3),
        };
        let alt_cfg = AltitudeHoldConfig {
            height_kp: 1.5,
            hover_throttle: 0.55,
            speed_pid: PidConfig::new(0.25, 0.3, 0.0)
                .with_output_limits(0.05, 0.95)
                .with_integral_limits(-0.3, 0.3),
            ..AltitudeHoldConfig::default()
        };
        Ok(Self {
            shaping: StickShaping::new(SticksConfig::default()).map_err(err)?,
            level: LevelController::new(LevelConfig::default()).map_err(err)?,
            rate: RateController::new(rate_cfg).map_err(err)?,
            mixer: Mixer::new(MixerConfig::default()).map_err(err)?,
            alt: AltitudeHold::new(alt_cfg).map_err(err)?,
            alt_cfg,
            armed: false,
            height_target_m: None,
            link_lost_at_s: None,
            still_since_s: None,
            last_throttle: 0.0,
        })
    }

    fn disarm(&mut self) -> ControlOutput {
        self.armed = false;
        self.height_target_m = None;
        self.rate.clear();
        ControlOutput::default()
    }
}

impl FlightControl for LoopsFc {
    fn name(&self) -> &'static str {
        "control loops (stand-in flight controller)"
    }

    fn step(&mut self, input: &ControlInput) -> Result<ControlOutput, String> {
        let failsafe = input.pilot.is_none();
        let (sticks, mode) = match input.pilot {
            Some(p) => {
                self.link_lost_at_s = None;
                if !p.arm {
                    return Ok(self.disarm());
                }
                if !self.armed {
                    let ok = p.sticks.throttle < 0.05 && input.gyro_bias_done;
                    if !ok {
                        return Ok(self.disarm());
                    }
                    self.armed = true;
                    self.rate.clear();
                }
                (p.sticks, p.mode)
            }
            None => {
                if !self.armed {
                    return Ok(self.disarm());
                }
                let lost = *self.link_lost_at_s.get_or_insert(input.t_s);
                // Level, hold, then descend: the throttle stick's climb-rate
                // meaning gives both (centre = hold, below = descend).
                let descend = input.t_s - lost >= LINK_LOSS_HOLD_S;
                let throttle = if descend {
                    0.5 - HOLD_BAND
                        - (0.5 - HOLD_BAND) * LINK_LOSS_DESCENT_MPS / self.alt_cfg.max_descent_mps
                } else {
                    0.5
                };
                let sticks = Sticks {
                    roll: 0.0,
                    pitch: 0.0,
                    yaw: 0.0,
                    throttle,
                };
                (sticks, Mode::AltitudeHold)
            }
        };
        let q = input.q_ned_from_body;
        let q = Quat {
            w: q[0],
            x: q[1],
            y: q[2],
            z: q[3],
        };
        let gyro = BodyRates {
            roll_rps: input.gyro_body_rps[0],
            pitch_rps: input.gyro_body_rps[1],
            yaw_rps: input.gyro_body_rps[2],
        };
        let (tilt, yaw_rate) = self.shaping.level_setpoint(&sticks).map_err(err)?;
        let tilt_sp = Some([tilt.roll_rad, tilt.pitch_rad]);
        let setpoint = self.level.rate_setpoint(&q, &tilt, yaw_rate).map_err(err)?;
        let dt = input.dt_s;
        let mut torque = self.rate.update(&setpoint, &gyro, dt).map_err(err)?;
        let (throttle, height_target) = match (mode, input.height_m, input.vertical_speed_mps) {
            (Mode::AltitudeHold, Some(h), Some(v)) => {
                let target = match self.height_target_m {
                    Some(t) => t,
                    None => {
                        self.alt.reset(v, self.last_throttle).map_err(err)?;
                        h
                    }
                };
                let s = sticks.throttle - 0.5;
                let climb = if s > HOLD_BAND {
                    (s - HOLD_BAND) / (0.5 - HOLD_BAND) * self.alt_cfg.max_climb_mps
                } else if s < -HOLD_BAND {
                    (s + HOLD_BAND) / (0.5 - HOLD_BAND) * self.alt_cfg.max_descent_mps
                } else {
                    0.0
                };
                // The target does not run away from the body: at most 1 m ahead.
                let target = (target + climb * dt).clamp(h - 1.0, h + 1.0).max(0.0);
                self.height_target_m = Some(target);
                (
                    self.alt.update(target, h, v, dt).map_err(err)?,
                    Some(target),
                )
            }
            _ => {
                self.height_target_m = None;
                (self.shaping.throttle(sticks.throttle).map_err(err)?, None)
            }
        };
        self.last_throttle = throttle;
        // On the ground at low collective nothing should wind up.
        let grounded = input.height_m.is_none_or(|h| h < 0.3);
        if grounded && throttle < 0.3 {
            self.rate.clear();
            torque = TorqueCommand {
                roll: 0.0,
                pitch: 0.0,
                yaw: 0.0,
            };
        }
        // Landed during the failsafe descent: disarm.
        if failsafe && self.link_lost_at_s.is_some() {
            // Descending is asked for, yet the body does not move: on the ground.
            let still = input.vertical_speed_mps.is_some_and(|v| v.abs() < 0.15)
                && input.t_s - self.link_lost_at_s.unwrap_or(input.t_s) > LINK_LOSS_HOLD_S + 1.0;
            if still {
                let since = *self.still_since_s.get_or_insert(input.t_s);
                if input.t_s - since >= LANDED_S {
                    let mut out = self.disarm();
                    out.failsafe = true;
                    return Ok(out);
                }
            } else {
                self.still_since_s = None;
            }
        }
        let mix = self.mixer.mix(throttle, &torque).map_err(err)?;
        Ok(ControlOutput {
            motors: mix.motors,
            armed: true,
            tilt_setpoint_rad: tilt_sp,
            rate_setpoint_rps: Some([setpoint.roll_rps, setpoint.pitch_rps, setpoint.yaw_rps]),
            height_target_m: height_target,
            failsafe,
        })
    }
}
