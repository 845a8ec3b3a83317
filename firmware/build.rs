//! Puts the chip's memory layout on the linker search path as `memory.x`,
//! where cortex-m-rt's `link.x` finds it: `firmware/memory.x`
//! (STM32F103C8, 64 KiB) by default, `firmware/memory-cb.x` (STM32F103CB,
//! 128 KiB) with the `f103cb` feature. Neither lives in the workspace
//! root: the linker runs there and would take a `memory.x` in its working
//! directory before any search path, whatever the feature.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    // Read at run time, not with `env!`: a build script compiled in one
    // checkout and reused from a shared target dir by another must copy
    // that other checkout's layout.
    let manifest = env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let layout = if env::var_os("CARGO_FEATURE_F103CB").is_some() {
        "memory-cb.x"
    } else {
        "memory.x"
    };
    let memory_x = PathBuf::from(manifest).join(layout);
    fs::copy(&memory_x, out.join("memory.x")).expect("copy the memory layout to OUT_DIR");
    // `builder`: the builder's features (battery, telemetry, settings
    // console), in the STM32F103CB's flight build; its calibration build
    // (`f103cb` + `calibrate`) is the C8's calibration build on the CB's
    // layout.
    println!("cargo::rustc-check-cfg=cfg(builder)");
    let cb = env::var_os("CARGO_FEATURE_F103CB").is_some();
    if cb && env::var_os("CARGO_FEATURE_CALIBRATE").is_none() {
        println!("cargo:rustc-cfg=builder");
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");
}
