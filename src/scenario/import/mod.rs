//! Importers of recorded logs into [`Scenario`]s, and [`load`], which picks
//! the importer for a path, then re-centres, assigns roles and validates.
//!
//! Every importer takes bytes plus the path they came from (for messages),
//! so fuzz targets and tests can feed them directly. Bad input is an
//! [`ImportError`] that names the file and where in it the problem is;
//! importers never panic.

pub mod argoverse2;
pub mod commonroad;
pub mod tfrecord;
pub mod womd_json;
pub mod womd_proto;

use std::fmt;
use std::path::{Path, PathBuf};

use super::{Scenario, SourceFormat, roles};

/// Where in a file a problem was found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// The file as a whole.
    File,
    /// A byte offset from the start of the file.
    ByteOffset(u64),
    /// A TFRecord record: its index and the byte offset where it starts.
    Record {
        /// Zero-based record index.
        index: usize,
        /// Offset of the record's length field.
        byte_offset: u64,
    },
    /// A line and column in a text file (both 1-based).
    LineColumn {
        /// Line, 1-based.
        line: usize,
        /// Column, 1-based.
        column: usize,
    },
    /// A path to an element, such as `objects[3].heading[17]` or
    /// `row 212, column position_x`.
    Element(String),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::File => f.write_str("whole file"),
            Self::ByteOffset(o) => write!(f, "byte {o}"),
            Self::Record { index, byte_offset } => write!(f, "record {index} (byte {byte_offset})"),
            Self::LineColumn { line, column } => write!(f, "line {line}, column {column}"),
            Self::Element(e) => f.write_str(e),
        }
    }
}

/// Why a file could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}", path = path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not in a format any importer recognises.
    #[error("{path}: not a scenario file this tool reads: {reason}", path = path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// What was looked at.
        reason: String,
    },
    /// The file is in a known format but its content is broken.
    #[error("{path}: {format:?}: {location}: {message}", path = path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// The format it was read as.
        format: SourceFormat,
        /// Where the problem is.
        location: Location,
        /// What is wrong.
        message: String,
    },
}

impl ImportError {
    /// Shorthand for [`ImportError::Malformed`].
    pub fn malformed(path: &Path, format: SourceFormat, location: Location, message: impl Into<String>) -> Self {
        Self::Malformed { path: path.to_path_buf(), format, location, message: message.into() }
    }
}

/// Which importer a path needs, judged from its name and (for JSON) its
/// first bytes.
pub fn detect_format(path: &Path) -> Result<SourceFormat, ImportError> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or_default().to_ascii_lowercase();
    let unknown = |reason: &str| ImportError::UnknownFormat { path: path.to_path_buf(), reason: reason.to_string() };
    if path.is_dir() {
        let has_parquet = std::fs::read_dir(path)
            .map(|rd| rd.filter_map(Result::ok).any(|e| e.path().extension().is_some_and(|x| x == "parquet")))
            .unwrap_or(false);
        return match argoverse2::find_scenario_files(path) {
            Ok(_) => Ok(SourceFormat::Argoverse2),
            // A folder with a parquet: the importer's reason (such as the missing map) is the useful one.
            Err(e) if has_parquet => Err(e),
            Err(_) => Err(unknown(
                "a directory, but not an Argoverse 2 scenario folder (scenario_*.parquet + log_map_archive_*.json)",
            )),
        };
    }
    match ext.as_str() {
        "tfrecord" => Ok(SourceFormat::WomdProto),
        "xml" => Ok(SourceFormat::CommonRoad),
        "parquet" => Ok(SourceFormat::Argoverse2),
        "json" if name.starts_with("log_map_archive_") => {
            Err(unknown("an Argoverse 2 map; pass the scenario_*.parquet beside it or their folder"))
        }
        "json" => Ok(SourceFormat::WomdJson),
        _ if name.contains(".tfrecord") => Ok(SourceFormat::WomdProto),
        // A path that is not there is missing, not of an unknown format (a
        // mistyped `data:` set once read "not a scenario file this tool reads").
        _ if let Err(source) = std::fs::metadata(path) => Err(ImportError::Io { path: path.to_path_buf(), source }),
        _ => Err(unknown(
            "expected .tfrecord (WOMD), .json (WOMD JSON), .xml (CommonRoad) or .parquet / a folder (Argoverse 2)",
        )),
    }
}

/// Reads a recorded file: a regular file only (through links). A FIFO or a
/// device would block or never end: it is refused before it is opened.
fn read(path: &Path) -> Result<Vec<u8>, ImportError> {
    let meta = std::fs::metadata(path).map_err(|source| ImportError::Io { path: path.to_path_buf(), source })?;
    if !meta.is_file() {
        return Err(ImportError::UnknownFormat {
            path: path.to_path_buf(),
            reason: "not a regular file (a FIFO, device or socket is not read: it could block forever)".into(),
        });
    }
    std::fs::read(path).map_err(|source| ImportError::Io { path: path.to_path_buf(), source })
}

