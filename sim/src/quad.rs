//! A quadcopter (quad-X) as a rigid body flown by its four motors: the truth
//! the chips sample when the simulator closes the loop around a flight
//! controller.
//!
//! Frames and units as everywhere in `sim`: body FRD, earth NED, SI units.
//!
//! What is modelled:
//! * rigid body: mass, diagonal inertia tensor, Euler's equations (with the
//!   gyroscopic ω × Iω term), the attitude integrated as an exact rotation
//!   per step;
//! * each motor: a command in `[0, 1]` sets a steady-state speed
//!   `ω_ss = command · ω_max · V / V_nominal` reached with a first-order lag
//!   (time constant `tau_s`); thrust `k_f ω²` along −z body, reaction torque
//!   `k_m ω²` about z opposite to the propeller's spin;
//! * wiring errors, as a builder makes them: an ESC's signal wire on
//!   another motor's output ([`MotorParams::esc_input`]), a motor turning
//!   the wrong way with a propeller that pushes air down at a fraction of
//!   the thrust ([`QuadParams::with_reversed_motor`]);
//! * drag: linear (rotor drag) plus quadratic (form drag) on the velocity
//!   relative to still air, per body axis; linear angular damping;
//! * battery: open-circuit voltage falling with the charge drawn, sag
//!   `I · R_internal`; the current follows from the propellers' mechanical
//!   power and a motor+ESC efficiency, so thrust at a given command falls with
//!   the square of the terminal voltage;
//! * ground: flat and rigid at height 0. The body starts at rest on it,
//!   never goes below it, and while thrust is below weight it stays there
//!   (no bounce, no tip-over model: a touch-down within 45° of level
//!   settles on the feet, roll and pitch level; beyond it the body stays at
//!   the attitude it hit the ground with, as a crashed quad on its side).
//!
//! * wind: a constant air-mass velocity ([`DragParams::wind_ned_mps`]); the
//!   rotor drag optionally growing with the rotors' speed
//!   ([`DragParams::linear_scales_with_rotor_speed`]).
//! * vibration ([`vibration`]): each rotor's imbalance at its rotation
//!   frequency with harmonics and the blade-pass thrust ripple, seen by the
//!   board through one frame mode; superposed on the rigid body's motion
//!   for the chips (it does not feed back into the rigid body).
//!
//! Not modelled: propeller inertia torque on speed changes, blade flapping,
//! ground effect, gusts, ESC non-linearity.
//!
//! [`QuadParams::class_250`] is a typical 250-class racer; its sources are
//! given field by field. [`QuadLink`] hands the body's motion to a
//! [`SimBus`](crate::SimBus): the MPU-9250, AK8963 and MS5611 models then
//! read it like any trajectory.

pub mod vibration;

use crate::math::{self, Quat, Vec3};
use crate::physics::{Pose, Trajectory, TruthSample, G0_MPS2};
use std::cell::Cell;
use std::f64::consts::PI;
use std::rc::Rc;
pub use vibration::VibrationParams;

/// Which way a propeller turns, seen from above.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Spin {
    /// Clockwise seen from above: its angular velocity points down (+z FRD),
    /// its reaction torque on the body yaws the nose left (−z).
    Clockwise,
    /// Counter-clockwise seen from above: reaction torque yaws the nose right (+z).
    CounterClockwise,
}

impl Spin {
    /// Sign of the reaction torque on the body about +z (FRD).
    pub fn reaction_sign(self) -> f64 {
        match self {
            Spin::Clockwise => -1.0,
            Spin::CounterClockwise => 1.0,
        }
    }
}

/// One motor with its propeller, as built (wiring errors included).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorParams {
    /// Position of the rotor hub in the body frame (FRD, m from the centre of mass).
    pub position_body_m: Vec3,
    /// Propeller spin direction.
    pub spin: Spin,
    /// Which of the four commands (the flight controller's motor order)
    /// this motor's ESC receives: its own index when the ESC's signal wire
    /// is on the right output (see [`QuadParams::with_swapped_esc_signals`]).
    pub esc_input: usize,
    /// Thrust and drag torque as a fraction of a correct propeller's, in
    /// `(0, 1]`: 1 for a propeller that matches its motor (see
    /// [`QuadParams::with_reversed_motor`]).
    pub prop_fraction: f64,
}

