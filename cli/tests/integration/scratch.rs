//! Scratch folders for tests: fresh, named for the test that made them, and
//! deleted with everything in them when the test is done (also when it
//! fails), so repeated `cargo test` runs leave nothing in the temp folder.
//! With `SAFER_TEST_KEEP_SCRATCH=1` they are kept, and their paths printed,
//! for a person to look at what a test made.

use std::ops::Deref;
use std::path::Path;

/// A fresh folder under the temp directory, removed on drop. Derefs to its
/// path, so `dir.join(..)` and `&dir` work as on a `Path`.
#[derive(Debug)]
pub struct Scratch(tempfile::TempDir);

impl Scratch {
    /// A new empty folder whose name starts with `safer-{tag}-`.
    pub fn new(tag: &str) -> Self {
        Self(tempfile::Builder::new().prefix(&format!("safer-{tag}-")).tempdir().expect("create a scratch folder"))
    }
}

impl Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::env::var_os("SAFER_TEST_KEEP_SCRATCH").is_some() {
            let kept = std::mem::replace(&mut self.0, tempfile::tempdir().expect("a placeholder folder")).keep();
            eprintln!("kept scratch folder {}", kept.display());
        }
    }
}
