//! The transitions (s, a, h(s), s', done) of the ego–CBV state that the
//! feasibility value V_h is trained on offline: closed-loop rollouts on
//! NGSIM scenes (public domain) and synthetic traffic, with several ego
//! policies (the IDM lane follower, the evasive sampling planner, constant
//! velocity) against several CBV policies (aggressive pursuit of the ego
//! with random aim points, IDM, constant velocity, and the SaFeR adversary
//! without the feasibility constraint when the prior is available). One
//! transition per 0.1 s step; a = the ego's acceleration and yaw rate over
//! the step; an episode ends at the horizon or at the ego's first
//! collision.
//!
//! The expectile in V_h's training can only learn escapes that the data
//! shows, and these ego policies rarely escape a close, fast CBV. So every
//! episode also gets *witness branches*: from states of its rollout where
//! the CBV is close (box distance up to [`BRANCH_MAX_DISTANCE_M`]), the
//! witness search looks for an ego trajectory that keeps every agent
//! beyond d_th while they replay the rollout; each one found is a branch
//! whose transitions show that escape (the paper's stage 2 replays the CBV
//! the same way). They cover the boundary of the feasible region, where
//! V_h decides between adversarial and unavoidable.
//!
//! The [`Collection`] (scenes, their roles and [`Split`], the episodes) is
//! a pure function of the recorded scenes, the number of synthetic scenes
//! and the seed, so `safer feasibility-eval` rebuilds exactly the episodes
//! of the held-out scenes that `safer feasibility-dataset` wrote.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::Arc;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::held_out::Split;
use super::{DatasetError, source_name};
use crate::eval::witness::{FixedTraffic, Witness, WitnessBudget, search_witness};
use crate::geometry::wrap_angle;
use crate::harness::methods::{BackgroundDriver, MapEncodings, MethodSettings, ModelSet};
use crate::models::feasibility::DISTANCE_THRESHOLD_M;
use crate::models::feasibility::{FEASIBILITY_FEATURES, box_distance_m, constraint_cost, feasibility_features, pair};
use crate::models::shard::{ShardColumn, write_shard};
use crate::planners::BuiltinPlanner;
use crate::policies::cbv_rules::EgoPursuit;
use crate::policies::prior_sampling::TokenSampling;
use crate::policies::{AgentPolicy, BackgroundPolicy};
use crate::scenario::{AgentKind, AgentState, Scenario, TrackIndex};
use crate::sim::synthetic::{SpeedSample, SyntheticTraffic, random_template};
use crate::sim::{Rollout, SimConfig, Simulation};
use crate::spec::suite::AdversaryMethod;

/// Scenario step an episode starts at (or the second-to-last step of a shorter scene).
const EPISODE_START_STEP: usize = 10;
/// Longest episode, simulator steps (8 s).
const EPISODE_STEPS: usize = 80;
/// States whose ego–CBV box distance exceeds this are not recorded, m.
const MAX_BOX_DISTANCE_M: f64 = 60.0;
/// Index of the box distance among the [`feasibility_features`].
pub const BOX_DISTANCE_FEATURE: usize = 12;
/// Values per action: the ego's acceleration (m/s²) and yaw rate (rad/s).
pub const ACTION_VALUES: usize = 2;
/// A witness branch starts where the ego–CBV box distance is at most this, m.
pub const BRANCH_MAX_DISTANCE_M: f64 = 10.0;
/// Branch starts are tried every this many steps (0.5 s) ...
const BRANCH_EVERY_STEPS: usize = 5;
/// ... at most this many per episode, closest first.
const MAX_BRANCHES_PER_EPISODE: usize = 4;
/// Agents this close to the ego when a branch starts are its obstacles, m
/// (at 30 m/s closing speed, 4 s covers 120 m; the collection's closing
/// speeds stay far below that, and the CBV is within 10 m).
const BRANCH_OBSTACLE_RANGE_M: f64 = 60.0;
/// A branch (and the witness search) looks this far ahead, steps (4 s, as
/// the witness labels of `safer feasibility-eval`).
const BRANCH_STEPS: usize = 40;
/// Steps of a synthetic collection scene (10 s at 0.1 s).
const SYNTHETIC_STEPS: usize = 101;
/// The ego policies of every scene.
pub const EGO_PLANNERS: [BuiltinPlanner; 3] =
    [BuiltinPlanner::Idm, BuiltinPlanner::Evasive, BuiltinPlanner::ConstantVelocity];