/// The propulsion common to all four motors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PropulsionParams {
    /// Thrust coefficient: thrust = `k_f_n_per_rps2 · ω²` (N, ω in rad/s).
    pub k_f_n_per_rps2: f64,
    /// Torque coefficient: reaction torque = `k_m_nm_per_rps2 · ω²` (N·m).
    pub k_m_nm_per_rps2: f64,
    /// Loaded speed at command 1 and the nominal voltage (rad/s).
    pub omega_max_rps: f64,
    /// Terminal voltage at which `omega_max_rps` is reached (V).
    pub v_nominal_v: f64,
    /// First-order time constant of the rotor speed (s).
    pub tau_s: f64,
    /// Motor and ESC efficiency, electrical to shaft power (0..1].
    pub efficiency: f64,
}

/// The battery.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatteryParams {
    /// Cells in series.
    pub cells: u8,
    /// Capacity (A·h).
    pub capacity_ah: f64,
    /// Pack internal resistance including wiring (Ω).
    pub r_internal_ohm: f64,
    /// Charge already drawn at the start (A·h).
    pub used_at_start_ah: f64,
    /// Constant current of the flight controller, receiver, ESC logic (A).
    pub avionics_a: f64,
}

/// Per-cell open-circuit voltage of a LiPo against state of charge, (SoC, V):
/// the typical resting-voltage curve of LiPo cells (flat between about 80 %
/// and 20 %, falling steeply below 10 %).
const LIPO_OCV: [(f64, f64); 8] = [
    (0.0, 3.27),
    (0.05, 3.50),
    (0.10, 3.68),
    (0.20, 3.74),
    (0.50, 3.85),
    (0.80, 4.00),
    (0.90, 4.08),
    (1.00, 4.20),
];

impl BatteryParams {
    /// Open-circuit pack voltage with `used_ah` drawn (V).
    pub fn open_circuit_v(&self, used_ah: f64) -> f64 {
        let soc = (1.0 - used_ah / self.capacity_ah).clamp(0.0, 1.0);
        let mut cell = LIPO_OCV[0].1;
        for w in LIPO_OCV.windows(2) {
            let ((s0, v0), (s1, v1)) = (w[0], w[1]);
            if soc >= s0 && soc <= s1 {
                cell = v0 + (v1 - v0) * (soc - s0) / (s1 - s0);
            }
        }
        cell * f64::from(self.cells)
    }
}

/// Air drag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DragParams {
    /// Linear drag per body axis (N per m/s): rotor drag, dominant at low speed.
    pub linear_n_per_mps: Vec3,
    /// Quadratic drag per body axis (N per (m/s)²): ½ ρ C_d A.
    pub quadratic_n_per_mps2: Vec3,
    /// Angular damping per body axis (N·m per rad/s).
    pub angular_nm_per_rps: Vec3,
    /// Whether the linear (rotor) drag grows with the rotors' speed: Leishman
    /// et al. (2014) measured rotor drag proportional to the sum of the rotor
    /// speeds; with this set the linear coefficients are the hover's and scale
    /// with Σω / (4·ω_hover). Off: constant coefficients.
    pub linear_scales_with_rotor_speed: bool,
    /// Velocity of the air mass (m/s, NED): drag acts on the velocity relative
    /// to it. Zero: still air.
    pub wind_ned_mps: Vec3,
}

impl DragParams {
    /// The same drag with both coefficients (linear and quadratic, not the
    /// angular damping) times `scale`.
    pub fn scaled(self, scale: f64) -> Self {
        Self {
            linear_n_per_mps: math::scale(self.linear_n_per_mps, scale),
            quadratic_n_per_mps2: math::scale(self.quadratic_n_per_mps2, scale),
            ..self
        }
    }
}

