//! The firmware's flight controller (`flight::flightctl::FlightController`:
//! arming checks, modes, rate and self-level loops, altitude hold, mixer,
//! crash/landing disarm, failsafe) as the closed loop's [`FlightControl`].
//! The scenarios fly it with its default configuration, as the firmware
//! ships it.

use super::closed_loop::{ControlInput, ControlOutput, FlightControl, Mode};
use control::shaping::StickShaping;
use flight::flightctl::{
    Event, FailsafePhase, FlightConfig, FlightController, FlightState, SystemStatus,
};

/// The firmware's flight controller in the loop.
pub struct FirmwareFc {
    fc: FlightController,
    shaping: StickShaping,
    events: Vec<String>,
}

impl FirmwareFc {
    /// With `cfg`.
    pub fn new(cfg: FlightConfig) -> Result<Self, String> {
        Ok(Self {
            fc: FlightController::new(cfg).map_err(|e| e.to_string())?,
            shaping: StickShaping::new(cfg.sticks).map_err(|e| format!("sticks: {e}"))?,
            events: Vec::new(),
        })
    }
}

impl FlightControl for FirmwareFc {
    fn name(&self) -> &'static str {
        "flight::flightctl::FlightController"
    }

    fn step(&mut self, input: &ControlInput) -> Result<ControlOutput, String> {
        let status = SystemStatus {
            sensors_healthy: input.sensors_healthy,
            gyro_bias_done: input.gyro_bias_done,
            calibration_running: false,
            accel_calibrated: input.accel_calibrated,
        };
        let out = self
            .fc
            .step(input.now_us, &input.pilot, &status, &input.vehicle);
        self.events
            .extend(out.events.iter().map(|e: Event| e.to_string()));
        let flying = matches!(out.state, FlightState::Armed | FlightState::Failsafe(_));
        let failsafe = matches!(out.state, FlightState::Failsafe(_));
        // The tilt the self-levelling modes aim at: the sticks' (level in a failsafe).
        let tilt = if !flying || out.mode == Mode::Acro {
            None
        } else if failsafe {
            Some([0.0, 0.0])
        } else {
            let sticks = input.pilot.sticks;
            let (t, _) = self
                .shaping
                .level_setpoint(&sticks)
                .map_err(|e| format!("sticks: {e}"))?;
            Some([t.roll_rad, t.pitch_rad])
        };
        let r = out.rate_setpoint;
        Ok(ControlOutput {
            motors: out.motors.commands(),
            armed: flying,
            tilt_setpoint_rad: tilt,
            rate_setpoint_rps: flying.then_some([r.roll_rps, r.pitch_rps, r.yaw_rps]),
            height_target_m: self.fc.altitude_target_m(),
            failsafe: failsafe
                || matches!(out.state, FlightState::Failsafe(FailsafePhase::Descend)),
            in_flight: self.fc.in_flight(),
            gyro_rps: input
                .vehicle
                .gyro()
                .map(|g| [g.roll_rps, g.pitch_rps, g.yaw_rps]),
            torque: flying.then_some([out.torque.roll, out.torque.pitch, out.torque.yaw]),
        })
    }

    fn drain_events(&mut self) -> Vec<String> {
        std::mem::take(&mut self.events)
    }
}
