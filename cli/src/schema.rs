//! `safer schema KIND [--out FILE] [--force]`: the JSON Schema of a spec kind, for
//! editors. The committed copies under `schemas/` are what spec files point
//! at (`# yaml-language-server: $schema=../../schemas/suite.schema.json`);
//! a test keeps them equal to this output.

use super::*;
use std::path::Path;
use std::process::ExitCode;

use super::CliError;
use safer_scenarios::spec::{SpecKind, json_schema};

/// The schema of `kind` as the text `safer schema` prints and `schemas/`
/// holds: pretty JSON (keys sorted, so regenerating gives the same bytes)
/// with a final newline.
fn schema_text(kind: SpecKind) -> Result<String, CliError> {
    Ok(serde_json::to_string_pretty(&json_schema(kind))? + "\n")
}

pub(super) fn run(kind: SpecKind, out: Option<&Path>, force: bool) -> Result<ExitCode, CliError> {
    if let Some(path) = out {
        // A schema lands beside specs: never over one without asking.
        safer_scenarios::record::check_new_or_forced("--out", path, force)?;
        safer_scenarios::record::output::check_output(path)?;
    }
    let text = schema_text(kind)?;
    match out {
        // Atomic for a file, so an editor watching it never reads half a
        // schema; `-` is stdout, a device is written in place.
        Some(path) => safer_scenarios::record::write_output(path, text.as_bytes())?,
        None => print!("{text}"),
    }
    Ok(ExitCode::SUCCESS)
}

/// The arguments of `safer schema`.
#[derive(Debug, clap::Args)]
pub(crate) struct SchemaArgs {
    /// Which spec.
    #[arg(value_parser = choice(SpecKind::ALL))]
    pub(crate) kind: SpecKind,
    /// Write to this file instead of stdout (`-`: stdout).
    #[arg(long, value_name = "FILE")]
    pub(crate) out: Option<PathBuf>,
    /// Replace an existing file at --out.
    #[arg(long)]
    pub(crate) force: bool,
}

/// Runs `safer schema`.
pub(crate) fn command(args: SchemaArgs) -> Result<ExitCode, CliError> {
    let SchemaArgs { kind, out, force } = args;
    run(kind, out.as_deref(), force)
}
