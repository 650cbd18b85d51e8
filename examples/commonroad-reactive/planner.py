#!/usr/bin/env python3
"""The CommonRoad reactive planner as a safer planner: the ego follows the
route the harness sends (extended at both ends as the reference path), the
other road users drive on at constant velocity in its collision checker, and
it plans every 0.5 s, following its last plan in between (reactive.py).
With SAFER_REACTIVE_LOG=DIR it writes what it was given in each variant
(its routes, its first observation, the ego's states) to
DIR/<suite>/<scenario>/<seed-K>.json for reproduce.py and roundtrip.py."""
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from reactive import DT, Driver  # noqa: E402
from safer_planner import Planner, PlannerError, Trajectory, TrajectoryPoint, run  # noqa: E402


class ReactivePlanner(Planner):
    name, protocol_minor, min_protocol_minor = "commonroad-reactive", 3, 1  # needs the stable route (1.1+)
    driver, revision_seen, log_out = None, None, None

    def on_hello(self, hello):
        if abs(hello.dt_s - DT) > 1e-9:
            raise PlannerError(f"the reactive planner steps {DT} s; the harness steps {hello.dt_s} s")
        if hello.step_timeout_s is not None and hello.step_timeout_s < 5.0:  # 1.3: the harness says its timeouts
            self.log(f"a plan can take seconds; the step timeout is {hello.step_timeout_s} s (see the spec)")
        out, variant = os.environ.get("SAFER_REACTIVE_LOG"), hello.scenario and hello.scenario.variant
        if out and variant:
            path = os.path.join(out, *variant.split("::")) + ".json"
            self.log_out = {"path": path, "hello": hello.raw, "routes": [], "ego": {}}

    def plan(self, obs):
        ego, k = obs.ego, obs.step - (self.hello.horizon.start_step if self.hello.horizon else 0)
        if not obs.route:
            raise PlannerError(f"no route at step {obs.step}: the reactive planner needs a reference path")
        if self.driver is None:  # drive at the speed the ego had when the rollout started
            self.driver = Driver(ego.length_m, ego.width_m, max(ego.speed_mps, 1.0))
        if obs.route.revision != self.revision_seen:
            self.driver.set_route(obs.route.points)
            self.revision_seen = obs.route.revision
            if self.log_out is not None:
                self.log_out["routes"].append({"step": k, "lanes": obs.route.lane_ids, "points": obs.route.points})
        if self.log_out is not None:  # what it saw, and where it put the ego next
            self.log_out.setdefault("first", dict(obs.raw, origin_world=self.hello.origin_world))
        agents = [(a.x, a.y, a.heading_rad, a.speed_mps, a.length_m, a.width_m) for a in obs.agents]
        states = self.driver.step(k, (ego.x, ego.y, ego.heading_rad, ego.speed_mps), agents)
        if self.log_out is not None:
            self.log_out["ego"].update({k: (ego.x, ego.y, ego.heading_rad), k + 1: states[0][:3]})
        return Trajectory([TrajectoryPoint(DT * (i + 1), x, y, h, max(v, 0.0))
                           for i, (x, y, h, v) in enumerate(states)],  # 1.3: kept in the recording
                          debug={"plan_step": self.driver.last[0], "plans": self.driver.plans})

    def on_bye(self):
        if self.log_out is not None:
            self.log_out.update(plans=self.driver and self.driver.plans, failed=self.driver and self.driver.failed)
            os.makedirs(os.path.dirname(self.log_out["path"]), exist_ok=True)
            with open(self.log_out.pop("path"), "w") as f:
                json.dump(self.log_out, f)


run(ReactivePlanner)
