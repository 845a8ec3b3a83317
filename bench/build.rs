//! Puts the benchmark's own linker script (`link.x`, memory layout of QEMU's
//! `mps2-an385`) and an empty `defmt.x` on the linker's search path.
//!
//! The workspace's `.cargo/config.toml` passes `-Tlink.x -Tdefmt.x` for every
//! thumbv7m build. The bench does not use cortex-m-rt (whose `link.x`
//! includes a chip's `memory.x`), so the only `link.x` on the path is ours.
use std::{env, fs, path::PathBuf, process::ExitCode};

fn main() -> ExitCode {
    let Some(out) = env::var_os("OUT_DIR").map(PathBuf::from) else {
        eprintln!("bench/build.rs: OUT_DIR not set (run through cargo)");
        return ExitCode::FAILURE;
    };
    let files = [
        ("link.x", include_str!("link.x")),
        ("defmt.x", "/* bench: no defmt */\n"),
    ];
    for (name, text) in files {
        if let Err(e) = fs::write(out.join(name), text) {
            eprintln!("bench/build.rs: writing {name}: {e}");
            return ExitCode::FAILURE;
        }
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=link.x");
    ExitCode::SUCCESS
}
