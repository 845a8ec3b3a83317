//! `--fault TIME:KIND[:ARG]`: the one fault syntax of `cargo sim` and
//! `cargo fil`, parsed here for both.
//!
//! TIME is seconds of simulated time (≥ 0): of the flight for `cargo sim`,
//! since power-on for the emulated board. KIND names a fault; some take
//! an ARG: a chip (`mpu`, `mag`, `baro`), a count, or a chip and a count
//! or id (`nack:mpu:50`, `wrong-id:mag:00`). Most kinds are faults of the
//! simulated chips and bus ([`Fault`]) and work on both rigs; a few are
//! the emulated board's own (its INT line, I2C1's errata, the RTT reader,
//! the button) and only `cargo fil` has them ([`Rig`]).
//!
//! ```
//! use sim::faults::{parse, FaultAction, Rig};
//! let f = parse("8:missing:mpu", Rig::Board).unwrap();
//! assert_eq!(f.at_s, 8.0);
//! assert_eq!(f.to_string(), "8:missing:mpu");
//! assert!(matches!(f.action(), FaultAction::Inject(_)));
//! assert!(parse("3:busy-lockup", Rig::Sim).is_err()); // the board's own
//! ```

use crate::bus::{magnet_pass, magnet_ride, Chip, Fault, AK8963_ADDRESS};
use crate::world::Vibration;
use std::fmt;

/// The MPU-9250's address (AD0 low, as on the board).
pub const MPU_ADDRESS: u8 = 0x68;
/// The MS5611's address (CSB low, as on the board).
pub const MS5611_ADDRESS: u8 = 0x77;

/// Which tool runs the faults.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rig {
    /// `cargo sim`: the simulated chips and bus only.
    Sim,
    /// `cargo fil`: the emulated board, its chips and bus and its own pins.
    Board,
}

/// What a kind's ARG is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArgKind {
    /// No ARG.
    None,
    /// A chip: `mpu`, `mag` or `baro`.
    Chip,
    /// A count `N` (0 .. 2³²−1).
    Count,
    /// A chip and a count: `CHIP:N`.
    ChipCount,
    /// A chip and an id byte in hex: `CHIP:ID`.
    ChipId,
    /// A dipole's distance (mm) and moment (µA·m²): `MM:UAM2`.
    Dipole,
}

impl ArgKind {
    /// The ARG as `--help` writes it.
    pub fn usage(self) -> &'static str {
        match self {
            Self::None => "",
            Self::Chip => ":CHIP",
            Self::Count => ":N",
            Self::ChipCount => ":CHIP:N",
            Self::ChipId => ":CHIP:ID",
            Self::Dipole => ":MM:UAM2",
        }
    }
}

/// The fault kinds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `missing:CHIP`.
    Missing,
    /// `nack:CHIP:N`.
    Nack,
    /// `chip-reset:CHIP`.
    ChipReset,
    /// `frozen:CHIP`.
    Frozen,
    /// `wrong-id:CHIP:ID`.
    WrongId,
    /// `mag-overflow`.
    MagOverflow,
    /// `stuck-bus`.
    StuckBus,
    /// `scl-stuck`.
    SclStuck,
    /// `sda-held:CHIP`.
    SdaHeld,
    /// `bus-error:N`.
    BusError,
    /// `arbitration:N`.
    Arbitration,
    /// `magnet`.
    Magnet,
    /// `magnet-ride`.
    MagnetRide,
    /// `dipole-ride:MM:UAM2`.
    DipoleRide,
    /// `vibration`.
    Vibration,
    /// `clear`.
    Clear,
    /// `busy-lockup` (board).
    BusyLockup,
    /// `spurious-berr` (board).
    SpuriousBerr,
    /// `imu-int-stops` (board).
    ImuIntStops,
    /// `imu-int-restored` (board).
    ImuIntRestored,
    /// `rtt-stops` (board).
    RttStops,
    /// `rtt-resumes` (board).
    RttResumes,
    /// `button-down` (board).
    ButtonDown,
    /// `button-up` (board).
    ButtonUp,
}

