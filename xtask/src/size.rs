//! `cargo xtask size [ELF] [--top N] [--modules]`: the firmware's flash and
//! static RAM against the budgets, every flashed byte attributed to a
//! feature group against the group's budget, and the flash plan's code
//! region (ARCHITECTURE.md, "Flash plan").

use crate::attrib::{attribute, Attribution};
use crate::classify::Group;
use crate::{elf_sizes, say, target_dir, Sizes};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Static RAM (.data + .bss + .uninit) budget; the stack takes the rest.
pub const RAM_BUDGET: u64 = 12 * 1024;
/// The flash plan's code region when the ELF does not name it
/// (`_flash_plan_code_end` in `memory.x`): 60 KiB.
pub const PLAN_CODE_REGION: u64 = 60 * 1024;
/// The flight builds' budget: 59.875 KiB, leaving 128 B of the code
/// region. The flash plan's aim was 58 KiB (2 KiB left): met at 59,192 B;
/// the log in words with its numbers' precision then took 392 B of the
/// reserve, the AHRS's multirotor mode (the drag model with its input
/// low-pass, and the flight controller's in-flight verdict it waits for)
/// 980 B, the rate loop's gyro filters (a PT1 and a notch per axis, fixed
/// point, designed at build time) and the integrals' hold at a low
/// collective 660 B. What comes next (the builder's
/// battery, telemetry and settings) does not fit this region: ARCHITECTURE.md
/// "Flash plan".
pub const DEFAULT_BUILD_TARGET: u64 = 59 * 1024 + 896;

/// A feature group's flash budget.
#[derive(Debug, Clone, Copy)]
pub struct GroupBudget {
    /// The group.
    pub group: Group,
    /// Flash bytes allowed.
    pub bytes: u64,
    /// Measured value and margin it was set from.
    pub note: &'static str,
}

/// Budgets of the flight builds (default CRSF and `ppm`), set from the
/// default build measured on 2026-11-27 (the flight controller's per-sample
/// path in fixed point, the calibration sessions in the calibration build,
/// the log in words with two or three decimals: 59,592 B; with the AHRS's
/// multirotor mode 60,572 B; with the gyro filters and the integrals' hold
/// 61,232 B; the fixed filter's reference following left out and the
/// tilt loop's hand-held form in, 60,812 B) plus the margin noted; they sum
/// to 61,010 B of the region's 61,440 B.
pub const FLIGHT_BUDGETS: [GroupBudget; 7] = [
    GroupBudget {
        group: Group::SensorsAhrs,
        bytes: 27830,
        note: "measured 27,796 (PPM the same) + 34 (no calibration session; the AHRS's multirotor drag model; the gyro filters; the tilt loop's hand-held form; the fixed filter's reference following is a feature the firmware leaves out: 28,234 before)",
    },
    GroupBudget {
        group: Group::FlightControl,
        bytes: 10180,
        note: "measured 10,144 + 36 (the rate loop's integrals held at a low collective)",
    },
    GroupBudget {
        group: Group::ReceiversOutputs,
        bytes: 5120,
        note: "measured 5,086 (CRSF; PPM 4,180) + 34",
    },
    GroupBudget {
        group: Group::Builder,
        bytes: 0,
        note: "none: the STM32F103CB build's (`--features f103cb`)",
    },
    GroupBudget {
        group: Group::Runtime,
        bytes: 9030,
        note: "measured 8,994 + 36",
    },
    GroupBudget {
        group: Group::Rest,
        bytes: 6590,
        note: "measured 6,577 + 13 (6.4 KiB)",
    },
    GroupBudget {
        group: Group::Unattributed,
        bytes: 2260,
        note: "measured 2,225 (PPM 2,237) + 23",
    },
];

/// Budgets of the calibration build (`--features calibrate`: the
/// six-position and ellipsoid sessions and the save, no flight controller).
pub const CALIBRATION_BUDGETS: [GroupBudget; 7] = [
    GroupBudget {
        group: Group::SensorsAhrs,
        bytes: 36400,
        note: "measured 36,372 + 28: the six-position and ellipsoid sessions (the fit 5.9 KiB, with the centre's standard error; refusals with their reason); 506 B less than before the fixed filter's reference following became a feature the firmware leaves out",
    },
    GroupBudget {
        group: Group::FlightControl,
        bytes: 2086,
        note: "measured 2,084 + 2: no flight controller",
    },
    GroupBudget {
        group: Group::ReceiversOutputs,
        bytes: 5042,
        note: "measured 5,040 + 2",
    },
    GroupBudget {
        group: Group::Builder,
        bytes: 0,
        note: "none",
    },
    GroupBudget {
        group: Group::Runtime,
        bytes: 9240,
        note: "measured 9,238 + 2",
    },
    GroupBudget {
        group: Group::Rest,
        bytes: 5950,
        note: "measured 5,934 + 16 (the STM32F103CB build's console and rate-log locals, units here, cost RTIC 6 B)",
    },
    GroupBudget {
        group: Group::Unattributed,
        bytes: 2290,
        note: "measured 2,270 + 20 (the group budgets sum to 61,008 B of the 61,440 B region; the AHRS's multirotor mode and the gyro filter are left out, `fc-ahrs/no-multirotor`, `sensor-stack/no-gyro-filter`)",
    },
];

