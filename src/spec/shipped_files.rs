//! The files `safer:` paths name, embedded in the build (the
//! `embedded-files` feature) and unpacked on demand into a cache folder,
//! for a `safer` binary run where the folder it was built from is gone
//! (copied into a CI image, installed on another machine).
//!
//! The cache folder is per version and content: a newer build never reads
//! an older build's files. Unpacking writes a sibling folder and renames
//! it into place, so concurrent runs never see half a copy.

use std::path::{Path, PathBuf};

use include_dir::{Dir, DirEntry, include_dir};
use sha2::{Digest, Sha256};

/// The folders `safer:` paths may name, as they are in the crate.
static SHIPPED: [(&str, Dir<'static>); 5] = [
    ("scenes", include_dir!("$CARGO_MANIFEST_DIR/scenes")),
    ("specs", include_dir!("$CARGO_MANIFEST_DIR/specs")),
    ("planners", include_dir!("$CARGO_MANIFEST_DIR/planners")),
    ("schemas", include_dir!("$CARGO_MANIFEST_DIR/schemas")),
    // The kit the shipped Python planners import (they put ../python on
    // sys.path themselves).
    ("python/safer_planner", include_dir!("$CARGO_MANIFEST_DIR/python/safer_planner")),
];

/// Whether a file belongs in the copy: Python's byte-code caches, left in
/// the source folder by a test run, do not.
fn shipped(path: &Path) -> bool {
    !path.components().any(|c| c.as_os_str() == "__pycache__")
}

fn files() -> Vec<(PathBuf, &'static [u8])> {
    fn walk(dir: &'static Dir<'static>, base: &Path, out: &mut Vec<(PathBuf, &'static [u8])>) {
        for entry in dir.entries() {
            match entry {
                DirEntry::Dir(d) => walk(d, base, out),
                DirEntry::File(f) if shipped(f.path()) => out.push((base.join(f.path()), f.contents())),
                DirEntry::File(_) => {}
            }
        }
    }
    let mut out = Vec::new();
    for (folder, dir) in &SHIPPED {
        // include_dir's paths are relative to the embedded folder.
        let base = Path::new(folder);
        walk(dir, base, &mut out);
    }
    out.sort();
    out
}

/// The cache root: `$SAFER_CACHE_DIR`, else `$XDG_CACHE_HOME/safer`, else
/// `~/.cache/safer`, else the system's temporary folder.
fn cache_root() -> PathBuf {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("SAFER_CACHE_DIR")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("safer")))
        .or_else(|| var("HOME").map(|d| d.join(".cache/safer")))
        .unwrap_or_else(|| std::env::temp_dir().join("safer-cache"))
}

/// This build's folder under `root`, named by version and content hash.
fn cache_dir(root: &Path, files: &[(PathBuf, &[u8])]) -> PathBuf {
    // A content hash (SHA-256, as model files are checked, over each
    // path and its bytes, lengths first): the same build finds its copy
    // again, a different one gets its own.
    let mut hash = Sha256::new();
    for (path, bytes) in files {
        let name = path.to_string_lossy();
        hash.update((name.len() as u64).to_le_bytes());
        hash.update(name.as_bytes());
        hash.update((bytes.len() as u64).to_le_bytes());
        hash.update(bytes);
    }
    let digest: String = hash.finalize().iter().take(8).map(|b| format!("{b:02x}")).collect();
    root.join(format!("shipped-{}-{digest}", env!("CARGO_PKG_VERSION")))
}

/// The folder holding the embedded files, unpacking them into the cache
/// first when no earlier run did. Errors name the folder that could not
/// be written.
pub fn unpacked() -> Result<PathBuf, String> {
    unpack_into(&cache_root())
}

fn unpack_into(root: &Path) -> Result<PathBuf, String> {
    let files = files();
    let dir = cache_dir(root, &files);
    if dir.join(".complete").is_file() {
        return Ok(dir);
    }
    let parent = dir.parent().unwrap_or(Path::new("."));
    let fail = |what: &str, path: &Path, e: std::io::Error| {
        format!("could not unpack safer's shipped files: {what} {}: {e}", path.display())
    };
    std::fs::create_dir_all(parent).map_err(|e| fail("creating", parent, e))?;
    let staging = parent.join(format!(".unpacking-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&staging);
    for (path, bytes) in &files {
        let target = staging.join(path);
        if let Some(folder) = target.parent() {
            std::fs::create_dir_all(folder).map_err(|e| fail("creating", folder, e))?;
        }
        std::fs::write(&target, bytes).map_err(|e| fail("writing", &target, e))?;
    }
    std::fs::write(staging.join(".complete"), b"").map_err(|e| fail("writing", &staging, e))?;
    match std::fs::rename(&staging, &dir) {
        Ok(()) => Ok(dir),
        // Another run unpacked the same files first: use its copy.
        Err(_) if dir.join(".complete").is_file() => {
            let _ = std::fs::remove_dir_all(&staging);
            Ok(dir)
        }
        Err(e) => Err(fail("moving into place", &dir, e)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_files_are_the_shipped_folders_byte_for_byte() {
        let files = files();
        assert!(files.iter().any(|(p, _)| p == Path::new("specs/scenarios/highway-overtake.yaml")));
        assert!(files.iter().any(|(p, _)| p == Path::new("scenes/ngsim/USA_US101-4_3_T-1.xml")));
        assert!(files.iter().any(|(p, _)| p == Path::new("python/safer_planner/planner.py")));
        let source = Path::new(env!("CARGO_MANIFEST_DIR"));
        for (path, bytes) in &files {
            assert!(shipped(path), "{}", path.display());
            assert_eq!(std::fs::read(source.join(path)).unwrap(), *bytes, "{}", path.display());
        }
    }

    #[test]
    fn unpacking_twice_reuses_the_first_copy() {
        let root = tempfile::tempdir().unwrap();
        let first = unpack_into(root.path()).unwrap();
        let planner = first.join("planners/lane_follower.py");
        assert!(planner.is_file());
        std::fs::write(first.join("marker"), b"").unwrap();
        let second = unpack_into(root.path()).unwrap();
        assert_eq!(first, second);
        assert!(second.join("marker").is_file(), "a complete copy is not unpacked again");
        let leftovers: Vec<_> = std::fs::read_dir(root.path()).unwrap().collect();
        assert_eq!(leftovers.len(), 1, "no staging folder is left behind");
    }
}
