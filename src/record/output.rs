//! Writing to a path the user chose (`--json OUT`, `--out FILE`, the
//! artefacts folder): one function, [`write_output`], with one set of
//! rules, so no command can damage what the user owns.
//!
//! - `-` is standard output (no file named `-` is created).
//! - A symbolic link is followed, through chains of links; the file it
//!   finally names is replaced atomically and the link stays a link. A
//!   dangling link creates the file it points at.
//! - A FIFO or a character device (`/dev/stdout`, `/dev/null`, `/dev/full`,
//!   a named pipe) is opened and written in place, never replaced; a write
//!   error (`/dev/full`'s "no space left on device") is an error naming the
//!   path.
//! - A folder, a block device or a socket is refused with an error.
//! - Anything else (a regular file, or nothing yet) is written atomically
//!   by [`super::atomic`]: temporary file beside it, flush, rename; the
//!   permissions of a replaced file are kept, and stale temporaries of
//!   killed runs in that folder are removed.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::RecordError;
use super::atomic;

/// The path that means standard output.
pub const STDOUT: &str = "-";

/// Most links followed before giving up (as the kernel's `ELOOP` limit).
const MAX_LINKS: usize = 40;

/// Whether `path` means standard output (`-`).
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == STDOUT
}

/// Checks, before a long computation, that `path` can take output by the
/// rules of this module (standard output, a file or nothing yet, a FIFO
/// or character device, through symlinks), so a run does not end by
/// refusing its report. Writes nothing; whether the folder exists and is
/// writable is only known at the write.
pub fn check_output(path: &Path) -> Result<(), RecordError> {
    if is_stdout(path) {
        return Ok(());
    }
    let target = follow_links(path)?;
    match target_kind(&target).map_err(|source| RecordError::Io { path: path.to_path_buf(), source })? {
        Kind::Regular | Kind::InPlace => Ok(()),
        Kind::Refused(what) => Err(refused(path, what)),
    }
}

/// Creates the folder that will hold output file `path` (nothing for `-`
/// or a bare file name), for commands whose default output lies in a
/// folder that may not exist yet.
pub fn create_parent_folder(path: &Path) -> Result<(), RecordError> {
    match path.parent().filter(|d| !d.as_os_str().is_empty() && !is_stdout(path)) {
        Some(dir) => std::fs::create_dir_all(dir).map_err(|source| RecordError::Io { path: dir.to_path_buf(), source }),
        None => Ok(()),
    }
}

/// Writes `bytes` to `path` by the rules of this module.
pub fn write_output(path: &Path, bytes: &[u8]) -> Result<(), RecordError> {
    write_output_with(path, |w| w.write_all(bytes))
}

/// Like [`write_output`], but lets `fill` stream the content into a
/// buffered writer. If `fill` fails, a regular file is left untouched; a
/// device or standard output may have received part of the content.
pub fn write_output_with(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), RecordError> {
    let io_error = |source| RecordError::Io { path: path.to_path_buf(), source };
    if is_stdout(path) {
        let mut out = std::io::stdout().lock();
        return fill(&mut out).and_then(|()| out.flush()).map_err(io_error);
    }
    let target = follow_links(path)?;
    match target_kind(&target).map_err(io_error)? {
        Kind::Regular => atomic::write_atomically_with(&target, |w| fill(w)),
        Kind::InPlace => {
            // No truncate or create: a device or FIFO is written as it is.
            let file = std::fs::OpenOptions::new().write(true).open(&target).map_err(io_error)?;
            let mut w = BufWriter::new(file);
            fill(&mut w).map_err(io_error)?;
            w.into_inner().map_err(|e| io_error(e.into_error()))?;
            Ok(())
        }
        Kind::Refused(what) => Err(refused(path, what)),
    }
}

/// One output of a command: the flag that named it and the path.
#[derive(Debug, Clone, Copy)]
pub struct NamedOutput<'a> {
    /// The flag (`--json`).
    pub flag: &'a str,
    /// The path given.
    pub path: &'a Path,
}

