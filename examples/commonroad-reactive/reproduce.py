#!/usr/bin/env python3
"""Drives the reactive planner inside CommonRoad on a variant safer exported
(``safer run --export-commonroad``), the way the planner's own
run_planner.py does: a closed loop from the planning problem's initial
state over the exported dynamic obstacles, the planner placing the ego on
its plan's next state at every step. It is given what planner.py was given
in safer (the kit's SAFER_PLANNER_SEEN_LOG): the same route from the same step, the same
replanning schedule, the obstacles within the same 120 m. Then it compares
the two outcomes: the first collision (agent and time) and the smallest
clearance, each side measured the same way (box against box).

    reproduce.py EXPORT.xml LOG.json [--report SAFER.json] [--json OUT] [--png OUT]

With --report (``safer run --json``), safer's side is safer's own verdict
on the variant (its collision and smallest gap) instead of the same
measurement on the ego safer moved.

--png draws the export with CommonRoad's own renderer (MPRenderer) at the
collision (else at its last step), with both egos' paths and boxes.

Exits 1 when the outcomes differ: another agent hit or the collision more
than 0.5 s apart, or, without a collision, the smallest clearances more
than 0.2 m apart."""
import argparse
import json
import math
import sys
import warnings
from pathlib import Path

warnings.filterwarnings("ignore")
from commonroad.common.file_reader import CommonRoadFileReader  # noqa: E402
from shapely.geometry import Polygon  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import commonroad_dc.pycrcc as pycrcc  # noqa: E402
from planner import DT, HORIZON_STEPS, Driver  # noqa: E402
from safer_planner import Agent, NoPlanLeft  # noqa: E402

PERCEPTION_M = 120.0  # safer sends the planner the road users within this range of the ego


def box(x, y, h, length, width):
    """The rectangle of a box centred at ``(x, y)`` heading ``h``."""
    c, s, l2, w2 = math.cos(h), math.sin(h), length / 2, width / 2
    return Polygon([(x + c * a - s * b, y + s * a + c * b) for a, b in ((l2, w2), (-l2, w2), (-l2, -w2), (l2, -w2))])


def frame_offset(problem, first):
    """What to subtract from the export's coordinates to get safer's local
    frame: nothing, or the scene's ``origin_world`` (an export in the source
    frame); whichever puts the planning problem's ego where safer's was."""
    ego, p = first["ego"], problem.initial_state.position
    for off in ((0.0, 0.0), tuple(first.get("origin_world") or (0.0, 0.0))):
        if math.hypot(p[0] - off[0] - ego["x"], p[1] - off[1] - ego["y"]) < 0.05:
            return off
    raise SystemExit(f"the exported ego starts at {tuple(p)}, safer's at ({ego['x']}, {ego['y']}): not the same frame")


def ego_size(export, log):
    """The ego's ``(length, width)``: from the export's sidecar
    (``NAME.commonroad.json``; CommonRoad 2020a has no place for it), else as safer sent it."""
    sidecar = Path(export).with_suffix(".commonroad.json")
    ego = json.loads(sidecar.read_text())["ego"] if sidecar.exists() else log["first"]["ego"]
    return ego["length_m"], ego["width_m"]


def load(export):
    """The export's scenario and its one planning problem."""
    scenario, problems = CommonRoadFileReader(str(export)).open()
    return scenario, next(iter(problems.planning_problem_dict.values()))


def obstacle_states(scenario, problem, off):
    """For each dynamic obstacle: its id, size and ``{k: (x, y, heading,
    speed)}`` in safer's frame, ``k`` counting from the planning problem's
    time step (the rollout's first)."""
    out, base = [], problem.initial_state.time_step
    for o in scenario.dynamic_obstacles:
        states = [o.initial_state] + (list(o.prediction.trajectory.state_list) if o.prediction else [])
        by_step = {s.time_step - base: (s.position[0] - off[0], s.position[1] - off[1], s.orientation, s.velocity)
                   for s in states}
        out.append((o.obstacle_id, o.obstacle_shape.length, o.obstacle_shape.width, by_step))
    return out


