//! `safer feasibility-dataset`: transitions (s, a, h(s), s', done) of the
//! ego–CBV state for training the feasibility value V_h offline. Closed-loop
//! rollouts on NGSIM scenes (public domain) and synthetic traffic, with
//! several ego policies (the IDM lane follower, the evasive sampling
//! planner, constant velocity) against several CBV policies (aggressive
//! pursuit of the ego with random aim points, IDM, constant velocity, and
//! the SaFeR adversary without the feasibility constraint when the prior is
//! shipped). One transition per 0.1 s step; a = the ego's acceleration and
//! yaw rate over the step; an episode ends at the horizon or at the ego's
//! first collision.

use std::collections::HashMap;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::{CliError, scene_paths};
use crate::geometry::wrap_angle;
use crate::harness::methods::{BackgroundDriver, MapEncodings, MethodSettings, ModelSet};
use crate::models::feasibility::{FEASIBILITY_FEATURES, box_distance_m, constraint_cost, feasibility_features, pair};
use crate::models::shard::{ShardColumn, write_shard};
use crate::planners::BuiltinPlanner;
use crate::policies::cbv_rules::EgoPursuit;
use crate::policies::prior_sampling::TokenSampling;
use crate::policies::{AgentPolicy, BackgroundPolicy};
use crate::scenario::{AgentKind, Scenario, TrackIndex, import};
use crate::sim::synthetic::{SpeedSample, SyntheticTraffic, random_template};
use crate::sim::{Rollout, SimConfig, Simulation};
use crate::spec::suite::AdversaryMethod;

/// What drives the CBV while transitions are collected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CollectionCbv {
    /// Pursues a random aim point relative to the ego.
    Pursuit(u8),
    /// IDM lane following.
    Idm,
    /// Constant velocity.
    ConstantVelocity,
    /// SaFeR without the feasibility constraint (distance only), prior-driven.
    AdversaryNoLfr,
}

/// Transitions of one episode, flattened.
#[derive(Debug, Default)]
struct Transitions {
    state: Vec<f32>,
    action: Vec<f32>,
    cost: Vec<f32>,
    next_state: Vec<f32>,
    done: Vec<f32>,
    scene: Vec<i64>,
}

impl Transitions {
    fn len(&self) -> usize {
        self.cost.len()
    }
    fn extend(&mut self, o: Transitions) {
        self.state.extend(o.state);
        self.action.extend(o.action);
        self.cost.extend(o.cost);
        self.next_state.extend(o.next_state);
        self.done.extend(o.done);
        self.scene.extend(o.scene);
    }
}

/// Settings of the command.
#[derive(Debug, Clone)]
pub struct FeasibilityDatasetRequest {
    /// Recorded scenes (licence must allow training).
    pub recorded: PathBuf,
    /// Output folder.
    pub out: PathBuf,
    /// Synthetic scenes.
    pub synthetic_scenes: usize,
    /// Base seed.
    pub seed: u64,
    /// Replace an existing dataset.
    pub force: bool,
}

/// The nearest other vehicle to the ego at `step`.
fn nearest_vehicle(s: &Scenario, ego: TrackIndex, step: usize) -> Option<TrackIndex> {
    let e = s.track(ego).state(step)?;
    (0..s.tracks.len())
        .filter(|&i| i != ego.0 && s.tracks[i].kind == AgentKind::Vehicle)
        .filter_map(|i| s.tracks[i].state(step).map(|st| (i, (st.position - e.position).norm())))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
        .map(|(i, _)| TrackIndex(i))
}

/// One collection episode's rollout (`None` when it cannot be set up).
#[allow(clippy::too_many_arguments)]
pub(super) fn episode(
    scene: &Arc<Scenario>,
    cbv: TrackIndex,
    ego_planner: BuiltinPlanner,
    cbv_policy: CollectionCbv,
    seed: u64,
    models: &ModelSet,
    maps: &MapEncodings,
) -> Option<Rollout> {
    let ego = scene.ego?;
    let start = 10.min(scene.num_steps().saturating_sub(2));
    let end = (start + 80).min(scene.num_steps() - 1);
    let config = SimConfig {
        start_step: Some(start),
        end_step: Some(end),
        background: BackgroundPolicy::LogReplay,
        stop_on_ego_collision: true,
        ..SimConfig::default()
    };
    let mut sim = Simulation::new(scene, config).ok()?;
    let policy: Box<dyn AgentPolicy> = match cbv_policy {
        CollectionCbv::Pursuit(k) => Box::new(EgoPursuit::random(ego, seed ^ u64::from(k))),
        CollectionCbv::Idm => BackgroundPolicy::Idm.instantiate(scene, cbv),
        CollectionCbv::ConstantVelocity => BackgroundPolicy::ConstantVelocity.instantiate(scene, cbv),
        CollectionCbv::AdversaryNoLfr => {
            let settings = MethodSettings {
                method: AdversaryMethod::NoLfr,
                trust_region: 20,
                background: BackgroundDriver::Configured,
                sampling: TokenSampling::default(),
            };
            let mut s2 = scene.as_ref().clone();
            s2.cbv = Some(cbv);
            let s2 = Arc::new(s2);
            crate::harness::methods::install(&mut sim, &s2, cbv, start, settings, models, maps, seed).ok()?;
            let mut planner = ego_planner.instantiate(scene, ego);
            return Some(sim.run(planner.as_mut()));
        }
    };
    sim.set_policy(cbv, policy);
    let mut planner = ego_planner.instantiate(scene, ego);
    Some(sim.run(planner.as_mut()))
}

