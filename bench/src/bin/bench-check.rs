//! Runs the correctness sequences of `bench::check` on the emulated Cortex-M3
//! and prints each result through semihosting as
//! `CHECK <name> i32|f32 <4 values>` (f32 as IEEE bit patterns in hex), then
//! `CHECK done`. `cargo xtask bench` compares them with the host's results.
//!
//! Before them it checks the firmware's own `__aeabi_memcpy*` /
//! `__aeabi_memclr*` (`firmware/src/mem.rs`, included here so this binary
//! links them as the firmware does) and prints one line per entry point,
//! `MEM <symbol> ok <calls>` or `MEM <symbol> FAIL <first wrong call>`;
//! `cargo xtask bench` fails unless all six say ok.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[path = "../rt.rs"]
mod rt;

#[cfg(target_os = "none")]
#[path = "../../../firmware/src/mem.rs"]
mod mem;

#[cfg(target_os = "none")]
#[path = "../mem_check.rs"]
mod mem_check;

#[cfg(target_os = "none")]
#[allow(unsafe_code)] // `no_mangle` entry point called by the reset handler
mod app {
    use bench::check::{self, Value};
    use cortex_m as _;
    use cortex_m_semihosting::hprintln;

    #[unsafe(no_mangle)]
    extern "C" fn bench_main() -> ! {
        super::mem_check::run(|o| match o.failure {
            None => hprintln!("MEM {} ok {}", o.name, o.cases),
            Some((n, sa, da, at)) => hprintln!(
                "MEM {} FAIL n={} src_offset={} dest_offset={} first_wrong_byte={}",
                o.name,
                n,
                sa,
                da,
                at
            ),
        });
        check::run(|name, v| match v {
            Value::I32(q) => hprintln!("CHECK {} i32 {} {} {} {}", name, q[0], q[1], q[2], q[3]),
            Value::F32(q) => hprintln!(
                "CHECK {} f32 {:08x} {:08x} {:08x} {:08x}",
                name,
                q[0].to_bits(),
                q[1].to_bits(),
                q[2].to_bits(),
                q[3].to_bits()
            ),
        });
        hprintln!("CHECK done");
        super::rt::exit(true)
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "bench-check runs on thumbv7m-none-eabi under qemu-system-arm: use `cargo xtask bench`"
    );
}
