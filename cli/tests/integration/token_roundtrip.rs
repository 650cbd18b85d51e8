//! The log → token → log round trip on every recorded scene: how faithfully
//! the 63×63 token vocabulary and the kinematic model reproduce real driving.

use std::collections::BTreeMap;

use rayon::prelude::*;
use safer_scenarios::motion::inversion::{RoundTripError, round_trip_error};
use safer_scenarios::motion::tokenize_track;
use safer_scenarios::scenario::{AgentKind, SourceFormat};

use crate::shared_data::all_scenes;

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn vehicle_round_trip_error_is_small_in_every_format() {
    let per_scene: Vec<(SourceFormat, RoundTripError)> = all_scenes()
        .par_iter()
        .map(|s| {
            let mut e = RoundTripError::default();
            for t in s.tracks.iter().filter(|t| t.kind == AgentKind::Vehicle) {
                e.merge(&round_trip_error(t, &tokenize_track(t, s.current_step)));
            }
            (s.source.format, e)
        })
        .collect();
    let mut by_format: BTreeMap<SourceFormat, RoundTripError> = BTreeMap::new();
    for (f, e) in per_scene {
        by_format.entry(f).or_default().merge(&e);
    }
    assert_eq!(by_format.len(), 4, "expected all four formats: {:?}", by_format.keys());
    for (f, e) in &by_format {
        eprintln!(
            "{f:?}: vehicle ADE {:.3} m, FDE {:.3} m, max {:.2} m over {} steps",
            e.ade_m(),
            e.fde_m(),
            e.max_displacement_m,
            e.steps
        );
        assert!(e.steps > 1000, "{f:?}: only {} steps compared", e.steps);
        let (ade_bound, fde_bound) = bounds_m(*f);
        assert!(e.ade_m() < ade_bound, "{f:?}: ADE {:.3} m ≥ {ade_bound}", e.ade_m());
        assert!(e.fde_m() < fde_bound, "{f:?}: FDE {:.3} m ≥ {fde_bound}", e.fde_m());
    }
}

/// (ADE, FDE) bounds per format, m: the measured figures (README) with
/// about 2x head-room, so a change to the grid, the kinematic model or the
/// inversion that makes them worse fails here. Argoverse 2 is higher because
/// its one scene's parked cars drift 3–4.5 m sideways in the log at
/// ≤ 0.1 m/s reported speed: tracking noise a unicycle cannot follow.
fn bounds_m(format: SourceFormat) -> (f64, f64) {
    match format {
        SourceFormat::WomdProto | SourceFormat::WomdJson => (0.1, 0.15),
        SourceFormat::CommonRoad => (0.15, 0.2),
        SourceFormat::Argoverse2 => (1.0, 1.5),
        SourceFormat::Authored => (0.1, 0.1),
    }
}
