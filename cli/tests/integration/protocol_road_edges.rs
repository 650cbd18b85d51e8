//! The planner protocol's road edges on every shared CommonRoad map (the
//! 84 NGSIM files and the shipped `scenes/ngsim/` scenes): each edge the
//! protocol sends is an outer boundary of the drivable area. Checked
//! independently of how the harness picks them, by probing the lanelets
//! (their bounds as polygons) beside every 2 m piece of every edge: none
//! beside it on its off-road side (a bound between lanes), and, for a piece
//! along an intersection lanelet's bound, none within 15 m beyond it (a
//! bound across the junction area). The importer's edges, which include
//! both kinds, are counted the same way for comparison.

use std::path::PathBuf;

use safer_scenarios::geometry::{Point2, Polygon, Polyline, Vector2};
use safer_scenarios::map::RoadMap;
use safer_scenarios::planners::external::protocol_road_edges;
use safer_scenarios::scenario::import;

use crate::shared_data::{data_dir, files};

/// Off-road probe beside an edge, m.
const BESIDE_M: f64 = 0.3;
/// How far beyond an intersection lanelet's bound the junction's lanes count, m.
const JUNCTION_M: f64 = 15.0;

/// Pieces of the edges (each `[x, y]` polyline cut into pieces of 2 m or
/// less) that are not real road edges: `(with a lanelet beside, across a
/// junction, all pieces, their length in m)`.
fn bad_pieces(map: &RoadMap, edges: &[Vec<[f64; 2]>]) -> (usize, usize, usize, f64) {
    let lanelets: Vec<Polygon> = map
        .lanes
        .iter()
        .filter_map(|l| {
            let (left, right) = (l.left_boundary.as_ref()?, l.right_boundary.as_ref()?);
            Some(Polygon::new(right.points().iter().chain(left.points().iter().rev()).copied().collect()))
        })
        .collect();
    let junction_bounds: Vec<&Polyline> = map
        .lanes
        .iter()
        .filter(|l| l.in_intersection)
        .flat_map(|l| [l.left_boundary.as_ref(), l.right_boundary.as_ref()])
        .flatten()
        .collect();
    let in_lanelet = |p: &Point2| lanelets.iter().any(|a| a.contains(p));
    let on_junction_bound =
        |p: &Point2| junction_bounds.iter().any(|b| b.project(p).is_some_and(|q| q.distance_m < 0.1));
    let (mut beside, mut across, mut total, mut length_m) = (0, 0, 0, 0.0);
    for edge in edges {
        let points: Vec<Point2> = edge.iter().map(|p| Point2::new(p[0], p[1])).collect();
        // Re-cut every piece into 2 m or less: the check does not rely on the
        // protocol's sampling.
        for pair in points.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            let along: Vector2 = b - a;
            let n = (along.norm() / 2.0).ceil().max(1.0) as usize;
            for k in 0..n {
                let p0 = a + along * (k as f64 / n as f64);
                let p1 = a + along * ((k + 1) as f64 / n as f64);
                let d = p1 - p0;
                if d.norm() < 1e-6 {
                    continue;
                }
                total += 1;
                length_m += d.norm();
                let out = Vector2::new(d.y, -d.x).normalize();
                let middle = Point2::from((p0.coords + p1.coords) * 0.5);
                if in_lanelet(&(middle + out * BESIDE_M)) {
                    beside += 1;
                } else if on_junction_bound(&p0)
                    && on_junction_bound(&p1)
                    && (1..=(JUNCTION_M / 0.5) as usize).any(|j| in_lanelet(&(middle + out * (j as f64 * 0.5))))
                {
                    across += 1;
                }
            }
        }
    }
    (beside, across, total, length_m)
}

#[test]
#[cfg_attr(not(recorded_data), ignore = "needs recorded data: set SAFER_DATA_DIR (docs/guide/recorded-data.md)")]
fn the_protocol_sends_only_real_road_edges_on_every_shared_commonroad_map() {
    let mut paths = files("commonroad-ngsim", "xml");
    assert_eq!(paths.len(), 84, "shared CommonRoad files in {}", data_dir().display());
    let shipped: Vec<PathBuf> = ["USA_US101-15_1_T-1.xml", "USA_US101-21_2_T-1.xml", "USA_US101-4_3_T-1.xml"]
        .iter()
        .map(|f| PathBuf::from(repo_root!()).join("scenes/ngsim").join(f))
        .collect();
    paths.extend(shipped);
    let (mut before, mut after) = ((0, 0, 0, 0.0), (0, 0, 0, 0.0));
    let (mut edges_before, mut edges_after) = (0, 0);
    for path in &paths {
        let s = import::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).remove(0);
        let importer: Vec<Vec<[f64; 2]>> =
            s.map.road_edges.iter().map(|e| e.polyline.points().iter().map(|p| [p.x, p.y]).collect()).collect();
        let sent = protocol_road_edges(&s.map);
        let b = bad_pieces(&s.map, &importer);
        let a = bad_pieces(&s.map, &sent);
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        println!(
            "{name}: importer's edges {} ({:.0} m, {} pieces, {} beside a lanelet, {} across a junction); \
             protocol's {} ({:.0} m, {} pieces, {} and {})",
            importer.len(),
            b.3,
            b.2,
            b.0,
            b.1,
            sent.len(),
            a.3,
            a.2,
            a.0,
            a.1
        );
        assert_eq!((a.0, a.1), (0, 0), "{name}: the protocol sends edges that are no road edges");
        // The outer kerbs stay: most of the importer's length is kept.
        assert!(a.3 > 0.75 * b.3, "{name}: only {:.0} m of {:.0} m of edges kept", a.3, b.3);
        before = (before.0 + b.0, before.1 + b.1, before.2 + b.2, before.3 + b.3);
        after = (after.0 + a.0, after.1 + a.1, after.2 + a.2, after.3 + a.3);
        edges_before += importer.len();
        edges_after += sent.len();
    }
    println!(
        "{} maps: importer's edges {edges_before} ({:.0} m, {} pieces of 2 m or less: {} beside a lanelet, {} across a \
         junction); protocol's {edges_after} ({:.0} m, {} pieces: {} and {})",
        paths.len(),
        before.3,
        before.2,
        before.0,
        before.1,
        after.3,
        after.2,
        after.0,
        after.1
    );
    // The importer's edges include junction bounds on the intersection maps
    // (Lankershim, Peachtree): the check finds them.
    assert!(before.1 > 0, "the check found no junction bound among the importer's edges");
}
