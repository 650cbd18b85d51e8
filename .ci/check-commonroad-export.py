"""Reads every CommonRoad scenario `safer run --export-commonroad` wrote
under a folder with the real parsers (commonroad-io, and the road boundary
of commonroad-drivability-checker) and checks that it finds what the export
holds, and, for an export of a CommonRoad recording, that it reproduces the
source:

- read: the lanelet network, the dynamic obstacles with their trajectories,
  and the ego's planning problem with its initial state and goal; the
  sidecar JSON with the ego's size.
- schema: the file validates against commonroad-io's CommonRoad 2020a XML
  schema, once the obstacles the sidecar lists as entering late (which the
  schema cannot express) are set aside.
- lanelets: the source's lanelet ids, and each lanelet's bounds, exactly.
- lights: the source's traffic lights, each showing at every time step t
  of the export the colour the source's shows at t + source_first_time_step.
- obstacles: every obstacle but the ego, the CBV (the adversary) and the
  agents the sidecar lists as left out (seen at a single step) at the
  export's time step 0 is where the source has it at the rollout's first
  time step, in the same frame, under the same id.
- boundary: CommonRoad's road boundary (create_road_boundary_obstacle)
  does not overlap the ego's initial box where the source's does not.

Prints one line per file and how many files pass each check; exits
non-zero when any file fails any check, naming it.
"""
import functools
import json
import sys
from pathlib import Path

from commonroad.common.file_reader import CommonRoadFileReader

# Positions written with Rust's shortest round-trip form: equal to the
# source's up to the origin shift's rounding.
TOLERANCE_M = 1e-6

CHECKS = ["read", "schema", "lanelets", "lights", "obstacles", "boundary"]
ALL_FILES = {"read", "schema"}


@functools.lru_cache(maxsize=1)
def commonroad_schema():
    """commonroad-io's CommonRoad 2020a XSD, compiled once for every file."""
    import commonroad
    from lxml import etree

    xsd = Path(commonroad.__file__).parent / "scenario_definition" / "xml_definition_files" / "XML_commonRoad_XSD.xsd"
    return etree.XMLSchema(etree.parse(str(xsd)))


def check_schema(path: Path, sidecar) -> None:
    from lxml import etree

    schema = commonroad_schema()
    doc = etree.parse(str(path))
    late = {str(i) for i in sidecar["late_obstacles"]}
    for o in doc.getroot().findall("dynamicObstacle"):
        if o.get("id") in late:
            o.getparent().remove(o)
    if not schema.validate(doc):
        errors = [f"line {e.line}: {e.message}" for e in list(schema.error_log)[:3]]
        raise AssertionError(f"{len(schema.error_log)} schema error(s), first: {'; '.join(errors)}")


def read(path: Path):
    scenario, problems = CommonRoadFileReader(str(path)).open()
    lanelets = scenario.lanelet_network.lanelets
    assert lanelets, "no lanelet"
    obstacles = scenario.dynamic_obstacles
    assert obstacles, "no dynamic obstacle"
    for o in obstacles:
        assert o.obstacle_shape.length > 0 and o.obstacle_shape.width > 0, f"obstacle {o.obstacle_id}: no size"
    moving = [o for o in obstacles if o.prediction is not None and len(o.prediction.trajectory.state_list) > 0]
    assert moving, "no obstacle has a trajectory"
    assert len(problems.planning_problem_dict) == 1, "not one planning problem"
    problem = next(iter(problems.planning_problem_dict.values()))
    assert problem.initial_state.velocity >= 0, "planning problem: no initial velocity"
    assert problem.goal.state_list, "planning problem: no goal"
    sidecar_path = path.with_suffix(".commonroad.json")
    sidecar = json.loads(sidecar_path.read_text())
    assert sidecar["format"] == "safer-commonroad-export", f"{sidecar_path}: not a sidecar"
    assert sidecar["ego"]["length_m"] > 0 and sidecar["ego"]["width_m"] > 0, "sidecar: no ego size"
    assert sidecar["ego"]["planning_problem_id"] == problem.planning_problem_id, "sidecar: another planning problem"
    goal_time = problem.goal.state_list[0].time_step
    assert goal_time.end == sidecar["last_time_step"], f"goal at {goal_time}, rollout ends {sidecar['last_time_step']}"
    return scenario, problem, sidecar


def check_lanelets(export, source) -> None:
    ours = {l.lanelet_id: l for l in export.lanelet_network.lanelets}
    theirs = {l.lanelet_id: l for l in source.lanelet_network.lanelets}
    assert sorted(ours) == sorted(theirs), f"lanelet ids {sorted(set(ours) ^ set(theirs))[:5]} differ"
    for i, l in theirs.items():
        o = ours[i]
        for side in ("left_vertices", "right_vertices"):
            a, b = getattr(o, side), getattr(l, side)
            assert a.shape == b.shape and abs(a - b).max() <= TOLERANCE_M, f"lanelet {i}: {side} differ"
        for rel in ("adj_left", "adj_right", "adj_left_same_direction", "adj_right_same_direction"):
            assert getattr(o, rel) == getattr(l, rel), f"lanelet {i}: {rel} differs"


