//! `safer feasibility-eval`: how well the shipped V_h tells feasible from
//! infeasible ego–CBV states. On the held-out scenes of the feasibility
//! collection (every 10th scene, never trained on), states are sampled from
//! the collection episodes; each is labelled by the witness search — can
//! the ego, from that state, keep the CBV (replaying its recorded future)
//! beyond d_th within its dynamic limits over the next 4 s? — and compared
//! with sign(V_h). Prints precision and recall of "infeasible", the V_h
//! batch-20 latency in tract and the witness time, and draws V_h over
//! relative CBV positions (the paper's LFR figure) as an SVG.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use rayon::prelude::*;

use super::CliError;
use super::feasibility_dataset::{FeasibilityDatasetRequest, collection, episode, scene_seed};
use crate::eval::witness::{FixedTraffic, WitnessBudget, search_witness};
use crate::geometry::{Point2, Vector2};
use crate::harness::methods::{MapEncodings, ModelSet};
use crate::models::feasibility::{DISTANCE_THRESHOLD_M, FeasibilityValue, box_distance_m, pair};
use crate::models::feasibility_oracle::EgoCbvState;
use crate::scenario::{AgentBody, AgentKind, AgentState};

/// Witness horizon from a sampled state, simulator steps (4 s).
const WITNESS_HORIZON_STEPS: usize = 40;
/// Sample a state every this many steps of an episode.
const SAMPLE_EVERY_STEPS: usize = 10;

#[derive(Debug, Clone, Copy)]
struct Labelled {
    value: f32,
    witness_found: bool,
    witness_s: f64,
}

/// Runs the command.
pub fn run(request: &FeasibilityDatasetRequest, max_states: usize, svg: &PathBuf) -> Result<ExitCode, CliError> {
    let models_dir = crate::models::models_dir();
    let value = FeasibilityValue::load(&models_dir).map_err(|e| CliError::Usage(e.to_string()))?;
    let (scenes, jobs, _) = collection(request)?;
    let models = ModelSet::shipped();
    let maps = MapEncodings::default();
    let held_out: Vec<_> = jobs.iter().filter(|(i, _, _)| i % 10 == 9).copied().collect();
    eprintln!("{} held-out episodes", held_out.len());
    let samples: Vec<(EgoCbvState, Vec<Option<AgentState>>, AgentBody)> = held_out
        .par_iter()
        .flat_map_iter(|&(i, e, c)| {
            let s = &scenes[i];
            let cbv = s.cbv.expect("collection scenes have a CBV");
            let ego = s.ego.expect("collection scenes have an ego");
            let rollout = episode(s, cbv, e, c, scene_seed(request.seed, i), &models, &maps);
            let mut out = Vec::new();
            if let Some(r) = rollout {
                let (eb, cb) = (r.bodies[ego.0], r.bodies[cbv.0]);
                for k in (0..r.states.len()).step_by(SAMPLE_EVERY_STEPS) {
                    let (Some(es), Some(cs)) = (r.states[k][ego.0], r.states[k][cbv.0]) else { continue };
                    let future: Vec<Option<AgentState>> =
                        (k..r.states.len()).take(WITNESS_HORIZON_STEPS + 1).map(|j| r.states[j][cbv.0]).collect();
                    if future.len() < WITNESS_HORIZON_STEPS / 2 {
                        continue;
                    }
                    out.push((pair(es, eb, cs, cb), future, cb));
                }
            }
            out.into_iter()
        })
        .collect();
    let samples: Vec<_> = samples.into_iter().take(max_states).collect();
    let labelled: Vec<Labelled> = samples
        .par_iter()
        .map(|(p, future, cbv_body)| {
            let states: Vec<Vec<Option<AgentState>>> = future.iter().map(|c| vec![None, *c]).collect();
            let bodies = [p.ego_body, *cbv_body];
            let traffic = FixedTraffic { states: &states, bodies: &bodies, ego: 0 };
            let budget = WitnessBudget { margin_m: DISTANCE_THRESHOLD_M, ..WitnessBudget::default() };
            let t = Instant::now();
            let found = search_witness(&p.ego, p.ego_body, &traffic, states.len() - 1, budget).is_found();
            let witness_s = t.elapsed().as_secs_f64();
            let v = value.evaluate(std::slice::from_ref(p)).map(|v| v[0]).unwrap_or(f32::NAN);
            Labelled { value: v, witness_found: found, witness_s }
        })
        .collect();
    let (mut tp, mut fp, mut fn_, mut tn) = (0usize, 0usize, 0usize, 0usize);
    for l in &labelled {
        match (l.value > 0.0, !l.witness_found) {
            (true, true) => tp += 1,
            (true, false) => fp += 1,
            (false, true) => fn_ += 1,
            (false, false) => tn += 1,
        }
    }
    let n = labelled.len().max(1) as f64;
    let precision = tp as f64 / (tp + fp).max(1) as f64;
    let recall = tp as f64 / (tp + fn_).max(1) as f64;
    println!("held-out states: {} (from {} episodes)", labelled.len(), held_out.len());
    println!("witness label: infeasible {}, feasible {}", tp + fn_, fp + tn);
    println!("sign(V_h) vs witness:      predicted infeasible  predicted feasible");
    println!("  infeasible (no witness)  {tp:>20}  {fn_:>18}");
    println!("  feasible (witness)       {fp:>20}  {tn:>18}");
    println!("precision of infeasible {precision:.3}, recall {recall:.3}, accuracy {:.3}", (tp + tn) as f64 / n);
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
    let batch: Vec<EgoCbvState> = samples.iter().take(20).map(|s| s.0).collect();
    if batch.len() == 20 {
        let mut times: Vec<f64> = (0..1000)
            .map(|_| {
                let t = Instant::now();
                value.evaluate(&batch).expect("ran once");
                t.elapsed().as_secs_f64() * 1e6
            })
            .collect();
        times.sort_by(f64::total_cmp);
        println!(
            "V_h batch-20 query in tract: median {:.1} µs ({} build)",
            times[500],
            if cfg!(debug_assertions) { "debug" } else { "release" }
        );
    }
    write_lfr_svg(&value, svg)?;
    println!("wrote {}", svg.display());
    Ok(ExitCode::SUCCESS)
}

