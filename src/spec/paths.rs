//! How paths in specs resolve: relative to the spec file's folder, except
//! - `data:REL`, which names a file in the recorded-data folder that
//!   `$SAFER_DATA_DIR` names, so suites over recorded logs work from any
//!   checkout; unset, a `data:` path is refused with a message saying so
//!   ([`data_dir`], [`recorded_data_required`]);
//! - `safer:REL`, which names a file safer itself ships (`scenes/`,
//!   `planners/`, `specs/`), inside the safer crate a planner crate depends
//!   on: its checkout for a path dependency, the unpacked package for a
//!   registry one. A planner crate needs no relative path into safer's tree.

use std::path::{Path, PathBuf};

/// The recorded-data folder: `$SAFER_DATA_DIR`, when set and not empty.
/// Recorded datasets (NGSIM, WOMD, Argoverse 2) are not part of safer;
/// where they come from is in `docs/guide/recorded-data.md`.
pub fn data_dir() -> Option<PathBuf> {
    // Set but empty is unset: "" would resolve `data:` against the
    // current folder.
    std::env::var_os("SAFER_DATA_DIR").filter(|d| !d.is_empty()).map(PathBuf::from)
}

/// Whether a missing recorded-data folder is a failure rather than a
/// reason to skip: in CI (`CI` set, as CI services set it) or with
/// `SAFER_REQUIRE_DATA=1`. A suite over recorded data must never pass
/// unrun where it is meant to run.
pub fn recorded_data_required() -> bool {
    super::env_flag("SAFER_REQUIRE_DATA") || super::env_flag("CI")
}

/// The message of a `data:` path met while `SAFER_DATA_DIR` is unset;
/// [`is_missing_data_dir`] recognises it in an error.
const MISSING_DATA_DIR: &str = "names recorded data, and SAFER_DATA_DIR is not set";

/// Whether an error message comes from a `data:` path met without
/// `SAFER_DATA_DIR` (the test runner lists such suites as ignored).
pub fn is_missing_data_dir(message: &str) -> bool {
    message.contains(MISSING_DATA_DIR)
}

/// The folder holding the files safer ships (`safer:` paths): the
/// crate's folder this library was built from (the checkout of a path
/// dependency, the unpacked package of a registry one) while it still
/// holds them; else, in a build with the `embedded-files` feature (the
/// `safer` command line), the copy embedded in the build, unpacked to a
/// cache folder. `SAFER_SHIPPED_FILES=embedded` uses that copy even where
/// the build folder is present, as on another machine.
pub fn shipped_dir() -> &'static Path {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let built = Path::new(env!("CARGO_MANIFEST_DIR"));
        let forced = std::env::var("SAFER_SHIPPED_FILES").is_ok_and(|v| v == "embedded");
        if !forced && built.join("specs").is_dir() {
            return built.to_path_buf();
        }
        #[cfg(feature = "embedded-files")]
        match super::shipped_files::unpacked() {
            Ok(dir) => return dir,
            Err(e) => eprintln!("warning: {e}"),
        }
        built.to_path_buf()
    })
}

/// Resolves a path written in a spec in `spec_dir`. A `data:` path
/// without `SAFER_DATA_DIR` resolves under a folder named
/// `$SAFER_DATA_DIR`, which does not exist; [`resolve_checked`] refuses it.
pub fn resolve(spec_dir: &Path, written: &str) -> PathBuf {
    if let Some(rel) = written.strip_prefix("data:") {
        data_dir().unwrap_or_else(|| PathBuf::from("$SAFER_DATA_DIR")).join(rel.trim_start_matches('/'))
    } else if let Some(rel) = written.strip_prefix("safer:") {
        shipped_dir().join(rel.trim_start_matches('/'))
    } else {
        spec_dir.join(written)
    }
}

