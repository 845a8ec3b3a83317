//! The parameter table: every setting a pilot may change without a
//! rebuild, with its name, unit, decimals, range, default and help, in one
//! place ([`TABLE`], indexed by [`ParamId`]), and the values in use
//! ([`ParamSet`]).
//!
//! Every value is an `i32` holding the decimal value times
//! 10^[`Param::decimals`] ("0.0045" with 4 decimals is 45), so it prints
//! and parses exactly as decimal text with no floating point
//! ([`crate::fixed`]).
//!
//! Channels count from 1, as the radio and the README do (the receiver
//! crate's 0-based index is the value − 1).

use sensor_stack::mounting::Mounting;

/// A parameter's unit (a byte in the table, its text from [`Unit::as_str`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// A ratio or a count.
    None,
    /// Seconds per radian (a rate-loop P gain: torque per rad/s).
    SPerRad,
    /// Per radian (a rate-loop I gain: torque per rad).
    PerRad,
    /// Second² per radian (a rate-loop D gain: torque per rad/s²).
    S2PerRad,
    /// Per second.
    PerS,
    /// Degrees per second.
    DegPerS,
    /// Degrees.
    Deg,
    /// Hertz.
    Hz,
    /// Milliseconds.
    Ms,
    /// Seconds.
    S,
    /// Metres per second.
    MPerS,
    /// A receiver channel, counted from 1.
    Ch,
    /// Centivolts (0.01 V).
    CentiVolt,
}

impl Unit {
    /// As the console prints it (`""` for [`Unit::None`]).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::None => "",
            Self::SPerRad => "s/rad",
            Self::PerRad => "1/rad",
            Self::S2PerRad => "s2/rad",
            Self::PerS => "1/s",
            Self::DegPerS => "deg/s",
            Self::Deg => "deg",
            Self::Hz => "Hz",
            Self::Ms => "ms",
            Self::S => "s",
            Self::MPerS => "m/s",
            Self::Ch => "ch",
            Self::CentiVolt => "cV",
        }
    }
}

/// One entry of the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Param {
    /// Dotted name, as typed on the console (`rate.roll.p`).
    pub name: &'static str,
    /// Unit of the decimal value.
    pub unit: Unit,
    /// Digits after the decimal point: the stored integer is the value
    /// times 10^`decimals`.
    pub decimals: u8,
    /// Lowest value, scaled.
    pub min: i32,
    /// Highest value, scaled.
    pub max: i32,
    /// Value of a board with nothing saved, scaled.
    pub default: i32,
    /// One short line of help.
    pub help: &'static str,
}

impl Param {
    /// `true` if the scaled `value` is within `min..=max`.
    pub fn in_range(&self, value: i32) -> bool {
        value >= self.min && value <= self.max
    }
}

/// `true` if `code` is a `sensor_stack::Mounting` code of a proper
/// rotation (a signed axis permutation with determinant +1).
fn is_rotation(code: i32) -> bool {
    u16::try_from(code).is_ok_and(|c| Mounting::from_code(c).is_ok())
}

/// Declares [`ParamId`], [`TABLE`] and [`ParamId::ALL`] from one list, so
/// the three cannot disagree.
macro_rules! params {
    ($($id:ident: $name:literal, $unit:ident, $dec:literal, $min:literal, $max:literal,
       $default:literal, $help:literal;)*) => {
        /// A parameter: the index of its [`TABLE`] entry.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[repr(u8)]
        pub enum ParamId {
            $(
                #[doc = $help]
                $id,
            )*
        }

        /// Every entry, in [`ParamId`] order (which is also the order of the
        /// values in the flash record).
        pub static TABLE: [Param; COUNT] = [$(Param {
            name: $name,
            unit: Unit::$unit,
            decimals: $dec,
            min: $min,
            max: $max,
            default: $default,
            // The `no-help` build keeps the table but not the help text.
            help: if cfg!(feature = "no-help") { "" } else { $help },
        },)*];

        impl ParamId {
            /// Every parameter, in table order.
            pub const ALL: [ParamId; COUNT] = [$(ParamId::$id,)*];
        }
    };
}