/// Reads every scenario in `path` with the importer its format needs, then
/// re-centres each, assigns ego and CBV where the source named none, and
/// checks the invariants. A TFRecord file may hold several scenarios; the
/// other formats hold one.
pub fn load(path: &Path) -> Result<Vec<Scenario>, ImportError> {
    let format = detect_format(path)?;
    let mut scenarios = match format {
        SourceFormat::WomdProto => womd_proto::parse(&read(path)?, path)?,
        SourceFormat::WomdJson => vec![womd_json::parse(&read(path)?, path)?],
        SourceFormat::CommonRoad => vec![commonroad::parse(&read(path)?, path)?],
        SourceFormat::Argoverse2 => {
            let files = argoverse2::find_scenario_files(path)?;
            // parse_files names the map file itself in errors about the map.
            vec![argoverse2::parse_files(&read(&files.scenario)?, &read(&files.map)?, &files)?]
        }
        SourceFormat::Authored => unreachable!("detect_format never returns Authored"),
    };
    let several = scenarios.len() > 1;
    for s in &mut scenarios {
        finish(path, format, s, several)?;
    }
    Ok(scenarios)
}

/// The scenario ids a recorded file holds, in order, when it can hold
/// several (a WOMD TFRecord; read without decoding the scenes); `None` for
/// the formats that hold exactly one.
pub fn scenario_ids(path: &Path) -> Result<Option<Vec<String>>, ImportError> {
    match detect_format(path)? {
        SourceFormat::WomdProto => womd_proto::scenario_ids(&read(path)?, path).map(Some),
        _ => Ok(None),
    }
}

/// The scenario at `index` of a recorded file, loaded as [`load`] loads
/// every one; a TFRecord decodes that record only (a shard holds hundreds).
pub fn load_one(path: &Path, index: usize) -> Result<Scenario, ImportError> {
    let format = detect_format(path)?;
    if format != SourceFormat::WomdProto {
        let mut all = load(path)?;
        return if index < all.len() {
            Ok(all.swap_remove(index))
        } else {
            Err(ImportError::malformed(
                path,
                format,
                Location::File,
                format!("no scenario {index}: the file holds {}", all.len()),
            ))
        };
    }
    let bytes = read(path)?;
    let records = tfrecord::read_records(&bytes, path)?;
    let record = records.get(index).ok_or_else(|| {
        ImportError::malformed(
            path,
            format,
            Location::File,
            format!("no record {index}: the file holds {}", records.len()),
        )
    })?;
    let mut scenario = womd_proto::parse_record(record, path)?;
    finish(path, format, &mut scenario, records.len() > 1)?;
    Ok(scenario)
}

/// What every imported scenario goes through: implausible states and map
/// points and duplicate ids refused, then re-centred, roles assigned and
/// invariants checked. `several`: the file holds more than one scenario
/// (errors then name the scenario).
fn finish(path: &Path, format: SourceFormat, s: &mut Scenario, several: bool) -> Result<(), ImportError> {
    // Before re-centring, which would spread one absurd sample's offset
    // over every other agent (and the map).
    let max_abs_m = super::bounds::MAX_ABS_WORLD_POSITION_M;
    let scenario = if several { format!("scenario {}, ", s.id) } else { String::new() };
    if let Some((track, step, why)) = s.first_implausible_state(max_abs_m) {
        let t = s.track(track);
        let time_s = step as f64 * s.dt_s;
        return Err(ImportError::malformed(
            path,
            format,
            Location::Element(format!("{scenario}agent {} (track {}), step {step} (t = {time_s:.1} s)", t.id, track.0)),
            format!("implausible recorded state: {why}"),
        ));
    }
    // One id, two tracks: the ego and the CBV could share it, and every
    // report naming an agent would be ambiguous.
    let mut seen = std::collections::HashMap::new();
    for (i, t) in s.tracks.iter().enumerate() {
        if let Some(first) = seen.insert(&t.id, i) {
            return Err(ImportError::malformed(
                path,
                format,
                Location::Element(format!("{scenario}agent {}", t.id)),
                format!("two tracks have this id (tracks {first} and {i}); agent ids must be unique"),
            ));
        }
    }
    if let Some((what, p)) = s.map.first_point_outside(max_abs_m) {
        return Err(ImportError::malformed(
            path,
            format,
            Location::Element(format!("{scenario}map {what}")),
            format!(
                "implausible map point ({:e}, {:e}): coordinates must be finite and within ±{max_abs_m:e} m",
                p.x, p.y
            ),
        ));
    }
    s.recentre();
    roles::assign(s);
    s.validate().map_err(|v| ImportError::malformed(path, format, Location::File, v.to_string()))?;
    Ok(())
}

/// Every scenario file under `dir` (recursively), sorted by path, each
/// Argoverse 2 folder counted once.
pub fn discover(dir: &Path) -> Result<Vec<PathBuf>, ImportError> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    // Folders already walked, by their real path: a symbolic link back up
    // the tree would otherwise be walked forever.
    let mut visited = std::collections::HashSet::new();
    while let Some(d) = stack.pop() {
        if !visited.insert(std::fs::canonicalize(&d).unwrap_or_else(|_| d.clone())) {
            continue;
        }
        let entries = std::fs::read_dir(&d).map_err(|source| ImportError::Io { path: d.clone(), source })?;
        for e in entries {
            let p = e.map_err(|source| ImportError::Io { path: d.clone(), source })?.path();
            if p.is_dir() {
                if argoverse2::find_scenario_files(&p).is_ok() {
                    out.push(p);
                } else {
                    stack.push(p);
                }
            } else if !p.is_file() {
                // A FIFO, device or socket is no scenario file (and reading it could block).
                continue;
            } else if detect_format(&p).is_ok() && p.extension().is_none_or(|e| e != "parquet") {
                out.push(p);
            } else if p.extension().is_some_and(|e| e == "parquet") && !out.contains(&d) {
                out.push(d.clone());
            }
        }
    }
    out.sort();
    out.dedup();
    Ok(out)
}