/// The STM32F103CB build's budgets (`--features f103cb`: the flight build
/// plus battery monitoring, CRSF telemetry and the settings console),
/// set from the build measured on 2026-11-27 (97,820 B) plus the margin
/// noted.
pub const CB_BUDGETS: [GroupBudget; 7] = [
    GroupBudget {
        group: Group::SensorsAhrs,
        bytes: 28_600,
        note: "measured 28,376 + 224",
    },
    GroupBudget {
        group: Group::FlightControl,
        bytes: 21_500,
        note: "measured 21,274 + 226: the controller designed at boot from the settings (the C8's is folded at build time: +10.9 KiB), the low-battery descent",
    },
    GroupBudget {
        group: Group::ReceiversOutputs,
        bytes: 5_950,
        note: "measured 5,792 + 158: the channel map and link timeout from the settings",
    },
    GroupBudget {
        group: Group::Builder,
        bytes: 11_900,
        note: "measured 11,618 + 282: params 6.8 KiB (table, console, storage, conversions and the save's check), telemetry 1.0, battery 1.4, the firmware's modules 2.1",
    },
    GroupBudget {
        group: Group::Runtime,
        bytes: 16_000,
        note: "measured 15,758 + 242: rtt-target (defmt's logger with the console's down channel); soft float (f32 and f64) and 64-bit division for the designs at boot",
    },
    GroupBudget {
        group: Group::Rest,
        bytes: 9_850,
        note: "measured 9,485 + 365",
    },
    GroupBudget {
        group: Group::Unattributed,
        bytes: 5_750,
        note: "measured 5,517 + 233: the table's names and help text, the console's messages",
    },
];

/// The STM32F103CB build's target: the sum of [`CB_BUDGETS`], leaving
/// 26.8 KiB of its 124 KiB code region for what comes next.
pub const CB_BUILD_TARGET: u64 = 99_550;

/// Which build an ELF is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Build {
    /// The C8's flight build (default CRSF, or `ppm`).
    Flight,
    /// The C8's calibration build (`calibrate`).
    Calibration,
    /// The STM32F103CB build (`f103cb`).
    Cb,
}

impl Build {
    /// The build of an attributed ELF: the calibration build by what it
    /// links (the same code on either chip: `f103cb` + `calibrate` is the
    /// C8's calibration build on the CB's layout), the CB's flight build by
    /// its flash plan (a code region over the C8's).
    pub fn of(a: &Attribution) -> Build {
        if is_calibration_build(a) {
            Build::Calibration
        } else if plan_code_region(&a.plan_symbols) > PLAN_CODE_REGION {
            Build::Cb
        } else {
            Build::Flight
        }
    }

    /// The build's name in the report.
    pub fn label(self) -> &'static str {
        match self {
            Build::Flight => "flight build",
            Build::Calibration => "calibration build",
            Build::Cb => "STM32F103CB build",
        }
    }

    /// Its group budgets.
    pub fn budgets(self) -> &'static [GroupBudget; 7] {
        match self {
            Build::Flight => &FLIGHT_BUDGETS,
            Build::Calibration => &CALIBRATION_BUDGETS,
            Build::Cb => &CB_BUDGETS,
        }
    }

    /// Its whole-image target below the code region, if it has one.
    pub fn target(self) -> Option<u64> {
        match self {
            Build::Flight => Some(DEFAULT_BUILD_TARGET),
            Build::Calibration => None,
            Build::Cb => Some(CB_BUILD_TARGET),
        }
    }
}

/// What `size` prints besides the totals and the group table.
#[derive(Debug, Default, Clone, Copy)]
pub struct Options {
    /// The largest N symbols with their groups.
    pub top: Option<usize>,
    /// Bytes per crate::module.
    pub modules: bool,
}

/// The calibration build links the ellipsoid fit; the flight builds do not.
pub fn is_calibration_build(a: &Attribution) -> bool {
    a.by_owner
        .iter()
        .any(|(o, b)| *b > 0 && o.krate == "calibration" && o.module == "ellipsoid_f32")
}