def known_future(obstacles, k):
    """A collision checker holding the obstacles on their exported
    trajectories from step ``k`` (what run_planner.py gives the planner)."""
    checker = pycrcc.CollisionChecker()
    for _, length, width, by_step in obstacles:
        tvo = pycrcc.TimeVariantCollisionObject(k)
        for i in range(k, k + HORIZON_STEPS + 1):
            if i not in by_step:
                break
            x, y, h, _ = by_step[i]
            tvo.append_obstacle(pycrcc.RectOBB(length / 2, width / 2, h, x, y))
        if k in by_step:
            checker.add_collision_object(tvo)
    return checker


def outcome(ego_states, size, obstacles, ids=None):
    """First collision ``(agent, time_s)`` (or ``None``) and the smallest
    clearance of the ego's boxes ``{step: (x, y, heading)}`` to the obstacles'."""
    first, clearance = None, math.inf
    for k in sorted(ego_states):
        e = box(*ego_states[k], *size)
        for oid, length, width, by_step in obstacles:
            if k in by_step:
                d = e.distance(box(*by_step[k][:3], length, width))
                clearance = min(clearance, d)
                if d == 0.0 and first is None:
                    first = ((ids or {}).get(oid, oid), round(k * DT, 3))
    return first, clearance


def agent(oid, x, y, heading, speed, length, width):
    """An exported obstacle's state as the kit's ``Agent`` (driving along its heading)."""
    return Agent(str(oid), "vehicle", x, y, heading, speed * math.cos(heading), speed * math.sin(heading), length, width)


def drive(log, problem, obstacles, off, steps, size, oracle=False):
    """The ego's states ``{step: (x, y, heading)}`` with the reactive planner
    in the loop, from the planning problem's initial state; with ``oracle``
    it plans against the obstacles' exported trajectories,
    as run_planner.py does, instead of what safer showed it."""
    init = problem.initial_state
    ego = (init.position[0] - off[0], init.position[1] - off[1], init.orientation, init.velocity)
    driver, routes, states = Driver(*size, max(init.velocity, 1.0)), {r["step"]: r for r in log["routes"]}, {}
    for k in range(steps):
        states[k] = ego[:3]
        if k in routes:
            driver.set_route(routes[k]["points"])
        near = [agent(oid, *s[k], length, width) for oid, length, width, s in obstacles
                if k in s and math.hypot(s[k][0] - ego[0], s[k][1] - ego[1]) <= PERCEPTION_M]
        try:
            ego = driver.step(k, ego, near, oracle and known_future(obstacles, k))[0]
        except NoPlanLeft:  # the planner gives up: the rollout ends here, in safer too
            break
    return states


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("export"), ap.add_argument("log"), ap.add_argument("--json"), ap.add_argument("--png")
    ap.add_argument("--report")
    ap.add_argument("--oracle", action="store_true",
                    help="plan against the exported trajectories (the future), as run_planner.py does; "
                         "reported beside, not compared")
    a = ap.parse_args()
    log = json.load(open(a.log))
    scenario, problem = load(a.export)
    off = frame_offset(problem, log["first"])
    obstacles = obstacle_states(scenario, problem, off)
    safer_ego = {int(k): tuple(v) for k, v in log["ego"].items()}
    size = ego_size(a.export, log)
    cr_ego = drive(log, problem, obstacles, off, len(safer_ego), size)
    ids = match_ids(log["first"], obstacles)
    safer, cr = outcome(safer_ego, size, obstacles, ids), outcome(cr_ego, size, obstacles, ids)
    if a.report:
        safer = reported(a.report, log["hello"]["scenario"]["variant"])
    drift = max(math.dist(cr_ego[k][:2], safer_ego[k][:2]) for k in safer_ego if k in cr_ego)
    same = (safer[0] is None) == (cr[0] is None) and (
        abs(safer[1] - cr[1]) <= 0.2 if safer[0] is None
        else safer[0][0] == cr[0][0] and abs(safer[0][1] - cr[0][1]) <= 0.5)
    report = {"export": a.export, "steps": len(safer_ego), "max_ego_distance_m": round(drift, 3), "same": same,
              "safer": {"collision": safer[0], "min_clearance_m": round(safer[1], 3)},
              "commonroad": {"collision": cr[0], "min_clearance_m": round(cr[1], 3)}}
    if a.oracle:
        future = drive(log, problem, obstacles, off, len(safer_ego), size, oracle=True)
        hit, gap = outcome(future, size, obstacles, ids)
        report["commonroad_knowing_the_future"] = {"collision": hit, "min_clearance_m": round(gap, 3)}
    print(json.dumps(report))
    if a.json:
        json.dump(report, open(a.json, "w"), indent=1)
    if a.png:
        picture(scenario, problem, off, {"safer": safer_ego, "CommonRoad": cr_ego}, size, cr, a.png)
    return 0 if same else 1


