//! Which feature group of the flash plan a piece of code belongs to, from a
//! demangled symbol name or from the source file the DWARF line table names.
//!
//! An [`Owner`] is a crate and its first module (`sensor_stack::pipeline`,
//! `core::fmt`); [`group_of`] maps it to a [`Group`]. The mapping is the
//! flash plan's (ARCHITECTURE.md, "Flash plan"): a module moved between
//! groups is moved here.

/// The feature groups the flash plan budgets, plus the bytes no symbol
/// covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Group {
    /// Sensor drivers, calibration, the AHRS and the sensor stack
    /// (`sensor_stack`).
    SensorsAhrs,
    /// The flight controller (`flight`) and the loops it calls (`control`).
    FlightControl,
    /// The pilot's receiver, the ESC outputs and the sensor bus driver.
    ReceiversOutputs,
    /// What a builder expects before a second flight, in the STM32F103CB
    /// build only: battery monitoring (`battery`, `firmware::adc`), CRSF
    /// telemetry (`rc_input::telemetry`, `firmware::crsf_tx`) and the
    /// settings (`params`, `firmware::console`, `firmware::rtt`).
    Builder,
    /// compiler_builtins (soft float), core (fmt, panics), defmt, RTIC,
    /// cortex-m, the HAL, libm: code the project does not write.
    Runtime,
    /// The firmware app (init, tasks, boot, clocks, report, watchdog) and
    /// any module not named in a group.
    Rest,
    /// Flashed bytes no symbol covers: alignment padding, anonymous
    /// `.rodata` (`.Lanon.*`: string literals, panic locations).
    Unattributed,
}

impl Group {
    /// Every group, in the table's order.
    pub const ALL: [Group; 7] = [
        Group::SensorsAhrs,
        Group::FlightControl,
        Group::ReceiversOutputs,
        Group::Builder,
        Group::Runtime,
        Group::Rest,
        Group::Unattributed,
    ];

    /// The group's name in tables.
    pub fn label(self) -> &'static str {
        match self {
            Group::SensorsAhrs => "sensors+AHRS",
            Group::FlightControl => "flight control",
            Group::ReceiversOutputs => "receivers/outputs",
            Group::Builder => "battery/telem/params",
            Group::Runtime => "runtime/libraries",
            Group::Rest => "rest (app)",
            Group::Unattributed => "unattributed",
        }
    }
}

/// A crate and its first module: the unit code is attributed to.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Owner {
    /// Crate name as in paths (`fc_ahrs`, `stm32f1xx_hal`).
    pub krate: String,
    /// First module below the crate root, or a placeholder (`lib`, `main`).
    pub module: String,
}

impl Owner {
    /// An owner from its two parts.
    pub fn new(krate: &str, module: &str) -> Owner {
        Owner {
            krate: krate.to_string(),
            module: module.to_string(),
        }
    }

    /// The owner's group.
    pub fn group(&self) -> Group {
        group_of(&self.krate, &self.module)
    }
}

impl std::fmt::Display for Owner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}::{}", self.krate, self.module)
    }
}

/// The project's crates; any other crate is a library (runtime group).
const WORKSPACE_CRATES: [&str; 12] = [
    "battery",
    "params",
    "mpu9250",
    "ak8963",
    "ms5611",
    "calibration",
    "fc_ahrs",
    "control",
    "flight",
    "sensor_stack",
    "rc_input",
    "firmware",
];

/// `firmware`'s modules of the builder's features (STM32F103CB build).
const FIRMWARE_BUILDER_MODULES: [&str; 5] = ["adc", "crsf_tx", "rtt", "console", "builder"];

/// `firmware`'s receiver, output and bus modules.
const FIRMWARE_IO_MODULES: [&str; 4] = ["receiver", "ppm", "outputs", "bus"];

/// The flash plan's group of `krate::module`.
pub fn group_of(krate: &str, module: &str) -> Group {
    match krate {
        "mpu9250" | "ak8963" | "ms5611" | "calibration" | "fc_ahrs" | "sensor_stack" => {
            Group::SensorsAhrs
        }
        "control" | "flight" => Group::FlightControl,
        "battery" | "params" => Group::Builder,
        "rc_input" if module == "telemetry" => Group::Builder,
        "rc_input" => Group::ReceiversOutputs,
        "firmware" if FIRMWARE_BUILDER_MODULES.contains(&module) => Group::Builder,
        "firmware" if FIRMWARE_IO_MODULES.contains(&module) => Group::ReceiversOutputs,
        // The compact memcpy/memset that replace compiler_builtins'.
        "firmware" if module == "mem" => Group::Runtime,
        k if WORKSPACE_CRATES.contains(&k) => Group::Rest,
        _ => Group::Runtime,
    }
}