/// Runs `cargo xtask size`; `Err` lists what is over budget.
pub fn run(elf: Option<PathBuf>, opts: Options) -> Result<(), String> {
    let elf = elf.unwrap_or_else(|| target_dir().join("thumbv7m-none-eabi/release/firmware"));
    if !elf.is_file() {
        return Err(format!(
            "{}: no such ELF (build the firmware first: `cargo fw`)",
            elf.display()
        ));
    }
    let s = elf_sizes(&elf)?;
    let a = attribute(&elf)?;
    let build = Build::of(&a);
    let mut over = print_totals(&elf, &s, plan_code_region(&a.plan_symbols));
    check_sum(&a, &s)?;
    over.extend(print_groups(&a, build));
    over.extend(print_plan(&a, &s, build));
    if let Some(n) = opts.top {
        print_top(&a, n);
    }
    if opts.modules {
        print_modules(&a);
    }
    if over.is_empty() {
        Ok(())
    } else {
        Err(format!("over budget: {}", over.join(", ")))
    }
}

/// The attribution's parts must add up to the flash total.
pub fn check_sum(a: &Attribution, s: &Sizes) -> Result<(), String> {
    let sum: u64 = a.by_group().values().sum();
    if sum != s.flash() || a.total != s.flash() {
        return Err(format!(
            "attribution sums to {sum} B, sections to {} B, llvm-size says {} B",
            a.total,
            s.flash()
        ));
    }
    Ok(())
}

/// Flash and static RAM against their budgets; the overruns.
fn print_totals(elf: &Path, s: &Sizes, flash_budget: u64) -> Vec<String> {
    say!("firmware size ({})", elf.display());
    say!("  text  {:>7} B", s.text);
    say!("  data  {:>7} B", s.data);
    say!("  bss   {:>7} B", s.bss);
    say!(
        "  flash {:>7} B of {} B budget ({:.1} %)",
        s.flash(),
        flash_budget,
        100.0 * s.flash() as f64 / flash_budget as f64
    );
    say!(
        "  ram   {:>7} B of {} B budget ({:.1} %) static; the stack takes the rest of 20 KiB",
        s.ram(),
        RAM_BUDGET,
        100.0 * s.ram() as f64 / RAM_BUDGET as f64
    );
    let mut over = Vec::new();
    if s.flash() > flash_budget {
        over.push(format!("flash {} B > {} B", s.flash(), flash_budget));
    }
    if s.ram() > RAM_BUDGET {
        over.push(format!("static RAM {} B > {} B", s.ram(), RAM_BUDGET));
    }
    over
}

/// The group table (group, bytes, budget, status); the groups over budget.
fn print_groups(a: &Attribution, build: Build) -> Vec<String> {
    let budgets = build.budgets();
    say!("flash by feature group ({} budgets):", build.label());
    say!(
        "  {:<18} {:>7} {:>7}  {:<20} budget basis",
        "group",
        "bytes",
        "budget",
        "status"
    );
    let by_group = a.by_group();
    let mut over = Vec::new();
    for b in budgets {
        let bytes = by_group.get(&b.group).copied().unwrap_or(0);
        let status = if bytes <= b.bytes {
            format!("ok ({} B spare)", b.bytes - bytes)
        } else {
            over.push(format!("{} {} B > {} B", b.group.label(), bytes, b.bytes));
            format!("OVER by {} B", bytes - b.bytes)
        };
        say!(
            "  {:<18} {:>7} {:>7}  {status:<20} {}",
            b.group.label(),
            bytes,
            b.bytes,
            b.note
        );
    }
    let gaps: Vec<String> = a
        .unattributed_by_section
        .iter()
        .map(|(name, b)| format!("{name} {b}"))
        .collect();
    say!("  (unattributed by section: {})", gaps.join(", "));
    let budget_sum: u64 = budgets.iter().map(|b| b.bytes).sum();
    say!("  {:<18} {:>7} {:>7}", "total", a.total, budget_sum);
    over
}

/// The flash plan's code region (every build) and the flight builds'
/// 58 KiB budget; the overruns.
fn print_plan(a: &Attribution, s: &Sizes, build: Build) -> Vec<String> {
    let plan = plan_code_region(&a.plan_symbols);
    let flash = s.flash();
    let mut over = Vec::new();
    say!("flash plan (memory.x, ARCHITECTURE.md \"Flash plan\"):");
    match flash.checked_sub(plan) {
        Some(d) if d > 0 => {
            say!("  code region {flash} B of the plan's {plan} B: OVER by {d} B");
            over.push(format!("code region {flash} B > {plan} B"));
        }
        _ => say!(
            "  code region {flash} B of the plan's {plan} B: fits ({} B spare)",
            plan - flash
        ),
    }
    let Some(target) = build.target() else {
        return over;
    };
    let name = build.label();
    match flash.checked_sub(target) {
        Some(d) if d > 0 => {
            say!(
                "  {name} {flash} B of {target} B (the rest of the code region is for what comes \
                 next): OVER by {d} B"
            );
            over.push(format!("{name} {flash} B > {target} B"));
        }
        _ => say!(
            "  {name} {flash} B of {target} B (the rest of the code region is for what comes next): \
             ok ({} B spare)",
            target - flash
        ),
    }
    over
}

