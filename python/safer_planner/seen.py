"""What a planner saw in each variant, written to a file per variant: the
input to check an export against (did a CommonRoad scenario show a planner
the same situation?) and to drive the same planner again elsewhere.

Turned on by :data:`SEEN_LOG_ENV` (a folder) or a planner's ``seen_log``
attribute; the kit then writes, for each rollout whose ``hello`` names its
variant (``suite::scenario::seed-K``), ``DIR/suite/scenario/seed-K.json``::

    {"hello": {...},                      # the hello message as sent
     "first": {..., "origin_world": ...}, # the first observation as sent
     "routes": [{"step": k, "lanes": [...], "points": [[x, y], ...]}],
     "ego": {"k": [x, y, heading_rad]},   # observed at k; at k + 1 the
                                          # reply's first trajectory point
     "debug": {...}}                      # the last reply's debug object

Steps ``k`` count from the rollout's first (``hello``'s horizon start); a
route is logged at each new revision. The file is written when the rollout
ends (``bye`` or end of input).
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Optional

from .messages import Hello, Observation, Trajectory

SEEN_LOG_ENV = "SAFER_PLANNER_SEEN_LOG"
"""A folder: log what the planner saw in each variant under it."""


class SeenLog:
    """One rollout's log of what the planner saw (see the module)."""

    def __init__(self, folder: str, hello: Hello) -> None:
        variant = hello.scenario.variant if hello.scenario else None
        if not variant:
            raise ValueError("hello names no variant to log under")
        self.path = os.path.join(folder, *variant.split("::")) + ".json"
        self.start = hello.horizon.start_step if hello.horizon else 0
        self.origin_world = hello.origin_world
        self.data: Dict[str, Any] = {"hello": hello.raw, "routes": [], "ego": {}, "debug": None}
        self.revision: Optional[Any] = None

    @classmethod
    def open(cls, folder: Optional[str], hello: Hello) -> Optional["SeenLog"]:
        """The log of this rollout under ``folder``, or ``None`` when there
        is no folder or ``hello`` names no variant."""
        if not folder or not (hello.scenario and hello.scenario.variant):
            return None
        return cls(folder, hello)

    def observed(self, obs: Observation, reply: Any) -> None:
        """Logs one observation and the planner's reply to it."""
        k = obs.step - self.start
        self.data.setdefault("first", dict(obs.raw, origin_world=self.origin_world))
        if obs.route and obs.route.revision != self.revision:
            self.revision = obs.route.revision
            self.data["routes"].append({"step": k, "lanes": obs.route.lane_ids, "points": obs.route.points})
        ego = obs.ego
        self.data["ego"][k] = (ego.x, ego.y, ego.heading_rad)
        if isinstance(reply, Trajectory) and reply.points:
            p = reply.points[0]
            self.data["ego"][k + 1] = (p.x, p.y, p.heading_rad)
        if getattr(reply, "debug", None) is not None:
            self.data["debug"] = reply.debug

    def write(self) -> None:
        """Writes the log (creating its folders)."""
        os.makedirs(os.path.dirname(self.path), exist_ok=True)
        with open(self.path, "w") as f:
            json.dump(self.data, f)


__all__ = ["SEEN_LOG_ENV", "SeenLog"]
