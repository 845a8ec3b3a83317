//! The airframe's vibration: what the rotors shake the sensor board with.
//!
//! Sources, per motor, from its speed ω and its rotor angle φ (integrated
//! from ω by the body model):
//! * the rotor's imbalance `u` (motor bell and propeller, kg·m): a force
//!   `u ω²` in the rotor plane turning with the rotor (1× the rotor
//!   frequency), and smaller in-plane forces at 2× and 3× (bearing and
//!   magnetic harmonics) as ratios of it;
//! * blade passing: a thrust ripple at `blades`× the rotor frequency, a
//!   fraction of the rotor's thrust, along −z at the hub.
//!
//! Response: each force acts at its hub, `rotor_height_m` above the centre
//! of mass, on the rigid body (acceleration `F/m`, angular acceleration
//! `I⁻¹ (r × F)`), and the board sees that motion through one lightly
//! damped frame mode: a fraction `participation` of the motion passes
//! through a base-excited oscillator at `mode_hz` with damping ratio
//! `mode_damping` (transmissibility 1 well below the mode, about
//! `participation / (2 ζ)` at it). Each source is a sinusoid, so the
//! response is evaluated exactly at any instant from its phasor: the board
//! sits at the centre of mass, and the vibration is superposed on the rigid
//! body's motion without feeding back into it (its mean force is zero and
//! its displacement micrometres).
//!
//! Default figures ([`VibrationParams::well_balanced`]): a balanced
//! 250-class quad. The imbalance, 1 g·mm per rotor, is chosen so that
//! the accelerometer's unfiltered vibration at hover is about 2 m/s² RMS
//! per horizontal axis (gyro: about 0.4 °/s roll and pitch, 1.6 °/s yaw;
//! at full throttle about 7 m/s² and 1-3.6 °/s): below the 3 m/s² an MPU-9250 read at 1 kHz showed on
//! a soft-mounted board of a quad at half throttle and well below the
//! 8 m/s² hard-mounted (diydrones.com forum, "Vibration analysis", an
//! MPU-9250 at 1 kHz on 2208 motors), and below the 15 m/s² ArduPilot's
//! "Measuring Vibration" page calls normal (standard deviation of the raw
//! accelerometer, 3DR IRIS). The frame mode (180 Hz, ζ = 0.05, 30 %
//! participation), the harmonic ratios (0.3, 0.15), the 10 % blade-pass
//! ripple and the 20 mm rotor height are assumptions of this model, not
//! measurements: the mode in the 150-250 Hz band typical of a 250 mm
//! carbon frame's arms, lightly damped as bolted carbon is.

use super::{MotorParams, QuadParams, QuadState, Spin};
use crate::math::{self, Vec3};
use std::f64::consts::PI;

/// The vibration sources and the frame mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VibrationParams {
    /// Multiplies every source: 0 = no vibration, 1 = these figures.
    pub scale: f64,
    /// Rotor imbalance, mass × eccentricity of the spinning parts (kg·m).
    pub imbalance_kgm: f64,
    /// In-plane force at 2× and 3× the rotor frequency, relative to the
    /// imbalance force at the same speed.
    pub harmonic_ratio: [f64; 2],
    /// Propeller blades (blade-pass frequency = blades × rotor frequency).
    pub blades: u8,
    /// Thrust ripple at blade pass, fraction of the rotor's thrust (peak).
    pub blade_pass_fraction: f64,
    /// Height of the rotor planes above the centre of mass (m).
    pub rotor_height_m: f64,
    /// Natural frequency of the frame mode (Hz).
    pub mode_hz: f64,
    /// Damping ratio of the frame mode.
    pub mode_damping: f64,
    /// Fraction of the board's motion that passes through the frame mode.
    pub participation: f64,
}

impl VibrationParams {
    /// A well-balanced 250-class quad (sources in the module doc).
    pub fn well_balanced() -> Self {
        Self {
            scale: 1.0,
            imbalance_kgm: 1.0e-6,
            harmonic_ratio: [0.3, 0.15],
            blades: 2,
            blade_pass_fraction: 0.1,
            rotor_height_m: 0.02,
            mode_hz: 180.0,
            mode_damping: 0.05,
            participation: 0.3,
        }
    }

    /// No vibration at all.
    pub fn none() -> Self {
        Self {
            scale: 0.0,
            ..Self::well_balanced()
        }
    }

    /// Every figure finite, non-negative; the mode's frequency and damping
    /// positive, participation at most 1.
    pub fn is_valid(&self) -> bool {
        let nn = |x: f64| x.is_finite() && x >= 0.0;
        [
            self.scale,
            self.imbalance_kgm,
            self.harmonic_ratio[0],
            self.harmonic_ratio[1],
            self.blade_pass_fraction,
            self.participation,
        ]
        .iter()
        .all(|&x| nn(x))
            && self.rotor_height_m.is_finite()
            && self.mode_hz.is_finite()
            && self.mode_hz > 0.0
            && self.mode_damping.is_finite()
            && self.mode_damping > 0.0
            && self.participation <= 1.0
    }

