//! The monitor: one ADC reading per call at [`SAMPLE_RATE_HZ`] → the pack's
//! presence, cell count, raw and sag-filtered voltage, and the latched
//! level (the rules are in the [crate docs](crate)).

use crate::error::{Error, Setting};
use crate::sag::SagFilter;
use crate::scale::{Scale, ADC_MAX_COUNT};

/// The rate [`BatteryMonitor::update`] must be called at, Hz: the filter is
/// designed for it and the hold times count its samples.
pub const SAMPLE_RATE_HZ: u32 = 10;

/// One sample period, ms.
pub const SAMPLE_PERIOD_MS: u32 = 1000 / SAMPLE_RATE_HZ;

/// Below this pack voltage no battery is connected (a board on USB reads
/// about 0 V), mV: no cell count, no warnings. 2.5 V leaves a 1S pack's
/// loaded voltage above it.
pub const PRESENT_MV: u32 = 2500;

/// Consecutive present readings, spread at most [`STABLE_SPREAD_MV`], that
/// the cell count waits for after a connection (0.5 s at 10 Hz: the
/// connector's bounce and the divider's capacitor settle in it).
pub const SETTLE_SAMPLES: u8 = 5;

/// The most the settling readings may spread, mV (Betaflight's 0.2 V).
pub const STABLE_SPREAD_MV: u32 = 200;

/// Consecutive readings below [`PRESENT_MV`] that mean the pack was
/// disconnected (0.5 s at 10 Hz); fewer are a glitch and are skipped.
pub const ABSENT_SAMPLES: u8 = 5;

/// The most cells detected or set.
pub const MAX_CELLS: u8 = 8;

/// The battery settings (defaults: [`Config::DEFAULT`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// ADC counts → pack mV.
    pub scale: Scale,
    /// Cells in series; 0 = detect at connection (1..=[`MAX_CELLS`]).
    pub cells_override: u8,
    /// A full cell for the detection, mV (4000..=4500; 4300: a charged
    /// LiPo with margin; set 4400 for LiHV packs).
    pub max_cell_mv: u16,
    /// Warning below this filtered cell voltage, mV (3000..=4000; 3500).
    pub warning_cell_mv: u16,
    /// Critical below this filtered cell voltage, mV (2800..warning; 3300).
    pub critical_cell_mv: u16,
    /// How long the filtered cell voltage must stay below the warning
    /// threshold, ms (100..=30 000, rounded up to whole samples; 3000).
    pub warning_hold_ms: u16,
    /// How long below the critical threshold, ms (as the warning's; 3000).
    pub critical_hold_ms: u16,
}

impl Config {
    /// The defaults: 11:1 divider, cells detected, 4.30 V a full cell,
    /// warning 3.50 V and critical 3.30 V per cell, each held 3 s.
    pub const DEFAULT: Self = Self {
        scale: Scale::DEFAULT,
        cells_override: 0,
        max_cell_mv: 4300,
        warning_cell_mv: 3500,
        critical_cell_mv: 3300,
        warning_hold_ms: 3000,
        critical_hold_ms: 3000,
    };

    /// Checks every setting's range.
    ///
    /// # Errors
    /// [`Error::Setting`] naming the first setting out of range.
    pub fn check(&self) -> Result<(), Error> {
        let bad = |ok: bool, s: Setting| if ok { Ok(()) } else { Err(Error::Setting(s)) };
        bad(self.cells_override <= MAX_CELLS, Setting::CellsOverride)?;
        bad(
            (4000..=4500).contains(&self.max_cell_mv),
            Setting::MaxCellVoltage,
        )?;
        bad(
            (3000..=4000).contains(&self.warning_cell_mv),
            Setting::WarningCellVoltage,
        )?;
        bad(
            (2800..self.warning_cell_mv).contains(&self.critical_cell_mv),
            Setting::CriticalCellVoltage,
        )?;
        bad(
            (100..=30_000).contains(&self.warning_hold_ms),
            Setting::WarningHold,
        )?;
        bad(
            (100..=30_000).contains(&self.critical_hold_ms),
            Setting::CriticalHold,
        )
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The pack's state, lowest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Level {
    /// No pack, or one still settling: no cell count, no warnings.
    #[default]
    NoBattery,
    /// Connected, cells known, above the thresholds.
    Ok,
    /// The filtered cell voltage stayed below the warning threshold for the
    /// hold time; latched until the pack is disconnected.
    Warning,
    /// Below the critical threshold for its hold time; latched likewise.
    Critical,
}

/// Where the cell count came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CellSource {
    /// Detected at connection: voltage / max cell voltage + 1.
    Detected,
    /// [`Config::cells_override`].
    Configured,
}

