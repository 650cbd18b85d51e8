//! Atomic artefact writes: the bytes go to a temporary file in the target's
//! own directory, are flushed to disk, and only then renamed over the
//! target. A reader (a person opening the picture, Foxglove opening the
//! recording, a CI job collecting artefacts) therefore sees either the old
//! file or the complete new one, never a half-written one; a failed write
//! removes its temporary file and leaves the target untouched.
//!
//! The temporary file sits in the same directory because `rename` is only
//! atomic within one file system. Its name is hidden (leading dot) and
//! unique per process and per call, so parallel test trials that write
//! artefacts into one folder never trip over each other's temporaries.
//!
//! A process killed mid-write leaves its temporary behind. Every write
//! therefore first removes, from the folder it writes into, the
//! temporaries of processes that no longer exist ([`remove_stale_temporaries`]):
//! only files whose name matches our marker exactly
//! (`.<name>.safer-tmp-<pid>-<n>`), never anything else. A process counts
//! as gone when `/proc/<pid>` does not exist (Linux, with `/proc` mounted);
//! elsewhere a temporary older than an hour counts as abandoned. Either way
//! a temporary younger than a minute is left alone, so a writer in another
//! PID namespace sharing the folder is not disturbed mid-write.
//!
//! A replaced file keeps its permission bits. The rules for *which* path
//! to write (standard output, symlinks, devices) live in
//! [`super::output`]; this module only knows regular files.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, SystemTime};

use super::RecordError;

/// Distinguishes temporaries of concurrent writes within one process.
static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

/// Marker in temporary file names, so leftovers of a killed process are
/// recognisable (`.<name>.safer-tmp-<pid>-<n>`).
pub const TEMP_MARKER: &str = ".safer-tmp-";

/// Writes `bytes` to `path` atomically (temporary file in the same
/// directory, flush, rename). The directory must exist.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), RecordError> {
    write_atomically_with(path, |w| w.write_all(bytes))
}

/// Like [`write_atomically`], but lets `fill` stream the content into a
/// buffered writer (for artefacts too large to assemble in memory first).
/// If `fill` fails, the temporary file is removed and `path` is untouched.
pub fn write_atomically_with(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), RecordError> {
    let io_error = |source| RecordError::Io { path: path.to_path_buf(), source };
    let temp = temp_path(path)?;
    remove_stale_temporaries(parent_dir(path));
    let file = OpenOptions::new().write(true).create_new(true).open(&temp).map_err(io_error)?;
    let result = (|| {
        // The replacement keeps the permissions of the file it replaces.
        if let Ok(old) = std::fs::metadata(path)
            && old.is_file()
        {
            file.set_permissions(old.permissions())?;
        }
        let mut w = BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        // Without the sync a power loss after the rename could leave an
        // empty file under the final name on some file systems.
        file.sync_all()?;
        drop(file);
        std::fs::rename(&temp, path)
    })();
    match result {
        Ok(()) => {
            sync_directory(path);
            Ok(())
        }
        Err(source) => {
            // Best effort: the write already failed, and that is the error to report.
            let _ = std::fs::remove_file(&temp);
            Err(io_error(source))
        }
    }
}

/// The temporary file for `path`: hidden, beside it, unique per call.
fn temp_path(path: &Path) -> Result<PathBuf, RecordError> {
    let Some(name) = path.file_name() else {
        return Err(RecordError::InvalidPath { path: path.to_path_buf(), reason: "it names no file".into() });
    };
    let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
    let mut temp_name = std::ffi::OsString::from(".");
    temp_name.push(name);
    temp_name.push(format!("{TEMP_MARKER}{}-{n}", std::process::id()));
    Ok(path.with_file_name(temp_name))
}

/// The folder `path` sits in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// The process id in a temporary's file name, when the name matches our
/// marker exactly: `.<name>.safer-tmp-<pid>-<n>` with a non-empty name and
/// decimal `pid` and `n`.
pub fn temporary_owner(file_name: &std::ffi::OsStr) -> Option<u32> {
    let name = file_name.to_str()?;
    let (before, after) = name.rsplit_once(TEMP_MARKER)?;
    let target = before.strip_prefix('.')?;
    let (pid, n) = after.split_once('-')?;
    let decimal = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if target.is_empty() || !decimal(pid) || !decimal(n) {
        return None;
    }
    pid.parse().ok()
}

/// A temporary younger than this is never removed (its writer may live in
/// another PID namespace).
const MIN_STALE_AGE: Duration = Duration::from_secs(60);

/// Where `/proc` is missing, a temporary older than this counts as abandoned.
const ABANDONED_AGE: Duration = Duration::from_secs(3600);

/// Whether the process that created a temporary last modified at
/// `modified` may still be writing it.
fn writer_may_be_alive(pid: u32, modified: SystemTime) -> bool {
    let age = SystemTime::now().duration_since(modified).unwrap_or(Duration::ZERO);
    if age < MIN_STALE_AGE || pid == std::process::id() {
        return true;
    }
    if cfg!(target_os = "linux") && Path::new("/proc/self").exists() {
        return Path::new("/proc").join(pid.to_string()).exists();
    }
    age < ABANDONED_AGE
}

