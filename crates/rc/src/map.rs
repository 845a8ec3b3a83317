//! From channel pulse widths to pilot commands: which channel is which
//! stick, per-channel calibration, deadband, switches.

use crate::frame::{RcFrame, MAX_CHANNELS};
use crate::{ConfigError, MissingChannel};

/// The four stick functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Axis {
    /// Aileron: roll, +1 at full right stick (on a normal, unreversed radio).
    Roll,
    /// Elevator: pitch, +1 at full forward stick.
    Pitch,
    /// Rudder: yaw, +1 at full right stick.
    Yaw,
    /// Throttle, 0 at the low end, 1 at the high end.
    Throttle,
}

impl Axis {
    /// The four axes in the order used by per-axis arrays here.
    pub const ALL: [Axis; 4] = [Axis::Roll, Axis::Pitch, Axis::Yaw, Axis::Throttle];

    fn index(self) -> usize {
        match self {
            Axis::Roll => 0,
            Axis::Pitch => 1,
            Axis::Yaw => 2,
            Axis::Throttle => 3,
        }
    }
}

/// Which 0-based channel carries each stick.
///
/// Named after the letters radios use: A(ileron) = roll, E(levator) =
/// pitch, T(hrottle), R(udder) = yaw, in channel order. ExpressLRS and
/// Crossfire default to AETR; Futaba/Spektrum/JR radios often to TAER.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChannelOrder {
    /// Channel index of [`Axis::Roll`], [`Axis::Pitch`], [`Axis::Yaw`],
    /// [`Axis::Throttle`].
    channels: [u8; 4],
}

impl ChannelOrder {
    /// Roll, pitch, throttle, yaw on channels 1..4.
    pub const AETR: Self = Self {
        channels: [0, 1, 3, 2],
    };
    /// Throttle, roll, pitch, yaw on channels 1..4.
    pub const TAER: Self = Self {
        channels: [1, 2, 3, 0],
    };

    /// An order from explicit 0-based channel indices, which must be below
    /// 16 and distinct.
    pub fn new(roll: u8, pitch: u8, yaw: u8, throttle: u8) -> Result<Self, ConfigError> {
        let channels = [roll, pitch, yaw, throttle];
        for (i, &c) in channels.iter().enumerate() {
            if usize::from(c) >= MAX_CHANNELS {
                return Err(ConfigError::ChannelOutOfRange { channel: c });
            }
            if channels.iter().take(i).any(|&other| other == c) {
                return Err(ConfigError::DuplicateChannel { channel: c });
            }
        }
        Ok(Self { channels })
    }

    /// Parses a four-letter order such as `"AETR"` or `"taer"`: the letter
    /// at position n names the function of channel n + 1.
    ///
    /// ```
    /// use rc_input::ChannelOrder;
    /// assert_eq!(ChannelOrder::from_letters("AETR"), Ok(ChannelOrder::AETR));
    /// assert_eq!(ChannelOrder::from_letters("taer"), Ok(ChannelOrder::TAER));
    /// assert!(ChannelOrder::from_letters("AETT").is_err());
    /// ```
    pub fn from_letters(letters: &str) -> Result<Self, ConfigError> {
        let bytes = letters.as_bytes();
        if bytes.len() != 4 {
            return Err(ConfigError::BadChannelOrder);
        }
        let mut channels = [u8::MAX; 4];
        for (channel, &letter) in (0u8..).zip(bytes) {
            let axis = match letter.to_ascii_uppercase() {
                b'A' => Axis::Roll,
                b'E' => Axis::Pitch,
                b'R' => Axis::Yaw,
                b'T' => Axis::Throttle,
                _ => return Err(ConfigError::BadChannelOrder),
            };
            let slot = &mut channels[axis.index()];
            if *slot != u8::MAX {
                return Err(ConfigError::BadChannelOrder);
            }
            *slot = channel;
        }
        Ok(Self { channels })
    }

    /// 0-based channel index of `axis`.
    pub fn channel(&self, axis: Axis) -> u8 {
        self.channels[axis.index()]
    }
}

/// Calibrated pulse widths of one channel: the stick ends and centre, µs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChannelRange {
    /// Pulse width at the low/left/back stick end, µs.
    pub min_us: u16,
    /// Pulse width at rest (centre), µs. Unused for throttle.
    pub center_us: u16,
    /// Pulse width at the high/right/forward stick end, µs.
    pub max_us: u16,
}

impl ChannelRange {
    /// The nominal 1000/1500/2000 µs.
    pub const NOMINAL: Self = Self {
        min_us: 1000,
        center_us: 1500,
        max_us: 2000,
    };

