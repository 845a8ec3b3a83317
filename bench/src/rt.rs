//! A minimal Cortex-M runtime for the benchmark binaries: vector table, reset
//! handler (.bss zeroing, .data copy), fault handler and panic handler, all of
//! which report through semihosting and end QEMU.
//!
//! cortex-m-rt is not used because its `link.x` includes a `memory.x` for
//! the chip it runs on (the Blue Pill's is `firmware/memory.x`); our own
//! `link.x` (see `build.rs`) describes QEMU's `mps2-an385` instead.
#![allow(unsafe_code)]

use cortex_m_semihosting::{debug, hprintln};

core::arch::global_asm!(
    r#"
    .section .vector_table, "a"
    .global __VECTORS
__VECTORS:
    .word _stack_start
    .word Reset
    .rept 14
    .word bench_fault
    .endr

    .section .text.Reset, "ax"
    .global Reset
    .type Reset, %function
    .thumb_func
Reset:
    ldr r0, =__sbss
    ldr r1, =__ebss
    movs r2, #0
1:  cmp r0, r1
    bhs 2f
    str r2, [r0], #4
    b 1b
2:  ldr r0, =__sdata
    ldr r1, =__edata
    ldr r2, =__sidata
3:  cmp r0, r1
    bhs 4f
    ldr r3, [r2], #4
    str r3, [r0], #4
    b 3b
4:  bl bench_main
5:  b 5b
    .ltorg
    .size Reset, . - Reset
"#
);

/// Any exception (HardFault, MemManage, ...) ends the run with a failure.
#[unsafe(no_mangle)]
extern "C" fn bench_fault() -> ! {
    hprintln!("FAULT: exception taken");
    exit(false)
}

/// Ends QEMU with the given status (semihosting `SYS_EXIT`).
pub fn exit(ok: bool) -> ! {
    debug::exit(if ok {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Not reached under QEMU with semihosting enabled.
    #[allow(clippy::empty_loop)]
    loop {}
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("PANIC: {}", info);
    exit(false)
}
