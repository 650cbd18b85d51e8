#!/usr/bin/env python3
"""Example external planner for SaFeR, speaking planner protocol version 1.

Standard library only. The harness writes one JSON object per line on stdin
(`hello`, then one `observation` per 0.1 s step, then `bye`); this planner
answers each with one JSON line on stdout and flushes, so the harness never
waits on a buffer. Logs go to stderr: stdout is for protocol messages only.

Driving: pure pursuit along the `route` hint for steering, and for speed an
intelligent-driver-model (IDM) rule: cruise at a desired speed, keep a time
headway to the nearest agent ahead in the ego's path, brake harder as the gap
closes. Signals are ignored (the observation names controlled lanes, not
stop lines), so this is a lane-keeping follower, not a full driver.

Protocol: docs/planner-protocol.md. Run by hand to see the exchange:

    echo '{"type":"hello","protocol":1,"dt_s":0.1,"ego":{"length_m":4.5,"width_m":2}}' \
        | python3 planners/example_planner.py
"""

import json
import math
import sys

PROTOCOL = 1

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


def log(*args):
    """Logs to stderr; the harness keeps the last lines to explain failures."""
    print("example_planner:", *args, file=sys.stderr, flush=True)


def send(message):
    """Writes one protocol message as one line and flushes it at once."""
    sys.stdout.write(json.dumps(message, allow_nan=False) + "\n")
    sys.stdout.flush()


def route_or_straight(obs):
    """The route hint, or a straight line along the ego's heading if there
    is none (off the map, or no lane in the ego's direction)."""
    route = obs.get("route") or []
    if len(route) >= 2:
        return route
    ego = obs["ego"]
    c, s = math.cos(ego["heading_rad"]), math.sin(ego["heading_rad"])
    return [[ego["x"] + c * d, ego["y"] + s * d] for d in range(0, 101, 2)]


def project(path, x, y):
    """Projects (x, y) onto the polyline `path`.

    Returns (arc length along the path, signed lateral offset with left
    positive) of the closest point. Points beyond the ends extend the first
    and last segments, so agents just past the route's end still count."""
    best = None
    s_start = 0.0
    last = len(path) - 2
    for i in range(len(path) - 1):
        (ax, ay), (bx, by) = path[i], path[i + 1]
        dx, dy = bx - ax, by - ay
        seg = math.hypot(dx, dy)
        if seg < 1e-9:
            continue
        ux, uy = dx / seg, dy / seg
        t = (x - ax) * ux + (y - ay) * uy
        # Clamp to the segment, except before the first and after the last.
        lo = -math.inf if i == 0 else 0.0
        hi = math.inf if i == last else seg
        t = min(max(t, lo), hi)
        px, py = ax + ux * t, ay + uy * t
        d = math.hypot(x - px, y - py)
        if best is None or d < best[0]:
            lateral = ux * (y - ay) - uy * (x - ax)  # cross product: left > 0
            best = (d, s_start + t, lateral)
        s_start += seg
    if best is None:
        return 0.0, 0.0
    return best[1], best[2]


def point_at(path, s):
    """The point at arc length s along the path (clamped to its ends)."""
    travelled = 0.0
    for (ax, ay), (bx, by) in zip(path, path[1:]):
        seg = math.hypot(bx - ax, by - ay)
        if seg > 1e-9 and travelled + seg >= s:
            t = max(0.0, (s - travelled) / seg)
            return ax + (bx - ax) * t, ay + (by - ay) * t
        travelled += seg
    return path[-1][0], path[-1][1]


def steer(obs, path, s_ego):
    """Pure pursuit: the yaw rate that puts the ego on the circle through a
    look-ahead point on the path (curvature = 2 sin(alpha) / distance)."""
    ego = obs["ego"]
    v = ego["speed_mps"]
    lookahead = max(LOOKAHEAD_MIN_M, LOOKAHEAD_TIME_S * v)
    tx, ty = point_at(path, s_ego + lookahead)
    dx, dy = tx - ego["x"], ty - ego["y"]
    distance = math.hypot(dx, dy)
    if distance < 1e-6:
        return 0.0
    alpha = math.atan2(dy, dx) - ego["heading_rad"]
    alpha = math.atan2(math.sin(alpha), math.cos(alpha))  # wrap to (-pi, pi]
    curvature = 2.0 * math.sin(alpha) / distance
    return max(-MAX_YAW_RATE_RADPS, min(MAX_YAW_RATE_RADPS, v * curvature))


def leader(obs, path, s_ego):
    """The nearest agent ahead whose box overlaps the ego's corridor along
    the path: (bumper-to-bumper gap in m, its speed along the path in m/s),
    or None."""
    ego = obs["ego"]
    best = None
    for agent in obs["agents"]:
        s, lateral = project(path, agent["x"], agent["y"])
        if s <= s_ego:
            continue  # behind (or beside) the ego's centre
        if abs(lateral) > (ego["width_m"] + agent["width_m"]) / 2.0 + PATH_MARGIN_M:
            continue  # in another lane or on the kerb
        gap = s - s_ego - (ego["length_m"] + agent["length_m"]) / 2.0
        if best is None or gap < best[0]:
            # Its speed along the path: the velocity projected on the path
            # direction at the ego (good enough over a short distance).
            ax, ay = point_at(path, s_ego)
            bx, by = point_at(path, s_ego + 1.0)
            norm = math.hypot(bx - ax, by - ay) or 1.0
            v_along = (agent["vx"] * (bx - ax) + agent["vy"] * (by - ay)) / norm
            best = (gap, v_along)
    return best


def heading_at(path, s):
    """Direction of the path at arc length s, radians."""
    x0, y0 = point_at(path, s)
    x1, y1 = point_at(path, s + 1.0)
    return math.atan2(y1 - y0, x1 - x0)


def curve_speed(path, s_ego):
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


def accelerate(obs, path, s_ego):
    """IDM acceleration: free-road term towards the desired speed (lowered
    for curves ahead), minus an interaction term that keeps the time
    headway to the leader."""
    v = obs["ego"]["speed_mps"]
    free = 1.0 - (v / curve_speed(path, s_ego)) ** 4
    interaction = 0.0
    lead = leader(obs, path, s_ego)
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


def plan(obs):
    """The control for one observation."""
    path = route_or_straight(obs)
    s_ego, _ = project(path, obs["ego"]["x"], obs["ego"]["y"])
    return {
        "type": "control",
        "accel_mps2": accelerate(obs, path, s_ego),
        "yaw_rate_radps": steer(obs, path, s_ego),
    }


def main():
    for line in sys.stdin:
        if not line.strip():
            continue
        message = json.loads(line)
        kind = message.get("type")
        if kind == "hello":
            if message.get("protocol") != PROTOCOL:
                send({"type": "error", "message": f"protocol {message.get('protocol')} is not supported"})
                return 1
            log("hello: ego", message["ego"], "dt", message["dt_s"])
            send({"type": "ready", "protocol": PROTOCOL, "name": "example-pure-pursuit-idm"})
        elif kind == "observation":
            try:
                send(plan(message))
            except Exception as e:  # report rather than crash: the harness shows it
                send({"type": "error", "message": f"{type(e).__name__}: {e}"})
        elif kind == "bye":
            return 0
        else:
            log("ignoring message of type", kind)
    return 0  # stdin closed without bye: the harness is gone


if __name__ == "__main__":
    sys.exit(main())