/// The owner of a symbol from its demangled name (hash suffix removed).
///
/// Paths (`sensor_stack::pipeline::Pipeline::new`) give their first two parts;
/// trait impls (`<flight::x::T as core::fmt::Debug>::fmt`) the implementing
/// type's path, or the trait's when the type is not a path (`<&T as ..>`);
/// `core::ptr::drop_in_place<T>` its `T`. Names without a path are C-ABI
/// symbols: see [`c_symbol_owner`].
pub fn symbol_owner(demangled: &str) -> Owner {
    let name = demangled.trim();
    if let Some(inner) = name.strip_prefix('<') {
        let (self_ty, trait_path) = split_impl(inner);
        return path_owner(self_ty)
            .or_else(|| trait_path.and_then(path_owner))
            .unwrap_or_else(|| c_symbol_owner(name));
    }
    if let Some(arg) = name
        .strip_prefix("core::ptr::drop_in_place<")
        .and_then(|a| a.strip_suffix('>'))
    {
        if let Some(owner) = path_owner(arg) {
            return owner;
        }
    }
    path_owner(name).unwrap_or_else(|| c_symbol_owner(name))
}

/// `T as Trait>::f` → (`T`, `Trait`), at bracket depth 0.
fn split_impl(inner: &str) -> (&str, Option<&str>) {
    let mut depth = 0i32;
    for (i, c) in inner.char_indices() {
        match c {
            '<' | '[' | '(' => depth += 1,
            '>' | ']' | ')' if depth == 0 => return (&inner[..i], None),
            '>' | ']' | ')' => depth -= 1,
            ' ' if depth == 0 && inner[i..].starts_with(" as ") => {
                let rest = &inner[i + 4..];
                let end = rest.find('>').unwrap_or(rest.len());
                return (&inner[..i], Some(&rest[..end]));
            }
            _ => {}
        }
    }
    (inner, None)
}

/// The first two parts of a Rust path, if `s` is one (`a::b::..`); leading
/// `&`, `&mut `, `*const `, `*mut ` and `dyn ` are skipped.
fn path_owner(s: &str) -> Option<Owner> {
    let mut s = s.trim();
    for prefix in ["&mut ", "&", "*const ", "*mut ", "dyn "] {
        while let Some(rest) = s.strip_prefix(prefix) {
            s = rest.trim_start();
        }
    }
    let mut parts = s.split("::");
    let krate = parts.next()?;
    let module = parts.next()?;
    let ident = |p: &str| !p.is_empty() && p.chars().all(|c| c.is_alphanumeric() || c == '_');
    if !ident(krate) {
        return None;
    }
    // `T::f` inside `<..>`, or a module like `_<impl X for T>`: keep the crate.
    let module: String = module
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    let module = if module.is_empty() { "_impl" } else { &module };
    Some(Owner::new(krate, module))
}

/// Owners of the C-ABI symbols the firmware links: compiler_builtins'
/// `__aeabi_*`/`__*sf*` routines and `mem*`, cortex-m-rt's vector table and
/// handlers, defmt-rtt's control block; interrupt handlers (`USART1`,
/// `SPI2`: RTIC's bound tasks and software-task dispatchers) and `main`
/// belong to the firmware app.
pub fn c_symbol_owner(name: &str) -> Owner {
    const RT: [&str; 9] = [
        "Reset",
        "DefaultHandler",
        "DefaultHandler_",
        "HardFault",
        "HardFault_",
        "HardFaultTrampoline",
        "DefaultPreInit",
        "__pre_init",
        "__vector_table",
    ];
    if RT.contains(&name) || name.starts_with("__RESET") || name.contains("EXCEPTIONS") {
        return Owner::new("cortex_m_rt", "vectors");
    }
    if name == "__INTERRUPTS" {
        return Owner::new("cortex_m_rt", "vectors");
    }
    if name.starts_with("_SEGGER_RTT") || name.starts_with("_defmt") {
        return Owner::new("defmt_rtt", "rtt");
    }
    if name.starts_with("__") || name.starts_with("mem") {
        return Owner::new("compiler_builtins", "c");
    }
    let handler = name
        .chars()
        .all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_');
    if handler || name == "main" {
        return Owner::new("firmware", "app");
    }
    Owner::new("?", name)
}

