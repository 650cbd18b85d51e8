//! Decoding an Argoverse 2 scenario parquet into its [`Table`] of tracks
//! (the `argoverse2` feature): on a thread of its own, within a deadline,
//! with the decoder's panics turned into errors that name the file.

use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::Field;

use super::*;
use crate::geometry::Vector2;
use crate::scenario::{AgentId, AgentState};

/// Largest `num_timestamps` accepted: bounds the per-track allocation on
/// hostile input (real files have 110).
const MAX_STEPS: i64 = 10_000;
/// Largest number of per-step state slots (tracks × steps) accepted: a few
/// bytes of run-length-encoded parquet can hold millions of rows, each of
/// which could open a new track. Real scenarios need under 50 000.
const MAX_STATE_SLOTS: usize = 20_000_000;

/// Longest a parquet file may take to decode. A real scenario file takes
/// milliseconds; fuzzing found 77 bytes whose footer keeps the `parquet`
/// crate's metadata decoder busy for seconds, time that grows with such
/// a file, so the decode runs on its own thread and is given up on here.
const PARQUET_DEADLINE: std::time::Duration = std::time::Duration::from_secs(20);

/// [`read_parquet_guarded`] within [`PARQUET_DEADLINE`]. A decode that
/// runs over is left to finish on its thread (nothing can stop it inside
/// the decoder); its file is reported as malformed at once.
pub(super) fn read_parquet_within_deadline(bytes: &[u8], path: &Path) -> Result<Table, ImportError> {
    let (owned, owned_path) = (bytes.to_vec(), path.to_path_buf());
    let (tx, rx) = std::sync::mpsc::channel();
    let spawned = std::thread::Builder::new().name("parquet-decode".into()).spawn(move || {
        let _ = tx.send(read_parquet_guarded(&owned, &owned_path));
    });
    if spawned.is_err() {
        // No thread to spare: decode here, without a deadline.
        return read_parquet_guarded(bytes, path);
    }
    rx.recv_timeout(PARQUET_DEADLINE).unwrap_or_else(|_| {
        Err(ImportError::malformed(
            path,
            FORMAT,
            Location::File,
            format!(
                "corrupt parquet: decoding its metadata took over {} s (a real scenario file takes milliseconds)",
                PARQUET_DEADLINE.as_secs()
            ),
        ))
    })
}

/// [`read_parquet`], with a panic inside the parquet decoder (seen on
/// corrupt files: slice indices out of range) turned into an error for this
/// file instead of taking the caller down.
fn read_parquet_guarded(bytes: &[u8], path: &Path) -> Result<Table, ImportError> {
    match catch_unwind(AssertUnwindSafe(|| read_parquet(bytes, path))) {
        Ok(result) => result,
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("unknown panic");
            Err(ImportError::malformed(
                path,
                FORMAT,
                Location::File,
                format!("corrupt parquet: the decoder failed ({what})"),
            ))
        }
    }
}

/// Columns this importer reads. `observed` (history vs. future) and the
/// timestamps are not needed: every row is a valid state, and the step
/// length is fixed by the dataset.
const COLUMNS: [&str; 12] = [
    "track_id",
    "object_type",
    "timestep",
    "position_x",
    "position_y",
    "heading",
    "velocity_x",
    "velocity_y",
    "scenario_id",
    "focal_track_id",
    "city",
    "num_timestamps",
];
/// Of [`COLUMNS`], the ones a file may lack.
const OPTIONAL_COLUMNS: [&str; 3] = ["focal_track_id", "city", "num_timestamps"];