/// What drives the CBV while transitions are collected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CollectionCbv {
    /// Pursues a random aim point relative to the ego (the style seed).
    Pursuit(u8),
    /// IDM lane following.
    Idm,
    /// Constant velocity.
    ConstantVelocity,
    /// SaFeR without the feasibility constraint (distance only), prior-driven.
    AdversaryNoLfr,
}

/// Transitions, flattened row by row.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Transitions {
    /// s: [n × FEASIBILITY_FEATURES].
    pub state: Vec<f32>,
    /// a: [n × ACTION_VALUES].
    pub action: Vec<f32>,
    /// h(s): `[n]`.
    pub cost: Vec<f32>,
    /// s': [n × FEASIBILITY_FEATURES].
    pub next_state: Vec<f32>,
    /// 1 on an episode's last transition: `[n]`.
    pub done: Vec<f32>,
    /// Index of the scene in the collection: `[n]`.
    pub scene: Vec<i64>,
}

impl Transitions {
    /// Number of transitions.
    pub fn len(&self) -> usize {
        self.cost.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.cost.is_empty()
    }

    /// Appends `other`.
    pub fn extend(&mut self, other: Transitions) {
        self.state.extend(other.state);
        self.action.extend(other.action);
        self.cost.extend(other.cost);
        self.next_state.extend(other.next_state);
        self.done.extend(other.done);
        self.scene.extend(other.scene);
    }

    /// Transitions whose h(s) is M (box distance at most d_th).
    pub fn violating(&self) -> usize {
        self.cost.iter().filter(|&&h| h > 0.0).count()
    }

    /// Transitions whose state has the CBV within `distance_m` (box distance).
    pub fn within(&self, distance_m: f32) -> usize {
        self.state.chunks_exact(FEASIBILITY_FEATURES).filter(|s| s[BOX_DISTANCE_FEATURE] < distance_m).count()
    }
}

/// A scene of the collection with its roles.
#[derive(Debug, Clone)]
pub struct CollectionScene {
    /// The scene (its `ego` and `cbv` set to the roles below).
    pub scene: Arc<Scenario>,
    /// The ego.
    pub ego: TrackIndex,
    /// The CBV.
    pub cbv: TrackIndex,
    /// Train or held out.
    pub split: Split,
}

/// One episode to collect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Episode {
    /// Index of the scene in [`Collection::scenes`].
    pub scene: usize,
    /// Who drives the ego.
    pub ego_planner: BuiltinPlanner,
    /// Who drives the CBV.
    pub cbv_policy: CollectionCbv,
}