/// Checks, before anything runs, that no output would overwrite one of
/// `inputs` (the files the run reads: through symbolic links and
/// different spellings of the same path) or another output, and that each
/// output's folder exists. Standard output may take one output only.
pub fn check_outputs_apart(outputs: &[NamedOutput<'_>], inputs: &[PathBuf]) -> Result<(), RecordError> {
    for (i, out) in outputs.iter().enumerate() {
        if is_stdout(out.path) {
            if let Some(other) = outputs[..i].iter().find(|o| is_stdout(o.path)) {
                return Err(RecordError::InvalidPath {
                    path: out.path.to_path_buf(),
                    reason: format!(
                        "{} and {} both write to standard output; give one of them a file",
                        other.flag, out.flag
                    ),
                });
            }
            continue;
        }
        if let Some(dir) = out.path.parent().filter(|d| !d.as_os_str().is_empty())
            && !dir.is_dir()
        {
            return Err(RecordError::InvalidPath {
                path: out.path.to_path_buf(),
                reason: format!("{}: the folder {} does not exist", out.flag, dir.display()),
            });
        }
        let identity = FileIdentity::of(out.path);
        if let Some(input) = inputs.iter().find(|input| FileIdentity::of(input) == identity) {
            return Err(RecordError::InvalidPath {
                path: out.path.to_path_buf(),
                reason: format!(
                    "{} would overwrite {}, which this run reads; write the report elsewhere",
                    out.flag,
                    input.display()
                ),
            });
        }
        if let Some(other) = outputs[..i].iter().find(|o| !is_stdout(o.path) && FileIdentity::of(o.path) == identity) {
            return Err(RecordError::InvalidPath {
                path: out.path.to_path_buf(),
                reason: format!(
                    "{} and {} name the same file; one report would replace the other",
                    other.flag, out.flag
                ),
            });
        }
    }
    Ok(())
}

/// What an output flag writes. An existing file is replaced only when it
/// already holds this kind, so a report cannot silently replace a spec, a
/// scene or anything else the user keeps beside it ([`check_replaceable`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// A JSON document (reports, schemas).
    Json,
    /// A JUnit XML report.
    JunitXml,
    /// An SVG picture.
    Svg,
    /// A CommonRoad scenario that safer exported (`author="safer"`).
    CommonRoadExport,
    /// The JSON sidecar of a CommonRoad export
    /// ([`super::commonroad::ExportSidecar`]).
    CommonRoadSidecar,
}

impl OutputKind {
    /// In words, for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Json => "a JSON document",
            Self::JunitXml => "a JUnit report",
            Self::Svg => "an SVG picture",
            Self::CommonRoadExport => "a CommonRoad scenario exported by safer",
            Self::CommonRoadSidecar => "the sidecar of a CommonRoad export by safer",
        }
    }

    /// Whether `head` (a file's first bytes) is this kind.
    fn holds(self, head: &[u8]) -> bool {
        let text = String::from_utf8_lossy(head);
        let text = text.trim_start_matches('\u{feff}').trim_start();
        match self {
            Self::Json => text.starts_with('{') || text.starts_with('['),
            Self::JunitXml => text.starts_with("<?xml") && text.contains("<testsuites"),
            Self::Svg => (text.starts_with("<?xml") || text.starts_with("<svg")) && text.contains("<svg"),
            Self::CommonRoadExport => text.contains("<commonRoad") && text.contains("author=\"safer\""),
            Self::CommonRoadSidecar => {
                text.starts_with('{')
                    && text.contains(&format!("\"format\": \"{}\"", super::commonroad::SIDECAR_FORMAT))
            }
        }
    }
}

/// How many leading bytes [`check_replaceable`] reads to recognise a file.
const SNIFF_BYTES: u64 = 4096;

/// Checks that writing `kind` to `path` replaces nothing the user keeps:
/// `-`, a device, a FIFO, a missing or empty file, or a file that already
/// holds `kind` may be written; any other existing file is refused unless
/// `force` (a command's `--force`) is set. A file the command reads is
/// refused by [`check_outputs_apart`] whatever `force` says.
pub fn check_replaceable(flag: &str, path: &Path, kind: OutputKind, force: bool) -> Result<(), RecordError> {
    use std::io::Read;
    if is_stdout(path) || force {
        return Ok(());
    }
    let target = follow_links(path)?;
    match std::fs::metadata(&target) {
        Ok(m) if m.is_file() && m.len() > 0 => {}
        _ => return Ok(()),
    }
    let mut head = Vec::new();
    std::fs::File::open(&target)
        .and_then(|f| f.take(SNIFF_BYTES).read_to_end(&mut head))
        .map_err(|source| RecordError::Io { path: path.to_path_buf(), source })?;
    if kind.holds(&head) {
        return Ok(());
    }
    Err(RecordError::InvalidPath {
        path: path.to_path_buf(),
        reason: format!(
            "{flag}: the file exists and is not {} safer would replace; choose another path, remove it \
             first, or pass --force where the command has it",
            kind.describe()
        ),
    })
}

