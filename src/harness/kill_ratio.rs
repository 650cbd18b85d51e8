//! How far a method's kill ratios over log replay's and the prior's move
//! with the scenes an evaluation happened to draw. A mutation table's
//! `×log` and `×prior` are ratios of two counts over the same few dozen
//! scenes, and a handful of scenes where one method catches a fault and
//! the other does not moves them by a tenth or more; a goal such as "twice
//! log replay's kills" is met only where the ratio's range over resampled
//! scenes stays above it.
//!
//! The range is a scene bootstrap: [`RESAMPLES`] draws of as many scenes
//! as the evaluation ran, with replacement, from a fixed seed; each draw's
//! ratio is the two methods' kills summed over the drawn scenes (each
//! scene's kills counted as the mutation table counts them,
//! [`MethodKills::of`] over that scene's variants); the range holds the
//! middle 95 % of the draws.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};

use super::evaluation::{VariantRecord, kills_inputs, stage2_modes};
use super::mutation::MethodKills;
use super::pipeline::Stage2Cbv;
use crate::spec::suite::AdversaryMethod;

/// Scene draws behind each range.
pub const RESAMPLES: usize = 2000;

/// The range of one method's kill ratios over resampled scenes.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct KillRatioRange {
    /// The method.
    pub method: AdversaryMethod,
    /// The CBV in stage 2.
    pub stage2_cbv: Stage2Cbv,
    /// Its kills over log replay's: the 2.5th and 97.5th percentiles of
    /// the draws (`None` where log replay did not run beside it).
    /// Infinite where a draw's scenes hold no log replay kill (`null` in a
    /// JSON report).
    /// Draws whose scenes hold no kill of either are left out; `None`
    /// where every draw is.
    pub over_log: Option<[f64; 2]>,
    /// The same over the prior's.
    pub over_prior: Option<[f64; 2]>,
}

/// The kill-ratio ranges of each method of `methods` (with mutants planted)
/// in each stage-2 mode `records` hold, in the mutation table's order.
pub fn kill_ratio_ranges(records: &[VariantRecord], methods: &[AdversaryMethod]) -> Vec<KillRatioRange> {
    let modes = stage2_modes(records);
    methods
        .iter()
        .flat_map(|&method| modes.iter().map(move |&mode| (method, mode)))
        .filter_map(|(method, mode)| {
            let own = kills_by_scene(records, method, mode)?;
            let over = |base: AdversaryMethod| resampled_ratio(&own, &kills_by_scene(records, base, mode)?);
            Some(KillRatioRange {
                method,
                stage2_cbv: mode,
                over_log: over(AdversaryMethod::Log),
                over_prior: over(AdversaryMethod::Prior),
            })
        })
        .collect()
}

/// Each scene's kills by `method`'s variants in stage-2 mode `mode`, as
/// [`MethodKills::of`] counts them over that scene's variants; `None`
/// where none of them ran with mutants.
fn kills_by_scene(
    records: &[VariantRecord],
    method: AdversaryMethod,
    mode: Stage2Cbv,
) -> Option<BTreeMap<&str, usize>> {
    let mut by_scene: BTreeMap<&str, Vec<&VariantRecord>> = BTreeMap::new();
    for r in records.iter().filter(|r| r.method == method && r.stage2_cbv == mode && r.error.is_none()) {
        by_scene.entry(r.scenario.as_str()).or_default().push(r);
    }
    let kills: BTreeMap<&str, usize> = by_scene
        .into_iter()
        .filter_map(|(scene, variants)| Some((scene, MethodKills::of(kills_inputs(&variants), None)?.kills)))
        .collect();
    (!kills.is_empty()).then_some(kills)
}