/// Something the log should say once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// A pack settled and its cell count is set.
    Connected {
        /// Cells in series.
        cells: u8,
        /// Detected or set.
        source: CellSource,
        /// The settled voltage the count was taken from, mV.
        pack_mv: u32,
    },
    /// The level rose to [`Level::Warning`] or [`Level::Critical`].
    Raised(Level),
    /// The pack was disconnected (the latch is cleared).
    Disconnected,
}

/// What the monitor knows after a reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// The latched level.
    pub level: Level,
    /// The last reading as pack voltage, mV, unfiltered (telemetry).
    pub raw_mv: u32,
    /// The sag-filtered pack voltage, mV; 0 without a pack.
    pub filtered_mv: u32,
    /// Cells in series; 0 without a pack.
    pub cells: u8,
    /// The filtered voltage per cell, mV (what the thresholds compare);
    /// 0 without a pack.
    pub filtered_cell_mv: u32,
}

/// The detection's window: consecutive present readings since the last
/// restart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Window {
    n: u8,
    min_mv: u32,
    max_mv: u32,
    sum_counts: u32,
}

impl Window {
    fn start(mv: u32, counts: u16) -> Self {
        Self {
            n: 1,
            min_mv: mv,
            max_mv: mv,
            sum_counts: u32::from(counts),
        }
    }

    /// Adds a reading; restarts from it when the spread gets too wide.
    fn push(&mut self, mv: u32, counts: u16) {
        let (lo, hi) = (self.min_mv.min(mv), self.max_mv.max(mv));
        if hi - lo > STABLE_SPREAD_MV {
            *self = Self::start(mv, counts);
        } else {
            *self = Self {
                n: self.n.saturating_add(1),
                min_mv: lo,
                max_mv: hi,
                sum_counts: self.sum_counts + u32::from(counts),
            };
        }
    }
}

/// The pack's presence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Absent,
    Settling(Window),
    Present { cells: u8 },
}

/// The battery monitor (rules and numbers in the [crate docs](crate)).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BatteryMonitor {
    cfg: Config,
    warning_hold: u16,
    critical_hold: u16,
    filter: SagFilter,
    phase: Phase,
    raw_mv: u32,
    /// Consecutive readings below [`PRESENT_MV`] while present.
    absent_run: u8,
    below_warning: u16,
    below_critical: u16,
    level: Level,
}

/// Hold samples of a hold time: whole sample periods, rounded up.
fn hold_samples(ms: u16) -> u16 {
    ms.div_ceil(SAMPLE_PERIOD_MS as u16)
}

impl BatteryMonitor {
    /// A monitor with no pack seen yet.
    ///
    /// # Errors
    /// [`Error::Setting`] for a setting out of range ([`Config::check`]).
    pub fn new(cfg: Config) -> Result<Self, Error> {
        cfg.check()?;
        Ok(Self::unplugged(cfg, 0))
    }

    /// No pack, `cfg` already checked, the last reading `raw_mv`.
    fn unplugged(cfg: Config, raw_mv: u32) -> Self {
        Self {
            cfg,
            warning_hold: hold_samples(cfg.warning_hold_ms),
            critical_hold: hold_samples(cfg.critical_hold_ms),
            filter: SagFilter::new(SAMPLE_PERIOD_MS),
            phase: Phase::Absent,
            raw_mv,
            absent_run: 0,
            below_warning: 0,
            below_critical: 0,
            level: Level::NoBattery,
        }
    }

    /// New settings (a new scale from a calibration, thresholds from the
    /// console): the pack is taken as just connected, so its cell count is
    /// detected again under them and the level latch is cleared. Meant for
    /// the bench, disarmed.
    ///
    /// # Errors
    /// [`Error::Setting`]; the monitor is then unchanged.
    pub fn set_config(&mut self, cfg: Config) -> Result<(), Error> {
        *self = Self::new(cfg)?;
        Ok(())
    }

    /// The settings.
    #[must_use]
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// One ADC reading of the pack's divider (12-bit counts; beyond 4095 is
    /// taken as 4095), at [`SAMPLE_RATE_HZ`]. Returns the event the log
    /// should report, if any; [`status`](Self::status) has the rest.
    pub fn update(&mut self, adc_counts: u16) -> Option<Event> {
        let counts = adc_counts.min(ADC_MAX_COUNT);
        let mv = self.cfg.scale.counts_to_mv(counts);
        self.raw_mv = mv;
        let present = mv >= PRESENT_MV;
        match self.phase {
            Phase::Absent => {
                if present {
                    self.phase = Phase::Settling(Window::start(mv, counts));
                }
                None
            }
            Phase::Settling(mut w) if present => {
                w.push(mv, counts);
                self.phase = Phase::Settling(w);
                (w.n >= SETTLE_SAMPLES).then(|| self.connect(w))
            }
            Phase::Settling(_) => {
                self.phase = Phase::Absent;
                None
            }
            Phase::Present { cells } => self.update_present(counts, present, cells),
        }
    }