/// Checks that `path` names no existing regular file (through links),
/// unless `force`: for outputs a user keeps (a picture, a schema), which
/// are never replaced without asking. `-` and devices always pass.
pub fn check_new_or_forced(flag: &str, path: &Path, force: bool) -> Result<(), RecordError> {
    if force || is_stdout(path) || !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return Ok(());
    }
    Err(RecordError::InvalidPath {
        path: path.to_path_buf(),
        reason: format!("{flag}: the file already exists; pass --force to replace it"),
    })
}

/// What makes two paths the same file: the device and inode of an
/// existing file (after links), else the absolute path of a file not yet
/// there (its folder resolved).
#[derive(Debug, PartialEq, Eq)]
enum FileIdentity {
    Existing(u64, u64),
    Planned(PathBuf),
}

impl FileIdentity {
    fn of(path: &Path) -> Self {
        if let Ok(m) = std::fs::metadata(path) {
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                return FileIdentity::Existing(m.dev(), m.ino());
            }
            #[cfg(not(unix))]
            let _ = m;
        }
        let target = follow_links(path).unwrap_or_else(|_| path.to_path_buf());
        let folder = target.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let folder = std::fs::canonicalize(folder).unwrap_or_else(|_| folder.to_path_buf());
        FileIdentity::Planned(folder.join(target.file_name().unwrap_or_default()))
    }
}

fn refused(path: &Path, what: &str) -> RecordError {
    RecordError::InvalidPath {
        path: path.to_path_buf(),
        reason: format!("it is {what}; give a file path, `-` for standard output, or a FIFO/character device"),
    }
}

/// How a resolved (link-free) path is written.
#[derive(Debug, PartialEq, Eq)]
enum Kind {
    /// A regular file or nothing yet: atomic replacement.
    Regular,
    /// A FIFO or character device: opened and written in place.
    InPlace,
    /// Never written; says what it is.
    Refused(&'static str),
}

fn target_kind(target: &Path) -> std::io::Result<Kind> {
    let meta = match std::fs::symlink_metadata(target) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Kind::Regular),
        Err(e) => return Err(e),
    };
    let ft = meta.file_type();
    if ft.is_file() {
        return Ok(Kind::Regular);
    }
    if ft.is_dir() {
        return Ok(Kind::Refused("a folder"));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() || ft.is_char_device() {
            return Ok(Kind::InPlace);
        }
        if ft.is_block_device() {
            return Ok(Kind::Refused("a block device"));
        }
        if ft.is_socket() {
            return Ok(Kind::Refused("a socket"));
        }
    }
    Ok(Kind::Refused("neither a file nor a device"))
}

