//! Settings changed without a rebuild.
//!
//! * [`table`]: the parameter table ([`TABLE`], one entry per [`ParamId`]:
//!   name, unit, decimals, range, default, help) and the values in use
//!   ([`ParamSet`]).
//! * [`fixed`]: the values as exact decimal text (no floating point).
//! * [`console`]: the text console's commands (`get`, `set`, `save`,
//!   `defaults`, `dump`, `diff`, `help`), refused while armed where they
//!   change something.
//! * [`store`]: the record in the two flash pages `PARAMS_A`/`PARAMS_B`,
//!   versioned, CRC-checked and safe against a power cut at any point of a
//!   save; [`ram`]: a RAM model of the pages with injected power cuts.
//! * [`convert`]: the values as the firmware's configurations
//!   (`FlightConfig`, the gyro filter, the channel map, the mounting).
//!
//! ```
//! use params::console::{execute, LineBuf, Outcome};
//! use params::{ParamId, ParamSet};
//! let mut set = ParamSet::defaults();
//! let mut out = LineBuf::default();
//! let outcome = execute(b"set rate.roll.p 0.05", &mut set, false, &mut out);
//! assert_eq!(outcome, Outcome::Changed(ParamId::RateRollP));
//! assert_eq!(set.get(ParamId::RateRollP), 500); // 4 decimals
//! assert_eq!(out.as_bytes(), b"set rate.roll.p 0.0500\n");
//! ```
#![no_std]
#![deny(missing_docs)]

pub mod console;
pub mod convert;
pub mod fixed;
pub mod ram;
pub mod store;
pub mod table;

pub use table::{Param, ParamError, ParamId, ParamSet, COUNT, TABLE};
