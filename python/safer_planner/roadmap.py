"""The road map and the route in convenient shapes.

:class:`RoadMap` holds the lanes of ``prepare`` (protocol 1.1 and later: the
whole map, once) or of an observation's ``map`` (1.0: the lanes near the ego,
with only ``id``, ``centreline`` and ``speed_limit_mps``). :class:`Route` is
an observation's route as a reference path.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

from .geometry import Path, Point, Projection, resample


def _point(p: Sequence[Any]) -> Point:
    return (float(p[0]), float(p[1]))


def _points(ps: Optional[Iterable[Sequence[Any]]]) -> List[Point]:
    return [] if ps is None else [_point(p) for p in ps]


def _opt_float(v: Any) -> Optional[float]:
    return None if v is None else float(v)


@dataclass
class Lane:
    """One lane. In protocol 1.0 maps only ``id``, ``centreline`` and
    ``speed_limit_mps`` are known; the other fields keep their defaults."""

    id: int
    """The source's lane id (as in ``signals``, ``route_lanes`` and the links)."""
    centreline: List[Point]
    """Centreline in the direction of travel, m, every 2 m or less."""
    speed_limit_mps: Optional[float] = None
    """Speed limit, m/s; ``None`` when the source gives none."""
    left_boundary: Optional[List[Point]] = None
    """Left border in the direction of travel, where the source has one."""
    right_boundary: Optional[List[Point]] = None
    """Right border in the direction of travel, where the source has one."""
    width_m: Optional[float] = None
    """Mean distance between the boundaries, m; ``None`` without them."""
    predecessors: List[int] = field(default_factory=list)
    successors: List[int] = field(default_factory=list)
    left_neighbours: List[int] = field(default_factory=list)
    right_neighbours: List[int] = field(default_factory=list)
    in_intersection: bool = False
    stop_line: Optional[Point] = None
    """Midpoint of the lane's stop line, where the source has one."""
    _path: Optional[Path] = field(default=None, init=False, repr=False, compare=False)

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "Lane":
        lb, rb, sl = d.get("left_boundary"), d.get("right_boundary"), d.get("stop_line")
        return cls(
            id=int(d["id"]),
            centreline=_points(d["centreline"]),
            speed_limit_mps=_opt_float(d.get("speed_limit_mps")),
            left_boundary=None if lb is None else _points(lb),
            right_boundary=None if rb is None else _points(rb),
            width_m=_opt_float(d.get("width_m")),
            predecessors=[int(i) for i in d.get("predecessors") or []],
            successors=[int(i) for i in d.get("successors") or []],
            left_neighbours=[int(i) for i in d.get("left_neighbours") or []],
            right_neighbours=[int(i) for i in d.get("right_neighbours") or []],
            in_intersection=bool(d.get("in_intersection", False)),
            stop_line=None if sl is None else _point(sl),
        )

    @property
    def path(self) -> Optional[Path]:
        """The centreline as a :class:`Path` (built once); ``None`` for a
        centreline of fewer than two points."""
        if self._path is None and len(self.centreline) >= 2:
            self._path = Path(self.centreline)
        return self._path

    def boundaries(self, count: Optional[int] = None) -> Optional[Tuple[List[Point], List[Point]]]:
        """``(left, right)`` boundaries resampled at equal arc-length steps to
        the same number of points, ``count`` (default: the longer one's point
        count, at least 2), so ``left[i]`` and ``right[i]`` face each other;
        ``None`` when the lane lacks either boundary (WOMD, 1.0 maps)."""
        if not self.left_boundary or not self.right_boundary:
            return None
        n = count if count is not None else max(2, len(self.left_boundary), len(self.right_boundary))
        return resample(self.left_boundary, n), resample(self.right_boundary, n)

    def polygon(self, count: Optional[int] = None) -> Optional[List[Point]]:
        """The lane's outline (left boundary forward, right boundary back),
        or ``None`` without boundaries."""
        b = self.boundaries(count)
        return None if b is None else b[0] + b[1][::-1]


@dataclass
class StopSign:
    """A stop sign and the lanes it controls."""

    position: Point
    lanes: List[int]

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "StopSign":
        return cls(_point(d["position"]), [int(i) for i in d.get("lanes") or []])