def check_lights(export, source, sidecar) -> None:
    ours = {t.traffic_light_id: t for t in export.lanelet_network.traffic_lights}
    theirs = {t.traffic_light_id: t for t in source.lanelet_network.traffic_lights}
    assert sorted(ours) == sorted(theirs), f"traffic lights {sorted(ours)}, the source has {sorted(theirs)}"
    shift = sidecar["source_first_time_step"]
    for i, light in theirs.items():
        if light.traffic_light_cycle is None:
            continue
        for t in range(sidecar["last_time_step"] + 1):
            a, b = ours[i].get_state_at_time_step(t), light.get_state_at_time_step(t + shift)
            assert a == b, f"traffic light {i} at time step {t}: {a}, the source's at {t + shift}: {b}"


def check_obstacles(export, source, sidecar) -> None:
    t = sidecar["source_first_time_step"]
    # The ego is the planning problem; an agent seen at a single step is left out.
    skip = {int(sidecar["ego"]["source_id"])} | {int(i) for i in sidecar["left_out"]}
    if sidecar["cbv"] is not None:
        skip.add(int(sidecar["cbv"]["source_id"]))
    ours = {o.obstacle_id: o.state_at_time(0) for o in export.dynamic_obstacles}
    theirs = {o.obstacle_id: o.state_at_time(t) for o in source.dynamic_obstacles + source.static_obstacles}
    ours = {i: s for i, s in ours.items() if s is not None and i not in skip}
    theirs = {i: s for i, s in theirs.items() if s is not None and i not in skip}
    assert sorted(ours) == sorted(theirs), f"at time step {t}, obstacles {sorted(set(ours) ^ set(theirs))[:5]} differ"
    for i, s in theirs.items():
        d = abs(ours[i].position - s.position).max()
        assert d <= TOLERANCE_M, f"obstacle {i} at time step {t}: {d:.3g} m from the source"


def boundary_overlaps(scenario, problem, sidecar) -> bool:
    from commonroad_dc import pycrcc
    from commonroad_dc.boundary.boundary import create_road_boundary_obstacle

    _, boundary = create_road_boundary_obstacle(scenario)
    s = problem.initial_state
    ego = pycrcc.RectOBB(sidecar["ego"]["length_m"] / 2, sidecar["ego"]["width_m"] / 2, s.orientation,
                         s.position[0], s.position[1])
    return boundary.collide(ego)


def check(path: Path, passed: dict) -> list:
    """The checks `path` fails, as messages."""
    failures = []
    try:
        export, problem, sidecar = read(path)
    except Exception as e:  # noqa: BLE001 - any failure names its file
        return [f"read: {type(e).__name__}: {e}"]
    passed["read"] += 1
    try:
        check_schema(path, sidecar)
        passed["schema"] += 1
    except Exception as e:  # noqa: BLE001
        failures.append(f"schema: {type(e).__name__}: {e}")
    if sidecar["source_format"] != "common-road" or sidecar["map"] != "copied":
        return failures
    source, _ = CommonRoadFileReader(sidecar["source_path"]).open()
    for name, run in [
        ("lanelets", lambda: check_lanelets(export, source)),
        ("lights", lambda: check_lights(export, source, sidecar)),
        ("obstacles", lambda: check_obstacles(export, source, sidecar)),
    ]:
        try:
            run()
            passed[name] += 1
        except Exception as e:  # noqa: BLE001 - each check reports its own failure
            failures.append(f"{name}: {type(e).__name__}: {e}")
    try:
        ours, theirs = boundary_overlaps(export, problem, sidecar), boundary_overlaps(source, problem, sidecar)
        assert theirs or not ours, "the road boundary overlaps the ego's initial box, the source's does not"
        passed["boundary"] += 1
        if theirs:
            passed["boundary (the source's overlaps too)"] += 1
    except Exception as e:  # noqa: BLE001
        failures.append(f"boundary: {type(e).__name__}: {e}")
    return failures


def main() -> int:
    root = Path(sys.argv[1])
    files = sorted(root.rglob("*.xml"))
    if not files:
        print(f"{root}: no exported scenario", file=sys.stderr)
        return 1
    passed = {c: 0 for c in CHECKS}
    passed["boundary (the source's overlaps too)"] = 0
    from_commonroad = 0
    failed = []
    for f in files:
        failures = check(f, passed)
        sidecar = f.with_suffix(".commonroad.json")
        if sidecar.exists() and json.loads(sidecar.read_text()).get("map") == "copied":
            from_commonroad += 1
        for message in failures:
            print(f"FAIL {f}: {message}", file=sys.stderr)
        if failures:
            failed.append(f)
        else:
            print(f"{f.relative_to(root)}: ok")
    print(f"{len(files)} exported scenario(s), {from_commonroad} copied from a CommonRoad source; passed: "
          + ", ".join(f"{c} {n}/{len(files) if c in ALL_FILES else from_commonroad}" for c, n in passed.items()))
    if failed:
        print(f"FAIL: {len(failed)} file(s) failed, first {failed[0]}", file=sys.stderr)
        return 1
    print(f"OK: commonroad-io read {len(files)} exported scenario(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