/// The 2.5th and 97.5th percentiles of `own`'s kills over `base`'s, summed
/// over [`RESAMPLES`] draws of as many scenes (those of either), with
/// replacement; a scene one of them did not run counts no kills for it,
/// and a draw with no kill of either says nothing of the ratio. `None`
/// where no draw holds a kill.
fn resampled_ratio(own: &BTreeMap<&str, usize>, base: &BTreeMap<&str, usize>) -> Option<[f64; 2]> {
    let scenes: Vec<(usize, usize)> = own
        .keys()
        .chain(base.keys())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .map(|scene| (own.get(scene).copied().unwrap_or(0), base.get(scene).copied().unwrap_or(0)))
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5afe_0002);
    let mut ratios: Vec<f64> = (0..RESAMPLES)
        .filter_map(|_| {
            let (a, b) = (0..scenes.len()).fold((0, 0), |(a, b), _| {
                let (x, y) = scenes[rng.random_range(0..scenes.len())];
                (a + x, b + y)
            });
            match (a, b) {
                (0, 0) => None,
                (_, 0) => Some(f64::INFINITY),
                _ => Some(a as f64 / b as f64),
            }
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    let last = ratios.len().checked_sub(1)?;
    let at = |q: f64| ratios[((q * last as f64).round() as usize).min(last)];
    Some([at(0.025), at(0.975)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::evaluation::table;
    use crate::harness::mutation::{MutantRecord, VariantMutation};
    use crate::planners::FaultOperator;

    /// A variant of `scene` by `method` whose planner passed, with a
    /// `no-brake` mutant that failed it where `killed`.
    fn variant(scene: &str, method: AdversaryMethod, seed: u32, killed: bool) -> VariantRecord {
        let mut r = VariantRecord::failed(scene, method, Stage2Cbv::ClosedLoop, seed, String::new());
        r.error = None;
        r.tally.cbv_path_digest = Some(u64::from(seed) + 1);
        r.mutation = Some(VariantMutation {
            base_failure: None,
            mutants: vec![MutantRecord {
                operator: FaultOperator::NoBrake,
                killed,
                failure: None,
                hit_cbv: killed,
                drove_differently: Some(true),
                path_departure_m: Some(0.0),
                error: None,
            }],
        });
        r
    }

    #[test]
    fn the_scenes_kills_add_up_to_the_tables_and_the_range_holds_the_ratio() {
        // Twelve scenes: the adversary kills in every one, log replay in
        // every third.
        let mut records = Vec::new();
        for s in 0..12 {
            let scene = format!("scene-{s:02}");
            records.push(variant(&scene, AdversaryMethod::Log, 0, s % 3 == 0));
            records.push(variant(&scene, AdversaryMethod::SaferInPath, 0, true));
            records.push(variant(&scene, AdversaryMethod::SaferInPath, 1, s % 2 == 0));
        }
        let methods = [AdversaryMethod::Log, AdversaryMethod::SaferInPath];
        let rows = table(&records, &methods);
        for method in methods {
            let by_scene = kills_by_scene(&records, method, Stage2Cbv::ClosedLoop).unwrap();
            let row = rows.iter().find(|r| r.method == method).unwrap();
            assert_eq!(by_scene.values().sum::<usize>(), row.kills.as_ref().unwrap().kills, "{method:?}");
        }
        let ranges = kill_ratio_ranges(&records, &methods);
        let in_path = ranges.iter().find(|r| r.method == AdversaryMethod::SaferInPath).unwrap();
        let [low, high] = in_path.over_log.unwrap();
        // 18 kills against 4: 4.5, inside a range that the draws widen;
        // no draw falls under 1 (where log replay kills, so does it).
        assert!(low < 4.5 && 4.5 < high, "{low}–{high}");
        assert!(low >= 1.0, "{low}–{high}");
        assert_eq!(in_path.over_prior, None, "no prior ran");
        // The same records give the same range (a fixed seed).
        assert_eq!(kill_ratio_ranges(&records, &methods), ranges);
        // Log replay over itself is one in every draw.
        let log = ranges.iter().find(|r| r.method == AdversaryMethod::Log).unwrap();
        assert_eq!(log.over_log, Some([1.0, 1.0]));
    }
}