/// One fault kind: its name, ARG, which rigs have it and what it does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KindInfo {
    /// Which kind.
    pub kind: Kind,
    /// The name after `TIME:`.
    pub name: &'static str,
    /// What follows the name.
    pub arg: ArgKind,
    /// Only the emulated board (`cargo fil`) has it.
    pub board_only: bool,
    /// What it does, for `--help`.
    pub help: &'static str,
}

const fn kind(
    kind: Kind,
    name: &'static str,
    arg: ArgKind,
    board_only: bool,
    help: &'static str,
) -> KindInfo {
    KindInfo {
        kind,
        name,
        arg,
        board_only,
        help,
    }
}

/// Every fault kind, in `--help` order.
pub const KINDS: [KindInfo; 24] = [
    kind(Kind::Missing, "missing", ArgKind::Chip, false, "CHIP never answers (NACK) from TIME on"),
    kind(Kind::Nack, "nack", ArgKind::ChipCount, false, "the next N transfers to CHIP are not acknowledged"),
    kind(Kind::ChipReset, "chip-reset", ArgKind::Chip, false, "CHIP resets itself (registers back to power-on values)"),
    kind(Kind::Frozen, "frozen", ArgKind::Chip, false, "CHIP's data stop updating (data-ready keeps firing)"),
    kind(Kind::WrongId, "wrong-id", ArgKind::ChipId, false, "CHIP reports WHO_AM_I/WIA = ID (hex byte; the MS5611 has none)"),
    kind(Kind::MagOverflow, "mag-overflow", ArgKind::None, false, "every AK8963 sample reports magnetic overflow (HOFL)"),
    kind(Kind::StuckBus, "stuck-bus", ArgKind::None, false, "SDA held low: every transfer fails until `clear`"),
    kind(Kind::SclStuck, "scl-stuck", ArgKind::None, false, "SCL held low (a shorted line) until `clear`"),
    kind(Kind::SdaHeld, "sda-held", ArgKind::Chip, false, "CHIP is left mid-byte holding SDA low until SCL is clocked (as after a reset during a read); \
         on the board at TIME 0: held at power-up"),
    kind(Kind::BusError, "bus-error", ArgKind::Count, false, "one transfer fails with a bus error after N bytes"),
    kind(Kind::Arbitration, "arbitration", ArgKind::Count, false, "the next N transfers lose arbitration"),
    kind(Kind::Magnet, "magnet", ArgKind::None, false, "a magnet passes the board: 60 µT peak on body x, 4 s wide, peaking 2 s after TIME"),
    kind(Kind::MagnetRide, "magnet-ride", ArgKind::None, false, "a magnet ~5 cm away rides along: 30 µT body-fixed (20, -15, 15 on x, y, z), reached 2 s after TIME"),
    kind(Kind::DipoleRide, "dipole-ride", ArgKind::Dipole, false, "a magnetic dipole of UAM2 µA·m² rides MM mm to the board's right (body y; 5..=1000 mm), its moment \
         along (x + z)/√2: a body-fixed μ0/(4π)·m/r³ (0.1·m/r³ µT, m in A·m², r in m), reached 1 s after TIME; e.g. a 3 × 1 mm NdFeB disc, 6800 µA·m², at 60 mm: 3.1 µT"),
    kind(Kind::Vibration, "vibration", ArgKind::None, false, "unbalanced props from TIME on: 3 m/s² and 4 °/s at 85 Hz on every axis"),
    kind(Kind::Clear, "clear", ArgKind::None, false, "clears every persistent chip/bus fault (not sda-held: only the wire frees that)"),
    kind(Kind::BusyLockup, "busy-lockup", ArgKind::None, true, "errata ES096: I2C1's analog filter locks BUSY"),
    kind(Kind::SpuriousBerr, "spurious-berr", ArgKind::None, true, "errata ES096: a spurious bus error in master mode"),
    kind(Kind::ImuIntStops, "imu-int-stops", ArgKind::None, true, "the MPU-9250 INT line (PB5) stops"),
    kind(Kind::ImuIntRestored, "imu-int-restored", ArgKind::None, true, "... and works again"),
    kind(Kind::RttStops, "rtt-stops", ArgKind::None, true, "the host stops reading RTT (a closed cargo embed)"),
    kind(Kind::RttResumes, "rtt-resumes", ArgKind::None, true, "... and reads again"),
    kind(Kind::ButtonDown, "button-down", ArgKind::None, true, "the PA0 button is pressed"),
    kind(Kind::ButtonUp, "button-up", ArgKind::None, true, "... and released"),
];