/// The plan's code region length from the ELF's `_flash_plan_code_start`
/// and `_flash_plan_code_end` (from `memory.x`), else [`PLAN_CODE_REGION`].
pub fn plan_code_region(symbols: &BTreeMap<String, u64>) -> u64 {
    match (
        symbols.get("_flash_plan_code_start"),
        symbols.get("_flash_plan_code_end"),
    ) {
        (Some(s), Some(e)) if e > s => e - s,
        _ => PLAN_CODE_REGION,
    }
}

/// The largest `n` symbols: bytes, group by name, and the line table's
/// split when it differs.
fn print_top(a: &Attribution, n: usize) {
    let mut syms: Vec<_> = a.symbols.iter().collect();
    syms.sort_by(|x, y| y.bytes.cmp(&x.bytes).then_with(|| x.name.cmp(&y.name)));
    say!("largest {n} symbols (bytes, group of the name; [split by source] when inlined code differs):");
    for s in syms.into_iter().take(n) {
        let group = s.owner.group();
        let split = if s.groups.len() > 1 || s.groups.first().is_some_and(|g| g.0 != group) {
            let parts: Vec<String> = s
                .groups
                .iter()
                .map(|(g, b)| format!("{} {b}", g.label()))
                .collect();
            format!("  [{}]", parts.join(", "))
        } else {
            String::new()
        };
        say!(
            "  {:>6}  {:<17}  {}{split}",
            s.bytes,
            group.label(),
            shorten(&s.name, 90)
        );
    }
}

/// Bytes per crate::module, largest first, with the group.
fn print_modules(a: &Attribution) {
    let mut owners: Vec<_> = a.by_owner.iter().filter(|(_, b)| **b > 0).collect();
    owners.sort_by(|x, y| y.1.cmp(x.1).then_with(|| x.0.cmp(y.0)));
    say!("flash by module:");
    for (o, b) in owners {
        say!("  {b:>6}  {:<17}  {o}", o.group().label());
    }
    say!(
        "  {:>6}  {:<17}  (padding, .Lanon.*)",
        a.unattributed,
        Group::Unattributed.label()
    );
}

/// `s` cut to `max` characters with an ellipsis.
fn shorten(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        return s.to_string();
    }
    let mut out: String = s.chars().take(max - 1).collect();
    out.push('…');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The attribution adds up to the flash total on a real ELF, if one
    /// was built (`cargo fw`); skipped otherwise.
    #[test]
    fn attribution_sums_to_flash_total() {
        let elf = target_dir().join("thumbv7m-none-eabi/release/firmware");
        if !elf.is_file() {
            eprintln!(
                "skipped: no firmware ELF at {} (run `cargo fw`)",
                elf.display()
            );
            return;
        }
        let (Ok(s), Ok(a)) = (elf_sizes(&elf), attribute(&elf)) else {
            panic!("could not read {}", elf.display());
        };
        assert_eq!(check_sum(&a, &s), Ok(()));
        assert!(
            a.unattributed < s.flash() / 20,
            "unattributed {} B",
            a.unattributed
        );
        let groups = a.by_group();
        for g in [Group::SensorsAhrs, Group::Runtime, Group::ReceiversOutputs] {
            assert!(groups[&g] > 0, "{} empty", g.label());
        }
    }

    #[test]
    fn plan_region_from_linker_symbols() {
        let mut syms = BTreeMap::new();
        assert_eq!(plan_code_region(&syms), PLAN_CODE_REGION);
        syms.insert("_flash_plan_code_start".to_string(), 0x0800_0000);
        syms.insert("_flash_plan_code_end".to_string(), 0x0800_F000);
        assert_eq!(plan_code_region(&syms), 60 * 1024);
    }

    #[test]
    fn cb_target_is_its_budgets_sum_and_fits_its_region() {
        let sum: u64 = CB_BUDGETS.iter().map(|b| b.bytes).sum();
        assert_eq!(sum, CB_BUILD_TARGET);
        const { assert!(CB_BUILD_TARGET < 124 * 1024) };
    }

    #[test]
    fn budgets_cover_every_group_once() {
        for set in [&FLIGHT_BUDGETS, &CALIBRATION_BUDGETS, &CB_BUDGETS] {
            let groups: Vec<Group> = set.iter().map(|b| b.group).collect();
            assert_eq!(groups, Group::ALL.to_vec());
        }
    }
}
