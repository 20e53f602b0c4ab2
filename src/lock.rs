//! The writer's lock of a folder: one process at a time writes a DATA folder or a run's
//! output folder.
//!
//! The lock is an advisory lock (`flock` on Unix, `LockFileEx` on Windows, through
//! [`std::fs::File::try_lock`]) on `<folder>/.minos.lock`, taken by every command that writes
//! the folder and held until it exits; the operating system releases it when the process dies,
//! `kill -9` included, so a lock is never stale (a dying holder's children can keep it a moment
//! longer, so a writer that finds the named holder gone tries again for up to
//! [`EXITED_HOLDER_GRACE`]). While held, the file says who holds it
//! (`<pid> <command>`), so a second writer fails at once with one line naming the holder, or
//! waits for it ([`LockMode::Wait`]). On release the file is emptied, so an interrupted run and
//! an uninterrupted one leave the same bytes. Readers never take it: a command that only reads
//! a folder is never blocked.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Name of the lock file inside a locked folder.
pub const LOCK_FILE: &str = ".minos.lock";

/// How long a writer keeps trying a lock whose named holder has exited. The lock goes with the
/// holder's last open copy of the lock file, and a child the holder was starting when it died
/// has a copy until it runs its program (the file is close-on-exec): on a loaded machine that
/// can be milliseconds after the holder is gone and reaped.
pub const EXITED_HOLDER_GRACE: Duration = Duration::from_secs(2);

/// What a writer does when another process holds the lock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LockMode {
    /// Fail at once, naming the holder (the default).
    #[default]
    Fail,
    /// Block until the holder finishes.
    Wait,
}

impl LockMode {
    /// [`LockMode::Wait`] when `wait` (the front doors' `--wait` and `wait=True`), else
    /// [`LockMode::Fail`].
    pub fn waiting_if(wait: bool) -> LockMode {
        if wait {
            LockMode::Wait
        } else {
            LockMode::Fail
        }
    }
}

/// Why a folder could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process writes the folder.
    #[error(
        "{}: in use by pid {holder} (minos {command}); wait for it to finish",
        folder.display()
    )]
    Held {
        /// The locked folder.
        folder: PathBuf,
        /// The holder's process id, as its lock file says (`?` when it cannot be read).
        holder: String,
        /// The holder's command.
        command: String,
    },
    /// The folder or its lock file cannot be created or locked.
    #[error("{}: cannot take the writer's lock", path.display())]
    Io {
        /// The lock file (or the folder).
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// A held writer's lock; released (and its file emptied) when dropped or when the process
/// ends.
#[derive(Debug)]
pub struct DirLock {
    file: File,
    path: PathBuf,
    /// Taken with [`DirLock::acquire_shared`]: the file is not this holder's to empty.
    shared: bool,
}

impl DirLock {
    /// Locks `folder` (created if missing) for `command`, a short name such as `ingest`.
    pub fn acquire(folder: &Path, command: &str, mode: LockMode) -> Result<DirLock, LockError> {
        let (mut file, path) = open_lock_file(folder)?;
        let io = |source| LockError::Io {
            path: path.clone(),
            source,
        };
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) if mode == LockMode::Wait => file.lock().map_err(io)?,
            Err(TryLockError::WouldBlock)
                if once_the_exited_holder_lets_go(&mut file, File::try_lock).map_err(io)? => {}
            Err(TryLockError::WouldBlock) => {
                let (holder, command) = holder_of(&mut file);
                return Err(LockError::Held {
                    folder: folder.to_path_buf(),
                    holder,
                    command,
                });
            }
            Err(TryLockError::Error(e)) => return Err(io(e)),
        }
        let me = format!("{} {command}\n", std::process::id());
        (|| {
            file.set_len(0)?;
            file.seek(SeekFrom::Start(0))?;
            file.write_all(me.as_bytes())?;
            file.flush()
        })()
        .map_err(io)?;
        Ok(DirLock {
            file,
            path,
            shared: false,
        })
    }

    /// Takes `folder`'s lock shared with other holders of the shared lock (the shards of one
    /// sharded command writing disjoint files of the folder at once) and against every
    /// exclusive writer: while any shard holds it, [`DirLock::acquire`] fails (or waits), and
    /// while an exclusive writer holds it, so does this. Shared holders leave the file empty,
    /// so an exclusive writer that finds them says "a sharded command".
    pub fn acquire_shared(folder: &Path, mode: LockMode) -> Result<DirLock, LockError> {
        let (mut file, path) = open_lock_file(folder)?;
        let io = |source| LockError::Io {
            path: path.clone(),
            source,
        };
        match file.try_lock_shared() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) if mode == LockMode::Wait => {
                file.lock_shared().map_err(io)?
            }
            Err(TryLockError::WouldBlock)
                if once_the_exited_holder_lets_go(&mut file, File::try_lock_shared)
                    .map_err(io)? => {}
            Err(TryLockError::WouldBlock) => {
                let (holder, held_by) = holder_of(&mut file);
                return Err(LockError::Held {
                    folder: folder.to_path_buf(),
                    holder,
                    command: held_by,
                });
            }
            Err(TryLockError::Error(e)) => return Err(io(e)),
        }
        Ok(DirLock {
            file,
            path,
            shared: true,
        })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        // Emptied before the lock goes, so the next holder never reads a finished one's pid.
        if !self.shared {
            let _ = self.file.set_len(0);
        }
        let _ = self.file.unlock();
    }
}

