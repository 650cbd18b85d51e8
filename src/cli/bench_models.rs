//! `safer bench-models`: latency of the learned models as the generator uses
//! them — the prior's map encoding (once per scenario), one CBV query
//! (features + decoder, batch 1), one full-scene step (features for every
//! agent + decoder in batches of 32) and a batch-20 feasibility query — in
//! tract, single-threaded. As the reference, the same ONNX graphs are timed
//! in onnxruntime and PyTorch in the same run (by the training
//! environment's `training/prior/bench_latency.py`, when it is installed),
//! and the ratios printed side by side.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use super::{CliError, evaluate::load_scenes};
use crate::models::ModelSource;
use crate::models::prior::{PriorVariant, RealismPrior, SCENE_BATCH};
use crate::models::prior_features::{MapTokens, StateHistory, build_query};
use crate::scenario::{AgentState, Scenario};

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

/// Runs the command.
pub(super) fn run(scenes: &Path, models: &ModelSource, repeat: usize) -> Result<ExitCode, CliError> {
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
    println!(
        "safer bench-models: {profile} build, single-threaded tract, median of {repeat} runs; scene {} ({} agents present)",
        scene.id,
        present.len()
    );
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
    println!("{:<52} {:>12}", "tract", "µs");
    println!(
        "{:<52} {:>12.0}",
        format!("map encoding, whole scenario ({} map tokens)", tokens.tokens.len()),
        encode_us
    );
    println!("{:<52} {:>12.0}", "CBV query: features only", features_us);
    println!("{:<52} {:>12.0}", "CBV query: features + decoder (batch 1)", query_us);
    println!(
        "{:<52} {:>12.0}",
        format!("full-scene step: {} agents, decoder batch {SCENE_BATCH}", present.len()),
        scene_us
    );
    let decoder_batch_us = {
        let qs: Vec<_> = present
            .iter()
            .take(SCENE_BATCH)
            .filter_map(|&a| build_query(&history, &bodies, &tokens, &scene.map, a, step))
            .collect();
        let refs: Vec<_> = qs.iter().collect();
        median_us(repeat.min(50), || {
            prior.logits(&refs, &embedding).expect("decoder ran once");
        })
    };
    let decoder_single_us = {
        let q = build_query(&history, &bodies, &tokens, &scene.map, cbv, step).expect("CBV present");
        median_us(repeat, || {
            prior.logits(&[&q], &embedding).expect("decoder ran once");
        })
    };
    println!("{:<52} {:>12.0}", "decoder only, batch 1", decoder_single_us);
    println!("{:<52} {:>12.0}", format!("decoder only, batch {SCENE_BATCH}"), decoder_batch_us);

    // The same graphs in onnxruntime and PyTorch, in this run.
    let python = Path::new("training/.venv/bin/python");
    let script = Path::new("training/prior/bench_latency.py");
    // The reference scripts live in a checkout (training/), whose models/
    // holds the originals of the embedded files.
    let reference_models = match models {
        ModelSource::Folder(dir) => dir.clone(),
        ModelSource::Embedded => PathBuf::from(crate::models::source::MODELS_FOLDER),
    };
    if python.exists() && script.exists() {
        let out = Command::new(python)
            .arg(script)
            .args(["--models", &reference_models.display().to_string(), "--batches", &format!("1,{SCENE_BATCH}")])
            .args(["--repeat", &repeat.to_string()])
            .output()?;
        let text = String::from_utf8_lossy(&out.stdout);
        match text.lines().rev().find_map(|l| serde_json::from_str::<serde_json::Value>(l).ok()) {
            Some(v) => {
                println!("\nreference (same ONNX graph, same machine, this run; single thread):");
                println!("{:<28} {:>12} {:>12} {:>14}", "decoder", "µs", "tract µs", "tract / ref");
                for (engine, key) in [("onnxruntime", "onnxruntime"), ("PyTorch (eager)", "torch")] {
                    for (batch, ours) in [(1, decoder_single_us), (SCENE_BATCH, decoder_batch_us)] {
                        if let Some(us) = v.get(key).and_then(|e| e.get(batch.to_string())).and_then(|x| x.as_f64()) {
                            println!(
                                "{:<28} {:>12.0} {:>12.0} {:>14.2}",
                                format!("{engine}, batch {batch}"),
                                us,
                                ours,
                                ours / us.max(1e-9)
                            );
                        }
                    }
                }
            }
            None => eprintln!(
                "reference run gave no JSON (exit {:?}): {}",
                out.status.code(),
                String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("")
            ),
        }
    } else {
        println!("\n(no reference: install the training environment, see training/README.md)");
    }
    Ok(ExitCode::SUCCESS)
}
