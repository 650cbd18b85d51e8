"""A replanning schedule: plan every few steps and follow the last plan in
between, the way sampling and optimisation planners that take longer than a
step to plan are usually driven.

:class:`ReplanSchedule` keeps the last plan (any sequence of states, the
first at the step it was made) and says, at each step, whether a plan is
due, which planned state to start a new plan from (the planned state at
this step, when the ego is on the plan: a plan started there keeps the
plan's acceleration and steering, where the observed state carries
neither), and what to follow when a plan finds nothing. It knows nothing
of the planner: the planner plans, the schedule decides when.
"""

from __future__ import annotations

import math
from typing import Any, Callable, List, Optional, Sequence

from .geometry import Point
from .planner import PlannerError


class NoPlanLeft(PlannerError):
    """No plan found and nothing left of the last plan to follow: the
    planner gives up (raised from ``plan``, the kit answers ``error``)."""


def _xy(state: Any) -> Point:
    return float(state[0]), float(state[1])


class ReplanSchedule:
    """Plan at every ``every_steps``-th step (steps counted by the caller,
    e.g. from the rollout's first), follow the last plan in between.

    A plan is due at a step that is a multiple of ``every_steps``, when
    nothing of the last plan is left after this step, and after
    :meth:`expire` until a plan is found. ``position`` gives a planned
    state's box-centre ``(x, y)`` (default: its first two items); the ego
    is on the plan when it is within ``on_plan_m`` of the planned state of
    the step.

    ``plans`` and ``failed`` count the plans tried and those that found
    nothing; ``plan`` is the last plan found, made at ``plan_step``, and
    ``kept`` what the planner kept with it (:meth:`planned`).
    """

    def __init__(
        self, every_steps: int, *, on_plan_m: float = 0.05, position: Optional[Callable[[Any], Point]] = None
    ) -> None:
        if not isinstance(every_steps, int) or every_steps < 1:
            raise ValueError(f"every_steps must be a whole number of steps, at least 1; got {every_steps!r}")
        if not (math.isfinite(on_plan_m) and on_plan_m >= 0.0):
            raise ValueError(f"on_plan_m must be a non-negative distance in metres, got {on_plan_m}")
        self.every_steps = every_steps
        self.on_plan_m = on_plan_m
        self.position = position or _xy
        self.plan: Optional[List[Any]] = None
        self.plan_step: Optional[int] = None
        self.kept: Any = None
        self.stale = False
        self.plans = 0
        self.failed = 0

    def ahead(self, step: int) -> bool:
        """Whether the last plan has a state for ``step`` and one after it."""
        if self.plan is None or self.plan_step is None:
            return False
        i = step - self.plan_step
        return 0 <= i and i + 1 < len(self.plan)

    def due(self, step: int) -> bool:
        """Whether to plan at ``step`` (else follow :meth:`following`)."""
        return self.stale or step % self.every_steps == 0 or not self.ahead(step)

    def expire(self) -> None:
        """Plan at the next step whatever the schedule (e.g. on a new
        reference path); the last plan stays, to follow if that plan finds
        nothing."""
        self.stale = True

    def following(self, step: int) -> List[Any]:
        """The last plan's states after ``step`` (empty when none are left)."""
        if not self.ahead(step):
            return []
        assert self.plan is not None and self.plan_step is not None
        return list(self.plan[step - self.plan_step + 1 :])

    def start(self, step: int, x: float, y: float) -> Optional[int]:
        """The index in :attr:`plan` of the planned state at ``step`` when
        the ego at ``(x, y)`` (box centre) is on the plan, else ``None``
        (start from the observed state)."""
        if not self.ahead(step):
            return None
        assert self.plan is not None and self.plan_step is not None
        i = step - self.plan_step
        return i if math.dist(self.position(self.plan[i]), (x, y)) < self.on_plan_m else None

    def planned(self, step: int, plan: Optional[Sequence[Any]], kept: Any = None) -> List[Any]:
        """Records the plan made at ``step`` (its first state at ``step``;
        ``None``: it found nothing), with ``kept`` (anything the planner
        needs of the plan later, e.g. its states in another frame) and returns the states to follow from
        the next step on: the new plan's, else what is left of the last
        one. Raises :class:`NoPlanLeft` when there is neither."""
        self.plans += 1
        if plan is None:
            self.failed += 1
            if not self.ahead(step):
                raise NoPlanLeft(f"no feasible trajectory at step {step} and no earlier plan left to follow")
        else:
            self.plan, self.plan_step, self.kept, self.stale = list(plan), step, kept, False
        return self.following(step)


__all__ = ["NoPlanLeft", "ReplanSchedule"]
