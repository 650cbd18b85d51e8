"""What lies ahead of the ego on its route and bounds its speed: the next
signal that shows it red (or amber) and where it must stop for it, and the
speed the curves ahead allow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

from .geometry import Path, Point
from .messages import Observation
from .roadmap import RoadMap

RED_STATES = ("stop", "arrow_stop", "flashing_stop")
"""Signal states that mean stop (solid, arrow or flashing red), as
:attr:`safer_planner.Signal.is_stop`."""

AMBER_STATES = ("caution", "arrow_caution")
"""Signal states that mean stop if you safely can (solid or arrow amber);
flashing amber (``flashing_caution``) means go with care and is in neither."""


@dataclass(frozen=True)
class SignalStopAhead:
    """Where the ego must stop for a signal on its route
    (:func:`next_signal_stop`)."""

    lane: int
    """The signal-controlled lane."""
    state: str
    """The signal's state (one of :data:`RED_STATES` or :data:`AMBER_STATES`)."""
    point: Point
    """The stop point: the map's ``signal_stops`` entry for the lane, else its
    stop line, else the end of its centreline."""
    s_m: float
    """The stop point's arc length along the route, m."""
    distance_m: float
    """From the ego's box centre to the stop point along the route, m
    (positive: ahead); the front bumper is half the ego's length nearer."""


def _stop_point(road_map: RoadMap, lane_id: int) -> Optional[Point]:
    for stop in road_map.signal_stops:
        if stop.lane == lane_id:
            return stop.stop_point
    lane = road_map.lane(lane_id)
    if lane is None:
        return None
    if lane.stop_line is not None:
        return lane.stop_line
    return lane.centreline[-1] if lane.centreline else None


def next_signal_stop(
    obs: Observation,
    road_map: Optional[RoadMap] = None,
    *,
    amber: bool = False,
    range_m: float = math.inf,
    max_offset_m: float = 1.0,
) -> Optional[SignalStopAhead]:
    """The nearest stop point ahead of the ego's box centre, along its route,
    for a signal that shows red now (and amber, with ``amber``), within
    ``range_m`` metres; ``None`` when there is none, the route is empty or
    no map is known.

    ``road_map`` is the map the stop points come from: the planner's
    ``self.map`` (1.1+), by default the observation's own (1.0). A signal
    counts when its lane is one of the route's lanes (1.1+; in 1.0, which
    sends none, any lane) and its stop point lies within ``max_offset_m`` of
    the route (a neighbouring lane's stop point lies a lane width away). A
    stop point the ego's centre has passed no longer counts: the ego is then
    in the junction and clears it.
    """
    road_map = road_map if road_map is not None else obs.map
    path = obs.route.path
    s_ego = obs.ego_route_s()
    if road_map is None or path is None or s_ego is None:
        return None
    states = RED_STATES + AMBER_STATES if amber else RED_STATES
    route_lanes = set(obs.route.lane_ids)
    best: Optional[SignalStopAhead] = None
    for signal in obs.signals:
        if signal.state not in states or (route_lanes and signal.lane not in route_lanes):
            continue
        point = _stop_point(road_map, signal.lane)
        if point is None:
            continue
        p = path.project(point[0], point[1], s_ego, s_ego + range_m)
        if p is None or abs(p.lateral) > max_offset_m:
            continue
        distance = p.s - s_ego
        if distance < 0.0 or distance > range_m:
            continue
        if best is None or distance < best.distance_m:
            best = SignalStopAhead(signal.lane, signal.state, point, p.s, distance)
    return best


def curve_speed_limit(
    path: Path,
    s: float,
    allowed_mps: float,
    *,
    max_lateral_accel_mps2: float = 2.0,
    max_yaw_rate_radps: float = 1.0,
    comfort_decel_mps2: float = 2.5,
    preview_m: float = 50.0,
    step_m: float = 2.0,
    window_m: float = 4.0,
    min_speed_mps: float = 1.0,
) -> float:
    """The speed at arc length ``s`` of ``path`` from which the ego can brake
    comfortably for every curve in the next ``preview_m`` metres: at most
    ``allowed_mps``, at least ``min_speed_mps``.

    At every ``step_m`` metres ``d`` ahead (from 0 to ``preview_m``), a
    curve of curvature ``kappa`` (:meth:`Path.curvature_at` over
    ``window_m``; straighter than 0.001 1/m counts as straight) allows
    ``v = min(sqrt(max_lateral_accel_mps2 / kappa), max_yaw_rate_radps /
    kappa)`` there, and so ``sqrt(v^2 + 2 comfort_decel_mps2 d)`` here.
    """
    for name, value in (
        ("max_lateral_accel_mps2", max_lateral_accel_mps2),
        ("max_yaw_rate_radps", max_yaw_rate_radps),
        ("comfort_decel_mps2", comfort_decel_mps2),
        ("step_m", step_m),
        ("window_m", window_m),
    ):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"curve_speed_limit: {name} must be a positive number, got {value}")
    allowed = allowed_mps
    d = 0.0
    while d <= preview_m:
        kappa = abs(path.curvature_at(s + d, window_m=window_m))
        if kappa > 1e-3:
            v_curve = min(math.sqrt(max_lateral_accel_mps2 / kappa), max_yaw_rate_radps / kappa)
            allowed = min(allowed, math.sqrt(v_curve * v_curve + 2.0 * comfort_decel_mps2 * d))
        d += step_m
    return max(allowed, min_speed_mps)
