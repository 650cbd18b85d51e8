//! `safer bench-models`: latency of the learned models as the generator uses
//! them — the prior's map encoding (once per scenario), one CBV query
//! (features + decoder, batch 1), one full-scene step (features for every
//! agent + decoder in batches of 32) and a batch-20 feasibility query — in
//! tract, single-threaded. As the reference, the same ONNX graphs are timed
//! in onnxruntime and PyTorch in the same run (by the training
//! environment's `training/prior/bench_latency.py`, when it is installed),
//! and the ratios printed side by side; when it is not installed the
//! report says so (in the table and in `--json OUT`) instead of failing.

use super::*;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use super::{CliError, evaluate::load_scenes};
use safer_scenarios::models::ModelSource;
use safer_scenarios::models::onnx::NodeCost;
use safer_scenarios::models::prior::{PriorVariant, RealismPrior, SCENE_BATCH};
use safer_scenarios::models::prior_features::{MapTokens, StateHistory, build_query};
use safer_scenarios::scenario::{AgentState, Scenario};

struct LogHistory<'a>(&'a Scenario);

impl StateHistory for LogHistory<'_> {
    fn state(&self, step: usize, agent: usize) -> Option<AgentState> {
        self.0.tracks.get(agent).and_then(|t| t.state(step).copied())
    }
    fn agents(&self) -> usize {
        self.0.tracks.len()
    }
}

fn median_us(repeat: usize, mut f: impl FnMut()) -> f64 {
    f();
    let mut times: Vec<Duration> = (0..repeat)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed()
        })
        .collect();
    times.sort();
    times[times.len() / 2].as_secs_f64() * 1e6
}

/// The whole report (`--json`).
#[derive(Debug, serde::Serialize)]
struct BenchModelsReport {
    /// `release` or `debug`.
    profile: &'static str,
    repeat: usize,
    scene: String,
    agents_present: usize,
    map_tokens: usize,
    /// tract, single-threaded, µs.
    tract: TractFigures,
    reference: Reference,
    /// Where the decoder's time goes (`--profile`; empty without it).
    decoder_profiles: Vec<DecoderProfile>,
}

/// Where the decoder's time goes at one batch size: tract's plan timed node
/// by node (the sum exceeds the plain run by the timing overhead).
#[derive(Debug, serde::Serialize)]
struct DecoderProfile {
    batch: usize,
    /// Sum of the node medians, µs.
    total_us: f64,
    /// Time per operator kind, µs, the costliest first.
    per_op: Vec<(String, f64)>,
    /// Every node, the costliest first.
    nodes: Vec<NodeCost>,
}

impl DecoderProfile {
    fn new(batch: usize, nodes: Vec<NodeCost>) -> Self {
        let mut per_op = std::collections::BTreeMap::<String, f64>::new();
        for n in &nodes {
            *per_op.entry(n.op.clone()).or_default() += n.median_us;
        }
        let mut per_op: Vec<_> = per_op.into_iter().collect();
        per_op.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        Self { batch, total_us: nodes.iter().map(|n| n.median_us).sum(), per_op, nodes }
    }

    fn print(&self, out: &mut impl Write, top: usize) -> std::io::Result<()> {
        writeln!(
            out,
            "\ndecoder profile, batch {}: {} nodes, {:.0} µs in all (node medians)",
            self.batch,
            self.nodes.len(),
            self.total_us
        )?;
        writeln!(out, "{:<40} {:>10} {:>7}", "operator", "µs", "share")?;
        for (op, us) in self.per_op.iter().take(top) {
            writeln!(out, "{:<40} {:>10.1} {:>6.1}%", op, us, 100.0 * us / self.total_us.max(1e-9))?;
        }
        writeln!(out, "{:<64} {:<16} {:>10}", "node", "operator", "µs")?;
        for n in self.nodes.iter().take(top) {
            writeln!(out, "{:<64} {:<16} {:>10.1}", n.node, n.op, n.median_us)?;
        }
        Ok(())
    }
}