/// Opens (creating it and its folder if missing) `folder`'s lock file, unlocked.
fn open_lock_file(folder: &Path) -> Result<(File, PathBuf), LockError> {
    let path = folder.join(LOCK_FILE);
    std::fs::create_dir_all(folder).map_err(|source| LockError::Io {
        path: folder.to_path_buf(),
        source,
    })?;
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&path)
        .map_err(|source| LockError::Io {
            path: path.clone(),
            source,
        })?;
    Ok((file, path))
}

/// Whether `lock` (the caller's try-lock) succeeds within [`EXITED_HOLDER_GRACE`] when the
/// held lock file names a holder that no longer runs; `false` at once when the holder runs or
/// is unknown (a shard, a holder not yet written, a platform without the check).
fn once_the_exited_holder_lets_go(
    file: &mut File,
    lock: fn(&File) -> Result<(), TryLockError>,
) -> std::io::Result<bool> {
    if !holder_has_exited(&holder_of(file).0) {
        return Ok(false);
    }
    let start = Instant::now();
    while start.elapsed() < EXITED_HOLDER_GRACE {
        std::thread::sleep(Duration::from_millis(10));
        match lock(file) {
            Ok(()) => return Ok(true),
            Err(TryLockError::WouldBlock) => {}
            Err(TryLockError::Error(e)) => return Err(e),
        }
    }
    Ok(false)
}

/// Whether the process `pid` (as a lock file spells it) is known to have exited.
#[cfg(target_os = "linux")]
fn holder_has_exited(pid: &str) -> bool {
    let Some(pid) = pid.parse().ok().and_then(rustix::process::Pid::from_raw) else {
        return false;
    };
    rustix::process::test_kill_process(pid) == Err(rustix::io::Errno::SRCH)
}

/// Whether the process `pid` is known to have exited: never known here.
#[cfg(not(target_os = "linux"))]
fn holder_has_exited(_pid: &str) -> bool {
    false
}