/// The owner of a source file the DWARF line table names, or `None` if the
/// path is not recognised (the enclosing symbol's owner is used then).
///
/// Recognised: the Rust standard library (`…/library/core/src/fmt/mod.rs` →
/// `core::fmt`), registry crates (`…/stm32f1xx-hal-0.11.0/src/gpio.rs` →
/// `stm32f1xx_hal::gpio`), the workspace (`…/crates/ahrs/src/fixed.rs` →
/// `fc_ahrs::fixed`, `…/firmware/src/bus.rs` → `firmware::bus`).
pub fn file_owner(path: &str) -> Option<Owner> {
    // A leading `/` so that relative paths (`library/core/..`) match too.
    let path = format!("/{}", path.replace('\\', "/").trim_start_matches('/'));
    if let Some(i) = path.find("/library/") {
        let (krate, rest) = path[i + "/library/".len()..].split_once('/')?;
        return Some(Owner::new(
            &krate.replace('-', "_"),
            module_after_src(rest)?,
        ));
    }
    if let Some(i) = path.find("/registry/src/") {
        let rest = path[i + "/registry/src/".len()..].split_once('/')?.1;
        let (dir, rest) = rest.split_once('/')?;
        return Some(Owner::new(&crate_dir_name(dir), module_after_src(rest)?));
    }
    workspace_file_owner(&path)
}

/// The module a file path below a crate's folder names: the part after the
/// first `src/`, without `.rs` (`compiler-builtins/src/float/add.rs` →
/// `float`).
fn module_after_src(rest: &str) -> Option<&str> {
    let mut parts = rest.split('/').skip_while(|p| *p != "src").skip(1);
    Some(parts.next()?.trim_end_matches(".rs"))
}

/// `stm32f1xx-hal-0.11.0` → `stm32f1xx_hal`.
fn crate_dir_name(dir: &str) -> String {
    let name = match dir.rfind('-') {
        Some(i) if dir[i + 1..].starts_with(|c: char| c.is_ascii_digit()) => &dir[..i],
        _ => dir,
    };
    name.replace('-', "_")
}

