"""Plane geometry on polylines: arc length, points and headings at an arc
length, projection of a point onto a path, equal-spacing resampling, paths
extended beyond their ends, and the corners of a road user's box.

Everything is in the scenario's local frame (metres, radians counter-clockwise
from +x), as the protocol sends it.
"""

from __future__ import annotations

import math
from typing import List, NamedTuple, Optional, Sequence, Tuple

Point = Tuple[float, float]
"""An ``(x, y)`` position in metres."""


class Projection(NamedTuple):
    """Where a point lies relative to a path."""

    s: float
    """Arc length of the closest point on the path, m (negative before the
    start, beyond the length after the end: the end segments extend)."""
    lateral: float
    """Signed distance from the path, m; left of the direction of travel is
    positive."""


def wrap_angle(angle: float) -> float:
    """``angle`` wrapped to (-pi, pi] (``atan2(sin, cos)``)."""
    return math.atan2(math.sin(angle), math.cos(angle))


def polyline_length(points: Sequence[Sequence[float]]) -> float:
    """Total length of a polyline, m."""
    return sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(points, points[1:]))


def resample(points: Sequence[Sequence[float]], count: int) -> List[Point]:
    """``count`` points at equal arc-length steps along a polyline, from its
    first point to its last (both kept). A polyline of one point (or of zero
    length) gives ``count`` copies of its first point."""
    if count < 2:
        raise ValueError(f"resample needs a count of at least 2, got {count}")
    if not points:
        raise ValueError("resample needs at least one point")
    pts = [(float(p[0]), float(p[1])) for p in points]
    if len(pts) == 1:
        return [pts[0]] * count
    path = Path(pts)
    total = path.length
    if total <= 0.0:
        return [pts[0]] * count
    out = [path.point_at(total * i / (count - 1)) for i in range(count - 1)]
    out.append(pts[-1])
    return out


def resample_spacing(points: Sequence[Sequence[float]], max_step_m: float) -> List[Point]:
    """The polyline resampled at equal arc-length steps of at most
    ``max_step_m`` metres (its ends kept)."""
    if max_step_m <= 0.0:
        raise ValueError(f"max_step_m must be positive, got {max_step_m}")
    total = polyline_length(points)
    return resample(points, max(2, int(math.ceil(total / max_step_m)) + 1))