/// The collection's scenes and episodes, in a fixed order.
#[derive(Debug, Clone)]
pub struct Collection {
    /// Recorded scenes (sorted by id), then synthetic ones; the held-out
    /// rule counts in this order as one sequence.
    pub scenes: Vec<CollectionScene>,
    /// Every scene × [`EGO_PLANNERS`] × [`Collection::cbv_policies`].
    pub episodes: Vec<Episode>,
    /// The CBV policies.
    pub cbv_policies: Vec<CollectionCbv>,
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

fn episode_start(scene: &Scenario) -> usize {
    EPISODE_START_STEP.min(scene.num_steps().saturating_sub(2))
}

/// Gives `s` an ego (its own, else the first vehicle present at the start)
/// and a CBV (its own, else the nearest vehicle at the start); `None` when
/// it has no such pair.
fn with_roles(mut s: Scenario) -> Option<(Scenario, TrackIndex, TrackIndex)> {
    let start = episode_start(&s);
    if s.ego.is_none_or(|e| s.track(e).state(start).is_none()) {
        s.ego = (0..s.tracks.len())
            .find(|&i| s.tracks[i].kind == AgentKind::Vehicle && s.tracks[i].state(start).is_some())
            .map(TrackIndex);
    }
    let ego = s.ego?;
    if s.cbv.is_none_or(|c| s.track(c).state(start).is_none()) {
        s.cbv = nearest_vehicle(&s, ego, start);
    }
    let cbv = s.cbv?;
    Some((s, ego, cbv))
}

/// The synthetic scenes of the collection (10 s of traffic on procedural
/// templates, desired speeds drawn from `recorded`'s vehicles).
pub fn synthetic_collection_scenes(recorded: &[Scenario], count: usize, seed: u64) -> Vec<Scenario> {
    let speeds = SpeedSample::new(
        recorded
            .iter()
            .flat_map(|s| s.tracks.iter().filter(|t| t.kind == AgentKind::Vehicle))
            .flat_map(|t| t.states.iter().step_by(5).flatten().map(|s| s.speed_mps()))
            .collect(),
    );
    let traffic = SyntheticTraffic {
        speeds,
        accel_noise_std_mps2: 1.0,
        duration_s: 10.0,
        max_agents: 60,
        choices: false,
        pedestrian_share: 0.0,
    };
    (0..count)
        .into_par_iter()
        .filter_map(|i| {
            let seed = seed.wrapping_add(2_000_000 + i as u64);
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let (_, map) = random_template(&mut rng, SYNTHETIC_STEPS, 0.1);
            traffic.generate(&format!("feasibility-synthetic-{i:05}"), map, seed)
        })
        .collect()
}

impl Collection {
    /// The collection over `recorded` (sorted by id, licence checked by the
    /// caller) and `synthetic_scenes` synthetic scenes; the SaFeR adversary
    /// drives the CBV in a sixth family of episodes when `prior_available`.
    pub fn new(recorded: Vec<Scenario>, synthetic_scenes: usize, seed: u64, prior_available: bool) -> Self {
        let synthetic = synthetic_collection_scenes(&recorded, synthetic_scenes, seed);
        let scenes: Vec<CollectionScene> = recorded
            .into_iter()
            .chain(synthetic)
            .filter_map(with_roles)
            .enumerate()
            .map(|(i, (scene, ego, cbv))| CollectionScene { scene: Arc::new(scene), ego, cbv, split: Split::of(i) })
            .collect();
        let mut cbv_policies = vec![
            CollectionCbv::Pursuit(0),
            CollectionCbv::Pursuit(1),
            CollectionCbv::Pursuit(2),
            CollectionCbv::Idm,
            CollectionCbv::ConstantVelocity,
        ];
        if prior_available {
            cbv_policies.push(CollectionCbv::AdversaryNoLfr);
        }
        let mut episodes = Vec::with_capacity(scenes.len() * EGO_PLANNERS.len() * cbv_policies.len());
        for scene in 0..scenes.len() {
            for &ego_planner in &EGO_PLANNERS {
                for &cbv_policy in &cbv_policies {
                    episodes.push(Episode { scene, ego_planner, cbv_policy });
                }
            }
        }
        Self { scenes, episodes, cbv_policies }
    }

    /// The episodes of the held-out scenes, in order.
    pub fn held_out_episodes(&self) -> Vec<Episode> {
        self.episodes_of(Split::HeldOut)
    }

    /// The episodes of the scenes in `split`, in order.
    pub fn episodes_of(&self, split: Split) -> Vec<Episode> {
        self.episodes.iter().filter(|e| self.scenes[e.scene].split == split).copied().collect()
    }

    /// Runs `episode` (`None` when it cannot be set up).
    pub fn run(&self, episode: Episode, seed: u64, models: &ModelSet, maps: &MapEncodings) -> Option<Rollout> {
        let scene = self.scenes.get(episode.scene)?;
        run_episode(scene, episode, scene_seed(seed, episode.scene), models, maps)
    }

