#!/usr/bin/env python3
"""Lane-following planner for SaFeR, speaking planner protocol 1.2.

Standard library only. It uses nothing but what the protocol sends:

- `hello` (protocol 1.1 fields): the scenario it drives, logged to stderr.
- `prepare`: the whole map once; the lanes' speed limits are kept.
- each `observation`: the stable `route` (with `route_lanes` and the ego's
  `route_s_m` along it), the ego and the agents around it; each reply
  names the `step` it answers (1.2).

Driving: pure pursuit on the route for steering; for speed an intelligent
driver model (IDM) towards a desired speed (the speed limit of the lane
the ego is on, else the speed it had at the first observation, lowered
ahead of curves) with a time headway to the nearest agent ahead in its
corridor along the route (the leader gap). Without a route (off the map)
it keeps its heading and speed.

Protocol: docs/planner-protocol.md. By hand:

    echo '{"type":"hello","protocol":1,"protocol_minor":2,"dt_s":0.1,"ego":{"length_m":4.5,"width_m":2}}' \
        | python3 planners/lane_follower.py
"""

import json
import math
import sys

PROTOCOL = 1
PROTOCOL_MINOR = 2

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


def log(*args):
    print("lane_follower:", *args, file=sys.stderr, flush=True)


def send(message):
    sys.stdout.write(json.dumps(message, allow_nan=False) + "\n")
    sys.stdout.flush()


class Path:
    """A polyline with cumulative arc lengths."""

    def __init__(self, points):
        self.points = points
        self.s = [0.0]
        for (ax, ay), (bx, by) in zip(points, points[1:]):
            self.s.append(self.s[-1] + math.hypot(bx - ax, by - ay))

    def length(self):
        return self.s[-1]

    def segment_at(self, s):
        """Index of the segment holding arc length s (binary search)."""
        lo, hi = 0, len(self.s) - 2
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self.s[mid] <= s:
                lo = mid
            else:
                hi = mid - 1
        return max(0, lo)

    def point_at(self, s):
        if s <= 0.0:
            return self.points[0]
        if s >= self.s[-1]:
            # Beyond the end: extend the last segment.
            (ax, ay), (bx, by) = self.points[-2], self.points[-1]
            seg = math.hypot(bx - ax, by - ay) or 1.0
            extra = s - self.s[-1]
            return bx + (bx - ax) / seg * extra, by + (by - ay) / seg * extra
        i = self.segment_at(s)
        (ax, ay), (bx, by) = self.points[i], self.points[i + 1]
        seg = self.s[i + 1] - self.s[i]
        t = 0.0 if seg < 1e-9 else (s - self.s[i]) / seg
        return ax + (bx - ax) * t, ay + (by - ay) * t

    def heading_at(self, s):
        x0, y0 = self.point_at(s)
        x1, y1 = self.point_at(s + 1.0)
        return math.atan2(y1 - y0, x1 - x0)

    def project(self, x, y, s_from, s_to):
        """(arc length, signed lateral offset, left > 0) of (x, y), searching
        segments between arc lengths s_from and s_to; the ends extend."""
        i0 = self.segment_at(max(0.0, s_from))
        i1 = self.segment_at(min(self.s[-1], s_to))
        last = len(self.points) - 2
        best = None
        for i in range(i0, i1 + 1):
            (ax, ay), (bx, by) = self.points[i], self.points[i + 1]
            seg = self.s[i + 1] - self.s[i]
            if seg < 1e-9:
                continue
            ux, uy = (bx - ax) / seg, (by - ay) / seg
            t = (x - ax) * ux + (y - ay) * uy
            lo = -math.inf if i == 0 else 0.0
            hi = math.inf if i == last else seg
            t = min(max(t, lo), hi)
            px, py = ax + ux * t, ay + uy * t
            d = math.hypot(x - px, y - py)
            if best is None or d < best[0]:
                best = (d, self.s[i] + t, ux * (y - ay) - uy * (x - ax))
        if best is None:
            return None
        return best[1], best[2]


