#!/usr/bin/env python3
"""Example external planner for SaFeR, written with the Python planner kit
(`python/safer_planner`, standard library only).

It speaks protocol 1.0, the protocol as first published (`protocol_minor =
0`): the map near the ego and a route *hint* from the ego forward in every
observation, no `prepare`. The kit does the protocol: it answers `hello`
with `ready`, each observation with one line on stdout (flushed at once,
naming the observation's `step`), exits on `bye`, and sends stray `print`s
to stderr (stdout is for protocol messages only).

Driving: pure pursuit along the `route` hint for steering, and for speed an
intelligent-driver-model (IDM) rule: cruise at a desired speed, keep a time
headway to the nearest agent ahead in the ego's path, brake harder as the gap
closes. Signals are ignored (the observation names controlled lanes, not
stop lines), so this is a lane-keeping follower, not a full driver.

Protocol: docs/planner-protocol.md; the kit: docs/python-kit.md. It runs
from the repository without installing the kit (it puts the repository's
`python/` folder on `sys.path`). Run by hand to see the exchange:

    echo '{"type":"hello","protocol":1,"dt_s":0.1,"ego":{"length_m":4.5,"width_m":2}}' \
        | python3 planners/example_planner.py
"""

import math
import os
import sys

# The repository's copy of the kit first (an installed one otherwise): the
# Rust tests drive this planner, so an older installed kit must not change it.
_KIT = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "python")
if os.path.isfile(os.path.join(_KIT, "safer_planner", "__init__.py")):
    sys.path.insert(0, os.path.normpath(_KIT))

try:
    from safer_planner import Control, Observation, Path, Planner, run
except ImportError as e:  # a copy of this script away from the repository
    sys.exit(f"example_planner: cannot import the planner kit ({e}): `pip install ./python` from the "
             "SaFeR repository, or put its python/ folder on PYTHONPATH")

# Speed keeping.
DESIRED_SPEED_MPS = 10.0
MAX_ACCEL_MPS2 = 2.0  # IDM "a": the comfortable acceleration
COMFORT_DECEL_MPS2 = 3.0  # IDM "b": the comfortable deceleration
MAX_BRAKE_MPS2 = 8.0  # harder than this is beyond a car's tyres
TIME_HEADWAY_S = 1.5  # IDM "T": the gap kept is this many seconds of travel
STANDSTILL_GAP_M = 2.5  # IDM "s0": bumper-to-bumper gap when stopped

# Steering.
LOOKAHEAD_MIN_M = 4.0
LOOKAHEAD_TIME_S = 0.8  # the look-ahead grows with speed for smooth tracking
MAX_YAW_RATE_RADPS = 1.0

# Curves: keep lateral acceleration and yaw rate within these limits, and
# slow down early enough (at the comfortable deceleration) for curves ahead.
MAX_LATERAL_ACCEL_MPS2 = 2.0
CURVE_PREVIEW_M = 40.0

# An agent is "in the path" when its box comes this close to the route
# laterally (half widths plus a margin).
PATH_MARGIN_M = 0.5


def route_or_straight(obs: Observation) -> Path:
    """The route hint, or a straight line along the ego's heading if there
    is none (off the map, or no lane in the ego's direction)."""
    if obs.route.path is not None:
        return obs.route.path
    ego = obs.ego
    c, s = math.cos(ego.heading_rad), math.sin(ego.heading_rad)
    return Path([(ego.x + c * d, ego.y + s * d) for d in range(0, 101, 2)])


def point_at(path: Path, s: float):
    """The point at arc length s along the path, clamped to its ends (a
    point past the hint's end is its last point)."""
    return path.point_at(min(s, path.length))


def heading_at(path: Path, s: float) -> float:
    """Direction of the path at arc length s, radians (0 past the end,
    where both points are the last one)."""
    x0, y0 = point_at(path, s)
    x1, y1 = point_at(path, s + 1.0)
    return math.atan2(y1 - y0, x1 - x0)


def project(path: Path, x: float, y: float):
    """(arc length, signed lateral offset with left positive) of (x, y) on
    the path. Points beyond the ends extend the first and last segments, so
    agents just past the route's end still count."""
    p = path.project(x, y)
    return (0.0, 0.0) if p is None else p