    /// Runs every episode (in parallel) and gathers their transitions in
    /// episode order, with the count of transitions and of violating ones
    /// per CBV policy.
    pub fn collect(&self, seed: u64, models: &ModelSet, maps: &MapEncodings) -> CollectedTransitions {
        let per_episode: Vec<(CollectionCbv, Option<EpisodeTransitions>)> = self
            .episodes
            .par_iter()
            .map(|&e| {
                let t = self.run(e, seed, models, maps).map(|r| {
                    let cbv = self.scenes[e.scene].cbv;
                    let mut t = transitions(&r, e.scene, r.ego, cbv);
                    let (mut branches, mut branch_transitions) = (0, 0);
                    for branch in witness_branches(&r, cbv) {
                        let b = transitions(&branch, e.scene, r.ego, cbv);
                        branches += 1;
                        branch_transitions += b.len();
                        t.extend(b);
                    }
                    EpisodeTransitions { transitions: t, branches, branch_transitions }
                });
                (e.cbv_policy, t)
            })
            .collect();
        let mut out = CollectedTransitions::default();
        for (cbv, t) in per_episode {
            let Some(EpisodeTransitions { transitions: t, branches, branch_transitions }) = t else { continue };
            let entry = out.per_cbv.entry(cbv).or_default();
            entry.transitions += t.len();
            entry.violating += t.violating();
            out.witness_branches += branches;
            out.witness_branch_transitions += branch_transitions;
            out.transitions.extend(t);
        }
        out
    }

    /// Writes `transitions` (collected on this collection) as a safetensors
    /// file: columns `state`, `action`, `cost`, `next_state`, `done`,
    /// `scene`, and the metadata key `scenes` (id, source, split of each
    /// scene) that `training/feasibility/train.py` splits by.
    pub fn write(&self, transitions: &Transitions, path: &Path) -> Result<(), DatasetError> {
        let n = transitions.len();
        let scene_meta: Vec<serde_json::Value> = self
            .scenes
            .iter()
            .map(|s| serde_json::json!({ "id": s.scene.id, "source": source_name(&s.scene), "split": s.split }))
            .collect();
        let columns = [
            ShardColumn::f32("state", vec![n, FEASIBILITY_FEATURES], &transitions.state),
            ShardColumn::f32("action", vec![n, ACTION_VALUES], &transitions.action),
            ShardColumn::f32("cost", vec![n], &transitions.cost),
            ShardColumn::f32("next_state", vec![n, FEASIBILITY_FEATURES], &transitions.next_state),
            ShardColumn::f32("done", vec![n], &transitions.done),
            ShardColumn::i64("scene", vec![n], &transitions.scene),
        ];
        let scenes = serde_json::to_string(&scene_meta)
            .map_err(|source| DatasetError::Metadata { path: path.to_path_buf(), source })?;
        Ok(write_shard(path, &columns, HashMap::from([("scenes".to_string(), scenes)]))?)
    }
}

/// Transitions of a whole collection.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct CollectedTransitions {
    /// All of them, in episode order.
    pub transitions: Transitions,
    /// Per CBV policy (episodes that could not be set up count nothing).
    pub per_cbv: BTreeMap<CollectionCbv, CbvCoverage>,
    /// Witness branches found (see [`witness_branches`]).
    pub witness_branches: usize,
    /// Transitions they hold (included in `transitions`).
    pub witness_branch_transitions: usize,
}

/// One episode's transitions, witness branches included, with the branches' share.
struct EpisodeTransitions {
    transitions: Transitions,
    branches: usize,
    branch_transitions: usize,
}

/// What one CBV policy contributed.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct CbvCoverage {
    /// Transitions.
    pub transitions: usize,
    /// Of which h(s) = M.
    pub violating: usize,
}

