//! The SaFeR adversary end to end on recorded scenes with the shipped
//! models: it drives the CBV closer to the ego than the log does, collides
//! more often than the prior while keeping the CBV plausible, its
//! variants are deterministic whatever the thread count, and the ablations
//! run by name.

use std::sync::Arc;

use safer_scenarios::harness::evaluation::{EvaluationRequest, MethodRow, Stage2Cbv, evaluate, table};
use safer_scenarios::harness::methods::{BackgroundDriver, ModelSet};
use safer_scenarios::planners::BuiltinPlanner;
use safer_scenarios::scenario::{AgentKind, Scenario};
use safer_scenarios::spec::suite::AdversaryMethod;

fn scenes() -> Vec<Arc<Scenario>> {
    let dir = crate::shared_data::data_dir().join("womd-tfrecord");
    let mut out = Vec::new();
    for p in safer_scenarios::scenario::import::discover(&dir).unwrap() {
        out.extend(
            safer_scenarios::scenario::import::load(&p).unwrap().into_iter().filter(|s| s.cbv.is_some()).map(Arc::new),
        );
    }
    assert!(!out.is_empty(), "no WOMD scene with a CBV in {}", dir.display());
    out
}

fn request(methods: Vec<AdversaryMethod>, seeds: u32) -> EvaluationRequest {
    EvaluationRequest {
        methods,
        seeds,
        base_seed: 7,
        planner: safer_scenarios::spec::planner::PlannerAdapter::builtin(BuiltinPlanner::Evasive),
        trust_region: 20,
        approach: safer_scenarios::policies::adversary::ApproachPhase::Seeded,
        feasibility: safer_scenarios::policies::adversary::FeasibilityScope::Pair,
        ego_contact: safer_scenarios::policies::adversary::EgoContactRule::Any,
        wrong_way: safer_scenarios::policies::adversary::WrongWayRule::Allowed,
        turning: safer_scenarios::policies::adversary::CbvTurningLimit::GRIP,
        turning_cost: safer_scenarios::policies::adversary::CbvTurningCost::NONE,
        background: BackgroundDriver::Configured,
        stage2_cbv: vec![Stage2Cbv::Replay],
        escape: None,
        horizon_s: 8.0,
        artefacts: None,
        artefacts_of: safer_scenarios::harness::evaluation::ArtefactVariants::Failing,
        mutants: Vec::new(),
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_adversary_brings_the_cbv_closer_than_the_log() {
    let scenes = scenes();
    let models = ModelSet::shipped();
    let req = request(vec![AdversaryMethod::Log, AdversaryMethod::Safer, AdversaryMethod::NoLfr], 2);
    let records = evaluate(&scenes, &req, &models, None, &|| {});
    assert!(records.iter().all(|r| r.error.is_none()), "{:?}", records.iter().find(|r| r.error.is_some()));
    let gap = |m: AdversaryMethod| -> f64 {
        let v: Vec<f64> = records.iter().filter(|r| r.method == m).filter_map(|r| r.stage1_min_gap_m).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    assert!(
        gap(AdversaryMethod::NoLfr) < gap(AdversaryMethod::Log),
        "no-lfr {} vs log {}",
        gap(AdversaryMethod::NoLfr),
        gap(AdversaryMethod::Log)
    );
    assert!(
        gap(AdversaryMethod::Safer) < gap(AdversaryMethod::Log),
        "safer {} vs log {}",
        gap(AdversaryMethod::Safer),
        gap(AdversaryMethod::Log)
    );
    // The table's variety column: the logged CBV is one variant whatever
    // the seed; SaFeR's seeds make more than one per scene.
    let rows = table(&records, &[AdversaryMethod::Log, AdversaryMethod::Safer]);
    assert_eq!(rows[0].distinct_rate, Some(0.5), "log: 2 seeds, one path per scene");
    assert!(rows[1].distinct_rate.is_some_and(|d| d > 0.5), "safer: {:?}", rows[1].distinct_rate);
    let rows = table(&records, &req.methods);
    // The log CBV reproduces its recording: no divergence from itself.
    assert_eq!(rows[0].vj, Some(0.0));
}

/// Without an approach phase (the paper's protocol) the adversary chooses
/// from the first token, and with the background on log replay its arg
/// min gives every seed of a scene the same variant.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn without_an_approach_phase_every_seed_gives_the_same_variant() {
    let scenes = scenes();
    let req = EvaluationRequest {
        approach: safer_scenarios::policies::adversary::ApproachPhase::None,
        ..request(vec![AdversaryMethod::Safer], 2)
    };
    let records = evaluate(&scenes, &req, &ModelSet::shipped(), None, &|| {});
    assert!(records.iter().all(|r| r.error.is_none()), "{:?}", records.iter().find(|r| r.error.is_some()));
    let rows = table(&records, &req.methods);
    assert_eq!(rows[0].distinct_rate, Some(0.5), "2 seeds, one path per scene");
    for scene in &scenes {
        let gaps: Vec<_> = records.iter().filter(|r| r.scenario == scene.id).map(|r| r.stage1_min_gap_m).collect();
        assert_eq!(gaps.len(), 2);
        assert_eq!(gaps[0], gaps[1], "{}", scene.id);
    }
}

/// SaFeR's aim, CR(safer) ≥ 2 × CR(prior), on every WOMD interactive
/// scene (their labelled pairs) with 2 seeds; and the
/// plausibility rule at work: SaFeR's CBV leaves the road and runs into
/// background traffic less often than the prior's unfiltered samples.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn safer_is_more_critical_than_the_prior_and_keeps_the_cbv_plausible() {
    let dir = crate::shared_data::data_dir().join("womd-interactive");
    let mut scenes: Vec<Arc<Scenario>> = Vec::new();
    for p in safer_scenarios::scenario::import::discover(&dir).unwrap() {
        scenes.extend(
            safer_scenarios::scenario::import::load(&p).unwrap().into_iter().filter(|s| s.cbv.is_some()).map(Arc::new),
        );
    }
    scenes.sort_by(|a, b| a.id.cmp(&b.id));
    assert!(scenes.len() >= 50, "{} WOMD interactive scenes with a CBV in {}", scenes.len(), dir.display());
    let req = request(vec![AdversaryMethod::Safer, AdversaryMethod::Prior], 2);
    let records = evaluate(&scenes, &req, &ModelSet::shipped(), None, &|| {});
    assert!(records.iter().all(|r| r.error.is_none()), "{:?}", records.iter().find(|r| r.error.is_some()));
    let rows = table(&records, &req.methods);
    let (safer, prior) = (&rows[0], &rows[1]);
    let (cr_safer, cr_prior) = (safer.cr.unwrap(), prior.cr.unwrap());
    assert!(cr_safer > 0.0 && cr_safer >= 2.0 * cr_prior, "CR safer {cr_safer} vs prior {cr_prior}");
    let (off_road, at_fault) = (
        |r: &MethodRow| r.cbv_off_road_rate.unwrap(),
        |r: &MethodRow| r.cbv_at_fault_background_collision_rate.unwrap(),
    );
    assert!(off_road(safer) < off_road(prior), "off road {safer:?} vs {prior:?}");
    assert!(at_fault(safer) < at_fault(prior), "at fault {safer:?} vs {prior:?}");
}

/// In this scene a pedestrian crosses in front of the CBV; the prior, which
/// learned from vehicles only, drives into them in most seeds. The contact
/// must be counted at fault and as one with a pedestrian, in each variant
/// and in the table.
#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn at_fault_contacts_with_pedestrians_are_counted_apart() {
    let file = crate::shared_data::data_dir().join("womd-interactive/tfrecord-00029-of-00150_122.json");
    let scenes: Vec<Arc<Scenario>> =
        safer_scenarios::scenario::import::load(&file).unwrap().into_iter().map(Arc::new).collect();
    assert_eq!(scenes[0].id, "5f1afb242983d951");
    let req = request(vec![AdversaryMethod::Prior], 10);
    let records = evaluate(&scenes, &req, &ModelSet::shipped(), None, &|| {});
    let vulnerable = records.iter().filter(|r| r.tally.cbv_at_fault_with_vulnerable).count();
    assert!(vulnerable > 0, "no seed's CBV hit the pedestrian at fault");
    assert!(records.iter().all(|r| !r.tally.cbv_at_fault_with_vulnerable || r.cbv_at_fault_with_background));
    // Each such variant names the person, when, and that the CBV was at fault.
    for r in records.iter().filter(|r| r.tally.cbv_at_fault_with_vulnerable) {
        let hit = r.cbv_background_contacts.iter().find(|c| c.other_kind == AgentKind::Pedestrian && c.at_fault);
        let hit = hit.unwrap_or_else(|| panic!("seed {}: {:?}", r.seed, r.cbv_background_contacts));
        assert!(hit.t_s > 0.0 && hit.t_s <= 8.0 && !hit.other.is_empty(), "{hit:?}");
    }
    assert!(records.iter().all(|r| r.cbv_hit_background != r.cbv_background_contacts.is_empty()));
    let row = &table(&records, &req.methods)[0];
    assert_eq!(row.cbv_at_fault_vulnerable_rate, Some(vulnerable as f64 / records.len() as f64));
    assert!(row.cbv_at_fault_vulnerable_rate <= row.cbv_at_fault_background_collision_rate);
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn variants_do_not_depend_on_the_thread_count() {
    let scenes = scenes();
    let models = ModelSet::shipped();
    let req = request(vec![AdversaryMethod::Safer, AdversaryMethod::Prior], 2);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let a = one.install(|| evaluate(&scenes, &req, &models, None, &|| {}));
    let b = evaluate(&scenes, &req, &models, None, &|| {});
    let key = |r: &safer_scenarios::harness::evaluation::VariantRecord| {
        (
            r.scenario.clone(),
            r.method,
            r.seed,
            r.stage1_collision,
            r.stage2_collision,
            r.stage1_min_gap_m.map(f64::to_bits),
        )
    };
    assert_eq!(a.iter().map(key).collect::<Vec<_>>(), b.iter().map(key).collect::<Vec<_>>());
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn every_ablation_runs_by_name() {
    let scenes = scenes();
    let models = ModelSet::shipped();
    let methods = vec![AdversaryMethod::NoTrustRegion, AdversaryMethod::NoMda, AdversaryMethod::Prior];
    let records = evaluate(&scenes[..1], &request(methods, 1), &models, None, &|| {});
    for r in &records {
        assert!(r.error.is_none(), "{:?}: {:?}", r.method, r.error);
    }
    assert_eq!(records.len(), 3);
}

/// A feasibility model that answers NaN (a broken export, say).
struct NanFeasibility;

impl safer_scenarios::policies::adversary::FeasibilityOracle for NanFeasibility {
    fn values(
        &self,
        pairs: &[safer_scenarios::policies::adversary::EgoCbvState],
    ) -> Result<Vec<f32>, safer_scenarios::models::ModelError> {
        Ok(vec![f32::NAN; pairs.len()])
    }
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn a_feasibility_model_answering_nan_fails_the_variant_naming_the_model() {
    // It once made every loss NaN and the adversary index an empty list.
    let shipped = ModelSet::shipped();
    let models = ModelSet {
        source: shipped.source.clone(),
        prior: shipped.prior.clone(),
        prior_plain: shipped.prior_plain.clone(),
        feasibility: Ok(Arc::new(NanFeasibility)),
    };
    let scenes = scenes();
    let records = evaluate(&scenes[..1], &request(vec![AdversaryMethod::Safer], 1), &models, None, &|| {});
    assert_eq!(records.len(), 1);
    let error = records[0].error.as_deref().expect("the variant must fail, not pass on NaN");
    assert!(error.contains("feasibility value V_h") && error.contains("NaN"), "{error}");
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn seeds_give_distinct_safer_variants() {
    // The arg min is deterministic; the seed's approach phase must still
    // make the CBV's stage-1 trajectories of one scene differ.
    use safer_scenarios::harness::methods::{MapEncodings, MethodSettings};
    use safer_scenarios::harness::pipeline::{self, VariantSetup};
    use safer_scenarios::policies::prior_sampling::TokenSampling;
    use safer_scenarios::sim::SimConfig;
    use safer_scenarios::spec::planner::PlannerAdapter;

    let models = ModelSet::shipped();
    let maps = MapEncodings::default();
    let sim = SimConfig::default();
    let planner = PlannerAdapter::Builtin {
        name: "constant-velocity".into(),
        planner: BuiltinPlanner::ConstantVelocity,
        idm: Default::default(),
        evasive: Default::default(),
    };
    for scenario in &scenes() {
        let cbv = scenario.cbv.unwrap();
        let end_states: Vec<_> = (0..3u64)
            .map(|seed| {
                let stages = pipeline::run(VariantSetup {
                    scenario,
                    settings: MethodSettings {
                        method: AdversaryMethod::Safer,
                        trust_region: 20,
                        background: BackgroundDriver::Configured,
                        sampling: TokenSampling::default(),
                        approach: safer_scenarios::policies::adversary::ApproachPhase::default(),
                        feasibility: safer_scenarios::policies::adversary::FeasibilityScope::Pair,
                        ego_contact: safer_scenarios::policies::adversary::EgoContactRule::Any,
                        wrong_way: safer_scenarios::policies::adversary::WrongWayRule::Allowed,
                        turning: safer_scenarios::policies::adversary::CbvTurningLimit::GRIP,
                        turning_cost: safer_scenarios::policies::adversary::CbvTurningCost::NONE,
                    },
                    seed,
                    sim: &sim,
                    stage2_cbv: Stage2Cbv::Replay,
                    planner: &planner,
                    models: &models,
                    maps: &maps,
                    variant: None,
                    escape: None,
                    ego_limits: None,
                    fault: None,
                })
                .unwrap();
                let track: Vec<_> = stages.stage1.states.iter().filter_map(|row| row[cbv.0]).collect();
                format!("{:?}", track.last().map(|s| s.position))
            })
            .collect();
        assert!(
            end_states.iter().any(|e| *e != end_states[0]),
            "{}: every seed ends the CBV at {}",
            scenario.id,
            end_states[0]
        );
    }
}