/// Removes from `dir` the temporaries left by writers that no longer exist
/// (see the module documentation for the rule); returns how many it
/// removed. Best effort: a folder or file that cannot be read or removed is
/// skipped, because a leftover temporary never makes a write wrong.
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let mut removed = 0;
    for entry in entries.flatten() {
        let Some(pid) = temporary_owner(&entry.file_name()) else { continue };
        // Not followed: a symlink or folder with our name is not ours to remove.
        let Ok(meta) = std::fs::symlink_metadata(entry.path()) else { continue };
        let Ok(modified) = meta.modified() else { continue };
        if meta.is_file() && !writer_may_be_alive(pid, modified) && std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Makes the rename itself durable where the platform allows it; failure
/// only weakens durability, never correctness, so it is ignored.
fn sync_directory(path: &Path) {
    #[cfg(unix)]
    {
        if let Ok(d) = File::open(parent_dir(path)) {
            let _ = d.sync_all();
        }
    }
    #[cfg(not(unix))]
    let _ = path;
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A fresh, empty folder for one test of `module`, removed (with all
    /// in it) when dropped.
    pub(in crate::record) fn scratch_dir_of(module: &str, name: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("safer-record-{module}-{name}-")).tempdir().unwrap()
    }

    fn scratch_dir(name: &str) -> tempfile::TempDir {
        scratch_dir_of("atomic", name)
    }

    /// The names in `dir`, sorted.
    pub(in crate::record) fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    #[test]
    fn atomic_write_replaces_the_file_and_leaves_no_temporary() {
        let tmp = scratch_dir("replace");
        let dir = tmp.path();
        let path = dir.join("a.svg");
        write_atomically(&path, b"first").unwrap();
        write_atomically(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert_eq!(entries(dir), vec!["a.svg".to_string()]);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn atomic_write_into_a_missing_directory_fails_without_leftovers() {
        let tmp = scratch_dir("missing");
        let dir = tmp.path();
        let path = dir.join("no-such-dir").join("a.mcap");
        let err = write_atomically(&path, b"x").unwrap_err();
        assert!(matches!(err, RecordError::Io { .. }), "{err}");
        assert!(err.to_string().contains("a.mcap"), "{err}");
        assert!(entries(dir).is_empty());
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn atomic_write_failing_midway_keeps_the_old_file() {
        let tmp = scratch_dir("midway");
        let dir = tmp.path();
        let path = dir.join("a.mcap");
        write_atomically(&path, b"old").unwrap();
        let err = write_atomically_with(&path, |w| {
            w.write_all(b"half of the new")?;
            Err(std::io::Error::other("simulated failure"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("simulated failure"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(dir), vec!["a.mcap".to_string()]);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn atomic_write_keeps_the_permissions_of_the_file_it_replaces() {
        use std::os::unix::fs::PermissionsExt;
        let tmp = scratch_dir("mode");
        let dir = tmp.path();
        let path = dir.join("report.json");
        write_atomically(&path, b"old").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_atomically(&path, b"new").unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode() & 0o777, 0o640);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn temporary_names_match_only_the_exact_marker() {
        let owner = |s: &str| temporary_owner(std::ffi::OsStr::new(s));
        assert_eq!(owner(".a.svg.safer-tmp-123-4"), Some(123));
        assert_eq!(owner(".a.safer-tmp-x.safer-tmp-7-0"), Some(7));
        for other in [
            "a.svg.safer-tmp-123-4",
            ".safer-tmp-123-4",
            ".a.svg.safer-tmp-123-4.bak",
            ".a.svg.safer-tmp-123-",
            ".a.svg.safer-tmp--4",
            ".a.svg.safer-tmp-12a-4",
            ".a.svg.safer-tmp-123",
            "a.svg",
        ] {
            assert_eq!(owner(other), None, "{other}");
        }
    }

    /// Makes `path` look written two hours ago.
    #[cfg(target_os = "linux")]
    fn age(path: &Path) {
        let old = SystemTime::now() - Duration::from_secs(7200);
        File::options().write(true).open(path).unwrap().set_modified(old).unwrap();
    }

    /// The pid of a process that has ended (spawned and reaped here).
    #[cfg(target_os = "linux")]
    fn dead_pid() -> u32 {
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        pid
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_write_removes_stale_temporaries_of_dead_writers_and_nothing_else() {
        let tmp = scratch_dir("stale");
        let dir = tmp.path();
        let dead = dead_pid();
        let live = std::process::id();
        let stale = format!(".report.json{TEMP_MARKER}{dead}-0");
        let fresh_dead = format!(".report.json{TEMP_MARKER}{dead}-1");
        let live_one = format!(".report.json{TEMP_MARKER}{live}-99999");
        let lookalike = format!(".report.json{TEMP_MARKER}{dead}-0.keep");
        let folder = format!(".sub{TEMP_MARKER}{dead}-0");
        for name in [&stale, &live_one, &lookalike, &fresh_dead] {
            std::fs::write(dir.join(name), b"x").unwrap();
        }
        std::fs::create_dir(dir.join(&folder)).unwrap();
        for name in [&stale, &live_one, &lookalike] {
            age(&dir.join(name));
        }
        write_atomically(&dir.join("other.svg"), b"picture").unwrap();
        let mut expected = vec![fresh_dead, live_one, lookalike, folder, "other.svg".to_string()];
        expected.sort();
        assert_eq!(entries(dir), expected);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn atomic_write_refuses_a_path_without_a_file_name() {
        let err = write_atomically(Path::new("/"), b"x").unwrap_err();
        assert!(matches!(err, RecordError::InvalidPath { .. }), "{err}");
    }
}