/// [`resolve`], refusing a `data:` or `safer:` path that would leave its
/// folder (`safer:../../etc/passwd`): the prefixes name files inside
/// their roots only; and a `data:` path while `SAFER_DATA_DIR` is unset.
/// The error says why, in a spec author's words.
pub fn resolve_checked(spec_dir: &Path, written: &str) -> Result<PathBuf, String> {
    let (prefix, rel) = match (written.strip_prefix("data:"), written.strip_prefix("safer:")) {
        (Some(rel), _) => ("data:", rel),
        (_, Some(rel)) => ("safer:", rel),
        _ => return Ok(resolve(spec_dir, written)),
    };
    let mut depth = 0usize;
    for part in Path::new(rel.trim_start_matches('/')).components() {
        match part {
            std::path::Component::ParentDir if depth == 0 => {
                return Err(format!(
                    "`{written}` leaves the folder `{prefix}` names ({}); a `{prefix}` path stays inside it",
                    root_words(prefix)
                ));
            }
            std::path::Component::ParentDir => depth -= 1,
            std::path::Component::Normal(_) => depth += 1,
            _ => {}
        }
    }
    if prefix == "data:" && data_dir().is_none() {
        return Err(format!(
            "`{written}` {MISSING_DATA_DIR}: set it to the folder that holds the recorded datasets \
             (docs/guide/recorded-data.md)"
        ));
    }
    Ok(resolve(spec_dir, written))
}

/// What a missing file at `written` needs, for the "does not exist"
/// message: where `data:` and `safer:` paths point.
pub fn missing_hint(written: &str) -> &'static str {
    if written.starts_with("data:") {
        " (recorded data: set SAFER_DATA_DIR to the folder that holds it)"
    } else if written.starts_with("safer:") {
        " (`safer:` names a file safer ships: under scenes/, planners/ or specs/)"
    } else {
        ""
    }
}

fn root_words(prefix: &str) -> &'static str {
    if prefix == "data:" { "the recorded-data folder, SAFER_DATA_DIR" } else { "the files safer ships" }
}

/// Entries a `glob:` walk visits at most before it gives up: a pattern
/// over a huge or endless tree (`/proc/**`) fails instead of hanging.
pub const MAX_GLOB_ENTRIES: usize = 200_000;