/// What a fault does to a rig.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultAction {
    /// A fault of the simulated chips or bus: `SimBus::inject`.
    Inject(Fault),
    /// `SimBus::clear_faults`.
    Clear,
    /// One of the emulated board's own faults.
    Board(BoardAction),
}

/// The emulated board's own faults (`cargo fil` only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoardAction {
    /// Errata ES096: I2C1's analog filter locks BUSY.
    BusyLockup,
    /// Errata ES096: a spurious bus error in master mode.
    SpuriousBerr,
    /// The MPU-9250 INT line stops.
    ImuIntStops,
    /// The MPU-9250 INT line works again.
    ImuIntRestored,
    /// The host stops reading RTT.
    RttStops,
    /// The host reads RTT again.
    RttResumes,
    /// The PA0 button: `true` pressed.
    Button(bool),
}

/// The ARG of a parsed fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultArg {
    /// No ARG.
    None,
    /// A chip.
    Chip(Chip),
    /// A count.
    Count(u32),
    /// A chip and a count.
    ChipCount(Chip, u32),
    /// A chip and an id byte.
    ChipId(Chip, u8),
    /// A dipole's distance (mm) and moment (µA·m²).
    Dipole(u32, u32),
}

/// One `--fault`: when, which kind, its ARG.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaultSpec {
    /// Seconds of simulated time, finite and ≥ 0.
    pub at_s: f64,
    /// The kind (an entry of [`KINDS`]).
    pub kind: &'static KindInfo,
    /// Its ARG.
    pub arg: FaultArg,
}

/// The chip names of an ARG.
pub fn chip_name(chip: Chip) -> &'static str {
    match chip {
        Chip::Mpu9250 => "mpu",
        Chip::Ak8963 => "mag",
        Chip::Ms5611 => "baro",
    }
}

/// The chip's I2C address on the board.
pub fn chip_address(chip: Chip) -> u8 {
    match chip {
        Chip::Mpu9250 => MPU_ADDRESS,
        Chip::Ak8963 => AK8963_ADDRESS,
        Chip::Ms5611 => MS5611_ADDRESS,
    }
}

fn parse_chip(s: &str) -> Result<Chip, String> {
    match s {
        "mpu" | "imu" => Ok(Chip::Mpu9250),
        "mag" => Ok(Chip::Ak8963),
        "baro" => Ok(Chip::Ms5611),
        _ => Err(format!("unknown chip `{s}` (CHIP: mpu, mag, baro)")),
    }
}

fn parse_count(s: &str) -> Result<u32, String> {
    s.parse()
        .map_err(|_| format!("N `{s}` is not a count (0 .. 4294967295)"))
}

fn parse_distance_mm(s: &str) -> Result<u32, String> {
    s.parse()
        .ok()
        .filter(|mm| (5..=1000).contains(mm))
        .ok_or_else(|| format!("MM `{s}` is not a distance of 5..=1000 mm"))
}

fn parse_id(s: &str) -> Result<u8, String> {
    let hex = s
        .strip_prefix("0x")
        .or_else(|| s.strip_prefix("0X"))
        .unwrap_or(s);
    if hex.is_empty() || hex.starts_with('+') {
        return Err(format!("ID `{s}` is not a hex byte (e.g. 71 or 0x71)"));
    }
    u8::from_str_radix(hex, 16).map_err(|_| format!("ID `{s}` is not a hex byte (e.g. 71 or 0x71)"))
}

fn parse_time(s: &str) -> Result<f64, String> {
    s.parse::<f64>()
        .ok()
        .filter(|t| t.is_finite() && *t >= 0.0)
        .ok_or_else(|| format!("TIME `{s}` is not a number of seconds >= 0"))
}

