//! Runaway-takeoff protection: a disarm for a craft that the rate loop
//! cannot hold just after arming, as a motor on the wrong ESC output, a
//! motor turning the wrong way or a propeller on upside down make it.
//!
//! Such a craft yaws or flips at take-off. The crash checks end that only
//! beyond 70° for 0.5 s or at 950 °/s for 0.3 s, and a yaw spin from a
//! reversed motor can stay below 950 °/s for good. This check looks for
//! the signature of a loop that pushes hard and gets the wrong answer.
//!
//! # Rule (numbers: [`SafetyConfig`] defaults)
//!
//! **Trigger**: armed, not yet switched off, and for
//! [`SafetyConfig::runaway_time_s`] (75 ms) without a break both
//! * the rate loop's torque command ([`TorqueCommand`], the "PID sum")
//!   on any axis at or beyond [`SafetyConfig::runaway_torque_min`] (0.6) in
//!   magnitude. A torque command of ±1 is the mixer's full authority on
//!   that axis: alone, at half collective, it spans the motors from 0 to 1
//!   (see [`control::mixer`]); 0.6 is 60 % of it; and
//! * the gyro above [`SafetyConfig::runaway_rate_roll_pitch_dps`]
//!   (15 °/s) on roll or pitch, or above
//!   [`SafetyConfig::runaway_rate_yaw_dps`] (50 °/s) on yaw, so a
//!   props-off bench test (no rotation) never triggers;
//!
//! then [`DisarmCause::RunawayTakeoff`](crate::arming::DisarmCause).
//!
//! **Switch-off**: once the craft has flown normally for
//! [`SafetyConfig::runaway_off_time_s`] (0.5 s) in total since arming, the
//! check is off until the next arming. Normal flight is a collective at or
//! above [`SafetyConfig::runaway_off_collective_min`] (0.2) with every
//! torque command below [`SafetyConfig::runaway_off_torque_max`] (0.1);
//! while the torque is larger the count pauses (it keeps what it has), so
//! a craft fighting a wiring error never earns the switch-off.
//!
//! These are the numbers of Betaflight's runaway-takeoff prevention
//! (its PID-sum threshold 600 of 1000 is the same 60 % of the mixer's
//! range). Unlike Betaflight it needs no stick movement for the
//! switch-off (altitude hold takes off with the sticks centred), and it
//! starts afresh at every arming rather than once per battery: a hard
//! landing can knock a propeller loose.
//!
//! Cost: a few integer comparisons per 1 kHz step while active (the Q16
//! gyro's magnitudes, the torques' bit patterns), one after it; 308 B of flash and 64 B of RAM
//! (its state and limits, and the seven `SafetyConfig` fields) in the firmware.

use control::controllers::TorqueCommand;

use crate::arming::{q16_limit, SafetyConfig};

const RAD_PER_DEG: f32 = core::f32::consts::PI / 180.0;

/// The runaway-takeoff check of one flight (see the [module docs](self)).
///
/// Rates are compared in Q16 rad/s, torques as their IEEE 754 bit
/// patterns: integer comparisons instead of the M3's soft-float calls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunawayCheck {
    torque_min: u32,
    /// Q16 rad/s.
    rate_rp_q16: u32,
    /// Q16 rad/s.
    rate_yaw_q16: u32,
    trigger_us: u32,
    off_collective: f32,
    off_torque: u32,
    off_us: u32,
    /// Time the trigger conditions have held without a break, µs.
    runaway_us: u32,
    /// Normal flight accumulated since arming, µs.
    normal_us: u32,
}

/// `|x|` as its IEEE 754 bit pattern: for finite values (and infinity)
/// these order as the magnitudes do; a NaN orders above them all, so it
/// counts as large (the controller never hands one over).
fn mag(x: f32) -> u32 {
    x.to_bits() & 0x7fff_ffff
}

/// Seconds → µs (config times are validated ≤ 60 s).
fn us(s: f32) -> u32 {
    (s * 1.0e6) as u32
}

impl RunawayCheck {
    /// Active, with the limits of `s` (validated by
    /// [`SafetyConfig::validate`]).
    #[inline(always)]
    pub fn new(s: &SafetyConfig) -> Self {
        Self {
            torque_min: mag(s.runaway_torque_min),
            rate_rp_q16: q16_limit(s.runaway_rate_roll_pitch_dps * RAD_PER_DEG),
            rate_yaw_q16: q16_limit(s.runaway_rate_yaw_dps * RAD_PER_DEG),
            trigger_us: us(s.runaway_time_s),
            off_collective: s.runaway_off_collective_min,
            off_torque: mag(s.runaway_off_torque_max),
            off_us: us(s.runaway_off_time_s),
            runaway_us: 0,
            normal_us: 0,
        }
    }

    /// Active again with nothing counted (at arming).
    pub fn restart(&mut self) {
        self.runaway_us = 0;
        self.normal_us = 0;
    }

    /// Still watching (not yet switched off by normal flight).
    pub fn active(&self) -> bool {
        self.normal_us < self.off_us
    }

