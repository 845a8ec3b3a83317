//! `cargo fil ARGS` (the alias runs `xtask fil ARGS`): checks that the
//! machine can build the emulator's unicorn core (cmake, and libclang for
//! bindgen), says in one line what to install if not, else runs
//! `cargo run -p emulator --bin fil -- ARGS` with `LIBCLANG_PATH` set to the
//! libclang it found. Without this a fresh machine meets unicorn-engine-sys'
//! build failing deep inside cmake's or bindgen's output.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// Where `scripts/check`'s `find_libclang` looks, in its order.
const LIBCLANG_GLOBS: [(&str, &str); 3] = [
    ("/usr/lib", "llvm-"),
    ("/usr/lib/x86_64-linux-gnu", ""),
    ("/usr/lib64", ""),
];

/// A folder holding a `libclang*.so*` (or `.dylib`), if `dir` is one.
fn has_libclang(dir: &Path) -> bool {
    std::fs::read_dir(dir).is_ok_and(|rd| {
        rd.flatten().any(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.starts_with("libclang") && (n.contains(".so") || n.ends_with(".dylib"))
        })
    })
}

/// `LIBCLANG_PATH` if it holds libclang, else the first folder
/// `scripts/check` would find.
fn find_libclang() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("LIBCLANG_PATH").map(PathBuf::from) {
        if has_libclang(&p) {
            return Some(p);
        }
    }
    for (base, prefix) in LIBCLANG_GLOBS {
        if prefix.is_empty() {
            let p = PathBuf::from(base);
            if has_libclang(&p) {
                return Some(p);
            }
            continue;
        }
        let mut llvm: Vec<PathBuf> = std::fs::read_dir(base)
            .into_iter()
            .flatten()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with(prefix))
            .map(|e| e.path().join("lib"))
            .collect();
        llvm.sort();
        if let Some(p) = llvm.into_iter().rev().find(|p| has_libclang(p)) {
            return Some(p);
        }
    }
    None
}

/// Whether `cmd --version` runs.
fn runs(cmd: &str) -> bool {
    Command::new(cmd)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The one line a machine without the build prerequisites gets, or the
/// libclang folder to build with.
fn prerequisites() -> Result<PathBuf, String> {
    let libclang = find_libclang();
    let mut missing = Vec::new();
    if !runs("cmake") {
        missing.push("cmake");
    }
    if libclang.is_none() {
        missing.push("libclang (Debian: libclang-dev)");
    }
    match (libclang, missing.is_empty()) {
        (Some(p), true) => Ok(p),
        _ => Err(format!(
            "building the emulator's unicorn core needs {}, not found: run `scripts/check setup` \
             (installs it), or e.g. `sudo apt-get install cmake clang libclang-dev`",
            missing.join(" and ")
        )),
    }
}

/// Checks the prerequisites, then runs `cargo fil`'s binary with `args`;
/// its exit status is returned as it is.
pub fn run(args: &[String]) -> ExitCode {
    let libclang = match prerequisites() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("cargo fil: {e}");
            return ExitCode::FAILURE;
        }
    };
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["run", "-p", "emulator", "--bin", "fil", "--"])
        .args(args)
        .env("LIBCLANG_PATH", libclang)
        .status();
    match status {
        Ok(s) => s
            .code()
            .and_then(|c| u8::try_from(c).ok())
            .map_or(ExitCode::FAILURE, ExitCode::from),
        Err(e) => {
            eprintln!("cargo fil: running cargo: {e}");
            ExitCode::FAILURE
        }
    }
}