@dataclass
class SignalStop:
    """Where traffic on a signal-controlled lane stops."""

    lane: int
    stop_point: Point

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "SignalStop":
        return cls(int(d["lane"]), _point(d["stop_point"]))


@dataclass
class RoadMap:
    """Lanes by id (in the order sent: id order), road edges (each with the
    road on its left), stop signs and signal stop points."""

    lanes: Dict[int, Lane] = field(default_factory=dict)
    road_edges: List[List[Point]] = field(default_factory=list)
    stop_signs: List[StopSign] = field(default_factory=list)
    signal_stops: List[SignalStop] = field(default_factory=list)

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "RoadMap":
        lanes: Dict[int, Lane] = {}
        for raw in d.get("lanes") or []:
            lane = Lane.from_json(raw)
            lanes[lane.id] = lane
        return cls(
            lanes=lanes,
            road_edges=[_points(e) for e in d.get("road_edges") or []],
            stop_signs=[StopSign.from_json(s) for s in d.get("stop_signs") or []],
            signal_stops=[SignalStop.from_json(s) for s in d.get("signal_stops") or []],
        )

    def lane(self, lane_id: int) -> Optional[Lane]:
        """The lane with this id, or ``None``."""
        return self.lanes.get(lane_id)

    def nearest_lane(
        self, x: float, y: float, among: Optional[Iterable[int]] = None
    ) -> Optional[Tuple[Lane, Projection]]:
        """The lane whose centreline (ends extended) passes closest to
        ``(x, y)``, with the point's projection onto it; only the lanes
        ``among`` (ids; unknown ones are skipped) when given, e.g. an
        observation's ``route.lane_ids``. Ties keep the first. ``None``
        when no lane qualifies."""
        ids = self.lanes.keys() if among is None else among
        best: Optional[Tuple[float, Lane, Projection]] = None
        for lane_id in ids:
            lane = self.lanes.get(lane_id)
            if lane is None or lane.path is None:
                continue
            p = lane.path.project(x, y)
            if p is not None and (best is None or abs(p.lateral) < best[0]):
                best = (abs(p.lateral), lane, p)
        return None if best is None else (best[1], best[2])


class Route:
    """An observation's route as a reference path.

    Protocol 1.1+: the stable route (the same points until ``revision``
    changes; the kit builds its :class:`Path` once per revision). 1.0: the
    route hint from the ego forward, new at every step. ``path`` is ``None``
    when the route has fewer than two points (no lane runs the ego's way).
    """

    __slots__ = ("points", "lane_ids", "revision", "path")

    def __init__(
        self, points: Sequence[Sequence[float]], lane_ids: Sequence[int] = (), revision: Optional[int] = None
    ) -> None:
        self.points: List[Point] = _points(points)
        self.lane_ids: List[int] = list(lane_ids)
        """The lanes the route runs along, in order (1.1+; empty in 1.0)."""
        self.revision: Optional[int] = revision
        """0 for the first route, +1 whenever it is planned anew (1.1+);
        ``None`` in 1.0."""
        self.path: Optional[Path] = Path(self.points) if len(self.points) >= 2 else None

    def __bool__(self) -> bool:
        return self.path is not None

    def __repr__(self) -> str:
        return f"Route(revision={self.revision}, {len(self.points)} points, lanes={self.lane_ids})"

    def _need(self) -> Path:
        if self.path is None:
            raise ValueError("the route is empty (no lane within 10 m runs the ego's way)")
        return self.path

    @property
    def length(self) -> float:
        """Arc length, m (0 for an empty route)."""
        return 0.0 if self.path is None else self.path.length

    def point_at(self, s: float, extrapolate: bool = False) -> Point:
        """The point at arc length ``s`` (see :meth:`Path.point_at`)."""
        return self._need().point_at(s, extrapolate)

    def heading_at(self, s: float, extrapolate: bool = False) -> float:
        """Direction of travel at arc length ``s``, rad (see :meth:`Path.heading_at`)."""
        return self._need().heading_at(s, extrapolate)

    def project(
        self, x: float, y: float, s_from: Optional[float] = None, s_to: Optional[float] = None
    ) -> Optional[Projection]:
        """``(s, lateral)`` of a point (see :meth:`Path.project`); ``None``
        for an empty route."""
        return None if self.path is None else self.path.project(x, y, s_from, s_to)