/// The transitions of an episode between `ego` and `cbv`.
fn transitions(rollout: &Rollout, scene_index: usize, ego: TrackIndex, cbv: TrackIndex) -> Transitions {
    let bodies = &rollout.bodies;
    let mut t = Transitions::default();
    let n = rollout.states.len();
    for k in 0..n.saturating_sub(1) {
        let (Some(e0), Some(c0), Some(e1), Some(c1)) = (
            rollout.states[k][ego.0],
            rollout.states[k][cbv.0],
            rollout.states[k + 1][ego.0],
            rollout.states[k + 1][cbv.0],
        ) else {
            continue;
        };
        let p0 = pair(e0, bodies[ego.0], c0, bodies[cbv.0]);
        let p1 = pair(e1, bodies[ego.0], c1, bodies[cbv.0]);
        let d0 = box_distance_m(&p0);
        if d0 > 60.0 {
            continue;
        }
        t.state.extend(feasibility_features(&p0));
        t.next_state.extend(feasibility_features(&p1));
        t.action.push(((e1.speed_mps() - e0.speed_mps()) / rollout.dt_s) as f32);
        t.action.push((wrap_angle(e1.heading_rad - e0.heading_rad) / rollout.dt_s) as f32);
        t.cost.push(constraint_cost(d0) as f32);
        t.done.push(if k + 2 == n { 1.0 } else { 0.0 });
        t.scene.push(scene_index as i64);
    }
    t
}

/// One episode to collect: scene index, ego planner, CBV policy.
pub(super) type Job = (usize, BuiltinPlanner, CollectionCbv);

/// The collection's scenes (each with an ego and a CBV) and episodes, in a fixed order.
pub(super) fn collection(
    request: &FeasibilityDatasetRequest,
) -> Result<(Vec<Arc<Scenario>>, Vec<Job>, Vec<CollectionCbv>), CliError> {
    let paths = scene_paths(&request.recorded)?;
    let mut recorded: Vec<Scenario> = Vec::new();
    for p in &paths {
        for s in import::load(p)? {
            if !s.source.licence.allows_training_shipped_models() {
                return Err(CliError::Usage(format!(
                    "{}: licence {:?} does not allow training the shipped models",
                    p.display(),
                    s.source.licence
                )));
            }
            recorded.push(s);
        }
    }
    recorded.sort_by(|a, b| a.id.cmp(&b.id));
    let speeds = SpeedSample::new(
        recorded
            .iter()
            .flat_map(|s| s.tracks.iter().filter(|t| t.kind == AgentKind::Vehicle))
            .flat_map(|t| t.states.iter().step_by(5).flatten().map(|s| s.speed_mps()))
            .collect(),
    );
    let traffic = SyntheticTraffic { speeds, accel_noise_std_mps2: 1.0, duration_s: 10.0, max_agents: 60 };
    let synthetic: Vec<Scenario> = (0..request.synthetic_scenes)
        .into_par_iter()
        .filter_map(|i| {
            let seed = request.seed.wrapping_add(2_000_000 + i as u64);
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let (_, map) = random_template(&mut rng, 101, 0.1);
            traffic.generate(&format!("feasibility-synthetic-{i:05}"), map, seed)
        })
        .collect();
    // Every scene gets an ego (its own, else the first vehicle) and its CBV
    // (its own, else the nearest vehicle at the start).
    let scenes: Vec<Arc<Scenario>> = recorded
        .into_iter()
        .chain(synthetic)
        .filter_map(|mut s| {
            let start = 10.min(s.num_steps().saturating_sub(2));
            if s.ego.is_none_or(|e| s.track(e).state(start).is_none()) {
                s.ego = (0..s.tracks.len())
                    .find(|&i| s.tracks[i].kind == AgentKind::Vehicle && s.tracks[i].state(start).is_some())
                    .map(TrackIndex);
            }
            let ego = s.ego?;
            if s.cbv.is_none_or(|c| s.track(c).state(start).is_none()) {
                s.cbv = nearest_vehicle(&s, ego, start);
            }
            s.cbv?;
            Some(Arc::new(s))
        })
        .collect();
    let prior_available = ModelSet::shipped().prior.is_ok();
    let mut cbvs = vec![
        CollectionCbv::Pursuit(0),
        CollectionCbv::Pursuit(1),
        CollectionCbv::Pursuit(2),
        CollectionCbv::Idm,
        CollectionCbv::ConstantVelocity,
    ];
    if prior_available {
        cbvs.push(CollectionCbv::AdversaryNoLfr);
    }
    let egos = [BuiltinPlanner::Idm, BuiltinPlanner::Evasive, BuiltinPlanner::ConstantVelocity];
    let mut jobs: Vec<(usize, BuiltinPlanner, CollectionCbv)> = Vec::new();
    for i in 0..scenes.len() {
        for &e in &egos {
            for &c in &cbvs {
                jobs.push((i, e, c));
            }
        }
    }
    Ok((scenes, jobs, cbvs))
}