/// Number of parameters.
pub const COUNT: usize = 44;

// Sources of the defaults (tested in `tests/defaults.rs`): the rate, level,
// stick, D-term, idle, failsafe and motor-test values are
// `settings::flight_config()`; the gyro filter is `settings::GYRO_FILTER`;
// the link timeout is `rc_input::CRSF_TIMEOUT_US`; the channels and the
// mounting are `firmware/src/config.rs`'s; the battery values and the trim
// are new (Betaflight's 3.5 V / 3.3 V per cell; no trim).
params! {
    RateRollP: "rate.roll.p", SPerRad, 4, 0, 20000, 2500, "roll rate P";
    RateRollI: "rate.roll.i", PerRad, 4, 0, 50000, 8000, "roll rate I";
    RateRollD: "rate.roll.d", S2PerRad, 4, 0, 1000, 45, "roll rate D";
    RatePitchP: "rate.pitch.p", SPerRad, 4, 0, 20000, 2500, "pitch rate P";
    RatePitchI: "rate.pitch.i", PerRad, 4, 0, 50000, 8000, "pitch rate I";
    RatePitchD: "rate.pitch.d", S2PerRad, 4, 0, 1000, 45, "pitch rate D";
    RateYawP: "rate.yaw.p", SPerRad, 4, 0, 20000, 5000, "yaw rate P";
    RateYawI: "rate.yaw.i", PerRad, 4, 0, 50000, 8000, "yaw rate I";
    RateYawD: "rate.yaw.d", S2PerRad, 4, 0, 1000, 0, "yaw rate D";
    LevelP: "level.p", PerS, 1, 1, 500, 120, "angle mode P";
    LevelMaxRate: "level.max_rate", DegPerS, 0, 10, 1000, 200, "angle mode max roll/pitch rate";
    LevelAngle: "level.angle", Deg, 0, 1, 80, 30, "angle mode tilt at full stick";
    LevelExpo: "level.expo", None, 2, 0, 100, 0, "angle mode stick expo";
    RatesRoll: "rates.roll", DegPerS, 0, 10, 2000, 500, "acro roll rate at full stick";
    RatesPitch: "rates.pitch", DegPerS, 0, 10, 2000, 500, "acro pitch rate at full stick";
    RatesYaw: "rates.yaw", DegPerS, 0, 10, 2000, 300, "yaw rate at full stick";
    ExpoRoll: "expo.roll", None, 2, 0, 100, 30, "roll stick expo";
    ExpoPitch: "expo.pitch", None, 2, 0, 100, 30, "pitch stick expo";
    ExpoYaw: "expo.yaw", None, 2, 0, 100, 30, "yaw stick expo";
    SticksDeadband: "sticks.deadband", None, 2, 0, 20, 2, "roll/pitch/yaw centre deadband";
    GyroLpf: "gyro.lpf", Hz, 0, 0, 449, 150, "gyro PT1 low-pass, 0 off";
    GyroNotch: "gyro.notch", Hz, 0, 0, 449, 200, "gyro notch centre, 0 off";
    GyroNotchQ: "gyro.notch_q", None, 2, 20, 2000, 200, "gyro notch Q";
    DtermLpf: "dterm.lpf", Hz, 0, 0, 449, 40, "roll/pitch D low-pass, 0 off";
    FailsafeTimeout: "failsafe.timeout", Ms, 0, 20, 1000, 100, "no frames this long: link lost";
    FailsafeHold: "failsafe.hold", S, 2, 1, 1000, 100, "level hold before descent";
    FailsafeDescent: "failsafe.descent", MPerS, 2, 10, 300, 50, "descent speed";
    FailsafeThrottle: "failsafe.throttle", None, 2, 20, 100, 60, "max collective, no altitude";
    RcRoll: "rc.roll", Ch, 0, 1, 16, 1, "roll stick channel";
    RcPitch: "rc.pitch", Ch, 0, 1, 16, 2, "pitch stick channel";
    RcYaw: "rc.yaw", Ch, 0, 1, 16, 4, "yaw stick channel";
    RcThrottle: "rc.throttle", Ch, 0, 1, 16, 3, "throttle channel";
    RcArm: "rc.arm", Ch, 0, 1, 16, 5, "arm switch channel (high arms)";
    RcMode: "rc.mode", Ch, 0, 1, 16, 6, "mode switch: low angle, mid alt, high acro";
    RcMotorTest: "rc.motor_test", Ch, 0, 1, 16, 7, "motor-test switch channel";
    BattScale: "batt.scale", None, 3, 3100, 24200, 11000, "pack volts per pin volt";
    BattWarn: "batt.warn_cv", CentiVolt, 0, 300, 400, 350, "warning, per cell";
    BattCrit: "batt.crit_cv", CentiVolt, 0, 280, 399, 330, "critical, per cell, below warn";
    BattCells: "batt.cells", None, 0, 0, 8, 0, "cells, 0 auto";
    ImuMount: "imu.mount", None, 0, 0, 511, 424, "mounting code, 424 face up x fwd";
    EscIdle: "esc.idle", None, 3, 0, 300, 50, "lowest motor command armed";
    EscTest: "esc.test", None, 3, 0, 200, 80, "motor-test command, PROPS OFF";
    TrimRoll: "trim.roll", Deg, 2, -1000, 1000, 0, "angle mode level trim, right down +";
    TrimPitch: "trim.pitch", Deg, 2, -1000, 1000, 0, "angle mode level trim, nose up +";
}

