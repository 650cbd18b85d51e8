"""Constant-velocity predictions of the other road users: where each agent of
an observation will be, and the box it will cover, at given times after the
observation, assuming it keeps its velocity and its heading.

The simplest prediction a planner can check its plan against (the
CommonRoad planners take one as their obstacles' trajectories); a stopped
agent stays where it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional, Sequence, Union

from .geometry import Point, box_corners
from .messages import Agent, Observation


@dataclass(frozen=True)
class PredictedState:
    """An agent's predicted state ``t`` seconds after the observation."""

    t: float
    """Time after the observation, s."""
    x: float
    """Box centre x, m."""
    y: float
    """Box centre y, m."""
    heading_rad: float
    """The agent's heading at the observation (kept)."""
    vx: float
    vy: float
    length_m: float
    width_m: float

    @property
    def position(self) -> Point:
        """``(x, y)``, m."""
        return self.x, self.y

    @property
    def speed_mps(self) -> float:
        """Norm of the velocity, m/s."""
        return math.hypot(self.vx, self.vy)

    def box(self) -> List[Point]:
        """The agent's box then: its four corners, counter-clockwise from the
        front right (:func:`safer_planner.box_corners`)."""
        return box_corners(self.x, self.y, self.heading_rad, self.length_m, self.width_m)


def horizon_times(horizon_s: float, dt_s: float, include_now: bool = False) -> List[float]:
    """The times ``dt_s, 2 dt_s, ...`` up to ``horizon_s`` (included when it is
    a whole number of steps, to within a millionth of a step), each computed
    as ``k * dt_s``; with ``include_now`` the list starts with 0."""
    if not (math.isfinite(dt_s) and dt_s > 0.0):
        raise ValueError(f"dt_s must be a positive number of seconds, got {dt_s}")
    if not (math.isfinite(horizon_s) and horizon_s >= 0.0):
        raise ValueError(f"horizon_s must be a non-negative number of seconds, got {horizon_s}")
    steps = int(math.floor(horizon_s / dt_s + 1e-6))
    return [k * dt_s for k in range(0 if include_now else 1, steps + 1)]


def predict_agent(agent: Agent, times: Sequence[float]) -> List[PredictedState]:
    """``agent`` at each of ``times`` (s after the observation, any order,
    none negative), moved along its velocity ``(vx, vy)``, heading and size
    kept."""
    out = []
    for t in times:
        t = float(t)
        if not (math.isfinite(t) and t >= 0.0):
            raise ValueError(f"prediction times must be non-negative seconds, got {t}")
        out.append(
            PredictedState(
                t,
                agent.x + agent.vx * t,
                agent.y + agent.vy * t,
                agent.heading_rad,
                agent.vx,
                agent.vy,
                agent.length_m,
                agent.width_m,
            )
        )
    return out


def predict_constant_velocity(
    source: Union[Observation, Iterable[Agent]],
    times: Optional[Sequence[float]] = None,
    *,
    horizon_s: Optional[float] = None,
    dt_s: Optional[float] = None,
) -> Dict[str, List[PredictedState]]:
    """Each agent's predicted states, by agent id (in the observation's
    order), at ``times`` (s after the observation) or, instead, over
    ``horizon_s`` at steps of ``dt_s`` (:func:`horizon_times`: ``dt_s`` to
    ``horizon_s``). ``source`` is an :class:`Observation` (its ``agents``)
    or the agents themselves."""
    if times is None:
        if horizon_s is None or dt_s is None:
            raise ValueError("predict_constant_velocity needs either times or both horizon_s and dt_s")
        times = horizon_times(horizon_s, dt_s)
    elif horizon_s is not None or dt_s is not None:
        raise ValueError("predict_constant_velocity takes either times or horizon_s and dt_s, not both")
    agents = source.agents if isinstance(source, Observation) else source
    return {agent.id: predict_agent(agent, times) for agent in agents}
