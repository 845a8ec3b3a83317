//! The firmware's flight controller (`flight::flightctl::FlightController`:
//! arming checks, modes, rate and self-level loops, altitude hold, mixer,
//! crash/landing disarm, failsafe) as the closed loop's [`FlightControl`].
//! The scenarios fly it with its default configuration, as the firmware
//! ships it, with the STM32F103CB build's battery monitoring: the pack's
//! voltage through the board's 11:1 divider and an ideal 12-bit ADC into
//! `battery`'s monitor and low-battery rule every 100 ms, the descent it
//! asks for into the controller (as `firmware/src/builder.rs` does).

use super::closed_loop::{ControlInput, ControlOutput, FlightControl, Mode};
use battery::{
    BatteryAction, BatteryMonitor, Config, DescentConfig, FlightContext, Level, LowBatteryDescent,
    SticksQ30, SAMPLE_PERIOD_MS,
};
use control::shaping::StickShaping;
use flight::flightctl::{
    Event, FailsafePhase, FlightConfig, FlightController, FlightState, PilotInput, SystemStatus,
};

/// The firmware's flight controller in the loop.
pub struct FirmwareFc {
    fc: FlightController,
    shaping: StickShaping,
    events: Vec<String>,
    battery: BatteryMonitor,
    descent: LowBatteryDescent,
    level: Level,
    next_battery_us: Option<u32>,
}

impl FirmwareFc {
    /// With `cfg`.
    pub fn new(cfg: FlightConfig) -> Result<Self, String> {
        Self::with_battery(cfg, Config::DEFAULT)
    }

    /// With `cfg` and the battery monitor's settings `battery`.
    pub fn with_battery(cfg: FlightConfig, battery: Config) -> Result<Self, String> {
        Ok(Self {
            fc: FlightController::new(cfg).map_err(|e| e.to_string())?,
            shaping: StickShaping::new(cfg.sticks).map_err(|e| format!("sticks: {e}"))?,
            events: Vec::new(),
            battery: BatteryMonitor::new(battery).map_err(|e| e.to_string())?,
            descent: LowBatteryDescent::new(DescentConfig::DEFAULT).map_err(|e| e.to_string())?,
            level: Level::NoBattery,
            next_battery_us: None,
        })
    }

    /// Every [`SAMPLE_PERIOD_MS`]: the pack into the monitor, the rule
    /// into the controller's descent request; its level changes as events.
    fn battery_step(&mut self, input: &ControlInput) {
        let due = self.next_battery_us.unwrap_or(input.now_us);
        if (input.now_us.wrapping_sub(due) as i32) < 0 {
            return;
        }
        self.next_battery_us = Some(due.wrapping_add(SAMPLE_PERIOD_MS * 1000));
        // 11:1 divider, 3.3 V full scale, 12 bits.
        let counts = (input.battery_v / 11.0 / 3.3 * 4096.0)
            .round()
            .clamp(0.0, 4095.0) as u16;
        self.battery.update(counts);
        let level = self.battery.status().level;
        if level != self.level {
            self.events.push(format!("battery: {level:?}"));
            self.level = level;
        }
        let ctx = FlightContext {
            armed: self.fc.is_armed(),
            in_air: self.fc.in_flight(),
            altitude_available: input.vehicle.altitude.is_some(),
            link_ok: input.pilot.link_ok,
        };
        let action = self.descent.update(level, &ctx, &sticks_q30(&input.pilot));
        self.fc
            .set_battery_descent(matches!(action, BatteryAction::Descend { .. }));
    }
}

/// The pilot's sticks in Q30, as the battery rule takes them.
fn sticks_q30(p: &PilotInput) -> SticksQ30 {
    let q = |x: f32| (f64::from(x.clamp(-1.0, 1.0)) * f64::from(1u32 << 30)) as i32;
    SticksQ30 {
        roll_q30: q(p.sticks.roll),
        pitch_q30: q(p.sticks.pitch),
        yaw_q30: q(p.sticks.yaw),
        throttle_q30: q(p.sticks.throttle),
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
        self.battery_step(input);
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