/// Everything about the airframe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadParams {
    /// All-up mass (kg).
    pub mass_kg: f64,
    /// Principal moments of inertia about body x, y, z (kg·m²); the frame's
    /// symmetry makes the products of inertia negligible.
    pub inertia_kgm2: Vec3,
    /// The four motors, in the flight controller's motor order.
    pub motors: [MotorParams; 4],
    /// The motors' common propulsion figures.
    pub propulsion: PropulsionParams,
    /// The battery.
    pub battery: BatteryParams,
    /// Drag.
    pub drag: DragParams,
    /// Vibration sources and the frame mode the board sees them through.
    pub vibration: VibrationParams,
}

impl QuadParams {
    /// Arm length (hub to centre, m) of a 250 mm frame: the motor-to-motor
    /// diagonal is 250 mm.
    pub const ARM_250_M: f64 = 0.125;

    /// A typical 250-class quad-X racer:
    /// * 0.60 kg all-up (frame ~150 g, four 2204-size motors ~28 g each,
    ///   four 12 A ESCs ~8 g each, 3S 1300 mAh LiPo ~110 g, electronics,
    ///   camera and wiring; builds of this class weigh 500–650 g);
    /// * 250 mm motor-to-motor diagonal, quad-X: arms at ±45°, 0.125 m;
    /// * inertia from point masses: motors+props (4 × 35 g at 0.088 m on
    ///   each horizontal axis) give 1.1e-3 kg·m² about x and y and 2.2e-3
    ///   about z; the central body (~0.46 kg, a 0.16 × 0.08 × 0.05 m box)
    ///   adds 0.35e-3 / 1.1e-3 / 1.2e-3: I = (2.0, 2.4, 3.6)e-3 kg·m²
    ///   rounded up for arms and wiring (the x/y asymmetry is the long
    ///   battery along x);
    /// * 2300 KV motors on 3S (11.1 V nominal): no-load 25 500 rpm, loaded
    ///   with a 5×4.5 propeller about 80 % of it, ω_max = 2 140 rad/s;
    /// * 5×4.5 propeller (D = 0.127 m), static C_T ≈ 0.11 and C_P ≈ 0.06
    ///   (UIUC propeller database range for 5" propellers):
    ///   k_f = C_T ρ D⁴ / (4π²) = 8.8e-7 N/(rad/s)², giving 4.0 N (410 g)
    ///   per motor at full command, thrust-to-weight 2.7;
    ///   k_m / k_f = C_P D / (2π C_T) = 0.011 m;
    /// * rotor speed time constant 30 ms (measured step responses of
    ///   2204–2206 motors on 5" propellers are 20–40 ms);
    /// * 3S 1300 mAh LiPo, 50 mΩ pack + wiring, motor+ESC efficiency 0.7,
    ///   0.5 A for the electronics: hover draws about 10 A;
    /// * drag: frontal area ~0.01 m² (x, y) and ~0.03 m² (z, the frame and
    ///   propeller disks) with C_d ≈ 1; rotor drag 0.1 N per m/s;
    /// * vibration of a well-balanced frame
    ///   ([`VibrationParams::well_balanced`], sources in [`vibration`]).
    pub fn class_250() -> Self {
        let a = Self::ARM_250_M * std::f64::consts::FRAC_1_SQRT_2;
        let k_f = 8.8e-7;
        Self {
            mass_kg: 0.60,
            inertia_kgm2: [2.0e-3, 2.4e-3, 3.6e-3],
            motors: [
                MotorParams {
                    position_body_m: [-a, a, 0.0],
                    spin: Spin::Clockwise,
                    esc_input: 0,
                    prop_fraction: 1.0,
                },
                MotorParams {
                    position_body_m: [a, a, 0.0],
                    spin: Spin::CounterClockwise,
                    esc_input: 1,
                    prop_fraction: 1.0,
                },
                MotorParams {
                    position_body_m: [-a, -a, 0.0],
                    spin: Spin::CounterClockwise,
                    esc_input: 2,
                    prop_fraction: 1.0,
                },
                MotorParams {
                    position_body_m: [a, -a, 0.0],
                    spin: Spin::Clockwise,
                    esc_input: 3,
                    prop_fraction: 1.0,
                },
            ],
            propulsion: PropulsionParams {
                k_f_n_per_rps2: k_f,
                k_m_nm_per_rps2: 0.011 * k_f,
                omega_max_rps: 2140.0,
                v_nominal_v: 11.1,
                tau_s: 0.030,
                efficiency: 0.7,
            },
            battery: BatteryParams {
                cells: 3,
                capacity_ah: 1.3,
                r_internal_ohm: 0.05,
                used_at_start_ah: 0.0,
                avionics_a: 0.5,
            },
            drag: DragParams {
                linear_n_per_mps: [0.1, 0.1, 0.1],
                quadratic_n_per_mps2: [0.006, 0.006, 0.018],
                angular_nm_per_rps: [2e-4, 2e-4, 3e-4],
                linear_scales_with_rotor_speed: false,
                wind_ned_mps: [0.0; 3],
            },
            vibration: VibrationParams::well_balanced(),
        }
    }

