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

Standard library only; Python 3.9 or later. The optional
``safer_planner.commonroad`` (``pip install "./python[commonroad]"``)
converts the map to a CommonRoad lanelet network, the ego to CommonRoad
states and the agents' predictions to a CommonRoad collision checker.
"""

from .ahead import AMBER_STATES, RED_STATES, SignalStopAhead, curve_speed_limit, next_signal_stop
from .geometry import Path, Point, Projection, box_corners, polyline_length, resample, resample_spacing, wrap_angle
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
from .prediction import PredictedState, horizon_times, predict_agent, predict_constant_velocity
from .roadmap import Lane, RoadMap, Route, SignalStop, StopSign
from .schedule import NoPlanLeft, ReplanSchedule
from .seen import SEEN_LOG_ENV, SeenLog
from .vehicle import CENTRE_TO_REAR_AXLE_M, WHEELBASE_M, centre_from_rear_axle, rear_axle_from_centre

__version__ = "0.1.0"

__all__ = [
    "AMBER_STATES",
    "CENTRE_TO_REAR_AXLE_M",
    "DEBUG_ENV",
    "PROTOCOL",
    "PROTOCOL_MINOR",
    "RED_STATES",
    "SEEN_LOG_ENV",
    "WHEELBASE_M",
    "Agent",
    "Control",
    "EgoSize",
    "EgoState",
    "Goal",
    "Hello",
    "Horizon",
    "Lane",
    "Leader",
    "NoPlanLeft",
    "Observation",
    "Path",
    "Planner",
    "PlannerError",
    "Point",
    "PredictedState",
    "Projection",
    "ReplanSchedule",
    "Reply",
    "RoadMap",
    "Route",
    "ScenarioInfo",
    "SeenLog",
    "Signal",
    "SignalStop",
    "SignalStopAhead",
    "StopSign",
    "Trajectory",
    "TrajectoryPoint",
    "__version__",
    "box_corners",
    "centre_from_rear_axle",
    "curve_speed_limit",
    "horizon_times",
    "next_signal_stop",
    "polyline_length",
    "predict_agent",
    "predict_constant_velocity",
    "rear_axle_from_centre",
    "resample",
    "resample_spacing",
    "run",
    "serve",
    "wrap_angle",
]