/// The kinds `rig` has, comma-separated.
pub fn kind_names(rig: Rig) -> String {
    kinds(rig).map(|k| k.name).collect::<Vec<_>>().join(", ")
}

/// The kinds `rig` has.
pub fn kinds(rig: Rig) -> impl Iterator<Item = &'static KindInfo> {
    KINDS
        .iter()
        .filter(move |k| rig == Rig::Board || !k.board_only)
}

fn find_kind(name: &str, rig: Rig) -> Result<&'static KindInfo, String> {
    match KINDS.iter().find(|k| k.name == name) {
        Some(k) if k.board_only && rig == Rig::Sim => Err(format!(
            "`{name}` is a fault of the emulated board only (cargo fil); cargo sim's kinds: {}",
            kind_names(rig)
        )),
        Some(k) => Ok(k),
        None => Err(format!(
            "unknown fault kind `{name}` (one of {})",
            kind_names(rig)
        )),
    }
}

fn parse_arg(k: &KindInfo, args: &[&str]) -> Result<FaultArg, String> {
    let want = k.arg.usage();
    let n_want = want.matches(':').count();
    if args.len() < n_want {
        return Err(format!("{} needs its ARG: {}{want}", k.name, k.name));
    }
    if args.len() > n_want {
        let how = if n_want == 0 {
            "takes no ARG".to_string()
        } else {
            format!("takes {}{want}", k.name)
        };
        return Err(format!("{} {how}", k.name));
    }
    Ok(match (k.arg, args) {
        (ArgKind::Chip, [c]) => FaultArg::Chip(parse_chip(c)?),
        (ArgKind::Count, [n]) => FaultArg::Count(parse_count(n)?),
        (ArgKind::ChipCount, [c, n]) => FaultArg::ChipCount(parse_chip(c)?, parse_count(n)?),
        (ArgKind::ChipId, [c, id]) => FaultArg::ChipId(parse_chip(c)?, parse_id(id)?),
        (ArgKind::Dipole, [mm, m]) => FaultArg::Dipole(parse_distance_mm(mm)?, parse_count(m)?),
        _ => FaultArg::None,
    })
}

/// The old `cargo sim --fault KIND@T` names and what they are now.
const OLD_NAMES: [(&str, &str); 19] = [
    ("magnet", "magnet"),
    ("magnet-ride", "magnet-ride"),
    ("vibration", "vibration"),
    ("frozen-imu", "frozen:mpu"),
    ("frozen-mag", "frozen:mag"),
    ("frozen-baro", "frozen:baro"),
    ("mag-overflow", "mag-overflow"),
    ("nack-imu", "nack:mpu:50"),
    ("nack-mag", "nack:mag:50"),
    ("nack-baro", "nack:baro:50"),
    ("bus-error", "bus-error:2"),
    ("arbitration-loss", "arbitration:5"),
    ("stuck-bus", "stuck-bus"),
    ("scl-stuck", "scl-stuck"),
    ("holds-sda-imu", "sda-held:mpu"),
    ("wrong-id-mag", "wrong-id:mag:00"),
    ("reset-imu", "chip-reset:mpu"),
    ("reset-mag", "chip-reset:mag"),
    ("reset-baro", "chip-reset:baro"),
];

/// The error for the old `KIND@T` form, with the spec in the new one.
fn old_form(kind: &str, t: &str) -> String {
    let new = OLD_NAMES
        .iter()
        .find(|(old, _)| *old == kind)
        .map_or(kind, |(_, new)| new);
    format!("the KIND@T form is gone: write TIME:KIND[:ARG], e.g. `{t}:{new}`")
}