    /// The vibration sources scaled by `scale` (0 = none, 1 = as built;
    /// [`QuadParams::validate`] rejects a negative or non-finite one).
    pub fn with_vibration_scale(mut self, scale: f64) -> Self {
        self.vibration.scale = scale;
        self
    }

    /// Weight (N).
    pub fn weight_n(&self) -> f64 {
        self.mass_kg * G0_MPS2
    }

    /// Rotor speed at which the four correct propellers carry the weight
    /// (rad/s): T = 4·k_f·ω².
    pub fn hover_rotor_rps(&self) -> f64 {
        (self.weight_n() / (4.0 * self.propulsion.k_f_n_per_rps2)).sqrt()
    }

    /// The ESC signal wires of motor indices `a` and `b` swapped at the
    /// flight controller: each motor gets the other's command (indices
    /// out of range change nothing).
    pub fn with_swapped_esc_signals(mut self, a: usize, b: usize) -> Self {
        let ia = self.motors.get(a).map(|m| m.esc_input);
        let ib = self.motors.get(b).map(|m| m.esc_input);
        if let (Some(ia), Some(ib)) = (ia, ib) {
            for (i, input) in [(a, ib), (b, ia)] {
                if let Some(m) = self.motors.get_mut(i) {
                    m.esc_input = input;
                }
            }
        }
        self
    }

    /// Motor index `i` turns against its design direction (two of its
    /// phase wires swapped, or a motor for the other hand) and carries a
    /// propeller that still pushes air down, but mounted the wrong way
    /// (its airfoil running backwards): the model keeps it simple, the
    /// reaction torque takes the actual spin's sign and thrust and drag
    /// torque are `fraction` of a correct propeller's (clamped to `(0, 1]`
    /// by validation). A propeller pushing air up is not modelled.
    pub fn with_reversed_motor(mut self, i: usize, fraction: f64) -> Self {
        if let Some(m) = self.motors.get_mut(i) {
            m.spin = match m.spin {
                Spin::Clockwise => Spin::CounterClockwise,
                Spin::CounterClockwise => Spin::Clockwise,
            };
            m.prop_fraction = fraction;
        }
        self
    }
}

/// Which [`QuadParams`] field is out of its physical range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QuadParamsError {
    /// `mass_kg` not finite and > 0.
    Mass,
    /// An `inertia_kgm2` entry not finite and > 0.
    Inertia,
    /// A motor position not finite.
    MotorPosition,
    /// A motor's `esc_input` not 0..=3 or its `prop_fraction` not in `(0, 1]`.
    MotorWiring,
    /// A propulsion figure not finite and > 0, or `efficiency` above 1.
    Propulsion,
    /// A battery figure out of range (no cells, capacity ≤ 0, negative
    /// resistance or current, more charge used than the capacity).
    Battery,
    /// A drag coefficient negative or not finite.
    Drag,
    /// A vibration figure out of range ([`VibrationParams::is_valid`]).
    Vibration,
}