fn read_parquet(bytes: &[u8], path: &Path) -> Result<Table, ImportError> {
    let err = |location: Location, message: String| ImportError::malformed(path, FORMAT, location, message);
    // `prost` re-exports the `bytes` crate that `parquet` uses for its
    // in-memory `ChunkReader`; see the report on adding `bytes` directly.
    let data = prost::bytes::Bytes::copy_from_slice(bytes);
    let reader = SerializedFileReader::new(data)
        .map_err(|e| err(Location::File, format!("not a readable parquet file: {e}")))?;

    let schema = reader.metadata().file_metadata().schema_descr();
    let names: Vec<String> = schema.root_schema().get_fields().iter().map(|f| f.name().to_string()).collect();
    let mut index = HashMap::new();
    for name in COLUMNS {
        match names.iter().position(|n| n == name) {
            Some(i) => {
                index.insert(name, i);
            }
            None if OPTIONAL_COLUMNS.contains(&name) => {}
            None => return Err(err(Location::Element(format!("column {name}")), "missing column".to_string())),
        }
    }

    let rows = reader.get_row_iter(None).map_err(|e| err(Location::File, format!("cannot read rows: {e}")))?;
    let mut scenario_id: Option<String> = None;
    let mut focal_track_id: Option<String> = None;
    let mut city: Option<String> = None;
    let mut num_steps: Option<usize> = None;
    let mut tracks: Vec<Track> = Vec::new();
    let mut track_of: HashMap<String, usize> = HashMap::new();

    for (row_index, row) in rows.enumerate() {
        let row = row.map_err(|e| err(Location::Element(format!("row {row_index}")), format!("cannot decode: {e}")))?;
        let fields = row.into_columns();
        let cell = Cell { fields: &fields, index: &index, row: row_index, path };

        let this_scenario = cell.string("scenario_id")?;
        match &scenario_id {
            None => scenario_id = Some(this_scenario),
            Some(id) if *id != this_scenario => {
                return Err(cell.error("scenario_id", format!("{this_scenario:?} differs from {id:?} in row 0")));
            }
            Some(_) => {}
        }
        if focal_track_id.is_none() {
            focal_track_id = cell.optional_string("focal_track_id")?;
        }
        if city.is_none() {
            city = cell.optional_string("city")?;
        }
        let steps = match num_steps {
            Some(n) => n,
            None => {
                let n = if index.contains_key("num_timestamps") {
                    let n = cell.integer("num_timestamps")?;
                    if !(1..=MAX_STEPS).contains(&n) {
                        return Err(cell.error("num_timestamps", format!("{n} outside 1..={MAX_STEPS}")));
                    }
                    n as usize
                } else {
                    NUM_STEPS
                };
                num_steps = Some(n);
                n
            }
        };

        let timestep = cell.integer("timestep")?;
        if !(0..steps as i64).contains(&timestep) {
            return Err(cell.error("timestep", format!("{timestep} outside 0..{steps}")));
        }
        let coordinate = |column: &'static str| -> Result<f64, ImportError> {
            let v = cell.number(column)?;
            if v.abs() > MAX_COORDINATE_M {
                return Err(cell.error(
                    column,
                    format!(
                        "{} is more than {} m from the origin",
                        crate::number::shown(v),
                        crate::number::shown(MAX_COORDINATE_M)
                    ),
                ));
            }
            Ok(v)
        };
        let heading_rad =
            crate::scenario::bounds::recorded_heading(cell.number("heading")?).map_err(|e| cell.error("heading", e))?;
        let state = AgentState {
            position: Point2::new(coordinate("position_x")?, coordinate("position_y")?),
            heading_rad,
            velocity_mps: Vector2::new(cell.number("velocity_x")?, cell.number("velocity_y")?),
        };

        let track_id = cell.string("track_id")?;
        let t = match track_of.get(&track_id) {
            Some(&t) => t,
            None => {
                if (tracks.len() + 1).saturating_mul(steps) > MAX_STATE_SLOTS {
                    return Err(cell.error(
                        "track_id",
                        format!(
                            "{} tracks of {steps} steps exceed the limit of {MAX_STATE_SLOTS} states",
                            tracks.len() + 1
                        ),
                    ));
                }
                let object_type = cell.string("object_type")?;
                let (kind, (length_m, width_m)) = kind_and_size(&object_type);
                tracks.push(Track {
                    id: AgentId(track_id.clone()),
                    kind,
                    length_m,
                    width_m,
                    states: vec![None; steps],
                });
                track_of.insert(track_id.clone(), tracks.len() - 1);
                tracks.len() - 1
            }
        };
        let slot = &mut tracks[t].states[timestep as usize];
        if slot.is_some() {
            return Err(cell.error("timestep", format!("track {track_id} has a second row for timestep {timestep}")));
        }
        *slot = Some(state);
    }

    let Some(scenario_id) = scenario_id else {
        return Err(err(Location::File, "no rows".to_string()));
    };
    Ok(Table { scenario_id, focal_track_id, city, num_steps: num_steps.unwrap_or(NUM_STEPS), tracks })
}