/// The seed of the episodes of scene `i`.
pub(super) fn scene_seed(base: u64, i: usize) -> u64 {
    base ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// Runs the command.
pub fn run(request: &FeasibilityDatasetRequest) -> Result<ExitCode, CliError> {
    let out_file = request.out.join("transitions.safetensors");
    if out_file.exists() && !request.force {
        return Err(CliError::Usage(format!("{} exists; pass --force to replace it", out_file.display())));
    }
    std::fs::create_dir_all(&request.out)?;
    let (scenes, jobs, cbvs) = collection(request)?;
    let models = ModelSet::shipped();
    let maps = MapEncodings::default();
    eprintln!("{} scenes, {} episodes (CBV policies: {cbvs:?})", scenes.len(), jobs.len());
    let episodes: Vec<(usize, CollectionCbv, Option<Transitions>)> = jobs
        .par_iter()
        .map(|&(i, e, c)| {
            let s = &scenes[i];
            let cbv = s.cbv.expect("collection scenes have a CBV");
            let rollout = episode(s, cbv, e, c, scene_seed(request.seed, i), &models, &maps);
            (i, c, rollout.map(|r| transitions(&r, i, r.ego, cbv)))
        })
        .collect();
    let mut all = Transitions::default();
    let mut per_cbv: HashMap<String, (usize, usize)> = HashMap::new();
    for (_, c, t) in episodes {
        let Some(t) = t else { continue };
        let e = per_cbv.entry(format!("{c:?}")).or_default();
        e.0 += t.len();
        e.1 += t.cost.iter().filter(|&&h| h > 0.0).count();
        all.extend(t);
    }
    let n = all.len();
    let violations = all.cost.iter().filter(|&&h| h > 0.0).count();
    let near = (0..n).filter(|&i| all.state[i * FEASIBILITY_FEATURES + 12] < 2.0).count();
    let near5 = (0..n).filter(|&i| all.state[i * FEASIBILITY_FEATURES + 12] < 5.0).count();
    println!("transitions: {n} from {} scenes", scenes.len());
    println!("coverage: {violations} with h = M (box distance <= 0.3 m), {near} within 2 m, {near5} within 5 m");
    let mut keys: Vec<_> = per_cbv.into_iter().collect();
    keys.sort();
    for (k, (t, v)) in keys {
        println!("  CBV {k:<22} {t:>8} transitions {v:>7} violating");
    }
    let scene_meta: Vec<serde_json::Value> = scenes
        .iter()
        .enumerate()
        .map(|(i, s)| {
            serde_json::json!({
                "id": s.id,
                "source": if s.source.licence == crate::scenario::DataLicence::PublicDomain { "ngsim" } else { "synthetic" },
                "split": if i % 10 == 9 { "held-out" } else { "train" },
            })
        })
        .collect();
    let columns = [
        ShardColumn::f32("state", vec![n, FEASIBILITY_FEATURES], &all.state),
        ShardColumn::f32("action", vec![n, 2], &all.action),
        ShardColumn::f32("cost", vec![n], &all.cost),
        ShardColumn::f32("next_state", vec![n, FEASIBILITY_FEATURES], &all.next_state),
        ShardColumn::f32("done", vec![n], &all.done),
        ShardColumn::i64("scene", vec![n], &all.scene),
    ];
    let meta = HashMap::from([("scenes".to_string(), serde_json::to_string(&scene_meta)?)]);
    write_shard(&out_file, &columns, meta).map_err(|e| CliError::Usage(e.to_string()))?;
    println!("wrote {}", out_file.display());
    Ok(ExitCode::SUCCESS)
}
