//! Checks the firmware's hand-written `__aeabi_memcpy*` / `__aeabi_memclr*`
//! (`firmware/src/mem.rs`, linked into this binary in place of
//! `compiler_builtins`' weak ones) on the emulated Cortex-M3.
//!
//! Every entry point, every length 0..=[`MAX_N`]; the byte variants at every
//! source and destination offset 0..=3 from an 8-byte boundary, the `4` / `8`
//! variants only at the offsets the run-time ABI lets their callers pass
//! (multiples of 4 / 8), with any length. After each call the whole buffer is
//! compared with what it must hold: the `n` bytes copied (or zero), every
//! other byte -- the guards on both sides of the range included -- as it was
//! filled, and the source unchanged.

/// Longest length tried: past several word-loop rounds and every remainder.
pub const MAX_N: usize = 67;

/// Bytes before and after the range that must stay untouched.
const GUARD: usize = 16;
const LEN: usize = GUARD + 8 + MAX_N + GUARD;

#[repr(C, align(8))]
struct Buf([u8; LEN]);

// SAFETY: the declarations match the run-time ABI's (ARM IHI 0043 §4.3.4)
// and `firmware/src/mem.rs`'s definitions: `memcpy(dest, src, n)`,
// `memclr(dest, n)`, no result.
#[allow(unsafe_code)]
extern "C" {
    fn __aeabi_memcpy(dest: *mut u8, src: *const u8, n: usize);
    fn __aeabi_memcpy4(dest: *mut u8, src: *const u8, n: usize);
    fn __aeabi_memcpy8(dest: *mut u8, src: *const u8, n: usize);
    fn __aeabi_memclr(dest: *mut u8, n: usize);
    fn __aeabi_memclr4(dest: *mut u8, n: usize);
    fn __aeabi_memclr8(dest: *mut u8, n: usize);
}

/// Fill patterns: never zero (a clear shows), different in the two buffers
/// and from one byte to the next (a shifted or swapped copy shows).
fn dest_fill(i: usize) -> u8 {
    0x80 | (i as u8).wrapping_mul(3)
}

fn src_fill(i: usize) -> u8 {
    1 + (i as u8).wrapping_mul(7) % 0x7f
}

type Copy = unsafe extern "C" fn(*mut u8, *const u8, usize);
type Clear = unsafe extern "C" fn(*mut u8, usize);

/// One entry point's result: cases run, and the first wrong case if any.
pub struct Outcome {
    /// The symbol checked.
    pub name: &'static str,
    /// Calls made and checked.
    pub cases: u32,
    /// The first failing call: (n, source offset, destination offset,
    /// index of the first wrong byte in the destination buffer, or
    /// `usize::MAX` for a changed source).
    pub failure: Option<(usize, usize, usize, usize)>,
}

#[allow(unsafe_code)]
fn check_copy(name: &'static str, f: Copy, offsets: &[usize]) -> Outcome {
    let mut out = Outcome {
        name,
        cases: 0,
        failure: None,
    };
    let mut dest = Buf([0; LEN]);
    let mut src = Buf([0; LEN]);
    for n in 0..=MAX_N {
        for &sa in offsets {
            for &da in offsets {
                for (i, b) in dest.0.iter_mut().enumerate() {
                    *b = dest_fill(i);
                }
                for (i, b) in src.0.iter_mut().enumerate() {
                    *b = src_fill(i);
                }
                // SAFETY: both ranges lie inside their buffers
                // (GUARD + 7 + MAX_N < LEN), and the offsets passed to the
                // `4`/`8` variants keep the alignment they promise.
                unsafe {
                    f(
                        dest.0.as_mut_ptr().add(GUARD + da),
                        src.0.as_ptr().add(GUARD + sa),
                        n,
                    );
                }
                out.cases += 1;
                let start = GUARD + da;
                let wrong = dest.0.iter().enumerate().position(|(i, &b)| {
                    let want = if (start..start + n).contains(&i) {
                        src_fill(i - start + GUARD + sa)
                    } else {
                        dest_fill(i)
                    };
                    b != want
                });
                let src_changed = src.0.iter().enumerate().any(|(i, &b)| b != src_fill(i));
                let bad = wrong.or(src_changed.then_some(usize::MAX));
                if let (None, Some(at)) = (out.failure, bad) {
                    out.failure = Some((n, sa, da, at));
                }
            }
        }
    }
    out
}

#[allow(unsafe_code)]
fn check_clear(name: &'static str, f: Clear, offsets: &[usize]) -> Outcome {
    let mut out = Outcome {
        name,
        cases: 0,
        failure: None,
    };
    let mut dest = Buf([0; LEN]);
    for n in 0..=MAX_N {
        for &da in offsets {
            for (i, b) in dest.0.iter_mut().enumerate() {
                *b = dest_fill(i);
            }
            // SAFETY: the range lies inside the buffer (GUARD + 7 + MAX_N
            // < LEN), and the offsets passed to the `4`/`8` variants keep
            // the alignment they promise.
            unsafe { f(dest.0.as_mut_ptr().add(GUARD + da), n) };
            out.cases += 1;
            let start = GUARD + da;
            let wrong = dest.0.iter().enumerate().position(|(i, &b)| {
                let want = if (start..start + n).contains(&i) {
                    0
                } else {
                    dest_fill(i)
                };
                b != want
            });
            if let (None, Some(at)) = (out.failure, wrong) {
                out.failure = Some((n, 0, da, at));
            }
        }
    }
    out
}

/// Runs the checks of all six entry points, handing each outcome to `emit`
/// as soon as it is known (a later fault still leaves the earlier lines).
pub fn run(mut emit: impl FnMut(&Outcome)) {
    const ANY: &[usize] = &[0, 1, 2, 3];
    const WORD: &[usize] = &[0, 4];
    const DOUBLE: &[usize] = &[0, 8];
    emit(&check_copy("__aeabi_memcpy", __aeabi_memcpy, ANY));
    emit(&check_copy("__aeabi_memcpy4", __aeabi_memcpy4, WORD));
    emit(&check_copy("__aeabi_memcpy8", __aeabi_memcpy8, DOUBLE));
    emit(&check_clear("__aeabi_memclr", __aeabi_memclr, ANY));
    emit(&check_clear("__aeabi_memclr4", __aeabi_memclr4, WORD));
    emit(&check_clear("__aeabi_memclr8", __aeabi_memclr8, DOUBLE));
}