    /// The settled window's mean is the pack: cell count and the filter's
    /// start (from there, no false sag from a filter rising from zero).
    fn connect(&mut self, w: Window) -> Event {
        let n = u64::from(w.n.max(1));
        let mean_q16 = ((u64::from(w.sum_counts) << 16) + n / 2) / n;
        // ≤ 4095 · 2^16 < 2^31.
        self.filter.reset(mean_q16 as i32);
        let pack_mv = self.cfg.scale.counts_q16_to_mv(self.filter.output_q16());
        let (cells, source) = match self.cfg.cells_override {
            0 => (
                cells_from_mv(pack_mv, self.cfg.max_cell_mv),
                CellSource::Detected,
            ),
            n => (n, CellSource::Configured),
        };
        self.phase = Phase::Present { cells };
        self.level = Level::Ok;
        Event::Connected {
            cells,
            source,
            pack_mv,
        }
    }

    /// A reading with a pack connected: a reading below [`PRESENT_MV`] is
    /// a glitch (skipped: no filter, no hold count) until
    /// [`ABSENT_SAMPLES`] of them in a row mean a disconnection.
    fn update_present(&mut self, counts: u16, present: bool, cells: u8) -> Option<Event> {
        if !present {
            self.absent_run = self.absent_run.saturating_add(1);
            if self.absent_run >= ABSENT_SAMPLES {
                *self = Self::unplugged(self.cfg, self.raw_mv);
                return Some(Event::Disconnected);
            }
            return None;
        }
        self.absent_run = 0;
        self.filter.apply(i32::from(counts) << 16);
        self.update_level(cells)
    }

    /// Counts the samples below each threshold and raises the latched
    /// level when one reaches its hold.
    fn update_level(&mut self, cells: u8) -> Option<Event> {
        let cell_mv = self.filtered_mv() / u32::from(cells.max(1));
        let count = |run: u16, below: bool| if below { run.saturating_add(1) } else { 0 };
        self.below_warning = count(
            self.below_warning,
            cell_mv < u32::from(self.cfg.warning_cell_mv),
        );
        self.below_critical = count(
            self.below_critical,
            cell_mv < u32::from(self.cfg.critical_cell_mv),
        );
        let reached = if self.below_critical >= self.critical_hold {
            Level::Critical
        } else if self.below_warning >= self.warning_hold {
            Level::Warning
        } else {
            Level::Ok
        };
        if reached > self.level {
            self.level = reached;
            return Some(Event::Raised(reached));
        }
        None
    }

    /// The filtered pack voltage, mV (0 without a pack).
    fn filtered_mv(&self) -> u32 {
        match self.phase {
            Phase::Present { .. } => self.cfg.scale.counts_q16_to_mv(self.filter.output_q16()),
            _ => 0,
        }
    }

    /// What the monitor knows now.
    #[must_use]
    pub fn status(&self) -> Status {
        let cells = match self.phase {
            Phase::Present { cells } => cells,
            _ => 0,
        };
        let filtered_mv = self.filtered_mv();
        Status {
            level: self.level,
            raw_mv: self.raw_mv,
            filtered_mv,
            cells,
            filtered_cell_mv: filtered_mv / u32::from(cells.max(1)),
        }
    }

    /// The sag-filtered ADC reading, rounded to counts, with a pack
    /// connected (the steady reading [`scale_from_reading`] wants: let the
    /// pack rest a few time constants first); `None` without one.
    ///
    /// [`scale_from_reading`]: crate::scale_from_reading
    #[must_use]
    pub fn filtered_counts(&self) -> Option<u16> {
        match self.phase {
            Phase::Present { .. } => {
                u16::try_from((self.filter.output_q16() + (1 << 15)) >> 16).ok()
            }
            _ => None,
        }
    }
}

/// Betaflight's detection: pack mV / `max_cell_mv` (integer division) + 1,
/// limited to 1..=[`MAX_CELLS`]. Right for a charged or part-used pack; a
/// pack below `max_cell_mv · (n − 1) / n` per cell reads one cell short
/// (4S below 3.23 V per cell), a LiHV pack charged above `max_cell_mv` one
/// cell over.
#[must_use]
pub fn cells_from_mv(pack_mv: u32, max_cell_mv: u16) -> u8 {
    let n = pack_mv / u32::from(max_cell_mv.max(1)) + 1;
    n.clamp(1, u32::from(MAX_CELLS)) as u8
}
