"""safer_planner: write a SaFeR planner in Python.

The kit speaks the harness's JSON-lines planner protocol (version 1,
revision 1.2: ``docs/planner-protocol.md`` in the SaFeR repository) so a
planner only says what to do at each step::

    from safer_planner import Control, Planner, run

    class Coast(Planner):
        name = "coast"

        def plan(self, obs):
            return Control(accel_mps2=0.0, yaw_rate_radps=0.0)

    run(Coast)

Standard library only; Python 3.9 or later.
"""

from .geometry import Path, Point, Projection, polyline_length, resample, resample_spacing, wrap_angle
from .messages import (
    PROTOCOL,
    PROTOCOL_MINOR,
    Agent,
    Control,
    EgoSize,
    EgoState,
    Goal,
    Hello,
    Horizon,
    Leader,
    Observation,
    Reply,
    ScenarioInfo,
    Signal,
    Trajectory,
    TrajectoryPoint,
)
from .planner import DEBUG_ENV, Planner, PlannerError, run, serve
from .roadmap import Lane, RoadMap, Route, SignalStop, StopSign

__version__ = "0.1.0"

__all__ = [
    "DEBUG_ENV",
    "PROTOCOL",
    "PROTOCOL_MINOR",
    "Agent",
    "Control",
    "EgoSize",
    "EgoState",
    "Goal",
    "Hello",
    "Horizon",
    "Lane",
    "Leader",
    "Observation",
    "Path",
    "Planner",
    "PlannerError",
    "Point",
    "Projection",
    "Reply",
    "RoadMap",
    "Route",
    "ScenarioInfo",
    "Signal",
    "SignalStop",
    "StopSign",
    "Trajectory",
    "TrajectoryPoint",
    "__version__",
    "polyline_length",
    "resample",
    "resample_spacing",
    "run",
    "serve",
    "wrap_angle",
]
