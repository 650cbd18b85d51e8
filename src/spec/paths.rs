//! How paths in specs resolve: relative to the spec file's folder, except
//! `data:REL`, which names a file in the shared recorded-data folder
//! (`$SAFER_DATA_DIR`, else `../shared/data` beside the project root, the
//! nearest folder above the spec holding a `Cargo.toml`), so suites over
//! recorded logs work from any checkout.

use std::path::{Path, PathBuf};

/// The shared recorded-data folder for a spec at `spec_dir`.
pub fn data_dir(spec_dir: &Path) -> PathBuf {
    // Set but empty is unset: "" would resolve `data:` against the
    // current folder.
    if let Some(d) = std::env::var_os("SAFER_DATA_DIR").filter(|d| !d.is_empty()) {
        return PathBuf::from(d);
    }
    let start = std::fs::canonicalize(spec_dir).unwrap_or_else(|_| spec_dir.to_path_buf());
    let root = start.ancestors().find(|d| d.join("Cargo.toml").is_file()).map(Path::to_path_buf).unwrap_or(start);
    root.join("../shared/data")
}

/// Resolves a path written in a spec in `spec_dir`.
pub fn resolve(spec_dir: &Path, written: &str) -> PathBuf {
    match written.strip_prefix("data:") {
        Some(rel) => data_dir(spec_dir).join(rel.trim_start_matches('/')),
        None => spec_dir.join(written),
    }
}