/// The seed of the episodes of scene `i`.
pub fn scene_seed(base: u64, i: usize) -> u64 {
    base ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// One collection episode's rollout on `scene` (`None` when it cannot be set up).
pub fn run_episode(
    scene: &CollectionScene,
    episode: Episode,
    seed: u64,
    models: &ModelSet,
    maps: &MapEncodings,
) -> Option<Rollout> {
    let (s, ego, cbv) = (&scene.scene, scene.ego, scene.cbv);
    let start = episode_start(s);
    let end = (start + EPISODE_STEPS).min(s.num_steps().saturating_sub(1));
    let config = SimConfig {
        start_step: Some(start),
        end_step: Some(end),
        background: BackgroundPolicy::LogReplay,
        stop_on_ego_collision: true,
        ..SimConfig::default()
    };
    let mut sim = Simulation::new(s, config).ok()?;
    let policy: Box<dyn AgentPolicy> = match episode.cbv_policy {
        CollectionCbv::Pursuit(k) => Box::new(EgoPursuit::random(ego, seed ^ u64::from(k))),
        CollectionCbv::Idm => BackgroundPolicy::Idm.instantiate(s, cbv),
        CollectionCbv::ConstantVelocity => BackgroundPolicy::ConstantVelocity.instantiate(s, cbv),
        CollectionCbv::AdversaryNoLfr => {
            let settings = MethodSettings {
                method: AdversaryMethod::NoLfr,
                trust_region: 20,
                background: BackgroundDriver::Configured,
                sampling: TokenSampling::default(),
                approach: crate::policies::adversary::ApproachPhase::default(),
                feasibility: crate::policies::adversary::FeasibilityScope::Pair,
                ego_contact: crate::policies::adversary::EgoContactRule::Any,
                wrong_way: Default::default(),
                turning: Default::default(),
                turning_cost: Default::default(),
            };
            crate::harness::methods::install(&mut sim, s, cbv, start, settings, models, maps, seed).ok()?;
            let mut planner = episode.ego_planner.instantiate(s, ego);
            return Some(sim.run(planner.as_mut()));
        }
    };
    sim.set_policy(cbv, policy);
    let mut planner = episode.ego_planner.instantiate(s, ego);
    Some(sim.run(planner.as_mut()))
}

/// The witness branches of `rollout` (see the module documentation): each
/// a copy of a stretch of it from a close ego–CBV state on, with the ego
/// following a witness trajectory that keeps every other agent (replaying
/// the rollout) beyond d_th.
pub fn witness_branches(rollout: &Rollout, cbv: TrackIndex) -> Vec<Rollout> {
    let ego = rollout.ego;
    let body = rollout.bodies[ego.0];
    let distance = |k: usize| {
        let (e, c) =
            (rollout.states[k].get(ego.0).copied().flatten()?, rollout.states[k].get(cbv.0).copied().flatten()?);
        Some(box_distance_m(&pair(e, body, c, rollout.bodies[cbv.0])))
    };
    let mut starts: Vec<(f64, usize)> = (0..rollout.states.len().saturating_sub(BRANCH_EVERY_STEPS))
        .step_by(BRANCH_EVERY_STEPS)
        .filter_map(|k| distance(k).map(|d| (d, k)))
        .filter(|(d, _)| *d > DISTANCE_THRESHOLD_M && *d <= BRANCH_MAX_DISTANCE_M)
        .collect();
    starts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    starts.truncate(MAX_BRANCHES_PER_EPISODE);
    starts.sort_by_key(|&(_, k)| k);
    let budget = WitnessBudget { margin_m: DISTANCE_THRESHOLD_M, ..WitnessBudget::default() };
    starts
        .into_iter()
        .filter_map(|(_, k)| {
            let end = (k + BRANCH_STEPS + 1).min(rollout.states.len());
            let start = rollout.states[k][ego.0]?;
            // Only agents that can come near the ego within the branch are
            // obstacles (the search's cost is per obstacle and step); the
            // branch itself keeps everyone.
            let near: Vec<bool> = rollout.states[k]
                .iter()
                .map(|a| a.is_some_and(|a| (a.position - start.position).norm() < BRANCH_OBSTACLE_RANGE_M))
                .collect();
            let obstacles: Vec<Vec<Option<AgentState>>> = rollout.states[k..end]
                .iter()
                .map(|row| row.iter().zip(&near).map(|(a, &n)| if n { *a } else { None }).collect())
                .collect();
            let ahead = &rollout.states[k..end];
            let traffic = FixedTraffic { states: &obstacles, bodies: &rollout.bodies, ego: ego.0, road: None };
            let Witness::Found { trajectory, .. } = search_witness(&start, body, &traffic, ahead.len() - 1, budget)
            else {
                return None;
            };
            let mut branch = rollout.clone();
            branch.start_step = rollout.start_step + k;
            branch.states = ahead.to_vec();
            for (row, s) in branch.states.iter_mut().zip(trajectory) {
                row[ego.0] = Some(s);
            }
            branch.collisions.clear();
            Some(branch)
        })
        .collect()
}

/// The transitions of a rollout between `ego` and `cbv`: one per step with
/// both present and the CBV within 60 m (box distance); `done` on the
/// rollout's last step.
pub fn transitions(rollout: &Rollout, scene_index: usize, ego: TrackIndex, cbv: TrackIndex) -> Transitions {
    let bodies = &rollout.bodies;
    let mut t = Transitions::default();
    let n = rollout.states.len();
    for k in 0..n.saturating_sub(1) {
        let agent = |k: usize, i: TrackIndex| rollout.states[k].get(i.0).copied().flatten();
        let (Some(e0), Some(c0), Some(e1), Some(c1)) =
            (agent(k, ego), agent(k, cbv), agent(k + 1, ego), agent(k + 1, cbv))
        else {
            continue;
        };
        let p0 = pair(e0, bodies[ego.0], c0, bodies[cbv.0]);
        let p1 = pair(e1, bodies[ego.0], c1, bodies[cbv.0]);
        let d0 = box_distance_m(&p0);
        if d0 > MAX_BOX_DISTANCE_M {
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

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;
    use crate::models::feasibility::{DISTANCE_THRESHOLD_M, SAFE_COST, VIOLATION_COST};

    /// One synthetic collection scene (the first seed the generator populates).
    fn scene() -> Scenario {
        (0..20)
            .find_map(|seed| synthetic_collection_scenes(&[], 1, seed).pop())
            .expect("the generator populates one of 20 templates")
    }

    /// Models that are not there: the episodes under test need none.
    fn no_models() -> ModelSet {
        ModelSet::load(crate::models::ModelSource::Folder(PathBuf::from("/nonexistent/safer-models")))
    }

    #[test]
    fn the_collection_holds_out_every_tenth_scene_with_all_its_episodes() {
        let base = scene();
        let recorded: Vec<Scenario> = (0..12)
            .map(|i| {
                let mut s = base.clone();
                s.id = format!("scene-{i:02}");
                s
            })
            .collect();
        let c = Collection::new(recorded, 0, 0, false);
        assert_eq!(c.scenes.len(), 12);
        assert_eq!(c.cbv_policies.len(), 5, "no prior: no adversary episodes");
        assert_eq!(c.episodes.len(), 12 * EGO_PLANNERS.len() * 5);
        let held: Vec<usize> =
            c.scenes.iter().enumerate().filter(|(_, s)| s.split == Split::HeldOut).map(|(i, _)| i).collect();
        assert_eq!(held, vec![9]);
        let episodes = c.held_out_episodes();
        assert_eq!(episodes.len(), EGO_PLANNERS.len() * 5);
        assert!(episodes.iter().all(|e| e.scene == 9));
        assert!(c.scenes.iter().all(|s| s.ego != s.cbv && s.scene.ego == Some(s.ego) && s.scene.cbv == Some(s.cbv)));
    }

    #[test]
    fn a_synthetic_episode_gives_well_formed_transitions() {
        let c = Collection::new(vec![scene()], 0, 0, false);
        let episode = Episode { scene: 0, ego_planner: BuiltinPlanner::Idm, cbv_policy: CollectionCbv::Pursuit(1) };
        let rollout = c.run(episode, 3, &no_models(), &MapEncodings::default()).expect("the episode runs");
        let t = transitions(&rollout, 0, c.scenes[0].ego, c.scenes[0].cbv);
        let n = t.len();
        assert!(n > 10, "a pursuing CBV stays within 60 m for more than 1 s: {n}");
        assert_eq!(t.state.len(), n * FEASIBILITY_FEATURES);
        assert_eq!(t.next_state.len(), n * FEASIBILITY_FEATURES);
        assert_eq!(t.action.len(), n * ACTION_VALUES);
        assert_eq!((t.done.len(), t.scene.len()), (n, n));
        assert!(t.state.iter().chain(&t.next_state).chain(&t.action).all(|v| v.is_finite()));
        assert!(t.scene.iter().all(|&s| s == 0));
        for (row, &h) in t.state.chunks_exact(FEASIBILITY_FEATURES).zip(&t.cost) {
            let d = f64::from(row[BOX_DISTANCE_FEATURE]);
            assert!((0.0..=MAX_BOX_DISTANCE_M).contains(&d), "box distance {d}");
            let expected = if d > DISTANCE_THRESHOLD_M { SAFE_COST } else { VIOLATION_COST };
            if (d - DISTANCE_THRESHOLD_M).abs() > 1e-4 {
                assert_eq!(f64::from(h), expected, "h at box distance {d}");
            }
        }
        // The next state of one transition is the state of the next one.
        for k in 0..n - 1 {
            if t.done[k] == 0.0 {
                let next = &t.next_state[k * FEASIBILITY_FEATURES..(k + 1) * FEASIBILITY_FEATURES];
                let following = &t.state[(k + 1) * FEASIBILITY_FEATURES..(k + 2) * FEASIBILITY_FEATURES];
                assert_eq!(next, following, "transition {k}");
            }
        }
        assert!(t.done[..n - 1].iter().all(|&d| d == 0.0));
        assert_eq!(t.violating(), t.cost.iter().filter(|&&h| h == VIOLATION_COST as f32).count());
        assert!(t.within(5.0) >= t.within(2.0));
    }

    #[test]
    fn witness_branches_escape_a_pursuing_cbv_that_the_constant_velocity_ego_does_not() {
        let c = Collection::new(vec![scene()], 0, 0, false);
        let (ego, cbv) = (c.scenes[0].ego, c.scenes[0].cbv);
        let branches: Vec<Rollout> = (1..=3)
            .flat_map(|style| {
                let episode = Episode {
                    scene: 0,
                    ego_planner: BuiltinPlanner::ConstantVelocity,
                    cbv_policy: CollectionCbv::Pursuit(style),
                };
                let rollout = c.run(episode, 3, &no_models(), &MapEncodings::default()).expect("the episode runs");
                witness_branches(&rollout, cbv)
            })
            .collect();
        assert!(!branches.is_empty(), "a pursuing CBV comes within 10 m and the witness escapes it at least once");
        for b in &branches {
            assert!(b.states.len() > 1 && b.states.len() <= BRANCH_STEPS + 1);
            let t = transitions(b, 0, ego, cbv);
            // Every branch state keeps the CBV beyond d_th: the escape is in the data.
            assert!(!t.is_empty() && t.violating() == 0, "{} of {} violating", t.violating(), t.len());
            assert!(
                t.state
                    .chunks_exact(FEASIBILITY_FEATURES)
                    .all(|r| f64::from(r[BOX_DISTANCE_FEATURE]) > DISTANCE_THRESHOLD_M)
            );
            assert!(t.done.iter().filter(|&&d| d == 1.0).count() <= 1);
        }
    }

    #[test]
    fn transitions_are_written_with_their_scene_split() {
        let c = Collection::new(vec![scene()], 0, 0, false);
        let mut t = Transitions::default();
        t.state.extend([0.0; FEASIBILITY_FEATURES]);
        t.next_state.extend([0.0; FEASIBILITY_FEATURES]);
        t.action.extend([0.0; ACTION_VALUES]);
        t.cost.push(SAFE_COST as f32);
        t.done.push(1.0);
        t.scene.push(0);
        let tmp = tempfile::Builder::new().prefix("safer-datasets-transitions-").tempdir().unwrap();
        let path = tmp.path().join("transitions.safetensors");
        c.write(&t, &path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let (_, meta) = safetensors::SafeTensors::read_metadata(&bytes).unwrap();
        let scenes = &meta.metadata().as_ref().unwrap()["scenes"];
        assert_eq!(scenes, &format!(r#"[{{"id":"{}","source":"synthetic","split":"train"}}]"#, c.scenes[0].scene.id));
        let shard = safetensors::SafeTensors::deserialize(&bytes).unwrap();
        assert_eq!(shard.tensor("state").unwrap().shape(), &[1, FEASIBILITY_FEATURES]);
        assert_eq!(shard.tensor("action").unwrap().shape(), &[1, ACTION_VALUES]);
        std::fs::remove_file(&path).unwrap();
    }
}
