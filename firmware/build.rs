//! Puts the workspace's `memory.x` on the linker search path, so that
//! cortex-m-rt's `link.x` finds it whichever directory cargo runs from.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    // Read at run time, not with `env!`: a build script compiled in one
    // checkout and reused from a shared target dir by another must copy
    // that other checkout's memory.x.
    let manifest = env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let memory_x = PathBuf::from(manifest).join("../memory.x");
    fs::copy(&memory_x, out.join("memory.x")).expect("copy memory.x to OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");
}
