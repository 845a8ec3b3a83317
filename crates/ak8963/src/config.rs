//! Typed configuration: operating mode and output resolution (CNTL1).

use crate::register as reg;

/// Operating mode (CNTL1 MODE). Fuse-ROM access and self-test are used
/// internally by [`Ak8963::init`](crate::Ak8963::init) and
/// [`Ak8963::self_test`](crate::Ak8963::self_test).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// 0000: power-down.
    PowerDown,
    /// 0001: one measurement, then back to power-down by itself.
    Single,
    /// 0010: continuous measurement mode 1, 8 Hz.
    Continuous8Hz,
    /// 0110: continuous measurement mode 2, 100 Hz.
    #[default]
    Continuous100Hz,
    /// 0100: one measurement per rising edge on TRG (not wired on most MPU-9250 boards).
    ExternalTrigger,
}

impl Mode {
    /// CNTL1 MODE field value.
    pub const fn bits(self) -> u8 {
        match self {
            Mode::PowerDown => reg::MODE_POWER_DOWN,
            Mode::Single => reg::MODE_SINGLE,
            Mode::Continuous8Hz => reg::MODE_CONTINUOUS_1,
            Mode::Continuous100Hz => reg::MODE_CONTINUOUS_2,
            Mode::ExternalTrigger => reg::MODE_EXTERNAL_TRIGGER,
        }
    }

    /// Output data rate in Hz for the continuous modes, `None` otherwise.
    pub const fn data_rate_hz(self) -> Option<u8> {
        match self {
            Mode::Continuous8Hz => Some(8),
            Mode::Continuous100Hz => Some(100),
            _ => None,
        }
    }
}

/// Output resolution (CNTL1 BIT).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Resolution {
    /// 14-bit output, 0.6 µT/LSB, data range −8190..=8190.
    Bits14,
    /// 16-bit output, 0.15 µT/LSB, data range −32760..=32760.
    #[default]
    Bits16,
}

impl Resolution {
    /// CNTL1 BIT value (already shifted).
    pub const fn bits(self) -> u8 {
        match self {
            Resolution::Bits14 => 0,
            Resolution::Bits16 => reg::CNTL1_BIT,
        }
    }

    /// Sensitivity in µT per LSB (datasheet: 0.6 or 0.15).
    pub const fn ut_per_lsb(self) -> f32 {
        match self {
            Resolution::Bits14 => 0.6,
            Resolution::Bits16 => 0.15,
        }
    }

    /// Sensitivity in nT per LSB, exact integer (600 or 150).
    pub const fn nt_per_lsb(self) -> u16 {
        match self {
            Resolution::Bits14 => 600,
            Resolution::Bits16 => 150,
        }
    }
}

/// Driver configuration. Default: continuous mode 2 (100 Hz), 16-bit
/// (CNTL1 = 0x16).
///
/// ```
/// use ak8963::{Config, Mode, Resolution};
/// assert_eq!(Config::default().cntl1(), 0x16);
/// let c = Config::new().mode(Mode::Continuous8Hz).resolution(Resolution::Bits14);
/// assert_eq!(c.cntl1(), 0x02);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Operating mode.
    pub mode: Mode,
    /// Output resolution.
    pub resolution: Resolution,
}

impl Default for Config {
    fn default() -> Self {
        Self::new()
    }
}

impl Config {
    /// Continuous 100 Hz, 16-bit.
    pub const fn new() -> Self {
        Self {
            mode: Mode::Continuous100Hz,
            resolution: Resolution::Bits16,
        }
    }

    /// Set the mode.
    #[must_use]
    pub const fn mode(mut self, mode: Mode) -> Self {
        self.mode = mode;
        self
    }

    /// Set the resolution.
    #[must_use]
    pub const fn resolution(mut self, resolution: Resolution) -> Self {
        self.resolution = resolution;
        self
    }

    /// CNTL1 register value.
    pub const fn cntl1(&self) -> u8 {
        self.resolution.bits() | self.mode.bits()
    }

    /// Whether a CNTL1 value read back agrees with this configuration. In
    /// single mode the chip returns to power-down by itself after the
    /// measurement, so MODE may read 0001 or 0000 there.
    pub const fn cntl1_matches(&self, found: u8) -> bool {
        let expected = self.cntl1();
        if matches!(self.mode, Mode::Single) {
            found == expected || found == self.resolution.bits() | reg::MODE_POWER_DOWN
        } else {
            found == expected
        }
    }
}
