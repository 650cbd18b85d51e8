"""The ego's reference points: the box centre the protocol speaks of and the
rear axle that bicycle-model planners (the CommonRoad planners among them)
plan for.

Every position the harness sends or takes (``ego``, ``agents``, trajectory
points) is a **box centre**. The simulator moves that centre as a kinematic
unicycle, and its vehicle-limit checks take a car's rear axle to be
:data:`CENTRE_TO_REAR_AXLE_M` behind the centre (half a
:data:`WHEELBASE_M` wheelbase, ``src/motion/vehicle_limits.rs``); the
defaults below are those values, so a planner that plans the rear axle
converts with them unless it knows its car's own.

The two points lie on the ego's heading, so the conversion moves the
position only: the heading is the same at both. Speeds differ by the yaw
rate times the offset across the heading (0.15 m/s at 0.1 rad/s), which
these functions leave to the planner.
"""

from __future__ import annotations

import math

from .geometry import Point

WHEELBASE_M = 3.0
"""The wheelbase the simulator assumes for a car, m."""

CENTRE_TO_REAR_AXLE_M = 1.5
"""How far behind the box centre the simulator puts a car's rear axle, m
(half of :data:`WHEELBASE_M`)."""


def _offset(offset_m: float) -> float:
    v = float(offset_m)
    if not math.isfinite(v):
        raise ValueError(f"the centre-to-rear-axle offset is {v}; it must be a finite number of metres")
    return v


def rear_axle_from_centre(
    x: float, y: float, heading_rad: float, offset_m: float = CENTRE_TO_REAR_AXLE_M
) -> Point:
    """The rear axle's midpoint of a box centred at ``(x, y)`` facing
    ``heading_rad``: ``offset_m`` metres behind the centre along the
    heading."""
    d = _offset(offset_m)
    return x - d * math.cos(heading_rad), y - d * math.sin(heading_rad)


def centre_from_rear_axle(
    x: float, y: float, heading_rad: float, offset_m: float = CENTRE_TO_REAR_AXLE_M
) -> Point:
    """The box centre of a car whose rear axle's midpoint is at ``(x, y)``
    facing ``heading_rad``: ``offset_m`` metres ahead of the axle along the
    heading (the inverse of :func:`rear_axle_from_centre`)."""
    d = _offset(offset_m)
    return x + d * math.cos(heading_rad), y + d * math.sin(heading_rad)
