"""The kit's :class:`~safer_planner.RoadMap` as a CommonRoad
``LaneletNetwork`` (commonroad-io 2024.x), for planners built on CommonRoad
(the reactive planner, the route planner, the drivability checker).

An optional extra: ``pip install "safer-planner[commonroad]"`` (from the
SaFeR repository: ``pip install "./python[commonroad]"``) installs
commonroad-io; the rest of the kit needs only the standard library.

What carries over, lane by lane (lanes of fewer than two centreline points
are left out):

- lanelet ids are the lane ids (the source's, as in ``signals`` and
  ``route_lanes``), so they must be non-negative integers;
- left and right bounds resampled to the same number of points, the centre
  vertices their midpoints; a lane without boundaries (WOMD) gets bounds
  half its width (or ``default_width_m``) either side of its centreline;
- predecessors and successors (links to lanes outside the map dropped);
- adjacency: the first same-direction neighbour the map names on each side;
  where it names none, an oncoming lane whose bound on that side runs along
  this lane's (within ``adjacency_tolerance_m``) is adjacent in the opposite
  direction;
- lanelet types: ``road_type`` (``urban`` by default), with ``intersection``
  added for lanes inside an intersection;
- a traffic light at each signal stop point, on its lane, with a stop line
  across the lane there; its cycle is one state, the observation's where
  ``signals`` name the lane, else inactive (unknown);
- a stop line across each lane at its ``stop_line`` point, and a stop sign
  (German sign 206, CommonRoad's default country) on each lane a stop sign
  controls (a stop sign that names no lane on the map is left out).

Ids of the traffic lights and signs follow the largest lane id.

For planners that plan with CommonRoad's states and collision checker:

- :func:`rear_axle_state` and :func:`ego_initial_state`: the ego (box
  centre) as a CommonRoad state of its rear axle, the state the CommonRoad
  planners plan from (``InitialState`` or a planner's own state class,
  e.g. the reactive planner's ``ReactivePlannerState``), and
  :func:`centre_of` back: a rear-axle state's box centre, heading, speed;
- :func:`collision_checker`: the observation's agents predicted at
  constant velocity (:func:`~safer_planner.predict_constant_velocity`) as a
  ``pycrcc.CollisionChecker`` of time-variant boxes, which needs
  commonroad-drivability-checker besides.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Dict, Iterable, List, Optional, Sequence, Set, Tuple

from .geometry import Path, Point
from .messages import Agent, EgoState, Signal
from .prediction import horizon_times, predict_constant_velocity
from .roadmap import Lane, RoadMap
from .vehicle import CENTRE_TO_REAR_AXLE_M, centre_from_rear_axle, rear_axle_from_centre

INSTALL_HINT = 'pip install "safer-planner[commonroad]" (from the SaFeR repository: pip install "./python[commonroad]")'
"""The command that installs what this module needs."""

try:
    # commonroad-io ships no type information.
    import numpy as np
    from commonroad.scenario.lanelet import (  # type: ignore[import-untyped]
        Lanelet,
        LaneletNetwork,
        LaneletType,
        LineMarking,
        StopLine,
    )
    from commonroad.scenario.state import InitialState  # type: ignore[import-untyped]
    from commonroad.scenario.traffic_light import (  # type: ignore[import-untyped]
        TrafficLight,
        TrafficLightCycle,
        TrafficLightCycleElement,
        TrafficLightState,
    )
    from commonroad.scenario.traffic_sign import (  # type: ignore[import-untyped]
        TrafficSign,
        TrafficSignElement,
        TrafficSignIDGermany,
    )
except ImportError as e:  # the extra is not installed
    raise ImportError(
        f"safer_planner.commonroad needs commonroad-io 2024.x, which is not installed ({e}): {INSTALL_HINT}"
    ) from e


class ConversionError(ValueError):
    """A road map that has no CommonRoad counterpart (says which lane and why)."""


_LIGHT_STATES = {
    "stop": "RED",
    "arrow_stop": "RED",
    "flashing_stop": "RED",
    "caution": "YELLOW",
    "arrow_caution": "YELLOW",
    "flashing_caution": "YELLOW",
    "go": "GREEN",
    "arrow_go": "GREEN",
}


def traffic_light_state(state: str) -> "TrafficLightState":
    """A protocol signal state as CommonRoad's: red for ``stop``,
    ``arrow_stop``, ``flashing_stop``; yellow for the ``caution`` states;
    green for the ``go`` states; inactive for ``unknown`` (or anything
    else)."""
    return TrafficLightState[_LIGHT_STATES.get(state, "INACTIVE")]


def _offset_line(points: Sequence[Point], offset_m: float) -> List[Point]:
    """``points`` moved ``offset_m`` to the left (right for a negative
    offset), each along the mean normal of the segments meeting there."""
    out = []
    n = len(points)
    for i in range(n):
        ax, ay = points[max(0, i - 1)]
        bx, by = points[min(n - 1, i + 1)]
        dx, dy = bx - ax, by - ay
        norm = math.hypot(dx, dy)
        if norm < 1e-9:
            dx, dy, norm = 1.0, 0.0, 1.0
        x, y = points[i]
        out.append((x - dy / norm * offset_m, y + dx / norm * offset_m))
    return out


def _bounds(lane: Lane, default_width_m: float) -> Tuple[List[Point], List[Point]]:
    b = lane.boundaries()
    if b is not None:
        return b
    half = 0.5 * (lane.width_m or default_width_m)
    return _offset_line(lane.centreline, half), _offset_line(lane.centreline, -half)


class _Border:
    """A lane border as a path, with its midpoint and bounding box (for a
    quick rejection before the exact test)."""

    __slots__ = ("path", "mid", "box")

    def __init__(self, points: Sequence[Point]) -> None:
        self.path = Path(points)
        self.mid = self.path.point_at(0.5 * self.path.length)
        xs, ys = [p[0] for p in points], [p[1] for p in points]
        self.box = (min(xs), min(ys), max(xs), max(ys))

    def near(self, point: Point, tolerance_m: float) -> bool:
        x0, y0, x1, y1 = self.box
        return x0 - tolerance_m <= point[0] <= x1 + tolerance_m and y0 - tolerance_m <= point[1] <= y1 + tolerance_m


def _runs_along(a: _Border, b: _Border, tolerance_m: float) -> bool:
    """Whether border ``a`` runs along border ``b`` the other way round:
    each one's midpoint within ``tolerance_m`` of the other line, the
    directions there opposite."""
    if not (b.near(a.mid, tolerance_m) and a.near(b.mid, tolerance_m)):
        return False
    for this, other in ((a, b), (b, a)):
        if this.path.length <= 0.0 or other.path.length <= 0.0:
            return False
        p = other.path.project(this.mid[0], this.mid[1])
        if p is None or abs(p.lateral) > tolerance_m or p.s < -tolerance_m or p.s > other.path.length + tolerance_m:
            return False
        s_mid = 0.5 * this.path.length
        turn = this.path.heading_at(min(s_mid, max(0.0, this.path.length - 1.0))) - other.path.heading_at(
            min(max(p.s, 0.0), max(0.0, other.path.length - 1.0))
        )
        if math.cos(turn) > -0.5:
            return False
    return True


def _stop_line(point: Point, left: Sequence[Point], right: Sequence[Point], refs: Dict[str, Set[int]]) -> "StopLine":
    """A stop line across the lane through ``point``: from the nearest point
    of the left bound to that of the right bound."""
    ends = []
    for bound in (left, right):
        path = Path(bound)
        p = path.project(point[0], point[1])
        ends.append(path.point_at(min(max(p.s, 0.0), path.length)) if p is not None else bound[0])
    return StopLine(
        np.array(ends[0]),
        np.array(ends[1]),
        LineMarking.SOLID,
        traffic_sign_ref=refs.get("signs") or None,
        traffic_light_ref=refs.get("lights") or None,
    )


def lanelet_network(
    road_map: RoadMap,
    *,
    signals: Optional[Iterable[Signal]] = None,
    road_type: str = "urban",
    default_width_m: float = 3.5,
    adjacency_tolerance_m: float = 0.5,
) -> "LaneletNetwork":
    """``road_map`` as a CommonRoad ``LaneletNetwork`` (see the module's
    description for what carries over). ``signals``: an observation's
    signal states, given to the traffic lights; ``road_type``: the CommonRoad
    ``laneletType`` of every lanelet (``urban``, ``country``, ``highway``,
    ...); ``default_width_m``: the width of a lane that has neither
    boundaries nor ``width_m``. Raises :class:`ConversionError` for a lane
    id CommonRoad cannot take."""
    try:
        base_type = LaneletType(road_type)
    except ValueError:
        raise ConversionError(
            f"road_type {road_type!r} is not a CommonRoad lanelet type ({', '.join(t.value for t in LaneletType)})"
        ) from None
    if not (math.isfinite(default_width_m) and default_width_m > 0.0):
        raise ConversionError(f"default_width_m must be a positive width in metres, got {default_width_m}")
    lanes = [lane for lane in road_map.lanes.values() if len(lane.centreline) >= 2]
    for lane in lanes:
        if not isinstance(lane.id, int) or lane.id < 0:
            raise ConversionError(f"lane {lane.id}: CommonRoad lanelet ids are non-negative integers")
    ids = {lane.id for lane in lanes}
    bounds = {lane.id: _bounds(lane, default_width_m) for lane in lanes}
    borders = {lane_id: (_Border(left), _Border(right)) for lane_id, (left, right) in bounds.items()}
    next_id = max(ids, default=-1) + 1

    def new_id() -> int:
        nonlocal next_id
        next_id += 1
        return next_id - 1

    # Traffic lights at the signal stop points, one per signal-controlled lane.
    states = {s.lane: s.state for s in signals or ()}
    lights: List[TrafficLight] = []
    light_of: Dict[int, Tuple[int, Point]] = {}
    for stop in road_map.signal_stops:
        if stop.lane not in ids or stop.lane in light_of:
            continue
        light_id = new_id()
        # A one-state cycle: CommonRoad files need a cycle on every light.
        state = traffic_light_state(states.get(stop.lane, "unknown"))
        cycle = TrafficLightCycle([TrafficLightCycleElement(state, 1)])
        lights.append(TrafficLight(light_id, np.array(stop.stop_point), traffic_light_cycle=cycle))
        light_of[stop.lane] = (light_id, stop.stop_point)

    # Stop signs on the lanes they control.
    signs: List[TrafficSign] = []
    signs_of: Dict[int, Set[int]] = {}
    for sign in road_map.stop_signs:
        controlled = [lane_id for lane_id in sign.lanes if lane_id in ids]
        if not controlled:
            continue
        sign_id = new_id()
        signs.append(
            TrafficSign(
                sign_id,
                [TrafficSignElement(TrafficSignIDGermany.STOP)],
                set(controlled),
                np.array(sign.position),
            )
        )
        for lane_id in controlled:
            signs_of.setdefault(lane_id, set()).add(sign_id)

    lanelets = []
    for lane in lanes:
        left, right = bounds[lane.id]
        centre = [((lx + rx) / 2.0, (ly + ry) / 2.0) for (lx, ly), (rx, ry) in zip(left, right)]
        adjacent = {}
        for side, neighbours in (("left", lane.left_neighbours), ("right", lane.right_neighbours)):
            same = next((i for i in neighbours if i in ids and i != lane.id), None)
            if same is not None:
                adjacent[side] = (same, True)
                continue
            k = 0 if side == "left" else 1
            for other in lanes:
                if other.id != lane.id and _runs_along(borders[lane.id][k], borders[other.id][k], adjacency_tolerance_m):
                    adjacent[side] = (other.id, False)
                    break
        stop_line = None
        light = light_of.get(lane.id)
        lane_signs = signs_of.get(lane.id, set())
        stop_at = light[1] if light is not None else lane.stop_line
        if stop_at is not None:
            refs = {"lights": {light[0]} if light is not None else set(), "signs": lane_signs}
            stop_line = _stop_line(stop_at, left, right, refs)
        types = {base_type, LaneletType.INTERSECTION} if lane.in_intersection else {base_type}
        lanelets.append(
            Lanelet(
                np.array(left),
                np.array(centre),
                np.array(right),
                lane.id,
                predecessor=[i for i in lane.predecessors if i in ids],
                successor=[i for i in lane.successors if i in ids],
                adjacent_left=adjacent.get("left", (None, None))[0],
                adjacent_left_same_direction=adjacent.get("left", (None, None))[1],
                adjacent_right=adjacent.get("right", (None, None))[0],
                adjacent_right_same_direction=adjacent.get("right", (None, None))[1],
                stop_line=stop_line,
                lanelet_type=types,
                traffic_signs=set(lane_signs),
                traffic_lights={light[0]} if light is not None else set(),
            )
        )

    network = LaneletNetwork.create_from_lanelet_list(lanelets, cleanup_ids=False)
    for light in lights:
        network.add_traffic_light(light, {lane for lane, (lid, _) in light_of.items() if lid == light.traffic_light_id})
    for sign in signs:
        network.add_traffic_sign(sign, set(sign.first_occurrence))
    return network


def rear_axle_state(
    x: float,
    y: float,
    heading_rad: float,
    speed_mps: float,
    *,
    time_step: int,
    offset_m: float = CENTRE_TO_REAR_AXLE_M,
    accel_mps2: float = 0.0,
    yaw_rate_radps: float = 0.0,
    steering_angle_rad: float = 0.0,
    state_type: Any = None,
) -> Any:
    """A CommonRoad state of the rear axle of the box centred at ``(x, y)``
    (:func:`~safer_planner.rear_axle_from_centre`, ``offset_m`` behind the
    centre) at ``time_step``: position, orientation, velocity, acceleration,
    yaw rate and steering angle, each where ``state_type`` (a CommonRoad
    state dataclass; default ``InitialState``, which has no steering angle)
    has the field."""
    cls = state_type or InitialState
    names = {f.name for f in dataclasses.fields(cls)}
    values = {
        "time_step": time_step,
        "position": np.array(rear_axle_from_centre(x, y, heading_rad, offset_m)),
        "orientation": heading_rad,
        "velocity": speed_mps,
        "acceleration": accel_mps2,
        "yaw_rate": yaw_rate_radps,
        "steering_angle": steering_angle_rad,
    }
    return cls(**{k: v for k, v in values.items() if k in names})


def ego_initial_state(
    ego: EgoState,
    time_step: int,
    *,
    offset_m: float = CENTRE_TO_REAR_AXLE_M,
    motion: bool = True,
    state_type: Any = None,
) -> Any:
    """:func:`rear_axle_state` of the observed ego: with ``motion``, its
    protocol 1.3 acceleration, yaw rate and steering angle (0 where the
    harness sends none); without, all three 0 (the planning problem of a
    CommonRoad export states none)."""
    def part(value: Optional[float]) -> float:
        return float(value) if motion and value is not None else 0.0

    return rear_axle_state(
        ego.x,
        ego.y,
        ego.heading_rad,
        ego.speed_mps,
        time_step=time_step,
        offset_m=offset_m,
        accel_mps2=part(ego.accel_mps2),
        yaw_rate_radps=part(ego.yaw_rate_radps),
        steering_angle_rad=part(ego.steering_angle_rad),
        state_type=state_type,
    )


def centre_of(state: Any, offset_m: float = CENTRE_TO_REAR_AXLE_M) -> Tuple[float, float, float, float]:
    """``(x, y, heading_rad, speed_mps)`` of the box centre of a CommonRoad
    rear-axle ``state`` (its position, orientation and velocity): the
    inverse of :func:`rear_axle_state`."""
    x, y = centre_from_rear_axle(float(state.position[0]), float(state.position[1]), state.orientation, offset_m)
    return x, y, float(state.orientation), float(state.velocity)


def collision_checker(
    agents: Iterable[Agent], time_step: int, horizon_steps: int, dt_s: float, *, along_heading: bool = False
) -> Any:
    """A ``pycrcc.CollisionChecker`` (commonroad-drivability-checker) with
    each of ``agents`` as a time-variant box from ``time_step`` (now) to
    ``horizon_steps`` steps of ``dt_s`` later, predicted at constant
    velocity (:func:`~safer_planner.predict_constant_velocity`): along its
    velocity ``(vx, vy)``, or with ``along_heading`` at its speed along its
    heading (as CommonRoad's obstacles drive)."""
    try:
        import commonroad_dc.pycrcc as pycrcc  # type: ignore[import-untyped]
    except ImportError as e:
        raise ImportError(f"collision_checker needs commonroad-drivability-checker, which is not installed ({e})") from e
    if not isinstance(time_step, int) or not isinstance(horizon_steps, int) or horizon_steps < 0:
        raise ValueError(f"time_step and horizon_steps must be whole numbers of steps, got {time_step}, {horizon_steps}")
    agents = list(agents)
    if along_heading:
        agents = [
            dataclasses.replace(a, vx=a.speed_mps * math.cos(a.heading_rad), vy=a.speed_mps * math.sin(a.heading_rad))
            for a in agents
        ]
    times = horizon_times(horizon_steps * dt_s, dt_s, include_now=True)[: horizon_steps + 1]
    checker = pycrcc.CollisionChecker()
    for states in predict_constant_velocity(agents, times).values():
        tvo = pycrcc.TimeVariantCollisionObject(time_step)
        for s in states:
            tvo.append_obstacle(pycrcc.RectOBB(s.length_m / 2, s.width_m / 2, s.heading_rad, s.x, s.y))
        checker.add_collision_object(tvo)
    return checker


__all__ = [
    "INSTALL_HINT",
    "ConversionError",
    "centre_of",
    "collision_checker",
    "ego_initial_state",
    "lanelet_network",
    "rear_axle_state",
    "traffic_light_state",
]
