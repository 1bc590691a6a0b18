//! Writing a file so that a reader sees the old file or the whole new one, never part of either.
//!
//! Every file Obscura writes (ray maps, ST-maps, renders, previews, deep images) goes through
//! [`write_atomically`]:
//!
//! 1. a temporary file is created *beside* the target (so the rename below stays on one filesystem
//!    and is atomic), named `.NAME.tmp-PID-COUNTER-RANDOM`: the process id tells processes apart, a
//!    process-wide counter tells this process's writers apart, and a random part guards against a
//!    stale file of a recycled process id. It is opened with `create_new`, so two writers never
//!    share a temporary file;
//! 2. the caller's callback writes it through a [`BufWriter`], which is then flushed and the file
//!    synced to disk (`fsync`), so the rename cannot publish data still in a cache;
//! 3. the file is renamed over the target, and the directory is synced where the platform allows it,
//!    so the new name survives a crash too;
//! 4. on every failure — creating, the callback's error, flushing, syncing, renaming, and a panic in
//!    the callback — the temporary file is removed (a guard deletes it on drop unless the rename
//!    committed it), and the target is left as it was.
//!
//! A process killed outright (SIGKILL, power loss) cannot remove its temporary file. The next write
//! of the same target removes those of dead processes ([`remove_stale_temporaries`]): the name holds
//! the writer's process id, and a file whose process no longer runs is garbage.

use std::collections::hash_map::RandomState;
use std::fs::{File, OpenOptions};
use std::hash::{BuildHasher, Hasher};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

