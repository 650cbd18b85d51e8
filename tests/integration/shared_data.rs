//! Locating the recorded scenes shared beside the repository.

use std::path::PathBuf;

/// The shared data folder: `$SAFER_DATA_DIR`, else `../shared/data` from the
/// crate root. Panics with instructions when it is missing, so a test that
/// needs real data can never pass without it.
pub fn data_dir() -> PathBuf {
    let dir = std::env::var_os("SAFER_DATA_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    assert!(
        dir.is_dir(),
        "recorded scenes not found at {}: put the shared data there or set SAFER_DATA_DIR",
        dir.display()
    );
    dir
}

/// Files directly in `data_dir()/sub` with the extension `ext`, sorted;
/// panics when there are none.
pub fn files(sub: &str, ext: &str) -> Vec<PathBuf> {
    let dir = data_dir().join(sub);
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .collect();
    out.sort();
    assert!(!out.is_empty(), "no .{ext} files in {}", dir.display());
    out
}

/// Every shared scene of every format, imported once per test process (in
/// parallel, returned in path order). Panics naming the file on any import
/// error: the shared data must import cleanly.
pub fn all_scenes() -> &'static [safer::scenario::Scenario] {
    use rayon::prelude::*;
    static SCENES: std::sync::OnceLock<Vec<safer::scenario::Scenario>> = std::sync::OnceLock::new();
    SCENES.get_or_init(|| {
        let paths = safer::scenario::import::discover(&data_dir()).expect("list shared data");
        let loaded: Vec<Vec<safer::scenario::Scenario>> =
            paths.par_iter().map(|p| safer::scenario::import::load(p).unwrap_or_else(|e| panic!("{e}"))).collect();
        loaded.into_iter().flatten().collect()
    })
}