def picture(scenario, problem, off, egos, size, result, out):
    """The export at the collision's step (else the end) drawn by MPRenderer,
    with each ego's path and box (safer's frame shifted back to the file's)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from commonroad.visualization.mp_renderer import MPRenderer

    k = round(result[0][1] / DT) if result[0] else max(egos["CommonRoad"])
    fig = plt.figure(figsize=(10, 7))
    rnd = MPRenderer(ax=fig.gca())
    rnd.draw_params.time_begin = problem.initial_state.time_step + k  # the export's time steps
    scenario.draw(rnd)
    problem.draw(rnd)
    rnd.render()
    for (name, states), colour, lw, ls in zip(egos.items(), ("tab:red", "tab:blue"), (3, 1.5), ("-", "--")):
        xs, ys = zip(*[(p[0] + off[0], p[1] + off[1]) for _, p in sorted(states.items())])
        rnd.ax.plot(xs, ys, color=colour, lw=lw, ls=ls, zorder=50, label=f"ego in {name}")
        x, y, h = states[min(k, max(states))]
        rnd.ax.add_patch(plt.Polygon(box(x + off[0], y + off[1], h, *size).exterior.coords, fill=False,
                                     ec=colour, lw=lw, ls=ls, zorder=51))
    hit = result[0] and str(result[0][0]).isdigit() and scenario.obstacle_by_id(int(result[0][0]))
    if hit and hit.state_at_time(problem.initial_state.time_step + k) is not None:  # the agent hit, outlined
        s = hit.state_at_time(problem.initial_state.time_step + k)
        rnd.ax.add_patch(plt.Polygon(box(*s.position, s.orientation, hit.obstacle_shape.length,
                                         hit.obstacle_shape.width).exterior.coords, fill=False, ec="tab:orange",
                                     lw=2.5, zorder=52, label=f"agent {hit.obstacle_id}, hit"))
    x, y, _ = egos["CommonRoad"][min(k, max(egos["CommonRoad"]))]
    rnd.ax.set_aspect("equal", adjustable="datalim")
    rnd.ax.set_xlim(x + off[0] - 20, x + off[0] + 20), rnd.ax.set_ylim(y + off[1] - 12, y + off[1] + 12)
    rnd.ax.legend(loc="lower left")
    what = f"collision with {result[0][0]}" if result[0] else "no collision"
    rnd.ax.set_title(f"{scenario.scenario_id} at t = {k * DT:.1f} s ({what})")
    fig.savefig(out, dpi=120, bbox_inches="tight")


def reported(report, variant):
    """safer's verdict on ``variant`` in a ``safer run --json`` report: its
    first collision ``(agent, time_s)`` (or ``None``) and smallest gap."""
    for suite in json.load(open(report))["suites"]:
        for v in suite["variants"]:
            if v["variant"] == variant:
                hit = v["stage2_collision"]
                agent, _, t = hit.rpartition(" at ") if hit else (None, None, None)
                return ((agent, float(t.removesuffix(" s"))) if hit else None), v["stage2_min_gap_m"]
    raise SystemExit(f"{report} has no variant {variant}")


def match_ids(first, obstacles):
    """safer's agent ids by exported obstacle id: the agent at the same place at step 0."""
    out = {}
    for agent in first["agents"]:
        for oid, _, _, s in obstacles:
            if 0 in s and math.hypot(s[0][0] - agent["x"], s[0][1] - agent["y"]) < 0.05:
                out[oid] = agent["id"]
    return out


if __name__ == "__main__":
    sys.exit(main())