/// V_h over relative CBV positions in the ego frame, for a few speeds and two
/// CBV headings (same direction, crossing from the right), as a heat map:
/// blue = feasible (V_h ≤ 0), red = infeasible.
fn write_lfr_svg(value: &FeasibilityValue, path: &PathBuf) -> Result<(), CliError> {
    let car = AgentBody { kind: AgentKind::Vehicle, length_m: 4.6, width_m: 1.9 };
    let speeds = [5.0, 10.0, 15.0];
    let headings = [(0.0, "same heading"), (std::f64::consts::FRAC_PI_2, "crossing from the right")];
    let (x_range, y_range, cell_m) = ((-15.0, 35.0), (-12.0, 12.0), 1.0);
    let (nx, ny) = (((x_range.1 - x_range.0) / cell_m) as usize, ((y_range.1 - y_range.0) / cell_m) as usize);
    let px = 8.0;
    let (panel_w, panel_h) = (nx as f64 * px, ny as f64 * px);
    let mut svg = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" font-family="sans-serif" font-size="12">
<text x="10" y="16">V_h over the CBV's position in the ego frame (ego at the origin, heading +x; x {}..{} m, y {}..{} m). Blue: feasible (V_h ≤ 0); red: infeasible. CBV speed = ego speed.</text>
"#,
        2.0 * panel_w + 60.0,
        speeds.len() as f64 * (panel_h + 40.0) + 40.0,
        x_range.0,
        x_range.1,
        y_range.0,
        y_range.1
    );
    for (row, &v) in speeds.iter().enumerate() {
        for (col, &(heading, label)) in headings.iter().enumerate() {
            let (ox, oy) = (20.0 + col as f64 * (panel_w + 20.0), 40.0 + row as f64 * (panel_h + 40.0));
            svg += &format!(r#"<text x="{ox}" y="{}">ego and CBV at {v} m/s, CBV {label}</text>"#, oy - 4.0);
            let mut pairs = Vec::with_capacity(nx * ny);
            for j in 0..ny {
                for i in 0..nx {
                    let x = x_range.0 + (i as f64 + 0.5) * cell_m;
                    let y = y_range.1 - (j as f64 + 0.5) * cell_m;
                    let ego =
                        AgentState { position: Point2::origin(), heading_rad: 0.0, velocity_mps: Vector2::new(v, 0.0) };
                    let h = if heading == 0.0 { 0.0 } else { heading };
                    let cbv = AgentState {
                        position: Point2::new(x, y),
                        heading_rad: h,
                        velocity_mps: Vector2::new(h.cos(), h.sin()) * v,
                    };
                    pairs.push(pair(ego, car, cbv, car));
                }
            }
            let values = value.evaluate(&pairs).map_err(|e| CliError::Usage(e.to_string()))?;
            let infeasible = values.iter().filter(|v| **v > 0.0).count();
            println!(
                "LFR panel: {v:>4} m/s, CBV {label:<24} infeasible cells {:>5.1} % of {} (x {}..{} m, y {}..{} m)",
                100.0 * infeasible as f64 / values.len() as f64,
                values.len(),
                x_range.0,
                x_range.1,
                y_range.0,
                y_range.1
            );
            for (k, (val, p)) in values.iter().zip(&pairs).enumerate() {
                let (i, j) = (k % nx, k / nx);
                let t = (*val as f64 / 16.0).clamp(-1.0, 1.0);
                let colour = if box_distance_m(p) <= 0.0 {
                    "black".to_string()
                } else if t > 0.0 {
                    format!("rgb(255,{0},{0})", (255.0 * (1.0 - t)) as u8)
                } else {
                    format!("rgb({0},{0},255)", (255.0 * (1.0 + t)) as u8)
                };
                svg += &format!(
                    r#"<rect x="{:.1}" y="{:.1}" width="{px}" height="{px}" fill="{colour}"/>"#,
                    ox + i as f64 * px,
                    oy + j as f64 * px
                );
            }
            // The ego's box.
            let (ex, ey) = (ox + (0.0 - x_range.0) / cell_m * px, oy + (y_range.1 - 0.0) / cell_m * px);
            svg += &format!(
                r#"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="none" stroke="green" stroke-width="2"/>"#,
                ex - 2.3 / cell_m * px,
                ey - 0.95 / cell_m * px,
                4.6 / cell_m * px,
                1.9 / cell_m * px
            );
        }
    }
    svg += "</svg>\n";
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, svg)?;
    Ok(())
}