    /// One step of `dt_us` with the rate loop's `torque`, the gyro
    /// (`gyro_q16`, Q16 rad/s, FRD) and the `collective` asked of the
    /// mixer; true: runaway, disarm.
    // Out of line: inlined into the flight controller's step, the firmware
    // measured 20 B larger.
    #[inline(never)]
    pub fn update(
        &mut self,
        dt_us: u32,
        torque: &TorqueCommand,
        gyro_q16: &[i32; 3],
        collective: f32,
    ) -> bool {
        if !self.active() {
            return false;
        }
        let t = mag(torque.roll).max(mag(torque.pitch)).max(mag(torque.yaw));
        // The integer compare first: the soft-float one only when it holds.
        if t < self.off_torque && collective >= self.off_collective {
            self.normal_us = self.normal_us.saturating_add(dt_us);
        }
        let [roll, pitch, yaw] = gyro_q16.map(i32::unsigned_abs);
        let turning = roll.max(pitch) > self.rate_rp_q16 || yaw > self.rate_yaw_q16;
        self.runaway_us = if t >= self.torque_min && turning {
            self.runaway_us.saturating_add(dt_us)
        } else {
            0
        };
        self.runaway_us >= self.trigger_us
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check() -> RunawayCheck {
        RunawayCheck::new(&SafetyConfig::default())
    }

    use control::fixed::f32_to_q;

    fn rates_dps(roll: f32, pitch: f32, yaw: f32) -> [i32; 3] {
        [roll, pitch, yaw].map(|r| f32_to_q(r * RAD_PER_DEG, 16))
    }

    /// Steps of 1 ms until it fires; the ms count, or `None` within `max`.
    fn fires_after_ms(
        c: &mut RunawayCheck,
        max: u32,
        tq: TorqueCommand,
        g: [i32; 3],
        coll: f32,
    ) -> Option<u32> {
        (1..=max).find(|_| c.update(1_000, &tq, &g, coll))
    }

    #[test]
    fn saturated_torque_while_turning_fires_after_75_ms() {
        let tq = TorqueCommand {
            roll: 0.0,
            pitch: -0.6,
            yaw: 0.0,
        };
        let mut c = check();
        assert_eq!(
            fires_after_ms(&mut c, 200, tq, rates_dps(16.0, 0.0, 0.0), 0.5),
            Some(75)
        );
        let mut c = check();
        assert_eq!(
            fires_after_ms(&mut c, 200, tq, rates_dps(0.0, 0.0, -51.0), 0.5),
            Some(75)
        );
    }

    #[test]
    fn below_the_thresholds_it_never_fires() {
        let big = TorqueCommand {
            roll: 1.0,
            pitch: 1.0,
            yaw: 1.0,
        };
        // Pushing hard without turning: held on the bench, props off.
        let mut c = check();
        assert_eq!(
            fires_after_ms(&mut c, 1_000, big, rates_dps(15.0, -15.0, 50.0), 0.1),
            None
        );
        // Turning fast with a torque just below 60 %: a pilot's flip.
        let mut c = check();
        let tq = TorqueCommand {
            roll: 0.59,
            pitch: -0.59,
            yaw: 0.59,
        };
        assert_eq!(
            fires_after_ms(&mut c, 1_000, tq, rates_dps(500.0, 0.0, 0.0), 0.1),
            None
        );
    }

    #[test]
    fn a_break_restarts_the_75_ms() {
        let tq = TorqueCommand {
            roll: 0.8,
            pitch: 0.0,
            yaw: 0.0,
        };
        let g = rates_dps(100.0, 0.0, 0.0);
        let mut c = check();
        assert_eq!(fires_after_ms(&mut c, 74, tq, g, 0.1), None);
        assert!(!c.update(1_000, &TorqueCommand::default(), &g, 0.1));
        assert_eq!(fires_after_ms(&mut c, 200, tq, g, 0.1), Some(75));
    }

    #[test]
    fn normal_flight_switches_it_off_after_half_a_second_in_total() {
        let calm = TorqueCommand {
            roll: 0.05,
            pitch: -0.05,
            yaw: 0.09,
        };
        let busy = TorqueCommand {
            roll: 0.3,
            pitch: 0.0,
            yaw: 0.0,
        };
        let still = rates_dps(0.0, 0.0, 0.0);
        let mut c = check();
        // Low collective or a busy loop does not count; calm flight does,
        // and the count survives the pauses.
        for (tq, coll, ms) in [(calm, 0.19, 1_000), (calm, 0.2, 300), (busy, 0.5, 1_000)] {
            assert_eq!(fires_after_ms(&mut c, ms, tq, still, coll), None);
        }
        assert!(c.active());
        assert_eq!(fires_after_ms(&mut c, 199, calm, still, 0.5), None);
        assert!(c.active());
        assert_eq!(fires_after_ms(&mut c, 1, calm, still, 0.5), None);
        assert!(!c.active());
        // Off: a runaway no longer disarms...
        let tq = TorqueCommand {
            roll: 1.0,
            pitch: 0.0,
            yaw: 0.0,
        };
        let g = rates_dps(300.0, 0.0, 0.0);
        assert_eq!(fires_after_ms(&mut c, 1_000, tq, g, 0.5), None);
        // ...until the next arming.
        c.restart();
        assert_eq!(fires_after_ms(&mut c, 1_000, tq, g, 0.5), Some(75));
    }
}
