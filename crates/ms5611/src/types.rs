//! Typed configuration: bus address, oversampling ratio, ADC channel.

use crate::command;

/// 7-bit I²C address, selected by the CSB pin.
///
/// The datasheet address is `111011Cx` where `C` is the *complement* of CSB:
/// CSB tied high gives 0x76, CSB low gives 0x77. Most GY-63 / GY-86
/// breakouts pull CSB low, hence the default 0x77.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Address {
    /// CSB = 1: address 0x76.
    CsbHigh,
    /// CSB = 0: address 0x77 (default).
    #[default]
    CsbLow,
}

impl Address {
    /// The 7-bit bus address.
    pub const fn addr(self) -> u8 {
        match self {
            Address::CsbHigh => 0x76,
            Address::CsbLow => 0x77,
        }
    }
}

impl From<Address> for u8 {
    fn from(a: Address) -> u8 {
        a.addr()
    }
}

/// ADC oversampling ratio: trades conversion time for resolution.
///
/// Conversion times are the datasheet *maximum* values; resolutions
/// (pressure RMS) are 0.065 / 0.042 / 0.027 / 0.018 / 0.012 mbar.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Osr {
    /// OSR 256: max 0.60 ms.
    Osr256,
    /// OSR 512: max 1.17 ms.
    Osr512,
    /// OSR 1024: max 2.28 ms.
    Osr1024,
    /// OSR 2048: max 4.54 ms.
    Osr2048,
    /// OSR 4096: max 9.04 ms (default; lowest noise).
    #[default]
    Osr4096,
}

impl Osr {
    /// Every ratio, smallest first.
    pub const ALL: [Osr; 5] = [
        Osr::Osr256,
        Osr::Osr512,
        Osr::Osr1024,
        Osr::Osr2048,
        Osr::Osr4096,
    ];

    /// Bits ORed into the conversion command (0x00, 0x02, ..., 0x08).
    pub const fn command_bits(self) -> u8 {
        match self {
            Osr::Osr256 => 0x00,
            Osr::Osr512 => 0x02,
            Osr::Osr1024 => 0x04,
            Osr::Osr2048 => 0x06,
            Osr::Osr4096 => 0x08,
        }
    }

    /// Maximum conversion time from the datasheet, µs. Reading the ADC
    /// earlier returns 0 *and corrupts the running conversion*.
    pub const fn conversion_time_us(self) -> u32 {
        match self {
            Osr::Osr256 => 600,
            Osr::Osr512 => 1_170,
            Osr::Osr1024 => 2_280,
            Osr::Osr2048 => 4_540,
            Osr::Osr4096 => command::MAX_CONVERSION_TIME_US,
        }
    }

    /// The oversampling ratio as a number (256..=4096).
    pub const fn ratio(self) -> u16 {
        match self {
            Osr::Osr256 => 256,
            Osr::Osr512 => 512,
            Osr::Osr1024 => 1024,
            Osr::Osr2048 => 2048,
            Osr::Osr4096 => 4096,
        }
    }
}

/// Which quantity an ADC conversion measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Channel {
    /// D1: digital pressure value.
    Pressure,
    /// D2: digital temperature value.
    Temperature,
}

impl Channel {
    /// The conversion command for this channel at `osr`
    /// (`0x40 | osr` for D1, `0x50 | osr` for D2).
    pub const fn convert_command(self, osr: Osr) -> u8 {
        let base = match self {
            Channel::Pressure => command::CONVERT_D1,
            Channel::Temperature => command::CONVERT_D2,
        };
        base | osr.command_bits()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_per_datasheet_table() {
        let d1: [u8; 5] = Osr::ALL.map(|o| Channel::Pressure.convert_command(o));
        let d2: [u8; 5] = Osr::ALL.map(|o| Channel::Temperature.convert_command(o));
        assert_eq!(d1, [0x40, 0x42, 0x44, 0x46, 0x48]);
        assert_eq!(d2, [0x50, 0x52, 0x54, 0x56, 0x58]);
    }

    #[test]
    fn conversion_times_increase_with_osr() {
        let t = Osr::ALL.map(Osr::conversion_time_us);
        assert_eq!(t, [600, 1170, 2280, 4540, 9040]);
        assert!(t.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(Osr::ALL.map(Osr::ratio), [256, 512, 1024, 2048, 4096]);
    }

    #[test]
    fn addresses() {
        assert_eq!(u8::from(Address::CsbHigh), 0x76);
        assert_eq!(u8::from(Address::CsbLow), 0x77);
        assert_eq!(Address::default().addr(), 0x77);
    }
}