class Path:
    """A polyline with cumulative arc lengths: the reference path of a lane
    or of the route.

    ``point_at`` and ``project`` extend the last segment beyond the end (a
    target a little past the route's end is still ahead of the ego);
    ``point_at`` clamps before the start unless asked to extrapolate, and
    :meth:`extended` gives a path with both ends continued. Needs at least
    two points.
    """

    __slots__ = ("points", "s")

    def __init__(self, points: Sequence[Sequence[float]]) -> None:
        if len(points) < 2:
            raise ValueError(f"a path needs at least 2 points, got {len(points)}")
        self.points: List[Point] = [(float(p[0]), float(p[1])) for p in points]
        s = [0.0]
        for (ax, ay), (bx, by) in zip(self.points, self.points[1:]):
            s.append(s[-1] + math.hypot(bx - ax, by - ay))
        self.s: List[float] = s
        """Arc length at each point, m (``s[0] == 0``)."""

    @property
    def length(self) -> float:
        """Total arc length, m."""
        return self.s[-1]

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        return f"Path({len(self.points)} points, {self.length:.1f} m)"

    def segment_at(self, s: float) -> int:
        """Index ``i`` of the segment ``points[i] -> points[i + 1]`` that
        holds arc length ``s`` (clamped to the first and last)."""
        lo, hi = 0, len(self.s) - 2
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self.s[mid] <= s:
                lo = mid
            else:
                hi = mid - 1
        return max(0, lo)

    def point_at(self, s: float, extrapolate: bool = False) -> Point:
        """The point at arc length ``s``: on the last segment's extension
        beyond the end; before the start the first point, or with
        ``extrapolate`` the point on the first segment's extension backwards
        (``s`` metres before the start for a negative ``s``)."""
        if s <= 0.0:
            if not extrapolate or s == 0.0:
                return self.points[0]
            (ax, ay), (ux, uy) = self.points[0], self._end_direction(first=True)
            return ax + ux * s, ay + uy * s
        if s >= self.s[-1]:
            (ax, ay), (bx, by) = self.points[-2], self.points[-1]
            seg = math.hypot(bx - ax, by - ay) or 1.0
            extra = s - self.s[-1]
            return bx + (bx - ax) / seg * extra, by + (by - ay) / seg * extra
        i = self.segment_at(s)
        (ax, ay), (bx, by) = self.points[i], self.points[i + 1]
        seg = self.s[i + 1] - self.s[i]
        t = 0.0 if seg < 1e-9 else (s - self.s[i]) / seg
        return ax + (bx - ax) * t, ay + (by - ay) * t

    def _end_direction(self, first: bool) -> Point:
        """Unit direction of the first (or last) segment of non-zero length;
        ``(0, 0)`` when every segment has zero length."""
        pairs = list(zip(self.points, self.points[1:]))
        for (ax, ay), (bx, by) in pairs if first else reversed(pairs):
            seg = math.hypot(bx - ax, by - ay)
            if seg >= 1e-9:
                return (bx - ax) / seg, (by - ay) / seg
        return 0.0, 0.0

    def extended(self, before_m: float = 0.0, after_m: float = 0.0) -> "Path":
        """This path with ``before_m`` metres added before its start (the
        first segment's direction continued backwards) and ``after_m``
        metres after its end (the last segment's continued): for a planner
        that needs its reference path to reach behind the ego, or past the
        route's end. Arc length ``s`` here is ``s + before_m`` on the
        extended path. Zero-length end segments are skipped for the
        direction; a path of zero length cannot be extended."""
        if not (math.isfinite(before_m) and math.isfinite(after_m)) or before_m < 0.0 or after_m < 0.0:
            raise ValueError(f"a path extends by finite, non-negative lengths, got before {before_m}, after {after_m}")
        first, last = self._end_direction(first=True), self._end_direction(first=False)
        if first == (0.0, 0.0) and (before_m > 0.0 or after_m > 0.0):
            raise ValueError("a path of zero length has no direction to extend in")
        points = list(self.points)
        if before_m > 0.0:
            (x, y), (ux, uy) = points[0], first
            points.insert(0, (x - ux * before_m, y - uy * before_m))
        if after_m > 0.0:
            (x, y), (ux, uy) = points[-1], last
            points.append((x + ux * after_m, y + uy * after_m))
        return Path(points)

    def heading_at(self, s: float, extrapolate: bool = False) -> float:
        """Direction of travel at arc length ``s``, rad: the chord from the
        point at ``s`` to the point 1 m further (``extrapolate``: as in
        :meth:`point_at`, so that before the start it is the first
        segment's direction)."""
        x0, y0 = self.point_at(s, extrapolate)
        x1, y1 = self.point_at(s + 1.0, extrapolate)
        return math.atan2(y1 - y0, x1 - x0)

    def project(
        self, x: float, y: float, s_from: Optional[float] = None, s_to: Optional[float] = None
    ) -> Optional[Projection]:
        """The closest point of the path to ``(x, y)``, as arc length and
        signed lateral offset (left > 0), searching only the segments between
        arc lengths ``s_from`` and ``s_to`` (default: the whole path); the
        first and last segments extend beyond the ends. ``None`` when every
        segment searched has zero length."""
        lo_s = 0.0 if s_from is None else max(0.0, s_from)
        hi_s = self.s[-1] if s_to is None else min(self.s[-1], s_to)
        i0 = self.segment_at(lo_s)
        i1 = self.segment_at(hi_s)
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
        return Projection(best[1], best[2])

    def distance_to(self, x: float, y: float) -> float:
        """Unsigned distance from ``(x, y)`` to the path (ends extended), m."""
        p = self.project(x, y)
        return math.inf if p is None else abs(p.lateral)

    def curvature_at(self, s: float, window_m: float = 4.0) -> float:
        """Signed curvature at ``s``, 1/m (left turn > 0): the heading change
        over the next ``window_m`` metres divided by ``window_m``."""
        return wrap_angle(self.heading_at(s + window_m) - self.heading_at(s)) / window_m


def box_corners(x: float, y: float, heading_rad: float, length_m: float, width_m: float) -> List[Point]:
    """The four corners of a box centred at ``(x, y)`` and turned to
    ``heading_rad``, counter-clockwise from the front right: front right,
    front left, rear left, rear right."""
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    hl, hw = 0.5 * length_m, 0.5 * width_m
    return [
        (x + c * along - s * across, y + s * along + c * across)
        for along, across in ((hl, -hw), (hl, hw), (-hl, hw), (-hl, -hw))
    ]
