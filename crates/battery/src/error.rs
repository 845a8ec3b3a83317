//! The crate's one error type: a calibration reading or a setting that was
//! refused (nothing was changed).

use core::fmt;

/// A setting of [`Config`](crate::Config) or
/// [`DescentConfig`](crate::DescentConfig), named for [`Error::Setting`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Setting {
    /// `cells_override` not within 0..=[`MAX_CELLS`](crate::MAX_CELLS).
    CellsOverride,
    /// `max_cell_mv` not within 4000..=4500 mV.
    MaxCellVoltage,
    /// `warning_cell_mv` not within 3000..=4000 mV.
    WarningCellVoltage,
    /// `critical_cell_mv` not within 2800 mV..`warning_cell_mv`.
    CriticalCellVoltage,
    /// `warning_hold_ms` not within 100..=30 000 ms.
    WarningHold,
    /// `critical_hold_ms` not within 100..=30 000 ms.
    CriticalHold,
    /// `descent_mps_q16` not within 0.1..=3 m/s.
    DescentRate,
    /// `stick_deadband_q30` not within 0.05..=0.5.
    StickDeadband,
    /// `throttle_move_q30` not within 0.05..=0.5.
    ThrottleMove,
}

/// Why a calibration reading or a setting was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// The ADC reading is below
    /// [`MIN_CALIBRATION_COUNTS`](crate::MIN_CALIBRATION_COUNTS): one count
    /// would be more than 0.33 % of it (connect a charged pack).
    CountsTooLow {
        /// The rejected reading, counts.
        counts: u16,
    },
    /// The ADC reading is at or beyond the converter's last code (4095): the
    /// pin is at or over its reference and the voltage is unknown.
    CountsSaturated {
        /// The rejected reading, counts.
        counts: u16,
    },
    /// The scale is not within
    /// [`Scale::MIN_FULL_SCALE_MV`](crate::Scale::MIN_FULL_SCALE_MV)..=
    /// [`Scale::MAX_FULL_SCALE_MV`](crate::Scale::MAX_FULL_SCALE_MV)
    /// (a divider from about 3:1 to 24:1 on a 3.3 V reference).
    ScaleOutOfRange {
        /// The rejected scale: pack mV at 4096 counts (saturated at
        /// `u32::MAX`).
        full_scale_mv: u32,
    },
    /// A setting out of its range.
    Setting(Setting),
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::CellsOverride => "cell count override not within 0..=8 (0 = detect)",
            Self::MaxCellVoltage => "detection's cell voltage not within 4000..=4500 mV",
            Self::WarningCellVoltage => "warning cell voltage not within 3000..=4000 mV",
            Self::CriticalCellVoltage => {
                "critical cell voltage not within 2800 mV..the warning voltage"
            }
            Self::WarningHold => "warning hold time not within 100..=30000 ms",
            Self::CriticalHold => "critical hold time not within 100..=30000 ms",
            Self::DescentRate => "low-battery descent rate not within 0.1..=3 m/s",
            Self::StickDeadband => "override stick deadband not within 0.05..=0.5",
            Self::ThrottleMove => "override throttle move not within 0.05..=0.5",
        })
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::CountsTooLow { counts } => write!(
                f,
                "ADC reading {counts} below {} counts: too little to calibrate on",
                crate::MIN_CALIBRATION_COUNTS
            ),
            Self::CountsSaturated { counts } => {
                write!(f, "ADC reading {counts} saturated (pin at its reference)")
            }
            Self::ScaleOutOfRange { full_scale_mv } => write!(
                f,
                "scale {full_scale_mv} mV at full scale not within {}..={} mV",
                crate::Scale::MIN_FULL_SCALE_MV,
                crate::Scale::MAX_FULL_SCALE_MV
            ),
            Self::Setting(s) => write!(f, "{s}"),
        }
    }
}

impl core::error::Error for Error {}