    /// The frame's transmissibility at `f_hz` (complex: re, im): the
    /// board's motion per unit of the rigid body's.
    pub fn transmissibility(&self, f_hz: f64) -> (f64, f64) {
        let r = f_hz / self.mode_hz;
        let z = self.mode_damping;
        // (1 + 2jζr) / (1 − r² + 2jζr)
        let (nr, ni) = (1.0, 2.0 * z * r);
        let (dr, di) = (1.0 - r * r, 2.0 * z * r);
        let d2 = dr * dr + di * di;
        let (qr, qi) = ((nr * dr + ni * di) / d2, (ni * dr - nr * di) / d2);
        let c = self.participation;
        (1.0 - c + c * qr, c * qi)
    }
}

/// Parses a `--vibration SCALE` command-line value (both flight rigs):
/// a number in [0, 100].
pub fn parse_scale(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    if !(0.0..=100.0).contains(&v) {
        return Err(format!("{s} is out of range: must be in [0, 100]"));
    }
    Ok(v)
}

impl Default for VibrationParams {
    fn default() -> Self {
        Self::well_balanced()
    }
}

/// The vibration's contribution to the board's motion at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VibrationSample {
    /// Angular rate, body FRD (rad/s).
    pub omega_body_rps: Vec3,
    /// Acceleration (adds to the specific force), body FRD (m/s²).
    pub accel_body_mps2: Vec3,
}

/// One sinusoidal force at a hub: its peak in-phase (cos) and quadrature
/// (sin) parts in the body frame, its angular frequency and phase.
struct Tone {
    cos_n: Vec3,
    sin_n: Vec3,
    omega_rps: f64,
    phase_rad: f64,
}

/// The vibration at `t_s` for a body in `state` (its rotor speeds and
/// angles extrapolated from `state.t_s` at constant speed).
pub fn at(params: &QuadParams, state: &QuadState, t_s: f64) -> VibrationSample {
    let v = params.vibration;
    let mut out = VibrationSample::default();
    if v.scale == 0.0 {
        return out;
    }
    for (i, m) in params.motors.iter().enumerate() {
        let w = state.rotor_rps[i];
        if w <= 0.0 {
            continue;
        }
        let phi = state.rotor_phase_rad[i] + w * (t_s - state.t_s);
        let hub = math::add(m.position_body_m, [0.0, 0.0, -v.rotor_height_m]);
        for tone in tones(params, m, w, phi) {
            add_response(&mut out, params, hub, &tone);
        }
    }
    out
}

/// The tones of motor `m` at speed `w` and rotor angle `phi`.
fn tones(params: &QuadParams, m: &MotorParams, w: f64, phi: f64) -> Vec<Tone> {
    let v = params.vibration;
    // The rotor turns about +z body when clockwise seen from above.
    let s = match m.spin {
        Spin::Clockwise => 1.0,
        Spin::CounterClockwise => -1.0,
    };
    let f1 = v.scale * v.imbalance_kgm * w * w;
    let mut out = Vec::with_capacity(4);
    for (k, ratio) in [
        (1.0, 1.0),
        (2.0, v.harmonic_ratio[0]),
        (3.0, v.harmonic_ratio[1]),
    ] {
        // F = f (cos kφ, s sin kφ, 0): a force turning with the rotor.
        out.push(Tone {
            cos_n: [f1 * ratio, 0.0, 0.0],
            sin_n: [0.0, s * f1 * ratio, 0.0],
            omega_rps: k * w,
            // Each harmonic with its own fixed phase to the rotor.
            phase_rad: k * phi + 0.7 * (k - 1.0),
        });
    }
    let thrust = m.prop_fraction * params.propulsion.k_f_n_per_rps2 * w * w;
    let b = f64::from(v.blades);
    out.push(Tone {
        cos_n: [0.0, 0.0, -v.scale * v.blade_pass_fraction * thrust],
        sin_n: [0.0; 3],
        omega_rps: b * w,
        phase_rad: b * phi,
    });
    out
}

/// Adds the board's response to one tone: acceleration and angular rate,
/// each through the frame's transmissibility at the tone's frequency.
fn add_response(out: &mut VibrationSample, params: &QuadParams, hub: Vec3, tone: &Tone) {
    let (tr, ti) = params
        .vibration
        .transmissibility(tone.omega_rps / (2.0 * PI));
    let (c, s) = (tone.phase_rad.cos(), tone.phase_rad.sin());
    // z = T e^{jθ}; the real force is Re(F̂ z) with F̂ = cos_n − j sin_n.
    let (zr, zi) = (tr * c - ti * s, tr * s + ti * c);
    let force =
        |re: f64, im: f64| math::add(math::scale(tone.cos_n, re), math::scale(tone.sin_n, im));
    let f_now = force(zr, zi);
    out.accel_body_mps2 = math::add(
        out.accel_body_mps2,
        math::scale(f_now, 1.0 / params.mass_kg),
    );
    // Rate = angular acceleration integrated: Re(α̂ z / (jΩ)), and
    // z / j = (zi, −zr).
    let f_rate = force(zi, -zr);
    let tau = math::cross(hub, f_rate);
    let inertia = params.inertia_kgm2;
    for k in 0..3 {
        out.omega_body_rps[k] += tau[k] / (inertia[k] * tone.omega_rps);
    }
}