impl std::fmt::Display for QuadParamsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "quadcopter parameters: {self:?} out of range")
    }
}

impl std::error::Error for QuadParamsError {}

impl QuadParams {
    /// Checks every field is physically meaningful.
    pub fn validate(&self) -> Result<(), QuadParamsError> {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        let non_neg = |x: f64| x.is_finite() && x >= 0.0;
        if !pos(self.mass_kg) {
            return Err(QuadParamsError::Mass);
        }
        if !self.inertia_kgm2.iter().all(|&i| pos(i)) {
            return Err(QuadParamsError::Inertia);
        }
        if !self
            .motors
            .iter()
            .all(|m| m.position_body_m.iter().all(|x| x.is_finite()))
        {
            return Err(QuadParamsError::MotorPosition);
        }
        if !self
            .motors
            .iter()
            .all(|m| m.esc_input < 4 && pos(m.prop_fraction) && m.prop_fraction <= 1.0)
        {
            return Err(QuadParamsError::MotorWiring);
        }
        let p = &self.propulsion;
        let prop = [
            p.k_f_n_per_rps2,
            p.k_m_nm_per_rps2,
            p.omega_max_rps,
            p.v_nominal_v,
            p.tau_s,
            p.efficiency,
        ];
        if !prop.iter().all(|&x| pos(x)) || p.efficiency > 1.0 {
            return Err(QuadParamsError::Propulsion);
        }
        let b = &self.battery;
        if b.cells == 0
            || !pos(b.capacity_ah)
            || !non_neg(b.r_internal_ohm)
            || !non_neg(b.avionics_a)
            || !non_neg(b.used_at_start_ah)
            || b.used_at_start_ah > b.capacity_ah
        {
            return Err(QuadParamsError::Battery);
        }
        let d = &self.drag;
        let drag = d
            .linear_n_per_mps
            .iter()
            .chain(&d.quadratic_n_per_mps2)
            .chain(&d.angular_nm_per_rps);
        if !drag.into_iter().all(|&x| non_neg(x)) {
            return Err(QuadParamsError::Drag);
        }
        if !self.vibration.is_valid() {
            return Err(QuadParamsError::Vibration);
        }
        Ok(())
    }
}

impl Default for QuadParams {
    fn default() -> Self {
        Self::class_250()
    }
}

/// The full state of the body, its motors and its battery.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadState {
    /// Simulated time (s).
    pub t_s: f64,
    /// Position of the centre of mass, NED, relative to the take-off point (m).
    pub position_ned_m: Vec3,
    /// Velocity, NED (m/s).
    pub velocity_ned_mps: Vec3,
    /// Acceleration over the last step, NED (m/s²).
    pub accel_ned_mps2: Vec3,
    /// Orientation.
    pub q_ned_from_body: Quat,
    /// Angular rate relative to NED, body frame (rad/s).
    pub omega_body_rps: Vec3,
    /// Rotor speeds (rad/s).
    pub rotor_rps: [f64; 4],
    /// Rotor angles, the integral of their speeds, in [0, 2π) (rad).
    pub rotor_phase_rad: [f64; 4],
    /// Charge drawn from the battery (A·h).
    pub battery_used_ah: f64,
    /// Battery current (A).
    pub battery_current_a: f64,
    /// Battery terminal voltage (V).
    pub battery_voltage_v: f64,
    /// Resting on the ground.
    pub on_ground: bool,
}

/// The quadcopter: parameters, state, and the integration.
#[derive(Clone, Debug)]
pub struct Quadcopter {
    params: QuadParams,
    state: QuadState,
}

/// Integration step (s): short against the motors' time constant and the
/// fastest rotational mode of the closed loop.
pub const STEP_S: f64 = 2.5e-4;