/// Parses `TIME:KIND[:ARG]` for `rig`. The error names what is wrong
/// (TIME, KIND, ARG) and quotes `spec`; the old `KIND@T` form gets an error
/// that shows the new one.
pub fn parse(spec: &str, rig: Rig) -> Result<FaultSpec, String> {
    let fail = |why: String| format!("--fault `{spec}`: {why}");
    if let Some((kind, t)) = spec.split_once('@') {
        return Err(fail(old_form(kind, t)));
    }
    let parts: Vec<&str> = spec.split(':').collect();
    let [time, kind, args @ ..] = parts.as_slice() else {
        let hint = match OLD_NAMES.iter().find(|(old, _)| *old == spec) {
            Some((_, new)) => format!(", e.g. `0:{new}`"),
            None if find_kind(spec, rig).is_ok() => format!(", e.g. `0:{spec}`"),
            None => String::new(),
        };
        return Err(fail(format!("expected TIME:KIND[:ARG]{hint}")));
    };
    let at_s = parse_time(time).map_err(fail)?;
    let kind = find_kind(kind, rig).map_err(fail)?;
    let arg = parse_arg(kind, args).map_err(fail)?;
    Ok(FaultSpec { at_s, kind, arg })
}

/// `parse(spec, Rig::Sim)`, for clap.
pub fn parse_sim(spec: &str) -> Result<FaultSpec, String> {
    parse(spec, Rig::Sim)
}

/// `parse(spec, Rig::Board)`, for clap.
pub fn parse_board(spec: &str) -> Result<FaultSpec, String> {
    parse(spec, Rig::Board)
}

impl fmt::Display for FaultSpec {
    /// The spec as [`parse`] reads it back.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.at_s, self.kind.name)?;
        match self.arg {
            FaultArg::None => Ok(()),
            FaultArg::Chip(c) => write!(f, ":{}", chip_name(c)),
            FaultArg::Count(n) => write!(f, ":{n}"),
            FaultArg::ChipCount(c, n) => write!(f, ":{}:{n}", chip_name(c)),
            FaultArg::ChipId(c, id) => write!(f, ":{}:{id:02x}", chip_name(c)),
            FaultArg::Dipole(mm, m) => write!(f, ":{mm}:{m}"),
        }
    }
}

impl FaultSpec {
    /// A `dipole-ride`'s field at the board (µT, body FRD): the dipole
    /// `MM` to the right, its moment along (x + z)/√2; zero for other kinds.
    pub fn dipole_field_body_ut(&self) -> crate::math::Vec3 {
        let FaultArg::Dipole(mm, uam2) = self.arg else {
            return [0.0; 3];
        };
        let m = 1e-6 * f64::from(uam2) * std::f64::consts::FRAC_1_SQRT_2;
        crate::physics::dipole_field_ut([m, 0.0, m], [0.0, 1e-3 * f64::from(mm), 0.0])
    }

    fn chip(&self) -> Chip {
        match self.arg {
            FaultArg::Chip(c) | FaultArg::ChipCount(c, _) | FaultArg::ChipId(c, _) => c,
            FaultArg::None | FaultArg::Count(_) | FaultArg::Dipole(..) => Chip::Mpu9250,
        }
    }

    fn count(&self) -> u32 {
        match self.arg {
            FaultArg::Count(n) | FaultArg::ChipCount(_, n) => n,
            FaultArg::ChipId(_, id) => u32::from(id),
            FaultArg::None | FaultArg::Chip(_) | FaultArg::Dipole(..) => 0,
        }
    }

    /// What the fault does to a rig.
    pub fn action(&self) -> FaultAction {
        let (chip, count) = (self.chip(), self.count());
        let fault = match self.kind.kind {
            Kind::Missing | Kind::Nack => Fault::Nack {
                address: chip_address(chip),
                transactions: (self.kind.kind == Kind::Nack).then_some(count),
            },
            Kind::ChipReset => Fault::ChipReset(chip),
            Kind::Frozen => Fault::Frozen(chip),
            Kind::WrongId => Fault::WrongChipId {
                chip,
                id: u8::try_from(count).unwrap_or(0),
            },
            Kind::MagOverflow => Fault::MagOverflow,
            Kind::StuckBus => Fault::StuckBus,
            Kind::SclStuck => Fault::SclStuckLow,
            Kind::SdaHeld => Fault::SlaveHoldsSda(chip),
            Kind::BusError => Fault::BusErrorMidTransfer {
                after_bytes: count as usize,
            },
            Kind::Arbitration => Fault::ArbitrationLoss {
                transactions: count,
            },
            Kind::Magnet => magnet_pass([60.0, 0.0, 0.0], self.at_s + 2.0, 4.0),
            Kind::MagnetRide => magnet_ride([20.0, -15.0, 15.0], self.at_s + 2.0, 4.0),
            Kind::DipoleRide => magnet_ride(self.dipole_field_body_ut(), self.at_s + 1.0, 1.0),
            Kind::Vibration => Fault::Vibration(Vibration {
                accel_amplitude_mps2: 3.0,
                gyro_amplitude_dps: 4.0,
                frequency_hz: 85.0,
            }),
            Kind::Clear => return FaultAction::Clear,
            board => return FaultAction::Board(board_action(board)),
        };
        FaultAction::Inject(fault)
    }
}