// Declared after the table: the macro cannot count, so the array length
// above is checked against the variants here.
const _: () = assert!(ParamId::ALL.len() == COUNT);

impl ParamId {
    /// Its table entry.
    pub fn param(self) -> &'static Param {
        // The enum's discriminants are 0..COUNT, the table's indices.
        &TABLE[self as usize]
    }

    /// Its index in [`TABLE`] and in the flash record.
    pub fn index(self) -> usize {
        self as usize
    }

    /// `true` if the scaled `value` is allowed: within the entry's range
    /// and, for [`ParamId::ImuMount`], a proper rotation.
    pub fn accepts(self, value: i32) -> bool {
        self.param().in_range(value) && (self != Self::ImuMount || is_rotation(value))
    }

    /// The parameter at `index`, if there is one.
    pub fn from_index(index: usize) -> Option<Self> {
        Self::ALL.get(index).copied()
    }

    /// The parameter called `name` (exact, case-sensitive).
    pub fn from_name(name: &[u8]) -> Option<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|id| same(id.param().name.as_bytes(), name))
    }
}

/// `a == b` by a byte loop (a slice comparison links `memcmp`).
pub(crate) fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x == y)
}

/// Why a value was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamError {
    /// Outside the entry's range (or, for the mounting, not a rotation).
    OutOfRange {
        /// The parameter.
        id: ParamId,
        /// Its lowest value, scaled.
        min: i32,
        /// Its highest value, scaled.
        max: i32,
    },
}

/// The values in use, one scaled integer per [`ParamId`], each within its
/// entry's range (the only way in is [`ParamSet::set`] and
/// [`ParamSet::from_values`], which check).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParamSet {
    values: [i32; COUNT],
}

impl Default for ParamSet {
    fn default() -> Self {
        Self::defaults()
    }
}

impl ParamSet {
    /// Every parameter at its default.
    pub fn defaults() -> Self {
        let mut values = [0; COUNT];
        for (v, p) in values.iter_mut().zip(TABLE.iter()) {
            *v = p.default;
        }
        Self { values }
    }

    /// The scaled value of `id`.
    pub fn get(&self, id: ParamId) -> i32 {
        self.values[id.index()]
    }

    /// Sets `id` to the scaled `value`. Errors: [`ParamError::OutOfRange`]
    /// (nothing changes).
    pub fn set(&mut self, id: ParamId, value: i32) -> Result<(), ParamError> {
        let p = id.param();
        if !id.accepts(value) {
            return Err(ParamError::OutOfRange {
                id,
                min: p.min,
                max: p.max,
            });
        }
        self.values[id.index()] = value;
        Ok(())
    }

