//! `safer render FILE [--step N] [--out OUT.svg] [--force]`: the top-down
//! picture of a scenario, from a recorded file (any importer format) or an
//! authored scenario spec (`specs/scenarios/*.yaml`).
//!
//! One scenario goes to `--out` (default `<stem>.svg` in the current
//! folder; `-` is standard output); a file holding several (a TFRecord)
//! needs `--out DIR` and gets one `<id>.svg` each. The drawn file is
//! never replaced; other existing files (also behind a symlink) only with
//! `--force`; a FIFO or device is written in place ([`record::output`]).
//! Every check runs before the first write, so a refused call leaves
//! nothing half done.

use super::*;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use super::CliError;
use safer_scenarios::harness::suite::sanitize;
use safer_scenarios::record::{self, SvgOptions};
use safer_scenarios::scenario::{Scenario, import};
use safer_scenarios::spec::{self, scenario::ScenarioSpec};

pub(super) fn run(file: &Path, step: Option<usize>, out: Option<&Path>, force: bool) -> Result<ExitCode, CliError> {
    let scenarios = load(file)?;
    let targets = targets(file, &scenarios, out)?;
    if let Some(k) = step {
        for s in &scenarios {
            if k >= s.num_steps() {
                return Err(CliError::Usage(format!(
                    "--step {k} is outside scenario {} (steps 0..={})",
                    s.id,
                    s.num_steps().saturating_sub(1)
                )));
            }
        }
    }
    // The drawn file is never replaced, even with --force; an existing
    // picture (a link to one counts) only with it.
    for (path, _) in &targets {
        record::check_outputs_apart(&[record::NamedOutput { flag: "--out", path }], &[file.to_path_buf()])?;
        record::check_new_or_forced("--out", path, force)?;
        record::output::check_output(path)?;
    }
    let opts = SvgOptions { step, ..SvgOptions::default() };
    for (path, scenario) in &targets {
        record::write_svg(path, &record::render_scenario_svg(scenario, &opts))?;
        let shown = step.unwrap_or(scenario.current_step);
        let line = format!(
            "wrote {} (scenario {}, step {shown} of 0..={})",
            if record::is_stdout(path) { "standard output".into() } else { path.display().to_string() },
            scenario.id,
            scenario.num_steps().saturating_sub(1)
        );
        // With the picture on stdout, the note goes to stderr.
        if record::is_stdout(path) {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The scenarios in `file`: a scenario spec is built (authored scenes are
/// simulated once into full tracks), anything else goes to the importers.
fn load(file: &Path) -> Result<Vec<Scenario>, CliError> {
    let ext = file.extension().and_then(|e| e.to_str()).unwrap_or_default().to_ascii_lowercase();
    let scenarios = match ext.as_str() {
        "yaml" | "yml" => spec::load_yaml::<ScenarioSpec>(file)?.build()?,
        "mcap" => {
            return Err(CliError::Usage(format!(
                "{}: MCAP recordings open in Foxglove; `safer render` draws scenario files and scenario specs",
                file.display()
            )));
        }
        _ => import::load(file)?,
    };
    if scenarios.is_empty() {
        return Err(CliError::Usage(format!("{}: holds no scenario", file.display())));
    }
    Ok(scenarios)
}

/// Where each scenario's picture goes.
fn targets<'a>(
    file: &Path,
    scenarios: &'a [Scenario],
    out: Option<&Path>,
) -> Result<Vec<(PathBuf, &'a Scenario)>, CliError> {
    let stem = || {
        let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scenario".into());
        PathBuf::from(format!("{}.svg", sanitize(&stem)))
    };
    match (scenarios, out) {
        ([one], None) => Ok(vec![(stem(), one)]),
        ([one], Some(path)) if record::is_stdout(path) => Ok(vec![(path.to_path_buf(), one)]),
        // An existing folder as --out gets the default name inside it.
        ([one], Some(dir)) if dir.is_dir() => Ok(vec![(dir.join(stem()), one)]),
        ([one], Some(path)) => Ok(vec![(path.to_path_buf(), one)]),
        (many, None) => Err(CliError::Usage(format!(
            "{} holds {} scenarios; pass --out DIR to write one <id>.svg per scenario",
            file.display(),
            many.len()
        ))),
        (many, Some(dir)) => {
            if record::is_stdout(dir) {
                return Err(CliError::Usage(format!(
                    "{} holds {} scenarios, so --out must be a folder, not standard output",
                    file.display(),
                    many.len()
                )));
            }
            if dir.exists() && !dir.is_dir() {
                return Err(CliError::Usage(format!(
                    "{} holds {} scenarios, so --out must be a folder, and {} is a file",
                    file.display(),
                    many.len(),
                    dir.display()
                )));
            }
            std::fs::create_dir_all(dir)
                .map_err(|source| record::RecordError::Io { path: dir.to_path_buf(), source })?;
            let mut out: Vec<(PathBuf, &Scenario)> = Vec::new();
            for s in many {
                // Ids are sanitised for file names; two that collide get the index too.
                let mut path = dir.join(format!("{}.svg", sanitize(&s.id)));
                if out.iter().any(|(p, _)| *p == path) {
                    path = dir.join(format!("{}-{}.svg", sanitize(&s.id), out.len()));
                }
                out.push((path, s));
            }
            Ok(out)
        }
    }
}

/// The arguments of `safer render`.
#[derive(Debug, clap::Args)]
pub(crate) struct RenderArgs {
    /// A recorded scenario (.tfrecord, .json, .xml, .parquet / AV2 folder; `data:REL`: in $SAFER_DATA_DIR) or a scenario spec (.yaml).
    #[arg(value_parser = data_path)]
    pub(crate) file: PathBuf,
    /// Step whose footprints are drawn (default: the scenario's current step).
    #[arg(long, value_name = "N")]
    pub(crate) step: Option<usize>,
    /// Output file (default: `<stem>.svg` in the current folder; `-`: standard output); a folder when FILE holds several scenarios.
    #[arg(long, value_name = "OUT")]
    pub(crate) out: Option<PathBuf>,
    /// Overwrite existing pictures.
    #[arg(long)]
    pub(crate) force: bool,
}

/// Runs `safer render`.
pub(crate) fn command(args: RenderArgs) -> Result<ExitCode, CliError> {
    let RenderArgs { file, step, out, force } = args;
    run(&file, step, out.as_deref(), force)
}
