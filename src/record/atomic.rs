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

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

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
    let file = OpenOptions::new().write(true).create_new(true).open(&temp).map_err(io_error)?;
    let result = (|| {
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

/// Makes the rename itself durable where the platform allows it; failure
/// only weakens durability, never correctness, so it is ignored.
fn sync_directory(path: &Path) {
    #[cfg(unix)]
    {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    #[cfg(not(unix))]
    let _ = path;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("safer-record-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    #[test]
    fn atomic_write_replaces_the_file_and_leaves_no_temporary() {
        let dir = scratch_dir("replace");
        let path = dir.join("a.svg");
        write_atomically(&path, b"first").unwrap();
        write_atomically(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert_eq!(entries(&dir), vec!["a.svg".to_string()]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn atomic_write_into_a_missing_directory_fails_without_leftovers() {
        let dir = scratch_dir("missing");
        let path = dir.join("no-such-dir").join("a.mcap");
        let err = write_atomically(&path, b"x").unwrap_err();
        assert!(matches!(err, RecordError::Io { .. }), "{err}");
        assert!(err.to_string().contains("a.mcap"), "{err}");
        assert!(entries(&dir).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn atomic_write_failing_midway_keeps_the_old_file() {
        let dir = scratch_dir("midway");
        let path = dir.join("a.mcap");
        write_atomically(&path, b"old").unwrap();
        let err = write_atomically_with(&path, |w| {
            w.write_all(b"half of the new")?;
            Err(std::io::Error::other("simulated failure"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("simulated failure"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(&dir), vec!["a.mcap".to_string()]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn atomic_write_refuses_a_path_without_a_file_name() {
        let err = write_atomically(Path::new("/"), b"x").unwrap_err();
        assert!(matches!(err, RecordError::InvalidPath { .. }), "{err}");
    }
}