class ExamplePlanner(Planner):
    name = "example-pure-pursuit-idm"
    log_name = "example_planner"
    protocol_minor = 0  # protocol 1.0: the map and the route hint in every observation

    def on_hello(self, hello):
        self.log("hello: ego", hello.raw["ego"], "dt", hello.dt_s)

    def plan(self, obs: Observation) -> Control:
        path = route_or_straight(obs)
        s_ego, _ = project(path, obs.ego.x, obs.ego.y)
        return Control(accel_mps2=self.accelerate(obs, path, s_ego), yaw_rate_radps=self.steer(obs, path, s_ego))

    def steer(self, obs: Observation, path: Path, s_ego: float) -> float:
        """Pure pursuit: the yaw rate that puts the ego on the circle through a
        look-ahead point on the path (curvature = 2 sin(alpha) / distance)."""
        ego = obs.ego
        v = ego.speed_mps
        lookahead = max(LOOKAHEAD_MIN_M, LOOKAHEAD_TIME_S * v)
        tx, ty = point_at(path, s_ego + lookahead)
        dx, dy = tx - ego.x, ty - ego.y
        distance = math.hypot(dx, dy)
        if distance < 1e-6:
            return 0.0
        alpha = math.atan2(dy, dx) - ego.heading_rad
        alpha = math.atan2(math.sin(alpha), math.cos(alpha))  # wrap to (-pi, pi]
        curvature = 2.0 * math.sin(alpha) / distance
        return max(-MAX_YAW_RATE_RADPS, min(MAX_YAW_RATE_RADPS, v * curvature))

    def leader(self, obs: Observation, path: Path, s_ego: float):
        """The nearest agent ahead whose box overlaps the ego's corridor along
        the path: (bumper-to-bumper gap in m, its speed along the path in m/s),
        or None."""
        ego = obs.ego
        best = None
        for agent in obs.agents:
            s, lateral = project(path, agent.x, agent.y)
            if s <= s_ego:
                continue  # behind (or beside) the ego's centre
            if abs(lateral) > (ego.width_m + agent.width_m) / 2.0 + PATH_MARGIN_M:
                continue  # in another lane or on the kerb
            gap = s - s_ego - (ego.length_m + agent.length_m) / 2.0
            if best is None or gap < best[0]:
                # Its speed along the path: the velocity projected on the path
                # direction at the ego (good enough over a short distance).
                ax, ay = point_at(path, s_ego)
                bx, by = point_at(path, s_ego + 1.0)
                norm = math.hypot(bx - ax, by - ay) or 1.0
                v_along = (agent.vx * (bx - ax) + agent.vy * (by - ay)) / norm
                best = (gap, v_along)
        return best

    def curve_speed(self, path: Path, s_ego: float) -> float:
        """The highest speed from which every curve in the next CURVE_PREVIEW_M
        can still be taken within the lateral-acceleration and yaw-rate limits,
        braking at the comfortable deceleration on the way."""
        allowed = DESIRED_SPEED_MPS
        d = 0.0
        while d <= CURVE_PREVIEW_M:
            # Curvature over a 4 m window: heading change / distance.
            dh = heading_at(path, s_ego + d + 4.0) - heading_at(path, s_ego + d)
            dh = math.atan2(math.sin(dh), math.cos(dh))
            kappa = abs(dh) / 4.0
            if kappa > 1e-3:
                v_curve = min(math.sqrt(MAX_LATERAL_ACCEL_MPS2 / kappa), MAX_YAW_RATE_RADPS / kappa)
                allowed = min(allowed, math.sqrt(v_curve * v_curve + 2.0 * COMFORT_DECEL_MPS2 * d))
            d += 2.0
        return max(allowed, 1.0)

    def accelerate(self, obs: Observation, path: Path, s_ego: float) -> float:
        """IDM acceleration: free-road term towards the desired speed (lowered
        for curves ahead), minus an interaction term that keeps the time
        headway to the leader."""
        v = obs.ego.speed_mps
        free = 1.0 - (v / self.curve_speed(path, s_ego)) ** 4
        interaction = 0.0
        lead = self.leader(obs, path, s_ego)
        if lead is not None:
            gap, v_lead = lead
            closing = v - v_lead
            desired_gap = STANDSTILL_GAP_M + max(
                0.0, v * TIME_HEADWAY_S + v * closing / (2.0 * math.sqrt(MAX_ACCEL_MPS2 * COMFORT_DECEL_MPS2))
            )
            interaction = (desired_gap / max(gap, 0.1)) ** 2
        accel = MAX_ACCEL_MPS2 * (free - interaction)
        if v <= 0.0 and accel < 0.0:
            accel = 0.0  # already stopped: the model cannot reverse anyway
        return max(-MAX_BRAKE_MPS2, min(MAX_ACCEL_MPS2, accel))


if __name__ == "__main__":
    run(ExamplePlanner)