/// The files matching `pattern` (`*`, `?` and `[...]` within one path
/// component, `**` across folders), sorted. The walk starts at the
/// pattern's literal folder prefix, does not follow symbolic links to
/// folders (a link back up the tree would never end; linked files match),
/// stays on one file system, goes no deeper than the pattern reaches, and
/// fails after [`MAX_GLOB_ENTRIES`] entries.
pub fn glob_files(pattern: &Path) -> Result<Vec<PathBuf>, String> {
    let text = pattern.to_string_lossy();
    let compiled = glob::Pattern::new(&text).map_err(|e| format!("bad glob: {e}"))?;
    let is_wild = |c: &std::path::Component<'_>| c.as_os_str().to_string_lossy().contains(['*', '?', '[']);
    let components: Vec<std::path::Component<'_>> = pattern.components().collect();
    let literal = components.iter().take_while(|c| !is_wild(c)).count();
    if literal == components.len() {
        return Ok(if pattern.is_file() { vec![pattern.to_path_buf()] } else { Vec::new() });
    }
    let base: PathBuf = components[..literal].iter().collect();
    let base = if base.as_os_str().is_empty() { PathBuf::from(".") } else { base };
    let rest = &components[literal..];
    let max_depth = if rest.iter().any(|c| c.as_os_str() == "**") { usize::MAX } else { rest.len() };
    let options = glob::MatchOptions {
        case_sensitive: true,
        require_literal_separator: true,
        require_literal_leading_dot: false,
    };
    let mut files = Vec::new();
    let walk =
        walkdir::WalkDir::new(&base).follow_links(false).same_file_system(true).min_depth(1).max_depth(max_depth);
    for (visited, entry) in walk.into_iter().enumerate() {
        if visited >= MAX_GLOB_ENTRIES {
            return Err(format!(
                "glob {} visited {MAX_GLOB_ENTRIES} entries under {} without finishing; narrow the pattern",
                pattern.display(),
                base.display()
            ));
        }
        // Unreadable folders (permissions, entries vanishing under /proc)
        // are skipped, as `ls` would report and go on.
        let Ok(entry) = entry else { continue };
        let path = entry.path();
        let matched = if base == Path::new(".") && !text.starts_with("./") {
            path.strip_prefix(".").is_ok_and(|p| compiled.matches_path_with(p, options))
        } else {
            compiled.matches_path_with(path, options)
        };
        if matched && path.is_file() {
            files.push(path.to_path_buf());
        }
    }
    files.sort();
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glob_matches_within_and_across_folders_without_following_links_up() {
        let tmp = tempfile::Builder::new().prefix("safer-glob-").tempdir().unwrap();
        let dir = tmp.path().to_path_buf();
        std::fs::create_dir_all(dir.join("a/b")).unwrap();
        for f in ["x.yaml", "a/y.yaml", "a/b/z.yaml", "a/b/w.txt"] {
            std::fs::write(dir.join(f), "").unwrap();
        }
        #[cfg(unix)]
        std::os::unix::fs::symlink(&dir, dir.join("a/b/loop")).unwrap();
        let names = |pattern: &str| -> Vec<String> {
            glob_files(&dir.join(pattern))
                .unwrap()
                .iter()
                .map(|p| p.strip_prefix(&dir).unwrap().display().to_string())
                .collect()
        };
        assert_eq!(names("*.yaml"), ["x.yaml"]);
        assert_eq!(names("a/*.yaml"), ["a/y.yaml"]);
        assert_eq!(names("**/*.yaml"), ["a/b/z.yaml", "a/y.yaml", "x.yaml"]);
        assert_eq!(names("a/b/z.yaml"), ["a/b/z.yaml"]);
        assert!(names("nothing/*.yaml").is_empty());
        assert!(glob_files(&dir.join("[.yaml")).unwrap_err().contains("bad glob"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_safer_path_names_a_file_the_crate_ships_from_anywhere() {
        let anywhere = Path::new("/nonexistent/planner-crate/specs/suites");
        let scene = resolve(anywhere, "safer:scenes/ngsim/USA_US101-4_3_T-1.xml");
        assert!(scene.is_file(), "{}", scene.display());
        assert_eq!(resolve(anywhere, "safer:/planners/idm.yaml"), shipped_dir().join("planners/idm.yaml"));
        assert_eq!(resolve(anywhere, "scenes/x.xml"), anywhere.join("scenes/x.xml"));
    }

    #[test]
    fn prefixed_paths_stay_inside_their_roots() {
        let here = Path::new("/tmp");
        for escaping in ["safer:../../../../etc/passwd", "data:../..", "safer:scenes/../../x", "data:/../etc"] {
            let e = resolve_checked(here, escaping).unwrap_err();
            assert!(e.contains("stays inside it"), "{escaping}: {e}");
        }
        assert_eq!(
            resolve_checked(here, "safer:scenes/../planners/idm.yaml").unwrap(),
            shipped_dir().join("scenes/../planners/idm.yaml")
        );
        assert_eq!(resolve_checked(here, "../x.yaml").unwrap(), here.join("../x.yaml"));
        assert!(missing_hint("safer:/etc/passwd").contains("safer ships"));
        assert!(missing_hint("data:x").contains("SAFER_DATA_DIR"));
        assert_eq!(missing_hint("x.yaml"), "");
    }

    #[test]
    fn a_glob_over_proc_ends() {
        // Unbounded before: links under /proc lead back to `/`.
        let t0 = std::time::Instant::now();
        let result = glob_files(Path::new("/proc/**/*.yaml"));
        assert!(
            result.as_ref().is_ok_and(|f| f.is_empty()) || result.as_ref().is_err_and(|e| e.contains("narrow")),
            "{result:?}"
        );
        assert!(t0.elapsed() < std::time::Duration::from_secs(60), "{:?}", t0.elapsed());
    }
}
