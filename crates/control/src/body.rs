//! The body-frame quantities every control stage passes on: body rates
//! (rad/s) and the normalised torque command, FRD axes. A leaf module (it
//! imports nothing from the crate), so the stages that share these types
//! (`shaping` → `loops` → `controllers`, the mixer) depend on it rather
//! than on one another. [`crate::controllers`] re-exports both.

/// Body rates about the FRD axes, rad/s (gyro `p`, `q`, `r`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BodyRates {
    /// About x (forward), rad/s.
    pub roll_rps: f32,
    /// About y (right), rad/s.
    pub pitch_rps: f32,
    /// About z (down), rad/s.
    pub yaw_rps: f32,
}

/// Normalised torque command per body axis, within each rate PID's output
/// limits (default −1..1); the mixer turns it into motor outputs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TorqueCommand {
    /// About x (forward).
    pub roll: f32,
    /// About y (right).
    pub pitch: f32,
    /// About z (down).
    pub yaw: f32,
}