/// The path `path` names after following symbolic links (a relative link
/// resolves against the folder holding the link).
fn follow_links(path: &Path) -> Result<PathBuf, RecordError> {
    let mut current = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&current) {
            Ok(m) if m.file_type().is_symlink() => {
                let to =
                    std::fs::read_link(&current).map_err(|source| RecordError::Io { path: current.clone(), source })?;
                current = match current.parent() {
                    Some(dir) if to.is_relative() => dir.join(to),
                    _ => to,
                };
            }
            _ => return Ok(current),
        }
    }
    Err(RecordError::InvalidPath {
        path: path.to_path_buf(),
        reason: format!("more than {MAX_LINKS} symbolic links to follow"),
    })
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::FileTypeExt;

    use crate::record::atomic::tests::{entries, scratch_dir_of};

    fn scratch_dir(name: &str) -> tempfile::TempDir {
        scratch_dir_of("output", name)
    }

    #[test]
    fn a_symlink_is_followed_and_stays_a_link() {
        let tmp = scratch_dir("symlink");
        let dir = tmp.path();
        std::fs::create_dir(dir.join("real")).unwrap();
        std::fs::write(dir.join("real/report.json"), b"old").unwrap();
        // Relative, and through a second link, as a user's dotfiles often are.
        std::os::unix::fs::symlink("real/report.json", dir.join("hop")).unwrap();
        std::os::unix::fs::symlink("hop", dir.join("link.json")).unwrap();
        write_output(&dir.join("link.json"), b"new").unwrap();
        for link in ["link.json", "hop"] {
            assert!(std::fs::symlink_metadata(dir.join(link)).unwrap().file_type().is_symlink(), "{link}");
        }
        assert_eq!(std::fs::read(dir.join("real/report.json")).unwrap(), b"new");
        assert_eq!(entries(&dir.join("real")), vec!["report.json".to_string()]);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_dangling_symlink_creates_its_target() {
        let tmp = scratch_dir("dangling");
        let dir = tmp.path();
        std::os::unix::fs::symlink("made.json", dir.join("link.json")).unwrap();
        write_output(&dir.join("link.json"), b"{}").unwrap();
        assert!(std::fs::symlink_metadata(dir.join("link.json")).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(dir.join("made.json")).unwrap(), b"{}");
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_symlink_loop_is_an_error_not_a_hang() {
        let tmp = scratch_dir("loop");
        let dir = tmp.path();
        std::os::unix::fs::symlink("b", dir.join("a")).unwrap();
        std::os::unix::fs::symlink("a", dir.join("b")).unwrap();
        let err = write_output(&dir.join("a"), b"x").unwrap_err();
        assert!(matches!(err, RecordError::InvalidPath { .. }), "{err}");
        assert_eq!(entries(dir), vec!["a".to_string(), "b".to_string()]);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_fifo_is_written_in_place() {
        let tmp = scratch_dir("fifo");
        let dir = tmp.path();
        let fifo = dir.join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status().expect("run mkfifo");
        assert!(made.success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        write_output(&fifo, b"through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), b"through the pipe");
        assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
        assert_eq!(entries(dir), vec!["pipe".to_string()]);
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn dev_null_is_written_in_place() {
        write_output(Path::new("/dev/null"), b"discarded").unwrap();
        assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn dev_full_is_an_error_naming_it_and_stays_a_device() {
        if !Path::new("/dev/full").exists() {
            eprintln!("skipped: no /dev/full here");
            return;
        }
        let err = write_output(Path::new("/dev/full"), b"too much").unwrap_err();
        match &err {
            RecordError::Io { path, source } => {
                assert_eq!(path, Path::new("/dev/full"));
                assert_eq!(source.raw_os_error(), Some(28), "ENOSPC expected: {source}");
            }
            other => panic!("expected an I/O error, got {other}"),
        }
        assert!(err.to_string().contains("/dev/full"), "{err}");
        assert!(std::fs::metadata("/dev/full").unwrap().file_type().is_char_device());
    }

    #[test]
    fn a_folder_is_refused_and_left_alone() {
        let tmp = scratch_dir("folder");
        let dir = tmp.path();
        std::fs::create_dir(dir.join("out")).unwrap();
        assert!(check_output(&dir.join("out")).is_err());
        assert!(check_output(&dir.join("new.json")).is_ok());
        assert!(check_output(Path::new("-")).is_ok() && check_output(Path::new("/dev/null")).is_ok());
        let err = write_output(&dir.join("out"), b"x").unwrap_err();
        assert!(matches!(err, RecordError::InvalidPath { .. }), "{err}");
        assert!(err.to_string().contains("folder"), "{err}");
        assert!(dir.join("out").is_dir());
        assert!(entries(&dir.join("out")).is_empty());
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn dash_means_standard_output() {
        assert!(is_stdout(Path::new("-")));
        assert!(!is_stdout(Path::new("./-")));
        // The bytes go to the test harness's stdout; what matters here is
        // that no file named `-` appears in the working folder.
        let existed = Path::new("-").exists();
        write_output(Path::new("-"), b"").unwrap();
        assert_eq!(Path::new("-").exists(), existed);
    }

    #[test]
    fn a_regular_file_is_replaced_atomically() {
        let tmp = scratch_dir("regular");
        let dir = tmp.path();
        let path = dir.join("report.json");
        write_output(&path, b"one").unwrap();
        write_output_with(&path, |w| w.write_all(b"two")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        assert_eq!(entries(dir), vec!["report.json".to_string()]);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