    /// `true` if `id` holds its default.
    pub fn is_default(&self, id: ParamId) -> bool {
        self.get(id) == id.param().default
    }

    /// All values in table order (the flash record's payload).
    pub fn values(&self) -> &[i32; COUNT] {
        &self.values
    }

    /// A set from values in table order, each checked. Errors: the first
    /// value out of range.
    pub fn from_values(values: &[i32; COUNT]) -> Result<Self, ParamError> {
        let mut set = Self::defaults();
        for (id, &v) in ParamId::ALL.iter().zip(values.iter()) {
            set.set(*id, v)?;
        }
        Ok(set)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::fixed;

    #[test]
    fn every_entry_is_well_formed() {
        for (i, (id, p)) in ParamId::ALL.iter().zip(TABLE.iter()).enumerate() {
            assert_eq!(id.index(), i);
            assert_eq!(ParamId::from_index(i), Some(*id));
            assert!(p.min <= p.default && p.default <= p.max, "{}", p.name);
            assert!(id.accepts(p.default), "{}", p.name);
            assert!(
                p.decimals <= 4,
                "{}: the f32 conversion knows 0..=4",
                p.name
            );
            assert!(
                p.name.bytes().all(|b| b.is_ascii_lowercase()
                    || b.is_ascii_digit()
                    || b == b'.'
                    || b == b'_')
                    && p.name.contains('.'),
                "{}",
                p.name
            );
            assert!(
                p.help.len() <= 44 && (cfg!(feature = "no-help") || !p.help.is_empty()),
                "{}",
                p.name
            );
            assert_eq!(ParamId::from_name(p.name.as_bytes()), Some(*id));
        }
        for (i, a) in TABLE.iter().enumerate() {
            assert!(
                TABLE.iter().skip(i + 1).all(|b| b.name != a.name),
                "{} twice",
                a.name
            );
        }
        assert_eq!(ParamId::from_index(COUNT), None);
        assert_eq!(ParamId::from_name(b"rate.roll"), None);
        assert_eq!(ParamId::from_name(b"RATE.ROLL.P"), None);
    }

    #[test]
    fn set_checks_the_range_and_changes_nothing_on_error() {
        let mut set = ParamSet::defaults();
        assert_eq!(set.set(ParamId::RateRollP, 20_000), Ok(()));
        assert_eq!(set.get(ParamId::RateRollP), 20_000);
        let before = set;
        assert_eq!(
            set.set(ParamId::RateRollP, 20_001),
            Err(ParamError::OutOfRange {
                id: ParamId::RateRollP,
                min: 0,
                max: 20_000
            })
        );
        assert!(set.set(ParamId::TrimRoll, -1001).is_err());
        assert_eq!(set, before);
        assert!(!set.is_default(ParamId::RateRollP));
        assert!(set.is_default(ParamId::RateYawP));
    }

    #[test]
    fn the_mounting_takes_exactly_the_24_rotations() {
        let valid: std::vec::Vec<i32> = (0..=511)
            .filter(|&c| ParamId::ImuMount.accepts(c))
            .collect();
        assert_eq!(valid.len(), 24, "a cube's proper rotations");
        assert_eq!(
            i32::from(Mounting::FACE_UP_X_FORWARD.to_code()),
            ParamId::ImuMount.param().default
        );
        let mut set = ParamSet::defaults();
        assert!(
            set.set(ParamId::ImuMount, 0).is_err(),
            "every axis from x_mpu"
        );
    }

    #[test]
    fn every_value_of_every_range_prints_and_parses_back_exactly() {
        for p in TABLE.iter() {
            for v in p.min..=p.max {
                let t = fixed::format(v, p.decimals);
                assert_eq!(fixed::parse(t.as_bytes(), p.decimals), Ok(v), "{}", p.name);
            }
        }
    }
}
