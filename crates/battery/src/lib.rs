//! Battery monitoring without hardware access, `#![no_std]`, no heap,
//! integer arithmetic only (the STM32F103 has no FPU): the firmware reads
//! ADC1 on the pack's divider at [`SAMPLE_RATE_HZ`] (10 Hz, off the 1 kHz
//! path) and hands each 12-bit reading to [`BatteryMonitor::update`]; the
//! flight controller asks [`LowBatteryDescent::update`] what to do about
//! it. Nothing here touches a register.
//!
//! # Wiring and scale
//!
//! PA4 (ADC12_IN4; free on this board) through a divider: 10 kΩ from the
//! pack's + to PA4, 1 kΩ from PA4 to GND (11:1; a 100 nF capacitor from PA4
//! to GND keeps the source quiet for the ADC's sampling capacitor). On a
//! 3.3 V reference the converter's full scale is 36.3 V of pack
//! ([`Scale::DEFAULT`], 8.86 mV a count):
//!
//! | pack | voltage (3.0–4.2 V a cell) | PA4 | counts |
//! |---|---|---|---|
//! | 2S | 6.0–8.4 V | 0.55–0.76 V | 677–948 |
//! | 3S | 9.0–12.6 V | 0.82–1.15 V | 1016–1422 |
//! | 4S | 12.0–16.8 V | 1.09–1.53 V | 1354–1896 |
//! | 6S | 18.0–25.2 V | 1.64–2.29 V | 2031–2844 |
//!
//! (8S at 4.2 V, 33.6 V, still reads 3791.) The scale is a setting, the pack
//! mV at 4096 counts (u32, 10 000..=80 000 mV); [`scale_from_reading`] sets
//! it from the filtered reading ([`BatteryMonitor::filtered_counts`]) and
//! one multimeter reading of the pack at rest.
//!
//! # Rules
//!
//! * **Sag filter**: a first-order low-pass at 10 Hz (state in Q16 ADC
//!   counts) that falls with a 4 s time constant ([`SAG_FALL_TAU_MS`]) and
//!   rises with 0.5 s ([`SAG_RISE_TAU_MS`]): it follows the voltage at the
//!   lightest recent load, nearer the resting voltage, so a burst's sag
//!   counts only when it lasts and the recovery after it at once. Its
//!   output is what the thresholds compare. The raw reading is kept for
//!   telemetry ([`Status::raw_mv`]).
//! * **No battery**: below 2.5 V of pack ([`PRESENT_MV`]) there is no
//!   pack (a board on USB): [`Level::NoBattery`], no cell count, no
//!   warnings. While a pack is connected, readings below it are skipped as
//!   a glitch; 5 in a row (0.5 s, [`ABSENT_SAMPLES`]) are a disconnection.
//! * **Cell count**, once per connection: after 5 consecutive present
//!   readings within 0.2 V of each other (0.5 s; [`SETTLE_SAMPLES`],
//!   [`STABLE_SPREAD_MV`]) their mean gives cells = pack mV / 4300 mV + 1
//!   (integer division, Betaflight's rule, [`cells_from_mv`]), limited to
//!   1..=8; [`Config::cells_override`] (0 = detect) sets it instead. The
//!   filter starts from that mean. It is never detected again while the
//!   pack stays connected, in particular not at arming: a part-used pack
//!   misdetects (4S below 3.23 V a cell reads as 3S), and the voltage under
//!   load is lower still. Known misdetections at connection: a 4S pack
//!   below 3.23 V a cell (3S), a 3S LiHV pack charged to 4.35 V a cell (4S;
//!   set [`Config::max_cell_mv`] to 4400 or the override).
//! * **Levels**: warning when the filtered voltage per cell stays below
//!   3.50 V ([`Config::warning_cell_mv`]) for 3 s ([`Config::warning_hold_ms`],
//!   30 consecutive readings), critical below 3.30 V
//!   ([`Config::critical_cell_mv`]) for 3 s ([`Config::critical_hold_ms`]).
//!   A level once raised stays until the pack is disconnected (no
//!   hysteresis band to tune: a pack recovers by its sag when the load
//!   drops, 0.2 V a cell from the simulated quad's hover to rest, and
//!   clearing the level there would flicker the warning in flight and show
//!   a pack that needs changing as healthy before the next take-off).
//!   On the simulated quad's 3S pack (`sim::quad`, 1.9 V of sag at full
//!   throttle, 3.21 V a cell under load at half charge), a full-throttle
//!   burst from the hover raises nothing up to 4.7 s at half charge, 3.6 s
//!   at 30 %, and six 3 s bursts with 3 s of hover between them raise
//!   nothing from half charge; 6 s at half charge raises the warning
//!   (`tests/sim_pack.rs`). A pack at rest below 3.50 V a cell is warned
//!   3 s after it settles; in a hover running the pack down, each level
//!   comes about 7 s after the loaded voltage crosses its threshold (the
//!   falling filter's 4 s lag and the 3 s hold; 7.1 s and 6.6 s in the
//!   test). The holds are 3 s rather than 2 s because 2 s raises the
//!   warning in those repeated bursts (tested too).
//! * **Action** ([`battery_action`], [`LowBatteryDescent`]): warning →
//!   [`BatteryAction::Warn`]; critical, armed, in the air, with the
//!   barometer → [`BatteryAction::Descend`] at 0.5 m/s
//!   ([`DescentConfig::descent_mps_q16`]), continued after touch-down until
//!   the landing detector disarms; critical without the barometer, on the
//!   ground or disarmed → [`BatteryAction::Warn`] only. The pilot
//!   overrides the descent with a roll, pitch or yaw stick beyond 20 % of
//!   its deflection or the throttle moved by more than 20 % of its travel
//!   from where it was when the descent began: control goes back to the
//!   pilot for the rest of the flight (until disarmed), with the warning
//!   kept. A low battery never disarms (no action does).
//!
//! ```
//! use battery::{BatteryMonitor, Config, Event, Level};
//! let mut monitor = BatteryMonitor::new(Config::DEFAULT)?;
//! // A 4S pack at 15.2 V: 15 200 mV · 4096 / 36 300 mV = 1715 counts,
//! // which read back as 1715 · 36 300 / 4096 = 15 199 mV.
//! let mut event = None;
//! for _ in 0..5 {
//!     event = monitor.update(1715);
//! }
//! assert!(matches!(event, Some(Event::Connected { cells: 4, .. })));
//! assert_eq!(monitor.status().level, Level::Ok);
//! assert_eq!(monitor.status().filtered_mv, 15_199);
//! assert_eq!(monitor.status().filtered_cell_mv, 3799); // 15 199 / 4
//! # Ok::<(), battery::Error>(())
//! ```
#![no_std]
#![deny(missing_docs)]

mod action;
mod error;
mod monitor;
mod sag;
mod scale;

pub use action::{
    battery_action, BatteryAction, DescentConfig, DescentPhase, FlightContext, LowBatteryDescent,
    SticksQ30,
};
pub use error::{Error, Setting};
pub use monitor::{
    cells_from_mv, BatteryMonitor, CellSource, Config, Event, Level, Status, ABSENT_SAMPLES,
    MAX_CELLS, PRESENT_MV, SAMPLE_PERIOD_MS, SAMPLE_RATE_HZ, SETTLE_SAMPLES, STABLE_SPREAD_MV,
};
pub use sag::{SAG_FALL_TAU_MS, SAG_RISE_TAU_MS};
pub use scale::{
    scale_from_reading, Scale, ADC_FULL_SCALE_COUNTS, ADC_MAX_COUNT, MIN_CALIBRATION_COUNTS,
};