/// Typed access to the cells of one row, with errors at `row N, column X`.
struct Cell<'a> {
    fields: &'a [(String, Field)],
    index: &'a HashMap<&'static str, usize>,
    row: usize,
    path: &'a Path,
}

impl Cell<'_> {
    fn error(&self, column: &str, message: String) -> ImportError {
        ImportError::malformed(
            self.path,
            FORMAT,
            Location::Element(format!("row {}, column {column}", self.row)),
            message,
        )
    }

    fn get(&self, column: &'static str) -> Result<&Field, ImportError> {
        self.index
            .get(column)
            .and_then(|&i| self.fields.get(i))
            .filter(|(name, _)| name == column)
            .map(|(_, f)| f)
            .ok_or_else(|| self.error(column, "missing in this row".to_string()))
    }

    fn number(&self, column: &'static str) -> Result<f64, ImportError> {
        let v = match self.get(column)? {
            Field::Double(v) => *v,
            Field::Float(v) => f64::from(*v),
            other => return Err(self.error(column, format!("expected a floating-point number, found {other:?}"))),
        };
        if v.is_finite() { Ok(v) } else { Err(self.error(column, format!("{v} is not a finite number"))) }
    }

    fn integer(&self, column: &'static str) -> Result<i64, ImportError> {
        match self.get(column)? {
            Field::Long(v) => Ok(*v),
            Field::Int(v) => Ok(i64::from(*v)),
            Field::Short(v) => Ok(i64::from(*v)),
            Field::Byte(v) => Ok(i64::from(*v)),
            Field::UInt(v) => Ok(i64::from(*v)),
            Field::UShort(v) => Ok(i64::from(*v)),
            Field::UByte(v) => Ok(i64::from(*v)),
            Field::ULong(v) => i64::try_from(*v).map_err(|_| self.error(column, format!("{v} is too large"))),
            other => Err(self.error(column, format!("expected an integer, found {other:?}"))),
        }
    }

    /// Text from a column the file may lack or leave null.
    fn optional_string(&self, column: &'static str) -> Result<Option<String>, ImportError> {
        if !self.index.contains_key(column) || matches!(self.get(column)?, Field::Null) {
            return Ok(None);
        }
        self.string(column).map(Some)
    }

    fn string(&self, column: &'static str) -> Result<String, ImportError> {
        match self.get(column)? {
            Field::Str(s) => Ok(s.clone()),
            Field::Bytes(b) => {
                b.as_utf8().map(str::to_string).map_err(|_| self.error(column, "text is not UTF-8".to_string()))
            }
            other => Err(self.error(column, format!("expected text, found {other:?}"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parquet_footer_that_keeps_the_decoder_busy_ends_in_an_error() {
        // 77 bytes the fuzzer found: the parquet crate's metadata decoder
        // spends seconds on them (over 30 s under the fuzzer's sanitizer).
        const SLOW: [u8; 77] = [
            66, 66, 163, 163, 163, 163, 6, 249, 250, 121, 242, 249, 249, 249, 249, 6, 207, 206, 206, 206, 6, 6, 250,
            253, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 6, 14, 217, 217, 217, 66, 163, 163, 163, 163, 6, 6, 6, 6, 6, 6, 134, 6,
            6, 6, 6, 6, 6, 6, 6, 6, 250, 253, 6, 6, 6, 6, 6, 6, 0, 64, 0, 0, 0, 80, 65, 82, 49,
        ];
        let started = std::time::Instant::now();
        let err = read_parquet_within_deadline(&SLOW, Path::new("s.parquet")).err().expect("not a parquet file");
        assert!(err.to_string().contains("parquet"), "{err}");
        assert!(started.elapsed() <= PARQUET_DEADLINE + std::time::Duration::from_secs(2));
    }

    #[test]
    fn garbage_parquet_is_an_error() {
        let err = read_parquet_guarded(b"PAR1 not really", Path::new("s.parquet")).err().unwrap().to_string();
        assert!(err.contains("s.parquet") && err.contains("parquet"), "{err}");
    }
}
