//! Compact `__aeabi_memcpy*` and `__aeabi_memclr*`, the routines LLVM
//! calls for struct copies and zeroing on ARM: a word loop for the
//! aligned variants and for a plain `__aeabi_memcpy` whose pointers are
//! both word-aligned at run time (LLVM calls it for struct copies whose
//! alignment it lost track of, on the 1 kHz path among them: 2 cycles a
//! byte instead of about 8 on the emulator's cycle model), a byte loop
//! otherwise (58 B in all). They take the place of `compiler_builtins`'
//! (1.6 KiB: an unrolled, alignment-fixing `memcpy` and six entry points
//! around it), which the flash budget cannot pay for. The price is speed
//! on long copies of unaligned data (about 4 cycles a byte), measured in
//! the firmware's own loop figures (BENCHMARKS.md).
//!
//! Arguments and clobbers are the run-time ABI's (ARM IHI 0043, §4.3.4):
//! `memcpy(dest r0, src r1, n r2)`, `memclr(dest r0, n r1)`, no result,
//! r0–r3 and the flags clobbered; the `4`/`8` variants get 4-byte aligned
//! pointers.
//!
//! `bench-check` includes this file and checks every entry point on the
//! emulated Cortex-M3 (`cargo xtask bench`, `bench/src/mem_check.rs`).

#![allow(unsafe_code)]

// Assembly rather than Rust: a Rust byte loop is what LLVM recognises as
// a memcpy idiom and would compile into a call to itself.
// SAFETY: each routine touches exactly `n` bytes at the caller's `dest`
// (and `src`), which the ABI makes the caller's promise, uses only the
// registers the ABI lets it clobber, and returns with `bx lr`. (The
// module allows `unsafe_code` for this one item: the lint cannot be
// allowed on a macro invocation.)
core::arch::global_asm!(
    ".syntax unified",
    ".section .text.fc_aeabi_mem,\"ax\",%progbits",
    // Both pointers word-aligned (the low two bits of their OR clear):
    // on into the word loop; otherwise to the byte loop.
    ".global __aeabi_memcpy",
    ".type __aeabi_memcpy,%function",
    ".thumb_func",
    "__aeabi_memcpy:",
    "    mov r3, r0",
    "    orrs r3, r1",
    "    lsls r3, r3, #30",
    "    bne 3f",
    ".global __aeabi_memcpy8",
    ".type __aeabi_memcpy8,%function",
    ".thumb_func",
    "__aeabi_memcpy8:",
    ".global __aeabi_memcpy4",
    ".type __aeabi_memcpy4,%function",
    ".thumb_func",
    "__aeabi_memcpy4:",
    "    subs r2, r2, #4",
    "    bcc 2f",
    "1:  ldr r3, [r1], #4",
    "    str r3, [r0], #4",
    "    subs r2, r2, #4",
    "    bcs 1b",
    "2:  adds r2, r2, #4",
    "3:  cbz r2, 5f",
    "4:  ldrb r3, [r1], #1",
    "    strb r3, [r0], #1",
    "    subs r2, r2, #1",
    "    bne 4b",
    "5:  bx lr",
    ".global __aeabi_memclr8",
    ".type __aeabi_memclr8,%function",
    ".thumb_func",
    "__aeabi_memclr8:",
    ".global __aeabi_memclr4",
    ".type __aeabi_memclr4,%function",
    ".thumb_func",
    "__aeabi_memclr4:",
    "    movs r2, #0",
    "    subs r1, r1, #4",
    "    bcc 6f",
    "5:  str r2, [r0], #4",
    "    subs r1, r1, #4",
    "    bcs 5b",
    "6:  adds r1, r1, #4",
    "    b 7f",
    ".global __aeabi_memclr",
    ".type __aeabi_memclr,%function",
    ".thumb_func",
    "__aeabi_memclr:",
    "    movs r2, #0",
    "7:  cbz r1, 9f",
    "8:  strb r2, [r0], #1",
    "    subs r1, r1, #1",
    "    bne 8b",
    "9:  bx lr",
);
