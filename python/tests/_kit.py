"""Makes `safer_planner` importable: the installed package where there is
one (`pip install ./python`), else the source next to these tests."""

import os
import sys

try:
    import safer_planner  # noqa: F401
except ImportError:
    sys.path.append(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir))
    import safer_planner  # noqa: F401

KIT_DIR = os.path.dirname(os.path.dirname(os.path.abspath(safer_planner.__file__)))
"""The folder holding the `safer_planner` package these tests use (for child processes)."""
REPO = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir))


def straight_lane(lane_id=0, y=0.0, length=100.0, step=2.0, **extra):
    """A 1.1 `prepare` lane along +x at height y."""
    n = int(length / step) + 1
    lane = {
        "id": lane_id,
        "centreline": [[i * step, y] for i in range(n)],
        "left_boundary": [[i * step, y + 1.75] for i in range(n)],
        "right_boundary": [[i * length / 4, y - 1.75] for i in range(5)],
        "width_m": 3.5,
        "speed_limit_mps": 13.9,
        "predecessors": [],
        "successors": [],
        "left_neighbours": [],
        "right_neighbours": [],
        "in_intersection": False,
        "stop_line": None,
    }
    lane.update(extra)
    return lane


def hello(minor=2, **extra):
    msg = {"type": "hello", "protocol": 1, "protocol_minor": minor, "dt_s": 0.1, "ego": {"length_m": 4.5, "width_m": 2.0}}
    msg.update(extra)
    return msg


def observation(step, x=10.0, y=0.0, speed=10.0, agents=(), revision=0, route_len=100.0, **extra):
    msg = {
        "type": "observation",
        "step": step,
        "time_s": 0.1 * step,
        "ego": {"x": x, "y": y, "heading_rad": 0.0, "speed_mps": speed, "vx": speed, "vy": 0.0,
                "length_m": 4.5, "width_m": 2.0},
        "agents": list(agents),
        "signals": [],
        "route": [[i * 2.0, 0.0] for i in range(int(route_len / 2.0) + 1)],
        "route_lanes": [0],
        "route_revision": revision,
        "route_s_m": x,
    }
    msg.update(extra)
    return msg


def agent(agent_id, x, y=0.0, vx=0.0, heading=0.0, length=4.5, width=2.0):
    return {"id": agent_id, "kind": "vehicle", "x": x, "y": y, "heading_rad": heading, "vx": vx, "vy": 0.0,
            "length_m": length, "width_m": width}
