//! `cargo xtask bench`: instruction counts on an emulated Cortex-M3.
//! (Being written; see issue 7.)

/// Runs the benchmark suite.
pub fn run(_args: &[String]) -> Result<(), String> {
    Err("bench: not implemented yet".into())
}
