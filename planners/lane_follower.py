#!/usr/bin/env python3
"""Lane-following planner for SaFeR, speaking planner protocol 1.2 through
the Python planner kit (`python/safer_planner`, standard library only).

It uses nothing but what the protocol sends:

- `hello` (protocol 1.1 fields): the scenario it drives, logged to stderr.
- `prepare`: the whole map once; the lanes' speed limits are used.
- each `observation`: the stable `route` (with `route_lanes` and the ego's
  `route_s_m` along it), the ego and the agents around it; the kit names
  the `step` each reply answers (1.2).

Driving: pure pursuit on the route for steering; for speed an intelligent
driver model (IDM) towards a desired speed (the speed limit of the lane
the ego is on, else the speed it had at the first observation, lowered
ahead of curves by the kit's `curve_speed_limit`) with a time headway to
the nearest agent ahead in its corridor along the route, or going its way
and moving across into it within a second (a car cutting in). Without a route (off the map)
it keeps its heading and speed.

Protocol: docs/planner-protocol.md; the kit: docs/python-kit.md. It runs
from the repository without installing the kit (it puts the repository's
`python/` folder on `sys.path`). By hand:

    echo '{"type":"hello","protocol":1,"protocol_minor":2,"dt_s":0.1,"ego":{"length_m":4.5,"width_m":2}}' \
        | python3 planners/lane_follower.py
"""

import math
import os
import sys

# The repository's copy of the kit first: the Rust tests and snapshot
# suites drive this planner, so an older installed kit must not change it.
_KIT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "python")
if os.path.isfile(os.path.join(_KIT, "safer_planner", "__init__.py")):
    sys.path.insert(0, os.path.normpath(_KIT))

try:
    from safer_planner import Control, Observation, Path, Planner, RoadMap, curve_speed_limit, run, wrap_angle
except ImportError as e:  # a copy of this script away from the repository
    sys.exit(f"lane_follower: cannot import the planner kit ({e}): `pip install ./python` from the "
             "SaFeR repository, or put its python/ folder on PYTHONPATH")

MAX_ACCEL_MPS2 = 1.5  # IDM "a"
COMFORT_DECEL_MPS2 = 2.5  # IDM "b"
MAX_BRAKE_MPS2 = 8.0
TIME_HEADWAY_S = 1.4  # IDM "T"
STANDSTILL_GAP_M = 2.5  # IDM "s0"
MAX_SPEED_MPS = 35.0

LOOKAHEAD_MIN_M = 5.0
LOOKAHEAD_TIME_S = 0.9
MAX_YAW_RATE_RADPS = 1.0
MAX_LATERAL_ACCEL_MPS2 = 2.0
CURVE_PREVIEW_M = 50.0

PATH_MARGIN_M = 0.4  # corridor: half widths plus this
LEADER_RANGE_M = 120.0  # route stretch searched for a leader
CUT_IN_ANTICIPATION_S = 1.0  # a car going our way into the corridor is a leader this long before it is in


class LaneFollower(Planner):
    name = "lane-follower"
    log_name = "lane_follower"
    min_protocol_minor = 1  # it needs `prepare` and the stable route

    def __init__(self):
        self.cruise_mps = None

    def on_hello(self, hello):
        scenario = hello.raw.get("scenario") or {}
        self.log("hello: scenario", scenario.get("id"), "variant", scenario.get("variant"),
                 "horizon", hello.raw.get("horizon"))

    def on_prepare(self, road_map: RoadMap):
        self.log("prepared:", sum(1 for lane in road_map.lanes.values() if lane.path is not None), "lanes")

    def desired_speed(self, obs: Observation):
        """The speed limit of the route lane the ego is on, else the speed it
        had at the first observation (the traffic's)."""
        nearest = self.map.nearest_lane(obs.ego.x, obs.ego.y, among=obs.route.lane_ids) if self.map else None
        if nearest is not None and nearest[0].speed_limit_mps:
            return min(nearest[0].speed_limit_mps, MAX_SPEED_MPS)
        return self.cruise_mps

    def plan(self, obs: Observation) -> Control:
        v = obs.ego.speed_mps
        if self.cruise_mps is None:
            self.cruise_mps = min(MAX_SPEED_MPS, max(v, 5.0))
        path = obs.route.path
        if path is None:
            return Control(0.0, 0.0)
        s_ego = obs.ego_route_s()
        desired = self.desired_speed(obs)
        desired = min(desired, self.curve_speed(path, s_ego, desired))
        return Control(self.idm(obs, desired), self.steer(obs, path, s_ego))

    def steer(self, obs: Observation, path: Path, s_ego):
        """Pure pursuit: the yaw rate onto the circle through the route's
        point a speed-dependent look-ahead ahead."""
        ego = obs.ego
        v = ego.speed_mps
        lookahead = max(LOOKAHEAD_MIN_M, LOOKAHEAD_TIME_S * v)
        tx, ty = path.point_at(s_ego + lookahead)
        dx, dy = tx - ego.x, ty - ego.y
        distance = math.hypot(dx, dy)
        if distance < 1e-6:
            return 0.0
        alpha = wrap_angle(math.atan2(dy, dx) - ego.heading_rad)
        curvature = 2.0 * math.sin(alpha) / distance
        return max(-MAX_YAW_RATE_RADPS, min(MAX_YAW_RATE_RADPS, max(v, 1.0) * curvature))

    def curve_speed(self, path: Path, s_ego, allowed):
        """At most `allowed`, and slow enough to brake comfortably for every
        curve (4 m curvature windows) in the next CURVE_PREVIEW_M."""
        return curve_speed_limit(
            path,
            s_ego,
            allowed,
            max_lateral_accel_mps2=MAX_LATERAL_ACCEL_MPS2,
            max_yaw_rate_radps=MAX_YAW_RATE_RADPS,
            comfort_decel_mps2=COMFORT_DECEL_MPS2,
            preview_m=CURVE_PREVIEW_M,
            step_m=2.0,
            window_m=4.0,
            min_speed_mps=1.0,
        )

    def idm(self, obs: Observation, desired):
        """IDM: towards `desired`, keeping a time headway to the leader."""
        v = obs.ego.speed_mps
        free = 1.0 - (v / max(desired, 0.1)) ** 4
        interaction = 0.0
        # The nearest agent ahead whose box reaches into the ego's corridor
        # along the route (its half extent across the route as it is turned),
        # or a car cutting in that will within CUT_IN_ANTICIPATION_S.
        lead = obs.leader(margin_m=PATH_MARGIN_M, range_m=LEADER_RANGE_M, anticipate_s=CUT_IN_ANTICIPATION_S)
        if lead is not None:
            gap, v_lead = lead.gap_m, lead.speed_mps
            closing = v - max(v_lead, 0.0)
            desired_gap = STANDSTILL_GAP_M + max(
                0.0, v * TIME_HEADWAY_S + v * closing / (2.0 * math.sqrt(MAX_ACCEL_MPS2 * COMFORT_DECEL_MPS2))
            )
            interaction = (desired_gap / max(gap, 0.1)) ** 2
        accel = MAX_ACCEL_MPS2 * (free - interaction)
        if v <= 0.0 and accel < 0.0:
            accel = 0.0
        return max(-MAX_BRAKE_MPS2, min(MAX_ACCEL_MPS2, accel))


if __name__ == "__main__":
    run(LaneFollower)