impl Quadcopter {
    /// At rest on the ground, level, facing north, motors stopped; the
    /// parameters are checked first ([`QuadParams::validate`]).
    pub fn new(params: QuadParams) -> Result<Self, QuadParamsError> {
        params.validate()?;
        let v = params
            .battery
            .open_circuit_v(params.battery.used_at_start_ah)
            - params.battery.avionics_a * params.battery.r_internal_ohm;
        Ok(Self {
            params,
            state: QuadState {
                t_s: 0.0,
                position_ned_m: [0.0; 3],
                velocity_ned_mps: [0.0; 3],
                accel_ned_mps2: [0.0; 3],
                q_ned_from_body: Quat::IDENTITY,
                omega_body_rps: [0.0; 3],
                rotor_rps: [0.0; 4],
                // Arbitrary, distinct starting angles of the four rotors.
                rotor_phase_rad: [0.0, 1.9, 3.7, 5.3],
                battery_used_ah: params.battery.used_at_start_ah,
                battery_current_a: params.battery.avionics_a,
                battery_voltage_v: v,
                on_ground: true,
            },
        })
    }

    /// The parameters.
    pub fn params(&self) -> &QuadParams {
        &self.params
    }

    /// The state.
    pub fn state(&self) -> &QuadState {
        &self.state
    }

    /// Replaces the state (to start a scenario in the air, for example).
    pub fn set_state(&mut self, state: QuadState) {
        self.state = state;
    }

    /// Thrust of motor `i` now (N); 0 for an index out of range.
    pub fn thrust_n(&self, i: usize) -> f64 {
        let w = self.state.rotor_rps.get(i).copied().unwrap_or(0.0);
        let f = self.params.motors.get(i).map_or(0.0, |m| m.prop_fraction);
        f * self.params.propulsion.k_f_n_per_rps2 * w * w
    }

    /// Total thrust now (N).
    pub fn total_thrust_n(&self) -> f64 {
        (0..4).map(|i| self.thrust_n(i)).sum()
    }

    /// Steady-state rotor speed for `command` at terminal voltage `v` (rad/s).
    pub fn steady_rotor_rps(&self, command: f64, v: f64) -> f64 {
        let p = &self.params.propulsion;
        command.clamp(0.0, 1.0) * p.omega_max_rps * (v / p.v_nominal_v).max(0.0)
    }

    /// The command that holds `thrust_n` per motor in steady state at the
    /// present battery voltage (may exceed 1 if the motors cannot).
    pub fn command_for_thrust(&self, thrust_n: f64) -> f64 {
        let p = &self.params.propulsion;
        let w = (thrust_n.max(0.0) / p.k_f_n_per_rps2).sqrt();
        w / (p.omega_max_rps * self.state.battery_voltage_v / p.v_nominal_v)
    }

