"""Typed protocol messages (docs/planner-protocol.md, version 1, revisions
1.0 to 1.3).

Harness messages are parsed with ``from_json`` (unknown fields are ignored,
as the protocol asks; each keeps the decoded line in ``raw`` for fields a
later revision adds). Replies are built as :class:`Control` or
:class:`Trajectory` and written with ``to_json``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Union

from .geometry import Point
from .roadmap import RoadMap, Route, _opt_float, _point

PROTOCOL = 1
"""The protocol version this kit speaks."""
PROTOCOL_MINOR = 2
"""The minor revision this kit's planners ask for (1.2: step-tagged replies).
The fields 1.3 adds (timeouts, the ego's acceleration, yaw rate and steering
angle, replies' ``debug``) need no asking: they are read and written here
whenever the harness sends or takes them."""
MAX_DEBUG_BYTES = 64 * 1024
"""The most bytes of compact JSON a reply's ``debug`` may take (1.3)."""


@dataclass
class EgoSize:
    """The ego's box, m."""

    length_m: float
    width_m: float

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "EgoSize":
        return cls(float(d["length_m"]), float(d["width_m"]))


@dataclass
class ScenarioInfo:
    """Which scene and variant runs (1.1 ``hello.scenario``)."""

    id: str
    format: str
    """``womd-proto``, ``womd-json``, ``common-road``, ``argoverse2`` or ``authored``."""
    source_file: str
    """The scene file, absolute path."""
    variant: Optional[str] = None
    """``suite::scenario::seed-k`` in suites."""
    seed: Optional[int] = None

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "ScenarioInfo":
        seed = d.get("seed")
        return cls(
            id=str(d["id"]),
            format=str(d.get("format", "")),
            source_file=str(d.get("source_file", "")),
            variant=d.get("variant"),
            seed=None if seed is None else int(seed),
        )


@dataclass
class Horizon:
    """How long the rollout runs (1.1 ``hello.horizon``)."""

    start_step: int
    """``step`` of the first observation."""
    steps: int
    """Observations at most (the rollout may end earlier)."""
    dt_s: float
    duration_s: float

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Horizon":
        return cls(int(d["start_step"]), int(d["steps"]), float(d["dt_s"]), float(d["duration_s"]))


@dataclass
class Goal:
    """The ego's last valid recorded state (1.1 ``hello.goal``): a hint, not a task."""

    x: float
    y: float
    heading_rad: float
    step: int

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Goal":
        return cls(float(d["x"]), float(d["y"]), float(d["heading_rad"]), int(d["step"]))


@dataclass
class Hello:
    """The harness's first message."""

    protocol: int
    """Protocol version the harness speaks (1)."""
    dt_s: float
    """Time between two observations, s."""
    ego: EgoSize
    protocol_minor: int = 0
    """Highest minor revision the harness speaks (0 for a 1.0 harness)."""
    scenario: Optional[ScenarioInfo] = None
    origin_world: Optional[Point] = None
    """World coordinates of the local frame's origin: world = local + this."""
    horizon: Optional[Horizon] = None
    goal: Optional[Goal] = None
    step_timeout_s: Optional[float] = None
    """1.3: time allowed to answer one observation, s (``None`` from an older harness)."""
    first_step_timeout_s: Optional[float] = None
    """1.3: time allowed to answer the first observation, s."""
    startup_timeout_s: Optional[float] = None
    """1.3: time allowed from the process's start to ``ready`` and on to ``prepared``, s."""
    raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Hello":
        def opt(key: str, parse: Any) -> Any:
            v = d.get(key)
            return None if v is None else parse(v)

        return cls(
            protocol=int(d["protocol"]),
            dt_s=float(d["dt_s"]),
            ego=EgoSize.from_json(d["ego"]),
            protocol_minor=int(d.get("protocol_minor") or 0),
            scenario=opt("scenario", ScenarioInfo.from_json),
            origin_world=opt("origin_world", _point),
            horizon=opt("horizon", Horizon.from_json),
            goal=opt("goal", Goal.from_json),
            step_timeout_s=_opt_float(d.get("step_timeout_s")),
            first_step_timeout_s=_opt_float(d.get("first_step_timeout_s")),
            startup_timeout_s=_opt_float(d.get("startup_timeout_s")),
            raw=dict(d),
        )


@dataclass
class EgoState:
    """The ego at one step (box centre, local frame)."""

    x: float
    y: float
    heading_rad: float
    speed_mps: float
    vx: float
    vy: float
    length_m: float
    width_m: float
    accel_mps2: Optional[float] = None
    """1.3: the change of its speed along the heading over the last step, per
    second, m/s² (negative: slowing); ``None`` from an older harness."""
    yaw_rate_radps: Optional[float] = None
    """1.3: the change of its heading over the last step, per second, rad/s
    (positive turns left)."""
    steering_angle_rad: Optional[float] = None
    """1.3: front-wheel angle of a kinematic bicycle with a 3.0 m wheelbase
    driving the last step's path, rad (positive steers left; 0 below 0.1 m/s)."""

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "EgoState":
        return cls(
            float(d["x"]),
            float(d["y"]),
            float(d["heading_rad"]),
            float(d["speed_mps"]),
            float(d["vx"]),
            float(d["vy"]),
            float(d["length_m"]),
            float(d["width_m"]),
            accel_mps2=_opt_float(d.get("accel_mps2")),
            yaw_rate_radps=_opt_float(d.get("yaw_rate_radps")),
            steering_angle_rad=_opt_float(d.get("steering_angle_rad")),
        )


@dataclass
class Agent:
    """Another road user within the ego's perception range."""

    id: str
    """Stable within the rollout."""
    kind: str
    """``vehicle``, ``pedestrian``, ``cyclist`` or ``other``."""
    x: float
    y: float
    heading_rad: float
    vx: float
    vy: float
    length_m: float
    width_m: float

    @property
    def speed_mps(self) -> float:
        """Norm of the velocity, m/s."""
        return math.hypot(self.vx, self.vy)

    def speed_along(self, heading_rad: float) -> float:
        """Velocity component along ``heading_rad``, m/s (negative: oncoming)."""
        return self.vx * math.cos(heading_rad) + self.vy * math.sin(heading_rad)

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Agent":
        return cls(
            str(d["id"]),
            str(d.get("kind", "other")),
            float(d["x"]),
            float(d["y"]),
            float(d["heading_rad"]),
            float(d["vx"]),
            float(d["vy"]),
            float(d["length_m"]),
            float(d["width_m"]),
        )


@dataclass
class Signal:
    """A traffic-signal state on a lane: ``unknown``, ``arrow_stop``,
    ``arrow_caution``, ``arrow_go``, ``stop``, ``caution``, ``go``,
    ``flashing_stop`` or ``flashing_caution``."""

    lane: int
    state: str

    @property
    def is_stop(self) -> bool:
        """Red (solid, arrow or flashing)."""
        return self.state in ("stop", "arrow_stop", "flashing_stop")

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Signal":
        return cls(int(d["lane"]), str(d["state"]))


@dataclass
class Observation:
    """The world at one simulation step."""

    step: int
    """Step index in the scenario's numbering; every reply names it (1.2)."""
    time_s: float
    """Time since the rollout started, s."""
    ego: EgoState
    agents: List[Agent]
    signals: List[Signal]
    route: Route
    """The stable route (1.1+) or the route hint (1.0), as a reference path."""
    route_s_m: Optional[float] = None
    """1.1+: the ego's arc length along ``route``, m; ``None`` in 1.0."""
    map: Optional[RoadMap] = None
    """1.0 only: the lanes and edges within 60 m (1.1+: ``Planner.map``)."""
    raw: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_json(cls, d: Mapping[str, Any], route: Optional[Route] = None) -> "Observation":
        """Parses an observation; ``route`` replaces building the route from
        ``d["route"]`` (the kit passes its cached one for an unchanged revision)."""
        if route is None:
            route = Route(d.get("route") or [], d.get("route_lanes") or [], d.get("route_revision"))
        m = d.get("map")
        return cls(
            step=int(d["step"]),
            time_s=float(d["time_s"]),
            ego=EgoState.from_json(d["ego"]),
            agents=[Agent.from_json(a) for a in d.get("agents") or []],
            signals=[Signal.from_json(s) for s in d.get("signals") or []],
            route=route,
            route_s_m=_opt_float(d.get("route_s_m")),
            map=None if m is None else RoadMap.from_json(m),
            raw=dict(d),
        )

    def ego_route_s(self) -> Optional[float]:
        """The ego's arc length along the route: ``route_s_m`` where the
        harness sends it (1.1+), else the ego's projection; ``None`` for an
        empty route."""
        if self.route.path is None:
            return None
        if self.route_s_m is not None:
            return self.route_s_m
        p = self.route.project(self.ego.x, self.ego.y)
        return None if p is None else p.s

    def leader(self, margin_m: float = 0.4, range_m: float = 120.0, anticipate_s: float = 0.0) -> Optional["Leader"]:
        """The nearest agent ahead of the ego whose box reaches into the
        ego's corridor along the route (the ego's half width, plus the
        agent's half extent across the route as it is turned, plus
        ``margin_m``), or, going the route's way (within 45° of it), will
        within ``anticipate_s`` seconds at its sideways speed across the
        route (a car cutting in counts before it is in), searching
        ``range_m`` metres of route ahead; ``None`` when there is none or
        the route is empty."""
        s_ego = self.ego_route_s()
        path = self.route.path
        if s_ego is None or path is None:
            return None
        ego = self.ego
        heading = path.heading_at(s_ego)
        hx, hy = math.cos(heading), math.sin(heading)
        best: Optional[Leader] = None
        for agent in self.agents:
            if math.hypot(agent.x - ego.x, agent.y - ego.y) > range_m + 10.0:
                continue
            p = path.project(agent.x, agent.y, s_ego - 5.0, s_ego + range_m)
            if p is None:
                continue
            s, lateral = p
            if s <= s_ego:
                continue
            route_heading = path.heading_at(s)
            rel = agent.heading_rad - route_heading
            half_across = 0.5 * (abs(math.sin(rel)) * agent.length_m + abs(math.cos(rel)) * agent.width_m)
            # Only a car going the route's way cuts in; crossing traffic
            # counts once it is in the corridor.
            within_s = anticipate_s if math.cos(rel) > CUT_IN_MAX_COS else 0.0
            if _closest_lateral(agent, route_heading, lateral, within_s) > (
                ego.width_m / 2.0 + half_across + margin_m
            ):
                continue
            half_along = 0.5 * (abs(math.cos(rel)) * agent.length_m + abs(math.sin(rel)) * agent.width_m)
            gap = s - s_ego - ego.length_m / 2.0 - half_along
            if best is None or gap < best.gap_m:
                best = Leader(agent, gap, agent.vx * hx + agent.vy * hy, s, lateral)
        return best


CUT_IN_MAX_COS = math.cos(math.pi / 4.0)
"""A car more than 45° off the route's way is crossing it, not cutting in
(:meth:`Observation.leader`)."""


def _closest_lateral(agent: Agent, route_heading_rad: float, lateral_m: float, within_s: float) -> float:
    """The smallest distance of ``agent``'s centre from the route over the
    next ``within_s`` seconds, at its sideways speed across the route
    (``lateral_m`` now, left > 0)."""
    if within_s <= 0.0:
        return abs(lateral_m)
    sideways_mps = -agent.vx * math.sin(route_heading_rad) + agent.vy * math.cos(route_heading_rad)
    later = lateral_m + sideways_mps * within_s
    if (later > 0.0) != (lateral_m > 0.0):
        return 0.0  # it crosses the route
    return min(abs(lateral_m), abs(later))


@dataclass
class Leader:
    """The nearest road user ahead in the ego's corridor along the route
    (:meth:`Observation.leader`)."""

    agent: Agent
    gap_m: float
    """Bumper-to-bumper distance along the route, m (negative: overlapping)."""
    speed_mps: float
    """Its velocity along the route's direction at the ego, m/s."""
    s_m: float
    """Its centre's arc length along the route, m."""
    lateral_m: float
    """Its centre's offset from the route, m (left > 0)."""


def _debug_json(debug: Any, what: str) -> Any:
    """``debug`` checked: JSON the harness takes (finite numbers, at most
    :data:`MAX_DEBUG_BYTES` as compact JSON)."""
    try:
        text = json.dumps(debug, allow_nan=False, separators=(",", ":"), ensure_ascii=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{what}.debug is not JSON the protocol takes: {e}") from None
    size = len(text.encode("utf-8"))
    if size > MAX_DEBUG_BYTES:
        raise ValueError(
            f"{what}.debug is {size} bytes of JSON; the harness keeps at most {MAX_DEBUG_BYTES} per step "
            "(log larger diagnostics to stderr)"
        )
    return debug


def _finite(value: float, what: str) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{what} is {v}; the protocol takes finite numbers only")
    return v


@dataclass
class Control:
    """Acceleration and yaw rate for one step (kinematic unicycle, not clipped)."""

    accel_mps2: float
    """Longitudinal acceleration, m/s² (negative brakes)."""
    yaw_rate_radps: float = 0.0
    """Yaw rate, rad/s (positive turns left)."""
    debug: Any = None
    """1.3: any JSON to keep with this step in the rollout's recording (at
    most 64 KiB); ``None`` sends none."""

    def to_json(self, step: Optional[int] = None) -> Dict[str, Any]:
        """The reply as a JSON object (``step``: the observation answered)."""
        out: Dict[str, Any] = {
            "type": "control",
            "accel_mps2": _finite(self.accel_mps2, "control.accel_mps2"),
            "yaw_rate_radps": _finite(self.yaw_rate_radps, "control.yaw_rate_radps"),
        }
        if step is not None:
            out["step"] = step
        if self.debug is not None:
            out["debug"] = _debug_json(self.debug, "control")
        return out


@dataclass
class TrajectoryPoint:
    """A planned state ``t`` seconds after the observation."""

    t: float
    x: float
    y: float
    heading_rad: float
    speed_mps: float

    def to_json(self) -> Dict[str, float]:
        return {
            "t": _finite(self.t, "trajectory point t"),
            "x": _finite(self.x, "trajectory point x"),
            "y": _finite(self.y, "trajectory point y"),
            "heading_rad": _finite(self.heading_rad, "trajectory point heading_rad"),
            "speed_mps": _finite(self.speed_mps, "trajectory point speed_mps"),
        }


@dataclass
class Trajectory:
    """Planned states; the ego takes the state interpolated at ``t = dt_s``.
    Times must be positive and increasing, the last at least ``dt_s``."""

    points: List[TrajectoryPoint]
    debug: Any = None
    """1.3: any JSON to keep with this step in the rollout's recording (at
    most 64 KiB); ``None`` sends none."""

    def to_json(self, step: Optional[int] = None) -> Dict[str, Any]:
        if not self.points:
            raise ValueError("a trajectory needs at least one point")
        last = 0.0
        for i, p in enumerate(self.points):
            if not p.t > last:
                raise ValueError(f"trajectory point {i} has t = {p.t} s; times must be positive and increasing")
            last = p.t
        out: Dict[str, Any] = {"type": "trajectory", "points": [p.to_json() for p in self.points]}
        if step is not None:
            out["step"] = step
        if self.debug is not None:
            out["debug"] = _debug_json(self.debug, "trajectory")
        return out


Reply = Union[Control, Trajectory]
"""What :meth:`safer_planner.Planner.plan` returns."""