/// The pid and command a held lock file names (`?` for what cannot be read: the holder may
/// not have written it yet).
fn holder_of(file: &mut File) -> (String, String) {
    let mut text = String::new();
    let _ = file
        .seek(SeekFrom::Start(0))
        .and_then(|_| file.read_to_string(&mut text));
    let mut words = text.split_whitespace();
    let Some(pid) = words.next() else {
        // Shared holders (shards) write nothing.
        return ("?".into(), "shards of a sharded command".into());
    };
    let pid = pid.to_string();
    let command = words.next().unwrap_or("?").to_string();
    (pid, command)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_share_the_lock_and_exclude_exclusive_writers() {
        let dir = tempfile::tempdir().unwrap();
        let a = DirLock::acquire_shared(dir.path(), LockMode::Fail).unwrap();
        let b = DirLock::acquire_shared(dir.path(), LockMode::Fail).unwrap();
        let Err(e) = DirLock::acquire(dir.path(), "ingest", LockMode::Fail) else {
            panic!("shards hold it")
        };
        let e = e.to_string();
        assert!(e.contains("shards of a sharded command"), "{e}");
        drop((a, b));
        let x = DirLock::acquire(dir.path(), "ingest", LockMode::Fail).unwrap();
        let Err(e) = DirLock::acquire_shared(dir.path(), LockMode::Fail) else {
            panic!("a writer holds it")
        };
        let e = e.to_string();
        assert!(e.contains("minos ingest"), "{e}");
        drop(x);
        assert!(DirLock::acquire_shared(dir.path(), LockMode::Fail).is_ok());
    }

    #[test]
    fn a_second_writer_fails_naming_the_holder_and_the_lock_is_released_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let first = DirLock::acquire(dir.path(), "bake", LockMode::Fail).unwrap();
        let text = std::fs::read_to_string(first.path()).unwrap();
        assert_eq!(text, format!("{} bake\n", std::process::id()));
        // A second open file description conflicts even within one process.
        let err = DirLock::acquire(dir.path(), "ingest", LockMode::Fail).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains(&format!("pid {} (minos bake)", std::process::id())),
            "{msg}"
        );
        assert!(!msg.contains('\n'), "{msg}");
        drop(first);
        assert_eq!(std::fs::read(dir.path().join(LOCK_FILE)).unwrap(), b"");
        let again = DirLock::acquire(dir.path(), "ingest", LockMode::Fail).unwrap();
        drop(again);
    }

    /// Takes `folder`'s lock for `command` on another thread; its result is what the lock
    /// file said while that thread held it.
    fn acquire_in_a_thread(
        folder: &Path,
        command: &'static str,
        mode: LockMode,
    ) -> std::thread::JoinHandle<Result<String, LockError>> {
        let folder = folder.to_path_buf();
        std::thread::spawn(move || {
            DirLock::acquire(&folder, command, mode).map(|l| {
                let text = std::fs::read_to_string(l.path()).unwrap_or_default();
                drop(l);
                text
            })
        })
    }

    #[test]
    fn a_writer_waits_out_a_holder_that_has_exited_but_not_one_that_runs() {
        let dir = tempfile::tempdir().unwrap();
        let first = DirLock::acquire(dir.path(), "bake", LockMode::Fail).unwrap();
        // The file names a process that has exited and been reaped, while another open copy
        // of the file (here, this process's `first`) still holds the lock: as when a killed
        // holder's child has not yet run its program.
        let mut gone = std::process::Command::new("true").spawn().unwrap();
        let gone_pid = gone.id();
        gone.wait().unwrap();
        std::fs::write(first.path(), format!("{gone_pid} run\n")).unwrap();
        let second = acquire_in_a_thread(dir.path(), "run", LockMode::Fail);
        std::thread::sleep(Duration::from_millis(200));
        assert!(
            !second.is_finished(),
            "the holder's copy still holds the lock"
        );
        drop(first);
        let text = second.join().unwrap().unwrap();
        assert_eq!(text, format!("{} run\n", std::process::id()));

        // A holder that runs is named at once, not waited for.
        let _held = DirLock::acquire(dir.path(), "bake", LockMode::Fail).unwrap();
        let start = Instant::now();
        let err = DirLock::acquire(dir.path(), "run", LockMode::Fail).unwrap_err();
        assert!(start.elapsed() < EXITED_HOLDER_GRACE / 2, "{err}");
    }

    #[test]
    fn a_waiting_writer_gets_the_lock_when_the_holder_lets_go() {
        let dir = tempfile::tempdir().unwrap();
        let first = DirLock::acquire(dir.path(), "bake", LockMode::Fail).unwrap();
        let waiter = acquire_in_a_thread(dir.path(), "split", LockMode::Wait);
        std::thread::sleep(std::time::Duration::from_millis(100));
        assert!(!waiter.is_finished(), "the waiter must block while held");
        drop(first);
        let text = waiter.join().unwrap().unwrap();
        assert!(text.ends_with(" split\n"), "{text:?}");
    }
}
