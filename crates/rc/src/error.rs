//! Error types: configuration that does not make sense, and frames that
//! lack a channel the configuration needs.

use core::fmt;

/// A configuration was rejected; nothing was changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// A channel index is not below 16.
    ChannelOutOfRange {
        /// The rejected 0-based channel index.
        channel: u8,
    },
    /// Two functions (sticks, arm switch) were given the same channel.
    DuplicateChannel {
        /// The 0-based channel index used twice.
        channel: u8,
    },
    /// A channel order string is not a permutation of the letters A, E, T, R.
    BadChannelOrder,
    /// A calibration range is not `800 ≤ min < center < max ≤ 2200` µs with
    /// at least 100 µs on each side of the centre.
    BadRange {
        /// Lower stick end, µs.
        min_us: u16,
        /// Centre, µs.
        center_us: u16,
        /// Upper stick end, µs.
        max_us: u16,
    },
    /// The deadband leaves less than 50 µs of stick travel on a side.
    DeadbandTooWide {
        /// The rejected deadband, µs.
        deadband_us: u16,
    },
    /// PPM thresholds are not `0 < pulse_min < pulse_max < sync_min`.
    PpmThresholds {
        /// Shortest channel interval, µs.
        pulse_min_us: u32,
        /// Longest channel interval, µs.
        pulse_max_us: u32,
        /// Shortest sync gap, µs.
        sync_min_us: u32,
    },
    /// A link-loss timeout of zero.
    ZeroTimeout,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::ChannelOutOfRange { channel } => {
                write!(f, "channel index {channel} is out of range (0..=15)")
            }
            Self::DuplicateChannel { channel } => {
                write!(f, "channel index {channel} is assigned to two functions")
            }
            Self::BadChannelOrder => {
                f.write_str("channel order must be a permutation of A, E, T, R (e.g. \"AETR\")")
            }
            Self::BadRange {
                min_us,
                center_us,
                max_us,
            } => write!(
                f,
                "calibration range {min_us}/{center_us}/{max_us} us is not \
                 800 <= min < center < max <= 2200 with >= 100 us each side"
            ),
            Self::DeadbandTooWide { deadband_us } => {
                write!(
                    f,
                    "deadband {deadband_us} us leaves under 50 us of stick travel"
                )
            }
            Self::PpmThresholds {
                pulse_min_us,
                pulse_max_us,
                sync_min_us,
            } => write!(
                f,
                "PPM thresholds {pulse_min_us}/{pulse_max_us}/{sync_min_us} us are not \
                 0 < pulse_min < pulse_max < sync_min"
            ),
            Self::ZeroTimeout => f.write_str("link-loss timeout must be above 0 us"),
        }
    }
}

impl core::error::Error for ConfigError {}

/// A frame did not carry a channel the [`crate::ChannelMap`] reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MissingChannel {
    /// The 0-based channel index that was needed.
    pub channel: u8,
    /// How many channels the frame had.
    pub count: u8,
}

impl fmt::Display for MissingChannel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "frame has {} channels, channel index {} is needed",
            self.count, self.channel
        )
    }
}

impl core::error::Error for MissingChannel {}