/// A file could not be written into place. Every variant names the target, not the temporary file.
#[derive(Debug, thiserror::Error)]
pub enum AtomicWriteError {
    /// Creating, writing, flushing or syncing the temporary file failed (or the callback did).
    #[error("cannot write {path}: {source}")]
    Write {
        /// The target file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
    /// Renaming the finished file into place failed.
    #[error("cannot move the finished file into place at {path}: {source}")]
    Rename {
        /// The target file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
}

impl AtomicWriteError {
    /// The target file the error is about.
    #[must_use]
    pub fn path(&self) -> &Path {
        match self {
            AtomicWriteError::Write { path, .. } | AtomicWriteError::Rename { path, .. } => path,
        }
    }
}

/// Writes `path` through `write`, atomically: see the [module documentation](self) for the steps.
///
/// `write` gets a buffered writer at the start of an empty temporary file (it may seek: the writer
/// is a plain file). Errors of other libraries can be passed through [`io::Error::other`]; their
/// message becomes the error's.
///
/// # Errors
/// [`AtomicWriteError::Write`] when the temporary file cannot be created (a missing or unwritable
/// directory), `write` fails, or flushing or syncing fails; [`AtomicWriteError::Rename`] when the
/// finished file cannot be moved into place. The temporary file is gone and the target untouched in
/// every case. A failure to sync the directory after the rename is not an error (some filesystems
/// refuse to sync directories); the file is in place by then.
///
/// # Panics
/// When `write` panics; the panic is resumed after the temporary file is removed.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> Result<(), AtomicWriteError> {
    let failed = |source| AtomicWriteError::Write {
        path: path.to_path_buf(),
        source,
    };
    let (file, mut temporary) = create_temporary(path).map_err(failed)?;
    let mut out = BufWriter::new(file);
    write(&mut out).map_err(failed)?;
    let file = out.into_inner().map_err(|e| failed(e.into_error()))?;
    file.sync_all().map_err(failed)?;
    drop(file);
    std::fs::rename(&temporary.path, path).map_err(|source| AtomicWriteError::Rename {
        path: path.to_path_buf(),
        source,
    })?;
    temporary.committed = true;
    sync_directory(&directory_of(path));
    Ok(())
}

/// Checks before any work that `path` could be written: creates its temporary file exactly as
/// [`write_atomically`] will, and removes it.
///
/// # Errors
/// The I/O error of creating the temporary file (a missing directory, no permission, a read-only
/// filesystem).
pub fn check_writable(path: &Path) -> io::Result<()> {
    create_temporary(path).map(drop)
}

/// Removes the temporary files of `path` left by processes that no longer run (killed while writing
/// it) and returns how many. Only files named as [`write_atomically`] names them are considered, and
/// only where the process table can be asked (`/proc` on Linux); elsewhere nothing is removed.
pub fn remove_stale_temporaries(path: &Path) -> usize {
    let prefix = temporary_prefix(path);
    let Ok(entries) = std::fs::read_dir(directory_of(path)) else {
        return 0;
    };
    let mut removed = 0;
    for entry in entries.filter_map(Result::ok) {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = name
            .strip_prefix(&prefix)
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if process_is_gone(pid) && std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// True when process `pid` is known not to run (Linux: no `/proc/PID`). Unknown counts as running.
fn process_is_gone(pid: u32) -> bool {
    if pid == std::process::id() {
        return false;
    }
    let proc_root = Path::new("/proc/self");
    proc_root.exists() && !Path::new(&format!("/proc/{pid}")).exists()
}

/// The temporary file of one write: removed when dropped, unless the rename committed it.
struct Temporary {
    path: PathBuf,
    committed: bool,
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Counts the temporary files this process has named, so that two of its writers never pick the same.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// The prefix every temporary file of `path` starts with: `.NAME.tmp-`.
fn temporary_prefix(path: &Path) -> String {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    format!(".{name}.tmp-")
}

/// The directory `path` is in (`.` for a bare file name).
fn directory_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Creates a new, empty temporary file beside `path` that no other writer has.
fn create_temporary(path: &Path) -> io::Result<(File, Temporary)> {
    remove_stale_temporaries(path);
    let prefix = temporary_prefix(path);
    let directory = directory_of(path);
    // A name is only taken again if another process with our id left it behind; then try anew.
    let mut last = None;
    for _ in 0..16 {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let nanos = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        // RandomState is seeded randomly per process: hashing the time and counter through it
        // gives a part no other process predicts.
        let mut hasher = RandomState::new().build_hasher();
        hasher.write_u128(nanos);
        hasher.write_u64(n);
        let random = hasher.finish();
        let candidate = directory.join(format!("{prefix}{}-{n}-{random:016x}", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&candidate) {
            Ok(file) => {
                let guard = Temporary {
                    path: candidate,
                    committed: false,
                };
                return Ok((file, guard));
            }
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| io::Error::other("no free temporary name")))
}

/// Syncs `directory` so that a rename in it is durable; best effort (see [`write_atomically`]).
fn sync_directory(directory: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(directory) {
        let _ = d.sync_all();
    }
    // Elsewhere a directory cannot be opened as a file; the rename is as durable as it gets.
    #[cfg(not(unix))]
    let _ = directory;
}

/// The temporary files of `path` left in its directory (none, after any write returned).
#[cfg(test)]
pub(crate) fn temporaries(path: &Path) -> Vec<PathBuf> {
    let prefix = temporary_prefix(path);
    let Ok(entries) = std::fs::read_dir(directory_of(path)) else {
        return Vec::new();
    };
    entries
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        .map(|e| e.path())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::sync::{Arc, Barrier};

    #[test]
    fn a_write_replaces_the_target_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        std::fs::write(&path, b"old").unwrap();
        write_atomically(&path, |w| w.write_all(b"new contents")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new contents");
        assert!(temporaries(&path).is_empty());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_failing_callback_leaves_the_target_untouched_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        std::fs::write(&path, b"old").unwrap();
        let err = write_atomically(&path, |w| {
            // Midway: some bytes are written (and flushed to the temporary file) before failing.
            w.write_all(&[7; 100_000])?;
            w.flush()?;
            Err(io::Error::other("the encoder gave up"))
        })
        .unwrap_err();
        assert!(matches!(err, AtomicWriteError::Write { .. }));
        assert_eq!(err.path(), path);
        let message = err.to_string();
        assert!(
            message.contains(&path.display().to_string()) && message.contains("the encoder gave up"),
            "{message}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert!(temporaries(&path).is_empty());
    }

    #[test]
    fn a_panicking_callback_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        std::fs::write(&path, b"old").unwrap();
        let panicked = std::panic::catch_unwind(|| {
            let _ = write_atomically(&path, |w| {
                w.write_all(&[1; 100_000])?;
                w.flush()?;
                assert!(
                    temporaries(&path).len() == 1,
                    "the temporary exists while writing"
                );
                panic!("the writer panicked");
            });
        });
        assert!(panicked.is_err());
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert!(temporaries(&path).is_empty());
    }

    #[test]
    fn concurrent_writers_each_leave_a_whole_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = Arc::new(dir.path().join("shared.bin"));
        const LEN: usize = 1 << 20;
        const WRITERS: u8 = 4;
        for round in 0..4 {
            let barrier = Arc::new(Barrier::new(WRITERS as usize));
            let threads: Vec<_> = (0..WRITERS)
                .map(|k| {
                    let (path, barrier) = (Arc::clone(&path), Arc::clone(&barrier));
                    std::thread::spawn(move || {
                        barrier.wait();
                        write_atomically(&path, |w| {
                            // Small pieces, so that writers sharing one file would interleave.
                            for _ in 0..LEN / 4096 {
                                w.write_all(&[b'a' + k; 4096])?;
                                w.flush()?;
                            }
                            Ok(())
                        })
                    })
                })
                .collect();
            for t in threads {
                t.join().unwrap().unwrap();
            }
            let bytes = std::fs::read(&*path).unwrap();
            assert_eq!(bytes.len(), LEN, "round {round}");
            assert!(
                (0..WRITERS).any(|k| bytes.iter().all(|&b| b == b'a' + k)),
                "round {round}: the file mixes writers"
            );
            assert!(temporaries(&path).is_empty());
        }
    }

    #[test]
    fn an_unwritable_directory_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let blocker = dir.path().join("a-file");
        std::fs::write(&blocker, b"").unwrap();
        // A missing directory, and a "directory" that is a file (refused even to root).
        for path in [
            dir.path().join("missing").join("out.exr"),
            blocker.join("out.exr"),
        ] {
            let err = write_atomically(&path, |w| w.write_all(b"x")).unwrap_err();
            assert!(matches!(err, AtomicWriteError::Write { .. }));
            assert!(err.to_string().contains(&path.display().to_string()), "{err}");
            assert!(!path.exists());
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_failed_rename_is_its_own_error_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        // A non-empty directory cannot be replaced by a file.
        let path = dir.path().join("taken");
        std::fs::create_dir(&path).unwrap();
        std::fs::write(path.join("inside"), b"").unwrap();
        let err = write_atomically(&path, |w| w.write_all(b"x")).unwrap_err();
        assert!(matches!(err, AtomicWriteError::Rename { .. }), "{err}");
        assert!(err.to_string().contains("into place at"), "{err}");
        assert!(temporaries(&path).is_empty());
        assert!(path.join("inside").exists());
    }

    #[test]
    fn temporary_names_are_unique_and_hidden_beside_the_target() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        let (_a, ga) = create_temporary(&path).unwrap();
        let (_b, gb) = create_temporary(&path).unwrap();
        assert_ne!(ga.path, gb.path);
        for g in [&ga, &gb] {
            assert_eq!(g.path.parent(), Some(dir.path()));
            let name = g.path.file_name().unwrap().to_string_lossy().into_owned();
            assert!(
                name.starts_with(&format!(".t.exr.tmp-{}-", std::process::id())),
                "{name}"
            );
        }
        assert_eq!(temporaries(&path).len(), 2);
        drop((ga, gb));
        assert!(temporaries(&path).is_empty());
        assert_eq!(directory_of(Path::new("bare.exr")), PathBuf::from("."));
    }

    #[test]
    fn temporaries_of_dead_processes_are_removed_by_the_next_write() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.exr");
        // A process id above Linux's pid_max (4194304) never runs; ours does.
        let dead = dir.path().join(".t.exr.tmp-4194305-0-00000000deadbeef");
        let ours = dir
            .path()
            .join(format!(".t.exr.tmp-{}-999999-0", std::process::id()));
        let other_target = dir.path().join(".u.exr.tmp-4194305-0-0");
        for p in [&dead, &ours, &other_target] {
            std::fs::write(p, [0u8; 1000]).unwrap();
        }
        check_writable(&path).unwrap();
        assert!(!dead.exists(), "a dead writer's temporary is removed");
        assert!(ours.exists() && other_target.exists());
        assert!(!path.exists());
        assert_eq!(remove_stale_temporaries(&path), 0);
    }
}
