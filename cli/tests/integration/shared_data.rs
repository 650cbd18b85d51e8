//! Locating the recorded datasets (`$SAFER_DATA_DIR`).

use std::path::PathBuf;

/// The recorded-data folder, `$SAFER_DATA_DIR`. Panics with instructions
/// when it is unset or missing, so a test that needs real data can never
/// pass without it. Such tests are marked
/// `#[cfg_attr(not(recorded_data), ignore = ...)]`: listed as ignored on a
/// machine without the data, run (and failing loudly) where
/// `SAFER_DATA_DIR`, `CI` or `SAFER_REQUIRE_DATA` is set (`build.rs`).
pub fn data_dir() -> PathBuf {
    let dir = std::env::var_os("SAFER_DATA_DIR").filter(|d| !d.is_empty()).map(PathBuf::from).unwrap_or_else(|| {
        panic!("this test needs the recorded datasets: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")
    });
    assert!(
        dir.is_dir(),
        "recorded scenes not found at {} (SAFER_DATA_DIR): put the recorded datasets there",
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
/// error (the shared data must import cleanly), and when the folder holds no
/// scene at all: a test over "every scene" must not pass on none.
pub fn all_scenes() -> &'static [safer_scenarios::scenario::Scenario] {
    use rayon::prelude::*;
    static SCENES: std::sync::OnceLock<Vec<safer_scenarios::scenario::Scenario>> = std::sync::OnceLock::new();
    SCENES.get_or_init(|| {
        let paths = safer_scenarios::scenario::import::discover(&data_dir()).expect("list shared data");
        let loaded: Vec<Vec<safer_scenarios::scenario::Scenario>> = paths
            .par_iter()
            .map(|p| safer_scenarios::scenario::import::load(p).unwrap_or_else(|e| panic!("{e}")))
            .collect();
        let scenes: Vec<safer_scenarios::scenario::Scenario> = loaded.into_iter().flatten().collect();
        assert!(
            !scenes.is_empty(),
            "no recorded scene in {}: the shared data is missing or empty",
            data_dir().display()
        );
        scenes
    })
}

/// Parse and load timings over the files of an import test, for its report.
#[derive(Debug, Default)]
pub struct ImportTimings {
    parse_total_s: f64,
    load_total_s: f64,
    slowest_parse: (f64, String),
    files: usize,
}

/// One file's import: the loaded scenarios and how long each stage took.
pub struct TimedImport {
    /// The file's bytes.
    pub bytes: Vec<u8>,
    /// What `load` returned (re-centred, roles assigned, validated).
    pub scenarios: Vec<safer_scenarios::scenario::Scenario>,
    /// Time of the format's own `parse`, s.
    pub parse_s: f64,
    /// Time of the whole `load`, s.
    pub load_s: f64,
}

impl ImportTimings {
    /// Runs the importer's `parse` on the file's bytes, then the full
    /// `load`, timing both; panics naming the file on any error.
    pub fn import<T, E: std::fmt::Display>(
        &mut self,
        path: &std::path::Path,
        parse: impl Fn(&[u8], &std::path::Path) -> Result<T, E>,
    ) -> TimedImport {
        use std::time::Instant;
        let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let started = Instant::now();
        parse(&bytes, path).unwrap_or_else(|e| panic!("{e}"));
        let parse_s = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let scenarios = safer_scenarios::scenario::import::load(path).unwrap_or_else(|e| panic!("{e}"));
        let load_s = started.elapsed().as_secs_f64();
        self.parse_total_s += parse_s;
        self.load_total_s += load_s;
        self.files += 1;
        if parse_s > self.slowest_parse.0 {
            self.slowest_parse = (parse_s, path.display().to_string());
        }
        TimedImport { bytes, scenarios, parse_s, load_s }
    }

    /// "parse X ms mean (slowest Y ms, FILE), load Z ms mean".
    pub fn summary(&self) -> String {
        let n = self.files.max(1) as f64;
        format!(
            "parse {:.0} ms mean (slowest {:.0} ms, {}), load {:.0} ms mean",
            self.parse_total_s * 1e3 / n,
            self.slowest_parse.0 * 1e3,
            self.slowest_parse.1,
            self.load_total_s * 1e3 / n
        )
    }
}