/// The board's own action for a board-only kind.
fn board_action(kind: Kind) -> BoardAction {
    match kind {
        Kind::BusyLockup => BoardAction::BusyLockup,
        Kind::SpuriousBerr => BoardAction::SpuriousBerr,
        Kind::ImuIntStops => BoardAction::ImuIntStops,
        Kind::ImuIntRestored => BoardAction::ImuIntRestored,
        Kind::RttStops => BoardAction::RttStops,
        Kind::RttResumes => BoardAction::RttResumes,
        Kind::ButtonDown => BoardAction::Button(true),
        // `ButtonUp`; the chip and bus kinds never come here.
        _ => BoardAction::Button(false),
    }
}

/// The `--help` text listing the kinds `rig` has.
pub fn help(rig: Rig) -> String {
    let (tool, time) = match rig {
        Rig::Sim => ("sim", "seconds of flight"),
        Rig::Board => ("fil", "simulated seconds since power-on"),
    };
    let mut s = format!(
        "Faults: --fault TIME:KIND[:ARG] (repeatable; TIME in {time}; CHIP: mpu, mag, baro; \
         persistent faults last until `clear` or the end):\n"
    );
    for k in kinds(rig) {
        let usage = format!("{}{}", k.name, k.arg.usage());
        s.push_str(&format!("  {usage:<20} {}\n", k.help));
    }
    s.push_str(&format!(
        "Example: cargo {tool} --fault 3:chip-reset:mpu --fault 5:nack:baro:200"
    ));
    s
}

impl FaultSpec {
    /// Applies a chip, bus or `clear` fault to `bus`; a board-only fault is
    /// an error (the simulator has no board).
    pub fn apply_to_bus(&self, bus: &crate::SimBus) -> Result<(), String> {
        match self.action() {
            FaultAction::Inject(f) => bus.inject(f),
            FaultAction::Clear => bus.clear_faults(),
            FaultAction::Board(_) => {
                return Err(format!(
                    "fault `{self}`: a fault of the emulated board only (cargo fil)"
                ))
            }
        }
        Ok(())
    }
}

/// Faults waiting for their time, earliest first (ties in the order given).
#[derive(Clone, Debug, Default)]
pub struct FaultSchedule {
    pending: std::collections::VecDeque<FaultSpec>,
}

impl FaultSchedule {
    /// `specs` in time order.
    pub fn new(specs: &[FaultSpec]) -> Self {
        let mut v = specs.to_vec();
        v.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        Self { pending: v.into() }
    }

    /// The next fault due at or before `now_s`, taken off the schedule.
    pub fn next_due(&mut self, now_s: f64) -> Option<FaultSpec> {
        if self.pending.front()?.at_s <= now_s {
            self.pending.pop_front()
        } else {
            None
        }
    }

    /// When the next fault is due (s).
    pub fn next_at_s(&self) -> Option<f64> {
        self.pending.front().map(|f| f.at_s)
    }

    /// Applies every fault due by `now_s` to `bus`, saying each with `say`.
    pub fn apply_due(
        &mut self,
        now_s: f64,
        bus: &crate::SimBus,
        mut say: impl FnMut(&FaultSpec),
    ) -> Result<(), String> {
        while let Some(f) = self.next_due(now_s) {
            say(&f);
            f.apply_to_bus(bus)?;
        }
        Ok(())
    }
}