    /// A range, validated: `800 ≤ min < center < max ≤ 2200` µs with at
    /// least 100 µs between the centre and each end.
    pub fn new(min_us: u16, center_us: u16, max_us: u16) -> Result<Self, ConfigError> {
        let ok = min_us >= 800
            && max_us <= 2200
            && center_us >= min_us.saturating_add(100)
            && max_us >= center_us.saturating_add(100);
        if ok {
            Ok(Self {
                min_us,
                center_us,
                max_us,
            })
        } else {
            Err(ConfigError::BadRange {
                min_us,
                center_us,
                max_us,
            })
        }
    }
}

impl Default for ChannelRange {
    fn default() -> Self {
        Self::NOMINAL
    }
}

/// Position of a two- or three-position switch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SwitchPosition {
    /// Below 1300 µs.
    Low,
    /// 1300..=1700 µs.
    Middle,
    /// Above 1700 µs.
    High,
}

impl SwitchPosition {
    /// Upper bound of [`SwitchPosition::Low`] (exclusive), µs.
    pub const LOW_BELOW_US: u16 = 1300;
    /// Lower bound of [`SwitchPosition::High`] (exclusive), µs.
    pub const HIGH_ABOVE_US: u16 = 1700;

    /// Decodes a pulse width. The thresholds sit 200 µs from the nominal
    /// 1000/1500/2000 µs positions, so trim and end-point differences between
    /// radios do not change the position.
    pub fn from_us(us: u16) -> Self {
        if us < Self::LOW_BELOW_US {
            Self::Low
        } else if us > Self::HIGH_ABOVE_US {
            Self::High
        } else {
            Self::Middle
        }
    }
}

/// Normalised stick positions.
// `control::shaping::Sticks` has the same fields on purpose: the receiver and the
// controllers do not depend on each other; `flight` converts between them.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sticks {
    /// −1..=1, +1 = full right.
    pub roll: f32,
    /// −1..=1, +1 = full forward.
    pub pitch: f32,
    /// −1..=1, +1 = full right.
    pub yaw: f32,
    /// 0..=1.
    pub throttle: f32,
}

/// Least stick travel the deadband must leave on each side of centre, µs.
const MIN_TRAVEL_US: u16 = 50;

/// Maps channel pulse widths to sticks and switches.
///
/// ```
/// use rc_input::{Axis, ChannelMap, ChannelOrder, ChannelRange, RcFrame};
///
/// let map = ChannelMap::new(ChannelOrder::from_letters("TAER")?)
///     .with_range(Axis::Throttle, ChannelRange::new(1100, 1500, 1900)?)?
///     .with_deadband_us(10)?
///     .with_arm_switch(4, rc_input::SwitchPosition::High)?;
/// let mut ch = [1500; 16];
/// ch[0] = 1100; // throttle low
/// ch[1] = 2000; // full right roll
/// ch[4] = 1950; // arm switch up
/// let frame = RcFrame::new(ch, 8);
/// let sticks = map.sticks(&frame)?;
/// assert_eq!((sticks.roll, sticks.throttle), (1.0, 0.0));
/// assert!(map.arm_switch(&frame)?);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChannelMap {
    order: ChannelOrder,
    ranges: [ChannelRange; 4],
    reversed: [bool; 4],
    deadband_us: u16,
    arm_channel: u8,
    arm_active: SwitchPosition,
}

impl Default for ChannelMap {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl ChannelMap {
    /// AETR, nominal ranges, 5 µs deadband, arm on channel 5 (index 4,
    /// "AUX1", which ExpressLRS always sends at full rate) in the high
    /// position.
    pub const DEFAULT: Self = Self {
        order: ChannelOrder::AETR,
        ranges: [ChannelRange::NOMINAL; 4],
        reversed: [false; 4],
        deadband_us: 5,
        arm_channel: 4,
        arm_active: SwitchPosition::High,
    };

    /// The default map with another channel order. The arm switch stays on
    /// the lowest channel the sticks leave free, 5 for any four-letter order.
    pub fn new(order: ChannelOrder) -> Self {
        let mut map = Self::DEFAULT;
        map.order = order;
        let free = (0u8..MAX_CHANNELS as u8).find(|c| !order.channels.contains(c) && *c >= 4);
        map.arm_channel = free.unwrap_or(4);
        map
    }

    /// Sets the calibration of one stick, checked against the deadband.
    pub fn with_range(mut self, axis: Axis, range: ChannelRange) -> Result<Self, ConfigError> {
        let range = ChannelRange::new(range.min_us, range.center_us, range.max_us)?;
        self.ranges[axis.index()] = range;
        self.check_deadband(self.deadband_us)?;
        Ok(self)
    }

    /// Reverses one stick (for a radio whose channel runs the other way).
    pub fn with_reversed(mut self, axis: Axis, reversed: bool) -> Self {
        self.reversed[axis.index()] = reversed;
        self
    }