/// tract's figures, µs (medians).
#[derive(Debug, serde::Serialize)]
struct TractFigures {
    map_encoding_us: f64,
    cbv_query_features_us: f64,
    cbv_query_us: f64,
    full_scene_step_us: f64,
    decoder_batch_1_us: f64,
    /// The batch of `decoder_scene_batch_us`.
    scene_batch: usize,
    decoder_scene_batch_us: f64,
}

/// The onnxruntime / PyTorch reference of the same run.
#[derive(Debug, serde::Serialize)]
struct Reference {
    /// Whether the reference ran and gave figures.
    available: bool,
    /// Why not, in words (`None` when it ran).
    missing_because: Option<String>,
    /// One row per engine and batch size.
    rows: Vec<ReferenceRow>,
    /// Why PyTorch gave no figures while onnxruntime did (its checkpoint is
    /// not on this machine), in words.
    torch_missing_because: Option<String>,
}

/// The decoder in a reference engine against tract.
#[derive(Debug, serde::Serialize)]
struct ReferenceRow {
    /// `onnxruntime` or `torch`.
    engine: String,
    batch: usize,
    reference_us: f64,
    tract_us: f64,
    /// `tract / reference`.
    ratio: f64,
}

/// Runs the command.
pub(super) fn run(
    scenes: &Path,
    models: &ModelSource,
    repeat: usize,
    python: &Path,
    profile_top: Option<usize>,
    json: Option<&Path>,
) -> Result<ExitCode, CliError> {
    if let Some(path) = json {
        super::check_json_report(path)?;
    }
    let mut out = super::table_writer(json);
    let profile = if cfg!(debug_assertions) { "debug" } else { "release" };
    let scenes = load_scenes(scenes, None)?;
    // The busiest scene is the honest case for a full-scene step.
    let scene = scenes
        .iter()
        .max_by_key(|s| (s.tracks.iter().filter(|t| t.state(s.current_step).is_some()).count(), s.id.clone()))
        .ok_or_else(|| CliError::Usage("no scene with an ego and a CBV".into()))?;
    let step = scene.current_step;
    let present: Vec<usize> = (0..scene.tracks.len()).filter(|&i| scene.tracks[i].state(step).is_some()).collect();
    let cbv = scene.cbv.map_or(present[0], |c| c.0);
    writeln!(
        out,
        "safer bench-models: {profile} build, single-threaded tract, median of {repeat} runs; scene {} ({} agents present)",
        scene.id,
        present.len()
    )?;
    let prior = RealismPrior::load(models, PriorVariant::Differential)?;
    let history = LogHistory(scene);
    let bodies: Vec<_> = scene.tracks.iter().map(|t| t.body()).collect();

    let tokens = MapTokens::build(&scene.map);
    let encode_us = median_us(repeat.min(20), || {
        let t = MapTokens::build(&scene.map);
        prior.encode_map(&t).expect("encoding worked once");
    });
    let embedding = prior.encode_map(&tokens)?;
    let query_us = median_us(repeat, || {
        let q = build_query(&history, &bodies, &tokens, &scene.map, cbv, step).expect("CBV present");
        prior.logits(&[&q], &embedding).expect("decoder ran once");
    });
    let features_us = median_us(repeat, || {
        build_query(&history, &bodies, &tokens, &scene.map, cbv, step);
    });
    let scene_us = median_us(repeat.min(50), || {
        let qs: Vec<_> =
            present.iter().filter_map(|&a| build_query(&history, &bodies, &tokens, &scene.map, a, step)).collect();
        let refs: Vec<_> = qs.iter().collect();
        prior.logits(&refs, &embedding).expect("decoder ran once");
    });
    writeln!(out, "{:<52} {:>12}", "tract", "µs")?;
    writeln!(
        out,
        "{:<52} {:>12.0}",
        format!("map encoding, whole scenario ({} map tokens)", tokens.tokens.len()),
        encode_us
    )?;
    writeln!(out, "{:<52} {:>12.0}", "CBV query: features only", features_us)?;
    writeln!(out, "{:<52} {:>12.0}", "CBV query: features + decoder (batch 1)", query_us)?;
    writeln!(
        out,
        "{:<52} {:>12.0}",
        format!("full-scene step: {} agents, decoder batch {SCENE_BATCH}", present.len()),
        scene_us
    )?;
    // One scene batch of real queries, for the decoder-only figure and the profile.
    let scene_queries: Vec<_> = present
        .iter()
        .take(SCENE_BATCH)
        .filter_map(|&a| build_query(&history, &bodies, &tokens, &scene.map, a, step))
        .collect();
    let scene_refs: Vec<_> = scene_queries.iter().collect();
    let decoder_batch_us = median_us(repeat.min(50), || {
        prior.logits(&scene_refs, &embedding).expect("decoder ran once");
    });
    let decoder_single_us = {
        let q = build_query(&history, &bodies, &tokens, &scene.map, cbv, step).expect("CBV present");
        median_us(repeat, || {
            prior.logits(&[&q], &embedding).expect("decoder ran once");
        })
    };
    writeln!(out, "{:<52} {:>12.0}", "decoder only, batch 1", decoder_single_us)?;
    writeln!(out, "{:<52} {:>12.0}", format!("decoder only, batch {SCENE_BATCH}"), decoder_batch_us)?;

    let mut profiles = Vec::new();
    if let Some(top) = profile_top {
        for batch in [1, SCENE_BATCH] {
            let chunk = &scene_refs[..batch.min(scene_refs.len())];
            let nodes = prior.profile_decoder(batch, chunk, &embedding, repeat.min(50))?;
            let profile = DecoderProfile::new(batch, nodes);
            profile.print(&mut out, top)?;
            profiles.push(profile);
        }
    }

    // The same graphs in onnxruntime and PyTorch, in this run.
    let script = Path::new("training/prior/bench_latency.py");
    // The reference scripts live in a checkout (training/), whose models/
    // holds the originals of the embedded files.
    let reference_models = match models {
        ModelSource::Folder(dir) => dir.clone(),
        ModelSource::Embedded => PathBuf::from(safer_scenarios::models::source::MODELS_FOLDER),
    };
    let mut reference =
        Reference { available: false, missing_because: None, rows: Vec::new(), torch_missing_because: None };
    if python.exists() && script.exists() {
        let ran = Command::new(python)
            .arg(script)
            .args(["--models", &reference_models.display().to_string(), "--batches", &format!("1,{SCENE_BATCH}")])
            .args(["--repeat", &repeat.to_string()])
            .output();
        match ran {
            Ok(ran) => {
                let text = String::from_utf8_lossy(&ran.stdout);
                match text.lines().rev().find_map(|l| serde_json::from_str::<serde_json::Value>(l).ok()) {
                    Some(v) => {
                        for key in ["onnxruntime", "torch"] {
                            for (batch, ours) in [(1, decoder_single_us), (SCENE_BATCH, decoder_batch_us)] {
                                if let Some(us) =
                                    v.get(key).and_then(|e| e.get(batch.to_string())).and_then(|x| x.as_f64())
                                {
                                    reference.rows.push(ReferenceRow {
                                        engine: key.to_string(),
                                        batch,
                                        reference_us: us,
                                        tract_us: ours,
                                        ratio: ours / us.max(1e-9),
                                    });
                                }
                            }
                        }
                        reference.available = !reference.rows.is_empty();
                        reference.torch_missing_because =
                            v.get("torch_missing_because").and_then(|x| x.as_str()).map(str::to_string);
                        if !reference.available {
                            reference.missing_because = Some(format!("{} gave no figures", script.display()));
                        }
                    }
                    None => {
                        reference.missing_because = Some(format!(
                            "{} gave no JSON (exit {:?}): {}",
                            script.display(),
                            ran.status.code(),
                            String::from_utf8_lossy(&ran.stderr).lines().last().unwrap_or("")
                        ))
                    }
                }
            }
            Err(e) => reference.missing_because = Some(format!("{} could not be started: {e}", python.display())),
        }
    } else {
        reference.missing_because = Some(format!(
            "the training environment is not installed ({} or {} missing; see training/README.md)",
            python.display(),
            script.display()
        ));
    }
    if reference.available {
        writeln!(out, "\nreference (same ONNX graph, same machine, this run; single thread):")?;
        writeln!(out, "{:<28} {:>12} {:>12} {:>14}", "decoder", "µs", "tract µs", "tract / ref")?;
        for r in &reference.rows {
            let engine = if r.engine == "torch" { "PyTorch (eager)" } else { r.engine.as_str() };
            writeln!(
                out,
                "{:<28} {:>12.0} {:>12.0} {:>14.2}",
                format!("{engine}, batch {}", r.batch),
                r.reference_us,
                r.tract_us,
                r.ratio
            )?;
        }
        if let Some(why) = &reference.torch_missing_because {
            writeln!(out, "no PyTorch reference in this run: {why}")?;
        }
    } else {
        writeln!(out, "\nno reference in this run: {}", reference.missing_because.as_deref().unwrap_or("unknown"))?;
    }
    out.flush()?;
    if let Some(path) = json {
        let report = BenchModelsReport {
            profile,
            repeat,
            scene: scene.id.clone(),
            agents_present: present.len(),
            map_tokens: tokens.tokens.len(),
            tract: TractFigures {
                map_encoding_us: encode_us,
                cbv_query_features_us: features_us,
                cbv_query_us: query_us,
                full_scene_step_us: scene_us,
                decoder_batch_1_us: decoder_single_us,
                scene_batch: SCENE_BATCH,
                decoder_scene_batch_us: decoder_batch_us,
            },
            reference,
            decoder_profiles: profiles,
        };
        super::write_json_report(path, &report)?;
        if !safer_scenarios::record::is_stdout(path) {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The arguments of `safer bench-models`.
#[derive(Debug, clap::Args)]
pub(crate) struct BenchModelsArgs {
    /// Scenes to pick the busiest from; `data:REL` is in $SAFER_DATA_DIR.
    #[arg(long, default_value = "data:womd-tfrecord", value_parser = data_path)]
    pub(crate) scenes: PathBuf,
    /// Folder of the models and their cards (default: $SAFER_MODELS, else the models embedded in safer).
    #[arg(long)]
    pub(crate) models: Option<PathBuf>,
    /// Repetitions (the median is reported), at least 1.
    #[arg(long, default_value_t = 200, value_parser = at_least_one())]
    pub(crate) repeat: usize,
    /// Python of the training environment, which times the reference (onnxruntime, PyTorch); without it the report says there is none.
    #[arg(long, default_value = "training/.venv/bin/python")]
    pub(crate) python: PathBuf,
    /// Also print where the decoder's time goes: the N costliest nodes of tract's plan and the time per operator, at batch 1 and the scene batch.
    #[arg(long, value_name = "N")]
    pub(crate) profile: Option<usize>,
    /// Also write the figures as JSON (`-`: standard output, the table then goes to stderr).
    #[arg(long, value_name = "OUT", num_args = 0..=1, default_missing_value = "-")]
    pub(crate) json: Option<PathBuf>,
}

/// Runs `safer bench-models`.
pub(crate) fn command(args: BenchModelsArgs) -> Result<ExitCode, CliError> {
    let BenchModelsArgs { scenes, models, repeat, python, profile, json } = args;
    run(
        &scenes,
        &safer_scenarios::models::ModelSource::folder_or_shipped(models),
        repeat,
        &python,
        profile,
        json.as_deref(),
    )
}
