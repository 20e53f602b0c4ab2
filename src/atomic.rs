//! Atomic file output: write to a temporary name beside the target, rename when complete.
//!
//! An interrupted run therefore never leaves a file under its final name that looks complete.
//! Temporary files are named `.<name>.tmp-<pid>` and are ignored by every reader; those a
//! killed process left behind are removed by the next run of a command that writes the same
//! folder ([`sweep_stale`]).
//!
//! Renames are durable: the temporary's data is flushed to stable storage (`fsync`) before
//! the rename and the folder after it ([`rename_durably`]), so a command that reported success
//! has its outputs on disk even if the machine loses power right after — not only when the
//! process is killed. `MINOS_FSYNC=0` in the environment skips the flushes (scratch outputs
//! on a file system that does not survive a crash anyway; the benches measure their cost).

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The temporary path used while `path` is being written.
pub fn temp_path(path: &Path) -> PathBuf {
    sibling(path, "tmp")
}

/// `.<name>.<kind>-<pid>` beside `path`: a name [`temp_owner`] reads and the sweep removes.
fn sibling(path: &Path, kind: &str) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{kind}-{}", std::process::id()))
}

/// Writes `path` through `fill`, which receives a buffered writer on a temporary file; the
/// file is renamed into place only when `fill` succeeds and the data is flushed.
pub fn write_atomic<T, E, F>(path: &Path, fill: F) -> Result<T, E>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<T, E>,
    E: From<io::Error>,
{
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir)?;
    }
    let tmp = temp_path(path);
    let result = (|| {
        let mut w = BufWriter::with_capacity(1 << 16, File::create(&tmp)?);
        let value = fill(&mut w)?;
        w.flush()?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        if durable() {
            file.sync_all()?;
        }
        drop(file);
        fs::rename(&tmp, path)?;
        sync_dir(parent_of(path))?;
        Ok(value)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// The folder holding `path` (`.` for a bare name).
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Whether renames are made durable: true unless the environment sets `MINOS_FSYNC=0`
/// (read once per process).
pub fn durable() -> bool {
    static DURABLE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *DURABLE.get_or_init(|| std::env::var_os("MINOS_FSYNC").is_none_or(|v| v != "0"))
}

/// Flushes the folder `dir`'s entries (a rename or a new name in it) to stable storage. On
/// platforms where a folder cannot be opened for that, nothing is done; nor with
/// `MINOS_FSYNC=0` ([`durable`]).
pub fn sync_dir(dir: &Path) -> io::Result<()> {
    if !durable() {
        return Ok(());
    }
    #[cfg(unix)]
    {
        File::open(dir)?.sync_all()
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        Ok(())
    }
}

/// Flushes the file at `path`, or every file and folder under the folder at `path`, to
/// stable storage (nothing with `MINOS_FSYNC=0`).
pub fn sync_tree(path: &Path) -> io::Result<()> {
    if !durable() {
        return Ok(());
    }
    if fs::metadata(path)?.is_dir() {
        for entry in fs::read_dir(path)? {
            sync_tree(&entry?.path())?;
        }
        sync_dir(path)
    } else {
        File::open(path)?.sync_all()
    }
}

/// Renames the complete temporary file or folder `tmp` to `path` durably: its data flushed
/// to stable storage first ([`sync_tree`]), then the rename, then the folder holding `path`.
pub fn rename_durably(tmp: &Path, path: &Path) -> io::Result<()> {
    sync_tree(tmp)?;
    fs::rename(tmp, path)?;
    sync_dir(parent_of(path))
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic(path, |w| w.write_all(bytes))
}

/// Writes `bytes` to `path` atomically (a temporary file renamed into place) but without
/// flushing it to stable storage: for the many files of one unit of work (a generated house)
/// that [`sync_filesystem`] then flushes at once, before the unit's completion marker is
/// written with [`write_bytes_atomic`]. One flush instead of one per file.
pub fn write_bytes_staged(path: &Path, bytes: &[u8]) -> io::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir)?;
    }
    let tmp = temp_path(path);
    let result = fs::write(&tmp, bytes).and_then(|()| fs::rename(&tmp, path));
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// Flushes everything written to the file system holding `path` (files and renames) to
/// stable storage: Linux's `syncfs`, elsewhere every file and folder under `path`
/// ([`sync_tree`]). Nothing with `MINOS_FSYNC=0` ([`durable`]).
pub fn sync_filesystem(path: &Path) -> io::Result<()> {
    if !durable() {
        return Ok(());
    }
    #[cfg(target_os = "linux")]
    {
        let dir = File::open(path)?;
        rustix::fs::syncfs(&dir).map_err(io::Error::from)
    }
    #[cfg(not(target_os = "linux"))]
    {
        sync_tree(path)
    }
}