class LaneFollower:
    def __init__(self):
        self.speed_limits = {}  # lane id -> m/s or None
        self.centrelines = {}  # lane id -> Path
        self.route = None
        self.route_revision = None
        self.cruise_mps = None

    def prepare(self, message):
        for lane in message["map"]["lanes"]:
            self.speed_limits[lane["id"]] = lane.get("speed_limit_mps")
            if len(lane["centreline"]) >= 2:
                self.centrelines[lane["id"]] = Path(lane["centreline"])
        log("prepared:", len(self.centrelines), "lanes")

    def desired_speed(self, obs, x, y):
        """The speed limit of the route lane the ego is on, else the speed it
        had at the first observation (the traffic's)."""
        best = None
        for lane_id in obs.get("route_lanes") or []:
            path = self.centrelines.get(lane_id)
            if path is None:
                continue
            p = path.project(x, y, 0.0, path.length())
            if p is not None and (best is None or abs(p[1]) < best[0]):
                best = (abs(p[1]), self.speed_limits.get(lane_id))
        if best is not None and best[1]:
            return min(best[1], MAX_SPEED_MPS)
        return self.cruise_mps

    def plan(self, obs):
        ego = obs["ego"]
        v = ego["speed_mps"]
        if self.cruise_mps is None:
            self.cruise_mps = min(MAX_SPEED_MPS, max(v, 5.0))
        points = obs.get("route") or []
        if len(points) < 2:
            return {"type": "control", "accel_mps2": 0.0, "yaw_rate_radps": 0.0}
        if self.route is None or obs.get("route_revision") != self.route_revision:
            self.route = Path(points)
            self.route_revision = obs.get("route_revision")
        path = self.route
        s_ego = obs.get("route_s_m")
        if s_ego is None:
            s_ego, _ = path.project(ego["x"], ego["y"], 0.0, path.length())
        desired = self.desired_speed(obs, ego["x"], ego["y"])
        desired = min(desired, self.curve_speed(path, s_ego, desired))
        accel = self.idm(obs, path, s_ego, desired)
        return {"type": "control", "accel_mps2": accel, "yaw_rate_radps": self.steer(ego, path, s_ego)}

    def steer(self, ego, path, s_ego):
        v = ego["speed_mps"]
        lookahead = max(LOOKAHEAD_MIN_M, LOOKAHEAD_TIME_S * v)
        tx, ty = path.point_at(s_ego + lookahead)
        dx, dy = tx - ego["x"], ty - ego["y"]
        distance = math.hypot(dx, dy)
        if distance < 1e-6:
            return 0.0
        alpha = math.atan2(dy, dx) - ego["heading_rad"]
        alpha = math.atan2(math.sin(alpha), math.cos(alpha))
        curvature = 2.0 * math.sin(alpha) / distance
        return max(-MAX_YAW_RATE_RADPS, min(MAX_YAW_RATE_RADPS, max(v, 1.0) * curvature))

    def curve_speed(self, path, s_ego, allowed):
        d = 0.0
        while d <= CURVE_PREVIEW_M:
            dh = path.heading_at(s_ego + d + 4.0) - path.heading_at(s_ego + d)
            dh = math.atan2(math.sin(dh), math.cos(dh))
            kappa = abs(dh) / 4.0
            if kappa > 1e-3:
                v_curve = min(math.sqrt(MAX_LATERAL_ACCEL_MPS2 / kappa), MAX_YAW_RATE_RADPS / kappa)
                allowed = min(allowed, math.sqrt(v_curve * v_curve + 2.0 * COMFORT_DECEL_MPS2 * d))
            d += 2.0
        return max(allowed, 1.0)

    def leader(self, obs, path, s_ego):
        """(bumper-to-bumper gap, speed along the route) of the nearest agent
        ahead in the ego's corridor, or None."""
        ego = obs["ego"]
        heading = path.heading_at(s_ego)
        hx, hy = math.cos(heading), math.sin(heading)
        best = None
        for agent in obs["agents"]:
            if math.hypot(agent["x"] - ego["x"], agent["y"] - ego["y"]) > LEADER_RANGE_M + 10.0:
                continue
            p = path.project(agent["x"], agent["y"], s_ego - 5.0, s_ego + LEADER_RANGE_M)
            if p is None:
                continue
            s, lateral = p
            if s <= s_ego:
                continue
            # The agent's box reaches into the corridor: its half extent
            # across the route depends on how it is turned.
            rel = agent["heading_rad"] - path.heading_at(s)
            half_across = 0.5 * (abs(math.sin(rel)) * agent["length_m"] + abs(math.cos(rel)) * agent["width_m"])
            if abs(lateral) > ego["width_m"] / 2.0 + half_across + PATH_MARGIN_M:
                continue
            half_along = 0.5 * (abs(math.cos(rel)) * agent["length_m"] + abs(math.sin(rel)) * agent["width_m"])
            gap = s - s_ego - ego["length_m"] / 2.0 - half_along
            v_along = agent["vx"] * hx + agent["vy"] * hy
            if best is None or gap < best[0]:
                best = (gap, v_along)
        return best

    def idm(self, obs, path, s_ego, desired):
        v = obs["ego"]["speed_mps"]
        free = 1.0 - (v / max(desired, 0.1)) ** 4
        interaction = 0.0
        lead = self.leader(obs, path, s_ego)
        if lead is not None:
            gap, v_lead = lead
            closing = v - max(v_lead, 0.0)
            desired_gap = STANDSTILL_GAP_M + max(
                0.0, v * TIME_HEADWAY_S + v * closing / (2.0 * math.sqrt(MAX_ACCEL_MPS2 * COMFORT_DECEL_MPS2))
            )
            interaction = (desired_gap / max(gap, 0.1)) ** 2
        accel = MAX_ACCEL_MPS2 * (free - interaction)
        if v <= 0.0 and accel < 0.0:
            accel = 0.0
        return max(-MAX_BRAKE_MPS2, min(MAX_ACCEL_MPS2, accel))


def main():
    planner = LaneFollower()
    for line in sys.stdin:
        if not line.strip():
            continue
        message = json.loads(line)
        kind = message.get("type")
        if kind == "hello":
            if message.get("protocol") != PROTOCOL or message.get("protocol_minor", 0) < 1:
                send({"type": "error", "message": "lane_follower needs protocol 1.1 or later"})
                return 1
            scenario = message.get("scenario") or {}
            log("hello: scenario", scenario.get("id"), "variant", scenario.get("variant"),
                "horizon", message.get("horizon"))
            send({"type": "ready", "protocol": PROTOCOL, "protocol_minor": PROTOCOL_MINOR, "name": "lane-follower"})
        elif kind == "prepare":
            try:
                planner.prepare(message)
                send({"type": "prepared"})
            except Exception as e:  # report rather than crash
                send({"type": "error", "message": f"prepare: {type(e).__name__}: {e}"})
        elif kind == "observation":
            try:
                send(dict(planner.plan(message), step=message["step"]))
            except Exception as e:
                send({"type": "error", "message": f"{type(e).__name__}: {e}"})
        elif kind == "bye":
            return 0
        else:
            log("ignoring message of type", kind)
    return 0


if __name__ == "__main__":
    sys.exit(main())
