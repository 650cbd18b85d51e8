"""Reads every CommonRoad scenario `safer run --export-commonroad` wrote
under a folder with the real parser (commonroad-io) and checks that it
finds what the export holds: the lanelet network, the dynamic obstacles
with their trajectories, and the ego's planning problem with its initial
state and goal. Exits non-zero naming the first file that fails."""
import sys
from pathlib import Path

from commonroad.common.file_reader import CommonRoadFileReader


def check(path: Path) -> str:
    scenario, problems = CommonRoadFileReader(str(path)).open()
    lanelets = scenario.lanelet_network.lanelets
    assert lanelets, "no lanelet"
    obstacles = scenario.dynamic_obstacles
    assert obstacles, "no dynamic obstacle"
    states = 0
    for o in obstacles:
        assert o.obstacle_shape.length > 0 and o.obstacle_shape.width > 0, f"obstacle {o.obstacle_id}: no size"
        trajectory = o.prediction.trajectory if o.prediction is not None else None
        states += 1 + (len(trajectory.state_list) if trajectory is not None else 0)
    moving = [o for o in obstacles if o.prediction is not None and len(o.prediction.trajectory.state_list) > 0]
    assert moving, "no obstacle has a trajectory"
    assert len(problems.planning_problem_dict) == 1, "not one planning problem"
    problem = next(iter(problems.planning_problem_dict.values()))
    assert problem.initial_state.velocity >= 0, "planning problem: no initial velocity"
    assert problem.goal.state_list, "planning problem: no goal"
    return (f"{len(lanelets)} lanelets, {len(obstacles)} obstacles ({len(moving)} moving, {states} states), "
            f"planning problem {problem.planning_problem_id} from "
            f"({problem.initial_state.position[0]:.1f}, {problem.initial_state.position[1]:.1f})")


def main() -> int:
    root = Path(sys.argv[1])
    files = sorted(root.rglob("*.xml"))
    if not files:
        print(f"{root}: no exported scenario", file=sys.stderr)
        return 1
    for f in files:
        try:
            print(f"{f.relative_to(root)}: {check(f)}")
        except Exception as e:  # noqa: BLE001 - any failure names its file
            print(f"FAIL {f}: {type(e).__name__}: {e}", file=sys.stderr)
            return 1
    print(f"OK: commonroad-io read {len(files)} exported scenario(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
