#!/usr/bin/env python3
"""Checks that a planner driven from safer's CommonRoad exports sees what
the planner saw in safer: for each export under EXPORTS with the log
planner.py wrote for it under LOGS (SAFER_PLANNER_SEEN_LOG, the same relative
path), the planning problem's initial state is the ego's first observed
state (and the sidecar's ego size its size), the dynamic obstacles at time 0 are the observed road users (same
place, heading and size; the same ones within the 120 m safer sends; but for those the sidecar lists as left
out, seen at a single step), and
CommonRoad's route planner (commonroad-route-planner, from the planning
problem to the farthest of its goal lanelets) finds a reference path along the lanes of safer's route: the
lanelet sequences, and how far safer's route strays from CommonRoad's
reference path over the stretch both cover ahead of the ego.

    roundtrip.py EXPORTS [LOGS] [--max-route-distance 1.0]

An export without a log (another planner's, or no LOGS) gets the route
check alone, against the route lanes its sidecar lists.

Prints one line per export; exits 1 naming the first mismatch."""
import argparse
import json
import math
import sys
import warnings
from pathlib import Path

warnings.filterwarnings("ignore")
import numpy as np  # noqa: E402
from commonroad_route_planner.reference_path_planner import ReferencePathPlanner  # noqa: E402
from commonroad_route_planner.route_planner import RoutePlanner  # noqa: E402
from shapely.geometry import LineString, Point  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reproduce import PERCEPTION_M, ego_size, frame_offset, load, obstacle_states  # noqa: E402


def commonroad_route(scenario, problem):
    """commonroad-route-planner's reference path from the planning problem
    to the farthest goal lanelet: the goal is every lanelet of the route,
    the ego's own included, so the shortest route would stop on the first."""
    sequences = RoutePlanner(scenario.lanelet_network, problem).plan_routes()
    longest = [max(sequences, key=lambda r: len(r.lanelet_ids))]
    return ReferencePathPlanner(scenario.lanelet_network, problem, longest).plan_shortest_reference_path()


def along(safer_lanes, cr_lanes):
    """Whether CommonRoad's lanelets are safer's route from the ego's
    lanelet on (safer's starts behind the ego, and may run past the goal)."""
    ahead = safer_lanes[safer_lanes.index(cr_lanes[0]):] if cr_lanes[0] in safer_lanes else []
    return ahead[: len(cr_lanes)] == cr_lanes


def check_route(export):
    """An export without a planner log: CommonRoad's route against safer's
    route lanes as the sidecar lists them (``goal_lanelets``)."""
    scenario, problem = load(export)
    lanes = json.loads(export.with_suffix(".commonroad.json").read_text())["goal_lanelets"]
    cr_lanes = list(commonroad_route(scenario, problem).lanelet_ids)
    line = f"route lanes safer {lanes} commonroad {cr_lanes} (no planner log: the route only)"
    assert along(lanes, cr_lanes), f"the lanelet sequences differ: {line}"
    return line


def check(export, log, max_route_m):
    """One export against its log: a summary line, or AssertionError."""
    scenario, problem = load(export)
    first = log["first"]
    off = frame_offset(problem, first)  # the initial position, in the file's frame
    ego, init = first["ego"], problem.initial_state
    assert abs(math.remainder(init.orientation - ego["heading_rad"], math.tau)) < 1e-3, "initial heading differs"
    assert abs(init.velocity - ego["speed_mps"]) < 0.01, f"initial speed {init.velocity} != {ego['speed_mps']}"
    size = ego_size(export, log)
    assert abs(size[0] - ego["length_m"]) < 0.01 and abs(size[1] - ego["width_m"]) < 0.01, f"ego size {size}"
    at0 = {oid: (s[0], l, w) for oid, l, w, s in obstacle_states(scenario, problem, off) if 0 in s}
    near = {oid for oid, (s, _, _) in at0.items() if math.hypot(s[0] - ego["x"], s[1] - ego["y"]) <= PERCEPTION_M}
    seen = set()
    # An agent seen at a single step is left out of the export (the sidecar says which).
    left_out = set(json.loads(export.with_suffix(".commonroad.json").read_text())["left_out"])
    for a in (a for a in first["agents"] if a["id"] not in left_out):
        match = [oid for oid, (s, l, w) in at0.items() if math.hypot(s[0] - a["x"], s[1] - a["y"]) < 0.05
                 and abs(math.remainder(s[2] - a["heading_rad"], math.tau)) < 1e-3
                 and abs(l - a["length_m"]) < 0.01 and abs(w - a["width_m"]) < 0.01]
        assert match, f"observed agent {a['id']} is no exported obstacle at time 0"
        seen.add(match[0])
    assert near <= seen, f"exported obstacles {sorted(near - seen)} within {PERCEPTION_M} m were not observed"
    route = log["routes"][0]
    reference = commonroad_route(scenario, problem)
    cr_lanes = list(reference.lanelet_ids)
    cr_path = LineString(reference.reference_path - np.asarray(off))
    safer_path = LineString(route["points"])
    start = safer_path.project(Point(ego["x"], ego["y"]))
    # The stretch both cover: from the ego ahead to where the shorter ends.
    end = min(safer_path.length, start + cr_path.length - cr_path.project(Point(ego["x"], ego["y"])))
    ahead = [safer_path.interpolate(s) for s in np.arange(start, end, 1.0)]
    distance = max((cr_path.distance(p) for p in ahead), default=math.inf)
    same_lanes = along(route["lanes"], cr_lanes)
    line = (f"{len(first['agents'])} agents matched, {len(near)} exported within {PERCEPTION_M:.0f} m; "
            f"route lanes safer {route['lanes']} commonroad {cr_lanes}; "
            f"safer's route within {distance:.2f} m of commonroad's over {end - start:.0f} m")
    assert same_lanes, f"the lanelet sequences differ: {line}"
    assert distance <= max_route_m, f"the reference paths are {distance:.2f} m apart: {line}"
    return line


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("exports", type=Path), ap.add_argument("logs", type=Path, nargs="?")
    ap.add_argument("--max-route-distance", type=float, default=1.0)
    a = ap.parse_args()
    done = logged = 0
    for export in sorted(a.exports.rglob("*.xml")):
        rel = export.relative_to(a.exports)
        if rel.name.endswith(".unshrunk.xml"):
            continue
        log = a.logs / rel.with_suffix(".json") if a.logs else None
        try:
            if log and log.exists():
                print(f"{rel}: {check(export, json.loads(log.read_text()), a.max_route_distance)}")
                logged += 1
            else:
                print(f"{rel}: {check_route(export)}")
        except (AssertionError, ValueError, KeyError, SystemExit) as e:
            print(f"FAIL {rel}: {e}", file=sys.stderr)
            return 1
        done += 1
    print(f"OK: {done} export(s): CommonRoad's route is safer's; {logged} show the planner all it saw in safer")
    return 0 if done else 1


if __name__ == "__main__":
    sys.exit(main())
