//! Output files that never destroy an existing file.
//!
//! A tool writes each output (plot, CSV, estimates) into a temporary file
//! beside its target, `.NAME.PID-N.tmp.EXT` (the target's extension last,
//! so a writer that picks its format by the extension sees the right one),
//! and [`SafeFile::commit`] renames it over the target once it is complete.
//! Until then the target is untouched:
//!
//! * a run that fails drops its [`SafeFile`]s, which removes their
//!   temporary files;
//! * a run that is interrupted (SIGINT, SIGTERM, SIGHUP) removes every live
//!   temporary file and exits with status 130 (the handler is installed by
//!   the first [`SafeFile::create`], so a tool that writes no file keeps the
//!   default signal behaviour).
//!
//! ```
//! use host_console::SafeFile;
//! use std::io::Write;
//!
//! let target = std::env::temp_dir().join(format!("safe-doc-{}.csv", std::process::id()));
//! std::fs::write(&target, "old").unwrap();
//! let (out, mut file) = SafeFile::create(&target).unwrap();
//! writeln!(file, "t_s").unwrap();
//! assert_eq!(std::fs::read_to_string(&target).unwrap(), "old");
//! drop(file);
//! out.commit().unwrap();
//! assert_eq!(std::fs::read_to_string(&target).unwrap(), "t_s\n");
//! # std::fs::remove_file(target).unwrap();
//! ```

use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Mutex, MutexGuard, Once};

/// The temporary files not yet committed or dropped (removed on a signal).
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Tells temporary files of one process apart.
static NEXT: AtomicU32 = AtomicU32::new(0);
static HANDLER: Once = Once::new();

fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// On SIGINT/SIGTERM/SIGHUP: removes every live temporary file, says so,
/// exits 130. The targets were never touched.
fn install_handler() {
    HANDLER.call_once(|| {
        let installed = ctrlc::set_handler(|| {
            let temps = live();
            for t in temps.iter() {
                let _ = std::fs::remove_file(t);
            }
            crate::note!("interrupted: no output written, existing files left as they were");
            std::process::exit(130);
        });
        if let Err(e) = installed {
            crate::note!("warning: no interrupt handler ({e}): an interrupted run may leave a temporary file");
        }
    });
}

/// An output being written beside its target (see the module docs).
#[derive(Debug)]
pub struct SafeFile {
    target: PathBuf,
    temp: PathBuf,
    committed: bool,
}

impl SafeFile {
    /// Creates `target`'s missing parent folders and an empty temporary file
    /// beside it, returned open for writing. `target` itself is not touched;
    /// an error if it is a folder or its folder cannot be created or written.
    pub fn create(target: &Path) -> io::Result<(Self, File)> {
        let name = target
            .file_name()
            .ok_or_else(|| io::Error::other("needs a file name"))?;
        if target.is_dir() {
            return Err(io::Error::other("is a folder"));
        }
        let dir = target.parent().filter(|d| !d.as_os_str().is_empty());
        if let Some(dir) = dir {
            std::fs::create_dir_all(dir).map_err(|e| {
                io::Error::new(e.kind(), format!("creating folder {}: {e}", dir.display()))
            })?;
        }
        install_handler();
        let ext = target
            .extension()
            .map(|e| format!(".{}", e.to_string_lossy()))
            .unwrap_or_default();
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let temp_name = format!(
            ".{}.{}-{n}.tmp{ext}",
            name.to_string_lossy(),
            std::process::id()
        );
        let temp = dir.map_or_else(|| PathBuf::from(&temp_name), |d| d.join(&temp_name));
        let mut temps = live();
        let file = File::options().write(true).create_new(true).open(&temp)?;
        temps.push(temp.clone());
        Ok((
            Self {
                target: target.to_path_buf(),
                temp,
                committed: false,
            },
            file,
        ))
    }

    /// The file to write (for writers that take a path, such as plotters).
    pub fn temp_path(&self) -> &Path {
        &self.temp
    }

    /// The file this output replaces when committed.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Renames the finished temporary file over the target. On an error
    /// the temporary file is removed and the target left as it was.
    pub fn commit(mut self) -> io::Result<()> {
        let mut temps = live();
        std::fs::rename(&self.temp, &self.target)?;
        temps.retain(|t| t != &self.temp);
        self.committed = true;
        Ok(())
    }
}

impl Drop for SafeFile {
    /// An output not committed is discarded: its temporary file is removed.
    fn drop(&mut self) {
        if self.committed {
            return;
        }
        let mut temps = live();
        let _ = std::fs::remove_file(&self.temp);
        temps.retain(|t| t != &self.temp);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::SafeFile;
    use std::io::Write;

    fn dir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("safe-file-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(d: &std::path::Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    /// Dropped without commit: the old file is byte-identical, no temp left.
    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let d = dir("fail");
        let target = d.join("plot.png");
        std::fs::write(&target, b"old bytes").unwrap();
        let (out, mut f) = SafeFile::create(&target).unwrap();
        assert!(out.temp_path().to_string_lossy().ends_with(".png"));
        f.write_all(b"half").unwrap();
        drop((out, f));
        assert_eq!(std::fs::read(&target).unwrap(), b"old bytes");
        assert_eq!(names(&d), ["plot.png"]);
        let _ = std::fs::remove_dir_all(d);
    }

    /// Committed: the new bytes replace the old; folders are created.
    #[test]
    fn a_commit_replaces_the_target() {
        let d = dir("commit");
        let target = d.join("new/deeper/out.csv");
        let (out, mut f) = SafeFile::create(&target).unwrap();
        f.write_all(b"new").unwrap();
        drop(f);
        assert!(!target.exists());
        out.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(names(&d.join("new/deeper")), ["out.csv"]);
        assert!(SafeFile::create(&d.join("new")).is_err(), "a folder");
        let _ = std::fs::remove_dir_all(d);
    }
}
