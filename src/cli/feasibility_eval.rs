//! `safer feasibility-eval`: how well the shipped V_h tells feasible from
//! infeasible ego–CBV states, on the held-out scenes of the feasibility
//! collection (never trained on; [`crate::datasets::held_out`]). States
//! sampled from their episodes are labelled by the witness search and
//! compared with sign(V_h) ([`crate::eval::feasibility_accuracy`]); prints
//! the confusion table with precision and recall of "infeasible", the V_h
//! batch-20 latency in tract and the witness time, and draws V_h over
//! relative CBV positions (the paper's LFR figure) as an SVG.

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use rayon::prelude::*;

use super::CliError;
use super::feasibility_dataset::{FeasibilityDatasetRequest, collection};
use crate::eval::feasibility_accuracy::{
    ConfusionTable, LabelledState, LfrGrid, LfrPanel, SampledState, WITNESS_HORIZON_STEPS, label_state, lfr_panels,
    sample_states,
};
use crate::harness::methods::{MapEncodings, ModelSet};
use crate::models::feasibility::FeasibilityValue;
use crate::models::feasibility_oracle::EgoCbvState;
use crate::record::svg::render_lfr_svg;

/// Runs the command.
pub fn run(request: &FeasibilityDatasetRequest, max_states: usize, svg: &Path) -> Result<ExitCode, CliError> {
    let models_dir = crate::models::models_dir();
    let value = FeasibilityValue::load(&models_dir)?;
    let models = ModelSet::shipped();
    let maps = MapEncodings::default();
    let collection = collection(request, &models)?;
    let held_out = collection.held_out_episodes();
    eprintln!("{} held-out episodes", held_out.len());
    let samples: Vec<SampledState> = held_out
        .par_iter()
        .flat_map_iter(|&e| {
            let scene = &collection.scenes[e.scene];
            let rollout = collection.run(e, request.seed, &models, &maps);
            rollout.map(|r| sample_states(&r, scene.ego, scene.cbv)).unwrap_or_default()
        })
        .collect();
    let samples: Vec<SampledState> = samples.into_iter().take(max_states).collect();
    let labelled: Vec<LabelledState> = samples.par_iter().map(|s| label_state(&value, s)).collect();
    let table = ConfusionTable::of(&labelled);
    let show = |r: Option<f64>| r.map_or("n/a".to_string(), |r| format!("{r:.3}"));
    println!("held-out states: {} (from {} episodes)", labelled.len(), held_out.len());
    println!("witness label: infeasible {}, feasible {}", table.infeasible(), table.feasible());
    println!("sign(V_h) vs witness:      predicted infeasible  predicted feasible");
    println!("  infeasible (no witness)  {:>20}  {:>18}", table.true_infeasible, table.missed_infeasible);
    println!("  feasible (witness)       {:>20}  {:>18}", table.false_infeasible, table.true_feasible);
    if table.unscored > 0 {
        println!("  V_h failed on {} state(s) (counted in no cell)", table.unscored);
    }
    println!(
        "precision of infeasible {}, recall {}, accuracy {}",
        show(table.precision()),
        show(table.recall()),
        show(table.accuracy())
    );
    let mut ws: Vec<f64> = labelled.iter().map(|l| l.witness_s * 1e3).collect();
    ws.sort_by(f64::total_cmp);
    if !ws.is_empty() {
        println!(
            "witness search: median {:.2} ms, p95 {:.2} ms per state ({} s horizon)",
            ws[ws.len() / 2],
            ws[ws.len() * 95 / 100],
            WITNESS_HORIZON_STEPS as f64 / 10.0
        );
    }
    let batch: Vec<EgoCbvState> = samples.iter().take(20).map(|s| s.pair).collect();
    if batch.len() == 20 {
        let mut times = Vec::with_capacity(1000);
        for _ in 0..1000 {
            let t = Instant::now();
            value.evaluate(&batch)?;
            times.push(t.elapsed().as_secs_f64() * 1e6);
        }
        times.sort_by(f64::total_cmp);
        println!(
            "V_h batch-20 query in tract: median {:.1} µs ({} build)",
            times[500],
            if cfg!(debug_assertions) { "debug" } else { "release" }
        );
    }
    let panels = lfr_panels(&value, LfrGrid::FIGURE)?;
    for p in &panels {
        print_panel(p);
    }
    crate::record::create_parent_folder(svg)?;
    crate::record::write_output(svg, render_lfr_svg(&panels).as_bytes())?;
    if !crate::record::is_stdout(svg) {
        println!("wrote {}", svg.display());
    }
    Ok(ExitCode::SUCCESS)
}

fn print_panel(p: &LfrPanel) {
    let g = p.grid;
    println!(
        "LFR panel: {:>4} m/s, CBV {:<24} infeasible cells {:>5.1} % of {} (x {}..{} m, y {}..{} m)",
        p.speed_mps,
        p.label,
        100.0 * p.infeasible_share().unwrap_or(f64::NAN),
        p.values.len(),
        g.x_range_m.0,
        g.x_range_m.1,
        g.y_range_m.0,
        g.y_range_m.1
    );
}
