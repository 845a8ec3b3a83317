//! Stack painting at boot and the high-water mark.
//!
//! flip-link places the stack at the bottom of RAM (it grows down towards
//! `0x2000_0000`) with the statics above it, so an overflow faults. At boot
//! the unused part of the stack is filled with a pattern; later the first
//! word from the bottom that no longer holds it marks the deepest use.

/// Bottom of RAM = lowest stack address under flip-link.
const RAM_START: usize = 0x2000_0000;
/// The paint pattern.
const PAINT: u32 = 0xACE0_BA5E;
/// Bytes below the current stack pointer left unpainted at boot.
const MARGIN: usize = 256;

extern "C" {
    /// Top of the stack (set by cortex-m-rt / flip-link).
    static _stack_start: u32;
}

fn stack_top() -> usize {
    (&raw const _stack_start) as usize
}

/// Paints the stack from the bottom of RAM up to `MARGIN` bytes below the
/// current stack pointer.
pub fn paint() {
    let sp = cortex_m::register::msp::read() as usize;
    let end = sp.saturating_sub(MARGIN) & !3;
    let mut addr = RAM_START;
    while addr < end {
        // SAFETY: [RAM_START, sp − MARGIN) is the unused part of the stack
        // (flip-link puts nothing else below the stack), word-aligned, and
        // nothing references it; interrupts are disabled during `init`.
        #[allow(unsafe_code)]
        unsafe {
            core::ptr::write_volatile(addr as *mut u32, PAINT)
        };
        addr += 4;
    }
}

/// Deepest stack use so far, bytes (from the paint), and the stack size.
pub fn high_water() -> (usize, usize) {
    let top = stack_top();
    let mut addr = RAM_START;
    while addr < top {
        // SAFETY: reading RAM inside the stack region; a volatile read of a
        // word-aligned address that is always mapped.
        #[allow(unsafe_code)]
        let w = unsafe { core::ptr::read_volatile(addr as *const u32) };
        if w != PAINT {
            break;
        }
        addr += 4;
    }
    (top.saturating_sub(addr), top.saturating_sub(RAM_START))
}