    /// Sets the roll/pitch/yaw deadband around centre, µs. It must leave at
    /// least 50 µs of travel on each side.
    pub fn with_deadband_us(mut self, deadband_us: u16) -> Result<Self, ConfigError> {
        self.check_deadband(deadband_us)?;
        self.deadband_us = deadband_us;
        Ok(self)
    }

    /// Puts the arm switch on a 0-based channel that no stick uses; armed
    /// is requested when the switch is in `active`.
    pub fn with_arm_switch(
        mut self,
        channel: u8,
        active: SwitchPosition,
    ) -> Result<Self, ConfigError> {
        if usize::from(channel) >= MAX_CHANNELS {
            return Err(ConfigError::ChannelOutOfRange { channel });
        }
        if self.order.channels.contains(&channel) {
            return Err(ConfigError::DuplicateChannel { channel });
        }
        self.arm_channel = channel;
        self.arm_active = active;
        Ok(self)
    }

    fn check_deadband(&self, deadband_us: u16) -> Result<(), ConfigError> {
        let need = deadband_us.saturating_add(MIN_TRAVEL_US);
        let fits = self.ranges[..3]
            .iter()
            .all(|r| r.center_us - r.min_us >= need && r.max_us - r.center_us >= need);
        if fits {
            Ok(())
        } else {
            Err(ConfigError::DeadbandTooWide { deadband_us })
        }
    }

    /// The channel order.
    pub fn order(&self) -> &ChannelOrder {
        &self.order
    }

    /// The calibration of `axis`.
    pub fn range(&self, axis: Axis) -> &ChannelRange {
        &self.ranges[axis.index()]
    }

    /// The deadband, µs.
    pub fn deadband_us(&self) -> u16 {
        self.deadband_us
    }

    /// 0-based channel of the arm switch.
    pub fn arm_channel(&self) -> u8 {
        self.arm_channel
    }

    /// Pulse width of `channel`, or which channel the frame lacks.
    pub fn channel_us(frame: &RcFrame, channel: u8) -> Result<u16, MissingChannel> {
        frame
            .channel_us(usize::from(channel))
            .ok_or(MissingChannel {
                channel,
                count: frame.count,
            })
    }

    /// Normalised position of one stick.
    pub fn axis(&self, frame: &RcFrame, axis: Axis) -> Result<f32, MissingChannel> {
        let us = Self::channel_us(frame, self.order.channel(axis))?;
        let i = axis.index();
        let r = self.ranges[i];
        let value = if axis == Axis::Throttle {
            let span = f32::from(r.max_us - r.min_us);
            ((f32::from(us) - f32::from(r.min_us)) / span).clamp(0.0, 1.0)
        } else {
            self.centred(us, &r)
        };
        Ok(match (self.reversed[i], axis) {
            (false, _) => value,
            (true, Axis::Throttle) => 1.0 - value,
            (true, _) => -value,
        })
    }

    /// −1..=1 with the deadband removed and the remaining travel rescaled,
    /// so the output is continuous at the deadband's edge.
    fn centred(&self, us: u16, r: &ChannelRange) -> f32 {
        let d = i32::from(us) - i32::from(r.center_us);
        let db = i32::from(self.deadband_us);
        if d.abs() <= db {
            return 0.0;
        }
        let (travel, span) = if d > 0 {
            (d - db, i32::from(r.max_us - r.center_us) - db)
        } else {
            (d + db, i32::from(r.center_us - r.min_us) - db)
        };
        (travel as f32 / span as f32).clamp(-1.0, 1.0)
    }

    /// All four sticks.
    pub fn sticks(&self, frame: &RcFrame) -> Result<Sticks, MissingChannel> {
        Ok(Sticks {
            roll: self.axis(frame, Axis::Roll)?,
            pitch: self.axis(frame, Axis::Pitch)?,
            yaw: self.axis(frame, Axis::Yaw)?,
            throttle: self.axis(frame, Axis::Throttle)?,
        })
    }

    /// Position of the switch on `channel` (any aux channel).
    pub fn switch(frame: &RcFrame, channel: u8) -> Result<SwitchPosition, MissingChannel> {
        Self::channel_us(frame, channel).map(SwitchPosition::from_us)
    }

    /// Position of auxiliary switch `aux` in the radio's numbering: AUX1 is
    /// channel 5 (index 4), AUX12 channel 16. `aux` outside 1..=12 is
    /// reported as a missing channel.
    pub fn aux(frame: &RcFrame, aux: u8) -> Result<SwitchPosition, MissingChannel> {
        let channel = if (1..=12).contains(&aux) {
            aux + 3
        } else {
            u8::MAX
        };
        Self::switch(frame, channel)
    }

    /// Whether the arm switch is in its active position.
    pub fn arm_switch(&self, frame: &RcFrame) -> Result<bool, MissingChannel> {
        Ok(Self::switch(frame, self.arm_channel)? == self.arm_active)
    }
}