    /// Advances to `t_s` with constant motor `commands` (each clamped to
    /// `[0, 1]`; NaN counts as 0) in steps of at most [`STEP_S`].
    pub fn advance_to(&mut self, t_s: f64, commands: [f64; 4]) {
        let commands = commands.map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) });
        while self.state.t_s < t_s - 1e-12 {
            let dt = (t_s - self.state.t_s).min(STEP_S);
            self.step(dt, commands);
        }
    }

    fn step(&mut self, dt: f64, commands: [f64; 4]) {
        let p = self.params;
        let s = &mut self.state;
        // Motors: exact first-order response over the step at the present voltage.
        let alpha = 1.0 - (-dt / p.propulsion.tau_s).exp();
        let v = s.battery_voltage_v;
        let mut thrust_total = 0.0;
        let mut torque = [0.0; 3];
        let mut shaft_w = 0.0;
        for (i, m) in p.motors.iter().enumerate() {
            let command = commands.get(m.esc_input).copied().unwrap_or(0.0);
            let target =
                command * p.propulsion.omega_max_rps * (v / p.propulsion.v_nominal_v).max(0.0);
            let w = s.rotor_rps[i] + (target - s.rotor_rps[i]) * alpha;
            s.rotor_rps[i] = w;
            s.rotor_phase_rad[i] = (s.rotor_phase_rad[i] + w * dt).rem_euclid(2.0 * PI);
            let thrust = m.prop_fraction * p.propulsion.k_f_n_per_rps2 * w * w;
            let q = m.prop_fraction * p.propulsion.k_m_nm_per_rps2 * w * w;
            thrust_total += thrust;
            // Thrust along −z at the hub: r × (0, 0, −T).
            torque = math::add(torque, math::cross(m.position_body_m, [0.0, 0.0, -thrust]));
            torque[2] += m.spin.reaction_sign() * q;
            shaft_w += q * w;
        }
        // Battery: current from the shaft power, then the sag it causes.
        let b = p.battery;
        let current = shaft_w / (p.propulsion.efficiency * v.max(1.0)) + b.avionics_a;
        s.battery_used_ah += current * dt / 3600.0;
        s.battery_current_a = current;
        s.battery_voltage_v =
            (b.open_circuit_v(s.battery_used_ah) - current * b.r_internal_ohm).max(0.0);

        // Forces in the body frame: thrust and drag on the air-relative velocity.
        let v_air = math::sub(s.velocity_ned_mps, p.drag.wind_ned_mps);
        let v_body = s.q_ned_from_body.conj().rotate(v_air);
        let mut f_body = [0.0, 0.0, -thrust_total];
        let linear_scale = if p.drag.linear_scales_with_rotor_speed {
            s.rotor_rps.iter().sum::<f64>() / (4.0 * p.hover_rotor_rps())
        } else {
            1.0
        };
        for k in 0..3 {
            f_body[k] -= linear_scale * p.drag.linear_n_per_mps[k] * v_body[k]
                + p.drag.quadratic_n_per_mps2[k] * v_body[k] * v_body[k].abs();
        }
        let f_ned = s.q_ned_from_body.rotate(f_body);
        let mut a_ned = math::scale(f_ned, 1.0 / p.mass_kg);
        a_ned[2] += G0_MPS2;

        // Rotation: I ω̇ = τ − ω × Iω − damping.
        let inertia = p.inertia_kgm2;
        let w = s.omega_body_rps;
        let h = [inertia[0] * w[0], inertia[1] * w[1], inertia[2] * w[2]];
        let gyro = math::cross(w, h);
        let mut w_dot = [0.0; 3];
        for k in 0..3 {
            w_dot[k] = (torque[k] - gyro[k] - p.drag.angular_nm_per_rps[k] * w[k]) / inertia[k];
        }

        // Ground: resting while the net force does not lift the body.
        let at_ground = s.position_ned_m[2] >= 0.0;
        if at_ground && (s.on_ground || s.velocity_ned_mps[2] >= 0.0) && a_ned[2] >= 0.0 {
            if !s.on_ground {
                // Touch-down: up to 45° of tilt the quad settles on its
                // feet (heading kept); beyond it, it lies where it fell.
                let down_body = s.q_ned_from_body.rotate([0.0, 0.0, 1.0]);
                if down_body[2] >= std::f64::consts::FRAC_1_SQRT_2 {
                    let yaw = s.q_ned_from_body.to_euler()[2];
                    s.q_ned_from_body = Quat::from_euler(0.0, 0.0, yaw);
                }
            }
            s.on_ground = true;
            s.position_ned_m[2] = 0.0;
            s.velocity_ned_mps = [0.0; 3];
            s.accel_ned_mps2 = [0.0; 3];
            s.omega_body_rps = [0.0; 3];
            s.t_s += dt;
            return;
        }
        s.on_ground = false;
        // Semi-implicit Euler: velocities first, positions with the new ones.
        s.velocity_ned_mps = math::add(s.velocity_ned_mps, math::scale(a_ned, dt));
        s.position_ned_m = math::add(s.position_ned_m, math::scale(s.velocity_ned_mps, dt));
        s.accel_ned_mps2 = a_ned;
        s.omega_body_rps = math::add(w, math::scale(w_dot, dt));
        let wn = s.omega_body_rps;
        let dq = Quat::from_axis_angle(wn, math::norm(wn) * dt);
        s.q_ned_from_body = s.q_ned_from_body.mul(&dq).normalized();
        if s.position_ned_m[2] > 0.0 {
            // Hit the ground this step: stop on it (inelastic).
            s.position_ned_m[2] = 0.0;
            s.velocity_ned_mps[2] = 0.0;
        }
        s.t_s += dt;
    }

    /// The pose at `t_s` near the present state, extrapolated with the
    /// state's own velocity, acceleration and angular rate (constant over
    /// the gap), so that differentiating it at the present time gives them
    /// back exactly.
    pub fn pose_near(state: &QuadState, t_s: f64) -> Pose {
        let d = t_s - state.t_s;
        let p = math::add(
            state.position_ned_m,
            math::add(
                math::scale(state.velocity_ned_mps, d),
                math::scale(state.accel_ned_mps2, 0.5 * d * d),
            ),
        );
        let w = state.omega_body_rps;
        let q = state
            .q_ned_from_body
            .mul(&Quat::from_axis_angle(w, math::norm(w) * d));
        (p, q)
    }

    /// The truth now, as the chips see it.
    pub fn truth(&self) -> TruthSample {
        let s = &self.state;
        let f_ned = math::sub(s.accel_ned_mps2, [0.0, 0.0, G0_MPS2]);
        TruthSample {
            t_s: s.t_s,
            q_ned_from_body: s.q_ned_from_body,
            omega_body_rps: s.omega_body_rps,
            specific_force_body_mps2: s.q_ned_from_body.conj().rotate(f_ned),
            position_ned_m: s.position_ned_m,
            velocity_ned_mps: s.velocity_ned_mps,
            height_m: -s.position_ned_m[2],
            moving: math::norm(s.omega_body_rps) > 0.05 || math::norm(s.accel_ned_mps2) > 0.2,
        }
    }
}