/// A workspace file: `crates/<dir>/src/<module>` or `firmware/src/<module>`.
fn workspace_file_owner(path: &str) -> Option<Owner> {
    let (krate, rest) = if let Some(i) = path.rfind("/crates/") {
        let rest = &path[i + "/crates/".len()..];
        let (dir, rest) = rest.split_once('/')?;
        let krate = match dir {
            "ahrs" => "fc_ahrs",
            "rc" => "rc_input",
            "sensor-stack" => "sensor_stack",
            d => d,
        };
        (krate, rest)
    } else if let Some(i) = path.rfind("/firmware/src/") {
        ("firmware", &path[i + "/firmware/".len()..])
    } else {
        return None;
    };
    Some(Owner::new(krate, module_after_src(rest)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group(sym: &str) -> Group {
        symbol_owner(sym).group()
    }

    #[test]
    fn paths_by_crate_and_module() {
        assert_eq!(
            group("sensor_stack::pipeline::Pipeline::new"),
            Group::SensorsAhrs
        );
        assert_eq!(
            group("flight::flightctl::Shaped::new"),
            Group::FlightControl
        );
        assert_eq!(
            group("flight::motortest::MotorTest::step"),
            Group::FlightControl
        );
        assert_eq!(group("control::rateq::MixerQ::mix"), Group::FlightControl);
        assert_eq!(group("fc_ahrs::fixed::unit4"), Group::SensorsAhrs);
        assert_eq!(
            group("mpu9250::device::Mpu9250<DI>::init"),
            Group::SensorsAhrs
        );
        assert_eq!(group("rc_input::crc::LOW_NIBBLE"), Group::ReceiversOutputs);
        assert_eq!(group("firmware::bus::on_irq"), Group::ReceiversOutputs);
        assert_eq!(group("rc_input::telemetry::encode"), Group::Builder);
        assert_eq!(group("battery::monitor::Monitor::update"), Group::Builder);
        assert_eq!(group("params::table::TABLE"), Group::Builder);
        assert_eq!(group("firmware::crsf_tx::CrsfTx::send"), Group::Builder);
        assert_eq!(group("rtt_target::defmt::Logger"), Group::Runtime);
        assert_eq!(
            group("firmware::outputs::Esc::set"),
            Group::ReceiversOutputs
        );
        assert_eq!(group("firmware::boot::probe_sensors"), Group::Rest);
        assert_eq!(group("firmware::app::pilot_input"), Group::Rest);
        assert_eq!(group("firmware::mem::copy"), Group::Runtime);
        assert_eq!(group("core::fmt::write"), Group::Runtime);
        assert_eq!(
            group("compiler_builtins::float::add::__addsf3"),
            Group::Runtime
        );
        assert_eq!(group("stm32f1xx_hal::rcc::Cfgr::freeze"), Group::Runtime);
        assert_eq!(group("defmt::export::istr"), Group::Runtime);
        assert_eq!(group("sensor_stack::lib_item"), Group::SensorsAhrs);
        assert_eq!(group("flight::lib_item"), Group::FlightControl);
    }

    #[test]
    fn impls_by_their_type_then_trait() {
        let s = "<sensor_stack::health::Health as defmt::traits::Format>::format";
        assert_eq!(symbol_owner(s), Owner::new("sensor_stack", "health"));
        let s = "<&T as core::fmt::Debug>::fmt";
        assert_eq!(symbol_owner(s), Owner::new("core", "fmt"));
        let s = "<[f32; 3] as core::fmt::Debug>::fmt";
        assert_eq!(symbol_owner(s), Owner::new("core", "fmt"));
        let s = "<&mut control::loops::X as core::ops::Drop>::drop";
        assert_eq!(symbol_owner(s), Owner::new("control", "loops"));
        let s = "core::ptr::drop_in_place<rc_input::crsf::Parser>";
        assert_eq!(symbol_owner(s), Owner::new("rc_input", "crsf"));
        let s = "rtic_time::monotonic::_<impl rtic_time::Timebase for T>::delay::{{closure}}";
        assert_eq!(symbol_owner(s).krate, "rtic_time");
    }

    #[test]
    fn c_symbols() {
        assert_eq!(group("__aeabi_fmul"), Group::Runtime);
        assert_eq!(group("__addsf3"), Group::Runtime);
        assert_eq!(group("memcpy"), Group::Runtime);
        assert_eq!(group("__INTERRUPTS"), Group::Runtime);
        assert_eq!(group("__RESET_VECTOR"), Group::Runtime);
        assert_eq!(group("Reset"), Group::Runtime);
        assert_eq!(group("HardFaultTrampoline"), Group::Runtime);
        assert_eq!(group("_SEGGER_RTT"), Group::Runtime);
        assert_eq!(group("CAN_RX1"), Group::Rest);
        assert_eq!(group("I2C1_EV"), Group::Rest);
        assert_eq!(group("main"), Group::Rest);
    }

    #[test]
    fn files_by_crate_and_module() {
        let f = |p| file_owner(p).map(|o| o.to_string());
        assert_eq!(
            f("/rustc/abc123/library/core/src/fmt/mod.rs").as_deref(),
            Some("core::fmt")
        );
        assert_eq!(
            f("/root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/stm32f1xx-hal-0.11.0/src/gpio.rs")
                .as_deref(),
            Some("stm32f1xx_hal::gpio")
        );
        assert_eq!(
            f("/cargo/registry/src/index.crates.io-1949cf8c6b5b557f/compiler_builtins-0.1.160/src/float/add.rs")
                .as_deref(),
            Some("compiler_builtins::float")
        );
        assert_eq!(
            f("/w/crates/ahrs/src/fixed.rs").as_deref(),
            Some("fc_ahrs::fixed")
        );
        assert_eq!(
            f("/w/crates/rc/src/crsf.rs").as_deref(),
            Some("rc_input::crsf")
        );
        assert_eq!(
            f("/w/crates/sensor-stack/src/calmode.rs").as_deref(),
            Some("sensor_stack::calmode")
        );
        assert_eq!(
            f("/w/firmware/src/bus.rs").as_deref(),
            Some("firmware::bus")
        );
        assert_eq!(
            f("/w/firmware/src/main.rs").as_deref(),
            Some("firmware::main")
        );
        assert_eq!(
            f("/w/crates/control/src/loops/level.rs").as_deref(),
            Some("control::loops")
        );
        assert_eq!(
            f("library/compiler-builtins/compiler-builtins/src/float/cmp.rs").as_deref(),
            Some("compiler_builtins::float")
        );
        assert_eq!(
            f("library/core/src/ops/bit.rs").as_deref(),
            Some("core::ops")
        );
        assert_eq!(
            f("crates/control/src/pid.rs").as_deref(),
            Some("control::pid")
        );
        assert_eq!(f("<built-in>"), None);
    }
}
