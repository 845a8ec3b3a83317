//! `cargo xtask <command>`: project automation that needs more than a shell
//! one-liner. The check command (`scripts/check`) calls these; `cargo xtask
//! --help` lists them. Exit status: 0 ok, 1 failed or over budget, 2 bad arguments.
//!
//! * `size [ELF] [--top N] [--modules]` — flash and static RAM of the
//!   firmware ELF against the budgets, flash per feature group against the
//!   flash plan (see `size.rs`, `attrib.rs`, `classify.rs`).
//! * `bench` — instruction counts on an emulated Cortex-M3 (see `bench.rs`).
//! * `fil ARGS` — what the `cargo fil` alias runs: the emulator's build
//!   prerequisites checked (one clear line if missing), then `cargo run -p
//!   emulator --bin fil -- ARGS` (see `fil.rs`).

use clap::{Parser, Subcommand};
use std::{
    env,
    path::{Path, PathBuf},
    process::{Command, ExitCode},
};

mod attrib;
mod bench;
mod classify;
mod fil;
mod size;

/// Project automation (`cargo xtask <command>`).
#[derive(Parser, Debug)]
#[command(name = "xtask", bin_name = "cargo xtask", version)]
struct Cli {
    #[command(subcommand)]
    command: Task,
}

#[derive(Subcommand, Debug)]
enum Task {
    /// Flash and static RAM of the firmware ELF against the budgets
    /// (flash 63 KiB, static RAM 12 KiB), every flashed byte attributed to
    /// a feature group against the group's budget, and the flash plan's
    /// code region (a warning until it fits); fails when over a budget.
    Size {
        /// The ELF [default: target/thumbv7m-none-eabi/release/firmware].
        elf: Option<PathBuf>,
        /// Also list the N largest symbols with their groups.
        #[arg(long, value_name = "N")]
        top: Option<usize>,
        /// Also list the flash per crate::module.
        #[arg(long)]
        modules: bool,
    },
    /// Instruction counts of the algorithms on an emulated Cortex-M3
    /// (qemu-system-arm), against their budgets; fails when over.
    Bench {
        /// Rewrite the table in BENCHMARKS.md with the new numbers.
        #[arg(long)]
        update_doc: bool,
        /// Also print where the instructions go (per-function profile).
        #[arg(long)]
        profile: bool,
    },
}

/// A closed stdout (`cargo xtask bench | head`) ends the process quietly,
/// as Unix tools do, instead of a panic in `println!`: Rust's runtime
/// ignores SIGPIPE, so put back the default action.
#[cfg(unix)]
fn quiet_on_closed_pipe() {
    // SAFETY: `signal` with a valid signal number and `SIG_DFL` only
    // changes this process's disposition; it runs first in `main`, before
    // any thread exists or any output is written.
    #[allow(unsafe_code)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(not(unix))]
fn quiet_on_closed_pipe() {}

fn main() -> ExitCode {
    quiet_on_closed_pipe();
    // `fil`'s arguments are the emulator's, passed on unparsed.
    let args: Vec<String> = env::args().collect();
    if args.get(1).is_some_and(|a| a == "fil") {
        return fil::run(&args[2..]);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Task::Size { elf, top, modules } => size::run(elf, size::Options { top, modules }),
        Task::Bench {
            update_doc,
            profile,
        } => bench::run(update_doc, profile),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `println!` without the panic on a closed stdout (`cargo xtask size | head`):
/// output stops, the command's result still decides the exit status.
#[macro_export]
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

/// Workspace root (the parent of this crate's folder).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// Cargo's target directory: `$CARGO_TARGET_DIR` if set, else `<root>/target`.
pub fn target_dir() -> PathBuf {
    env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target"))
}

/// Path of an LLVM tool from the pinned toolchain's `llvm-tools` component.
pub fn llvm_tool(name: &str) -> Result<PathBuf, String> {
    let out = Command::new("rustc")
        .args(["--print", "sysroot"])
        .output()
        .map_err(|e| format!("rustc --print sysroot: {e}"))?;
    let sysroot = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let lib = Path::new(&sysroot).join("lib/rustlib");
    let entries = std::fs::read_dir(&lib).map_err(|e| format!("{}: {e}", lib.display()))?;
    for entry in entries.flatten() {
        let candidate = entry.path().join("bin").join(name);
        if candidate.is_file() {
            return Ok(candidate);
        }
    }
    Err(format!(
        "{name} not found under {}: run `rustup component add llvm-tools`",
        lib.display()
    ))
}

/// Section sizes of an ARM ELF, summed the way the budgets count them.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Sizes {
    /// Code and read-only data in flash (.vector_table, .text, .rodata, defmt).
    pub text: u64,
    /// Initialised statics: occupy flash (load image) and RAM.
    pub data: u64,
    /// Zero-initialised and uninitialised statics: RAM only.
    pub bss: u64,
}

impl Sizes {
    /// Bytes written to flash.
    pub fn flash(&self) -> u64 {
        self.text + self.data
    }
    /// Bytes of static RAM (the stack comes on top).
    pub fn ram(&self) -> u64 {
        self.data + self.bss
    }
}

/// Reads `llvm-size -A` output and classifies each allocated section.
pub fn elf_sizes(elf: &Path) -> Result<Sizes, String> {
    let out = Command::new(llvm_tool("llvm-size")?)
        .arg("-A")
        .arg(elf)
        .output()
        .map_err(|e| format!("llvm-size: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "llvm-size failed on {}: {}",
            elf.display(),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let mut sizes = Sizes::default();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let mut cols = line.split_whitespace();
        let (Some(name), Some(size), Some(addr)) = (cols.next(), cols.next(), cols.next()) else {
            continue;
        };
        let (Ok(size), Ok(addr)) = (size.parse::<u64>(), addr.parse::<u64>()) else {
            continue;
        };
        // Only sections that occupy the target's address space count;
        // defmt's string table lives at address 0 and is never flashed.
        if addr == 0 || size == 0 {
            continue;
        }
        match name {
            ".data" => sizes.data += size,
            ".bss" | ".uninit" => sizes.bss += size,
            _ if (0x0800_0000..0x0810_0000).contains(&addr) => sizes.text += size,
            _ => {}
        }
    }
    Ok(sizes)
}
