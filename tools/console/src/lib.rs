//! Human-readable output for the host tools (`sim`, `replay`) that survives a
//! closed pipe.
//!
//! `tool ... | head` closes stdout early. Rust ignores SIGPIPE, so `println!`
//! would panic there; instead the first failed write marks the stream gone,
//! later lines are dropped, and the tool carries on so that its output files
//! are still written. A closed pipe is not an error (exit status 0); any other
//! write error on stdout (e.g. a full disk behind a redirect) is remembered,
//! and the tool asks [`stdout_failed`] at the end to exit non-zero.
//!
//! ```
//! use host_console::{note, say};
//!
//! say!("{} samples", 3);
//! note!("written to {}", "out.csv");
//! assert!(!host_console::stdout_failed());
//! ```
//!
//! Host-only: it uses `std`'s streams and process-wide state.
//!
//! [`canonical_path`] is here too: both tools refuse to write over one of
//! their inputs or to write two outputs to one file, whatever the spelling.
//!
//! [`SafeFile`] is how every tool writes a file: into a temporary file
//! beside the target, renamed over it only when complete, so a failed or
//! interrupted run never destroys an existing output (see [`output`]).

use std::io::{ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

pub mod output;
#[cfg(feature = "testing")]
pub mod testing;

pub use output::SafeFile;

/// Where [`say!`] lines go: stdout unless the tool's data goes there.
static TO_STDERR: AtomicBool = AtomicBool::new(false);
/// 0 = open, 1 = closed by the reader, 2 = failed otherwise.
static STATE: AtomicU8 = AtomicU8::new(0);

/// Sends [`say!`] lines to stderr from now on (stdout carries data).
pub fn use_stderr() {
    TO_STDERR.store(true, Ordering::Relaxed);
}

/// Writes one line of human-readable output (see the crate docs).
pub fn line(args: std::fmt::Arguments<'_>) {
    if TO_STDERR.load(Ordering::Relaxed) {
        let _ = writeln!(std::io::stderr().lock(), "{args}");
        return;
    }
    if STATE.load(Ordering::Relaxed) != 0 {
        return;
    }
    let mut out = std::io::stdout().lock();
    if let Err(e) = writeln!(out, "{args}").and_then(|()| out.flush()) {
        let state = if e.kind() == ErrorKind::BrokenPipe {
            1
        } else {
            2
        };
        STATE.store(state, Ordering::Relaxed);
    }
}

/// Whether stdout failed with something other than a closed pipe.
pub fn stdout_failed() -> bool {
    STATE.load(Ordering::Relaxed) == 2
}

/// `p` made absolute with its folder resolved, so two spellings of one
/// file compare equal even before the file exists.
pub fn canonical_path(p: &Path) -> PathBuf {
    if let Ok(c) = p.canonicalize() {
        return c;
    }
    let parent = p
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let dir = parent
        .canonicalize()
        .unwrap_or_else(|_| parent.to_path_buf());
    p.file_name().map_or(dir.clone(), |n| dir.join(n))
}

/// Writes one line to stderr. Unlike `eprintln!` it does not panic when
/// stderr is a closed pipe: there is nowhere left to report that.
pub fn err_line(args: std::fmt::Arguments<'_>) {
    let _ = writeln!(std::io::stderr().lock(), "{args}");
}

/// `eprintln!` that never panics (see [`err_line`]).
#[macro_export]
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::err_line(format_args!($($arg)*))
    };
}

/// `println!` that never panics (see the crate docs).
#[macro_export]
macro_rules! say {
    ($($arg:tt)*) => {
        $crate::line(format_args!($($arg)*))
    };
}

#[cfg(test)]
mod tests {
    use super::canonical_path;
    use std::path::Path;

    /// Two spellings of one file that does not exist yet compare equal; a
    /// different name does not.
    #[test]
    fn spellings_of_one_new_file_are_equal() {
        let dir = std::env::temp_dir();
        let a = dir.join("host-console-canonical-x.csv");
        let b = dir.join(".").join("host-console-canonical-x.csv");
        assert!(!a.exists());
        assert_eq!(canonical_path(&a), canonical_path(&b));
        assert_ne!(
            canonical_path(&a),
            canonical_path(&dir.join("host-console-canonical-y.csv"))
        );
        assert_eq!(
            canonical_path(Path::new("x")),
            canonical_path(Path::new("./x"))
        );
    }
}