/// The truth at `t_s` near `state` as the board sees it: the rigid body
/// extrapolated as [`Quadcopter::pose_near`] does (its velocity,
/// acceleration and rate constant over the gap) plus the frame's
/// vibration ([`vibration::at`]).
pub fn truth_near(params: &QuadParams, state: &QuadState, t_s: f64) -> TruthSample {
    let (p, q) = Quadcopter::pose_near(state, t_s);
    let d = t_s - state.t_s;
    let f_ned = math::sub(state.accel_ned_mps2, [0.0, 0.0, G0_MPS2]);
    let vib = vibration::at(params, state, t_s);
    let moving = math::norm(state.omega_body_rps) > 0.05 || math::norm(state.accel_ned_mps2) > 0.2;
    TruthSample {
        t_s,
        q_ned_from_body: q,
        omega_body_rps: math::add(state.omega_body_rps, vib.omega_body_rps),
        specific_force_body_mps2: math::add(q.conj().rotate(f_ned), vib.accel_body_mps2),
        position_ned_m: p,
        velocity_ned_mps: math::add(state.velocity_ned_mps, math::scale(state.accel_ned_mps2, d)),
        height_m: -p[2],
        moving,
    }
}

/// The link from a [`Quadcopter`] to the simulated chips: a trajectory
/// whose truth is the body's latest published state, extrapolated to the
/// instant a chip samples (sub-millisecond gaps), with the frame's
/// vibration ([`truth_near`]).
#[derive(Clone, Debug, Default)]
pub struct QuadLink {
    shared: Rc<Cell<Option<(QuadState, QuadParams)>>>,
}

impl QuadLink {
    /// A link with nothing published yet (the trajectory is then at rest, level).
    pub fn new() -> Self {
        Self::default()
    }

    /// Publishes the body's present state to the chips.
    pub fn publish(&self, quad: &Quadcopter) {
        self.shared.set(Some((quad.state, quad.params)));
    }

    /// The trajectory to put in `SimConfig::trajectory` (or
    /// `world.trajectory`): it follows every [`QuadLink::publish`].
    pub fn trajectory(&self) -> Trajectory {
        let shared = Rc::clone(&self.shared);
        Trajectory::Motion(Rc::new(move |t_s| match shared.get() {
            Some((s, p)) => truth_near(&p, &s, t_s),
            None => Trajectory::at_rest().sample(t_s),
        }))
    }
}