/// Removes folder `dir` and everything in it as one step for a reader: `dir` is first
/// renamed to `.<name>.old-<pid>` and only then emptied, so a process killed while removing
/// leaves a temporary folder that the next sweep ([`sweep_stale`]) removes, never a
/// half-emptied `dir` that still looks like what it was. A missing `dir` is already removed.
pub fn remove_dir_atomic(dir: &Path) -> io::Result<()> {
    let old = sibling(dir, "old");
    match fs::rename(dir, &old) {
        Ok(()) => fs::remove_dir_all(&old),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// Puts the finished folder `tmp` (written at [`temp_path`]`(dir)`) in place of `dir` as
/// one step for a reader: `tmp`'s files are synced, an existing `dir` is renamed to
/// `.<name>.old-<pid>`, `tmp` takes its name (and the parent folder is synced), then the old
/// copy is removed. When `tmp` cannot take the name, the old `dir` is put back. A process
/// killed in between leaves the old `dir` or the new one, and a temporary folder that the
/// next sweep ([`sweep_stale`]) removes.
pub fn replace_dir(tmp: &Path, dir: &Path) -> io::Result<()> {
    sync_tree(tmp)?;
    let old = sibling(dir, "old");
    let moved = match fs::rename(dir, &old) {
        Ok(()) => true,
        Err(e) if e.kind() == io::ErrorKind::NotFound => false,
        Err(e) => return Err(e),
    };
    if let Err(e) = fs::rename(tmp, dir) {
        if moved {
            let _ = fs::rename(&old, dir);
        }
        return Err(e);
    }
    sync_dir(parent_of(dir))?;
    match fs::remove_dir_all(&old) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    }
}

/// The process id in a temporary name — `.<name>.tmp-<pid>`, or `.<name>.old-<pid>` for a
/// folder being replaced — or `None` for any other name.
pub fn temp_owner(file_name: &str) -> Option<u32> {
    temp_of(file_name).map(|(_, pid)| pid)
}

/// The final name and the process id of a temporary name.
fn temp_of(file_name: &str) -> Option<(&str, u32)> {
    let rest = file_name.strip_prefix('.')?;
    let (stem, pid) = rest.rsplit_once('-')?;
    let pid: u32 = pid.parse().ok()?;
    let name = stem
        .strip_suffix(".tmp")
        .or_else(|| stem.strip_suffix(".old"))?;
    (!name.is_empty()).then_some((name, pid))
}

/// True when process `pid` is running, as far as this platform can tell without asking the
/// kernel directly: on Linux, when `/proc/<pid>` exists; elsewhere never (the caller holds
/// the folder's writer lock, so no other process writes there).
fn process_alive(pid: u32) -> bool {
    Path::new("/proc/self").exists() && Path::new("/proc").join(pid.to_string()).exists()
}

/// Removes the temporary files and folders in `dir` (not below it) that another process left
/// behind: those of a process that is no longer running. This process's own and a live
/// process's are kept. Returns what was removed, sorted; a missing `dir` has nothing to sweep.
///
/// Every command that writes a folder calls it before writing, under the folder's lock
/// ([`crate::lock`]), so files of a killed run never outlive the next run.
pub fn sweep_stale(dir: &Path) -> io::Result<Vec<PathBuf>> {
    sweep_where(dir, |_| true)
}

/// Removes the temporary files a process that is no longer running left while writing
/// `path` (and nothing else of its folder): for a command that writes one file into a folder
/// it does not own. Returns what was removed, sorted.
pub fn sweep_stale_of(path: &Path) -> io::Result<Vec<PathBuf>> {
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return Ok(Vec::new());
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    sweep_where(dir, |of| of == name)
}

/// Removes the temporary entries of `dir` that a process no longer running left while
/// writing the entries whose final name `wanted` accepts (for a writer that shares `dir` with
/// others, such as a bake shard).
pub fn sweep_stale_where(dir: &Path, wanted: impl Fn(&str) -> bool) -> io::Result<Vec<PathBuf>> {
    sweep_where(dir, wanted)
}

/// Removes the dead processes' temporary entries of `dir` whose final name `wanted` accepts.
fn sweep_where(dir: &Path, wanted: impl Fn(&str) -> bool) -> io::Result<Vec<PathBuf>> {
    let entries = match fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    let me = std::process::id();
    let mut removed = Vec::new();
    for entry in entries {
        let entry = entry?;
        let name = entry.file_name();
        let name = name.to_string_lossy();
        let Some((of, pid)) = temp_of(&name) else {
            continue;
        };
        if pid == me || !wanted(of) || process_alive(pid) {
            continue;
        }
        let path = entry.path();
        let gone = if entry.file_type()?.is_dir() {
            fs::remove_dir_all(&path)
        } else {
            fs::remove_file(&path)
        };
        match gone {
            Ok(()) => removed.push(path),
            Err(e) if e.kind() == io::ErrorKind::NotFound => {}
            Err(e) => return Err(e),
        }
    }
    removed.sort();
    Ok(removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staged_writes_land_whole_and_a_failed_one_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("room").join("fr_0rm_0f.obj");
        write_bytes_staged(&path, b"v 0 0 0\n").unwrap();
        write_bytes_staged(&path, b"v 1 1 1\n").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"v 1 1 1\n");
        sync_filesystem(dir.path()).unwrap();
        // Renaming onto a folder fails: the temporary file is removed, the folder untouched.
        let taken = dir.path().join("taken");
        fs::create_dir_all(taken.join("inside")).unwrap();
        assert!(write_bytes_staged(&taken, b"x").is_err());
        let names: Vec<String> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| temp_owner(n).is_none()), "{names:?}");
        assert!(taken.join("inside").is_dir());
    }

    #[test]
    fn temp_names_are_recognised_and_nothing_else() {
        assert_eq!(temp_owner(".h1.mscene.tmp-42"), Some(42));
        assert_eq!(temp_owner(".lerobot.old-7"), Some(7));
        for other in [
            "h1.mscene",
            ".h1.mscene",
            ".tmp-42",
            ".h1.tmp-x",
            "h1.tmp-42",
            ".minos.lock",
            ".parts",
        ] {
            assert_eq!(temp_owner(other), None, "{other}");
        }
    }

    #[test]
    fn sweep_removes_dead_processes_temps_and_keeps_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // A pid no process has: above the Linux maximum (2^22).
        let dead = 4_194_305 + 17;
        let mine = std::process::id();
        fs::write(d.join(format!(".a.nav.tmp-{dead}")), b"x").unwrap();
        fs::create_dir(d.join(format!(".lerobot.tmp-{dead}"))).unwrap();
        fs::write(d.join(format!(".lerobot.tmp-{dead}/f")), b"x").unwrap();
        fs::write(d.join(format!(".b.nav.tmp-{mine}")), b"x").unwrap();
        fs::write(d.join("a.nav"), b"keep").unwrap();
        fs::create_dir(d.join("sub")).unwrap();
        fs::write(d.join(format!("sub/.c.tmp-{dead}")), b"x").unwrap();
        let removed = sweep_stale(d).unwrap();
        assert_eq!(
            removed,
            vec![
                d.join(format!(".a.nav.tmp-{dead}")),
                d.join(format!(".lerobot.tmp-{dead}")),
            ]
        );
        let mut left: Vec<String> = fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(
            left,
            vec![format!(".b.nav.tmp-{mine}"), "a.nav".into(), "sub".into()]
        );
        assert!(sweep_stale(&d.join("missing")).unwrap().is_empty());
    }

    #[test]
    fn replace_dir_swaps_whole_folders_and_leaves_nothing_beside_them() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("ds");
        for (round, text) in [(0, "first"), (1, "second")] {
            let tmp = temp_path(&out);
            fs::create_dir(&tmp).unwrap();
            fs::write(tmp.join("f"), text).unwrap();
            replace_dir(&tmp, &out).unwrap();
            assert_eq!(
                fs::read_to_string(out.join("f")).unwrap(),
                text,
                "round {round}"
            );
            let names: Vec<_> = fs::read_dir(d.path())
                .unwrap()
                .map(|e| e.unwrap().file_name().into_string().unwrap())
                .collect();
            assert_eq!(names, vec!["ds".to_string()], "round {round}");
        }
        // A temporary folder that cannot take the name (here: none) is an error, and the
        // dataset in place stays where it was.
        let err = replace_dir(&temp_path(&out), &out).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::NotFound);
        assert_eq!(fs::read_to_string(out.join("f")).unwrap(), "second");
        assert_eq!(fs::read_dir(d.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_folder_goes_whole_and_what_a_killed_removal_left_is_swept() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let parts = d.join(".parts");
        fs::create_dir(&parts).unwrap();
        fs::write(parts.join("000007.json"), b"{}").unwrap();
        fs::write(parts.join("000007.obs.parquet"), b"x").unwrap();
        remove_dir_atomic(&parts).unwrap();
        assert_eq!(fs::read_dir(d).unwrap().count(), 0, "nothing left");
        remove_dir_atomic(&parts).expect("a missing folder is removed already");
        // A removal killed midway (after the rename) left a temporary folder, holding part of
        // what was there; `.parts` itself is gone, so no reader takes the rest for the whole.
        let dead = 4_194_305 + 17;
        let left = d.join(format!(".parts.old-{dead}"));
        fs::create_dir(&left).unwrap();
        fs::write(left.join("000007.json"), b"{}").unwrap();
        assert!(!parts.exists());
        assert_eq!(sweep_stale(d).unwrap(), vec![left]);
        assert_eq!(fs::read_dir(d).unwrap().count(), 0);
    }

    #[test]
    fn sweeping_for_one_file_leaves_the_others_temps() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let dead = 4_194_305 + 18;
        fs::write(d.join(format!(".e.parquet.tmp-{dead}")), b"x").unwrap();
        fs::write(d.join(format!(".other.parquet.tmp-{dead}")), b"x").unwrap();
        let removed = sweep_stale_of(&d.join("e.parquet")).unwrap();
        assert_eq!(removed, vec![d.join(format!(".e.parquet.tmp-{dead}"))]);
        assert!(d.join(format!(".other.parquet.tmp-{dead}")).exists());
    }

    #[test]
    fn failed_write_leaves_neither_file_nor_temp() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.bin");
        let r: io::Result<()> = write_atomic(&target, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("interrupted"))
        });
        assert!(r.is_err());
        assert!(!target.exists());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn successful_write_replaces_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("sub/out.txt");
        write_bytes_atomic(&target, b"one").unwrap();
        write_bytes_atomic(&target, b"two").unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"two");
        assert_eq!(fs::read_dir(target.parent().unwrap()).unwrap().count(), 1);
    }

    #[test]
    fn a_folder_renamed_durably_arrives_whole_and_a_missing_one_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let tmp = dir.path().join(".copy.tmp-1");
        fs::create_dir_all(tmp.join("meta")).unwrap();
        fs::write(tmp.join("meta/info.json"), b"{}").unwrap();
        fs::write(tmp.join("README.md"), b"card").unwrap();
        let out = dir.path().join("copy");
        rename_durably(&tmp, &out).unwrap();
        assert!(!tmp.exists());
        assert_eq!(fs::read(out.join("meta/info.json")).unwrap(), b"{}");
        assert_eq!(fs::read(out.join("README.md")).unwrap(), b"card");
        let file = dir.path().join("f.txt");
        write_bytes_atomic(&file, b"abc").unwrap();
        assert_eq!(fs::read(&file).unwrap(), b"abc");
        let missing = rename_durably(&dir.path().join("none"), &dir.path().join("x"));
        assert_eq!(missing.unwrap_err().kind(), io::ErrorKind::NotFound);
    }
}
