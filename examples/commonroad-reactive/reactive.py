"""The CommonRoad reactive planner (commonroad-reactive-planner) driving one
ego, step by step, the same way behind safer's protocol (planner.py) and
inside CommonRoad (reproduce.py): what it knows of the other road users
(their boxes now, predicted at constant velocity), its reference path (the
route it is given, extended at both ends), its replanning schedule and what
it does between plans (follow the last plan) are all here, so both sides
drive the same ego when they are given the same world."""
import math
import warnings

import commonroad_clcs.pycrccosy as crccosy
import commonroad_dc.pycrcc as pycrcc
import numpy as np
from commonroad.scenario.scenario import Scenario
from commonroad_rp.reactive_planner import ReactivePlanner
from commonroad_rp.state import ReactivePlannerState
from commonroad_rp.utility.config import ReactivePlannerConfiguration
from commonroad_rp.utility.utils_coordinate_system import create_coordinate_system
from safer_planner import Path, PlannerError, centre_from_rear_axle, rear_axle_from_centre

# commonroad-clcs divides by a straight reference path's zero curvature and copes.
warnings.filterwarnings("ignore", category=RuntimeWarning, module="commonroad_clcs")

DT = 0.1
HORIZON_STEPS = 30  # a 3 s plan: long enough to brake from highway speed, short enough to plan fast
REPLAN_EVERY = 5  # plan at every 5th step (0.5 s) and follow the last plan in between
EXTEND_M = 50.0  # the reference path runs this far past both ends of the route (no projection-domain errors)

PROJECTION_ERRORS = (ValueError, crccosy.CartesianProjectionDomainError,
                     crccosy.CurvilinearProjectionDomainLateralError,
                     crccosy.CurvilinearProjectionDomainLongitudinalError)
"""What commonroad-clcs raises for a point its reference path cannot project."""


def predict(agents, step, steps=HORIZON_STEPS):
    """A collision checker with each agent ``(x, y, heading, speed, length,
    width)`` (box centre) driving on at constant velocity from ``step``."""
    checker = pycrcc.CollisionChecker()
    for x, y, h, v, length, width in agents:
        tvo = pycrcc.TimeVariantCollisionObject(step)
        for i in range(steps + 1):
            d = v * i * DT
            tvo.append_obstacle(pycrcc.RectOBB(length / 2, width / 2, h, x + d * math.cos(h), y + d * math.sin(h)))
        checker.add_collision_object(tvo)
    return checker


class NoPlan(PlannerError):
    """No plan found and none left to follow (behind safer: the planner gives up)."""


class Driver:
    """The reactive planner with its schedule: ``step`` gives the ego's
    states (box centre) from the next step on."""

    def __init__(self, length_m, width_m, desired_speed_mps):
        config = ReactivePlannerConfiguration()
        config.planning.time_steps_computation, config.planning.planning_horizon = HORIZON_STEPS, HORIZON_STEPS * DT
        config.debug.multiproc, config.debug.logging_level = False, "ERROR"
        config.vehicle.length, config.vehicle.width = length_m, width_m
        config.scenario = Scenario(DT)  # used only for forbidden lanelets and a default checker reset() replaces
        self.planner, self.rear = ReactivePlanner(config), config.vehicle.wb_rear_axle
        self.desired, self.coords, self.last, self.plans, self.failed = desired_speed_mps, None, None, 0, 0

    def set_route(self, points):
        """A new route: the reference path from now on."""
        reference = np.array(Path(points).extended(EXTEND_M, EXTEND_M).points)
        self.coords = create_coordinate_system(reference)  # the last plan stays, to follow if no new one is found

    def centre(self, s):
        """``(x, y, heading, speed)`` of the box centre of planner state ``s`` (rear axle)."""
        return (*centre_from_rear_axle(*s.position, s.orientation, self.rear), s.orientation, s.velocity)

    def step(self, k, ego, agents, checker=None):
        """The ego's states from step ``k + 1`` on, given its state ``ego``
        ``(x, y, heading, speed)`` and the agents' (see :func:`predict`) at
        step ``k``, or a collision ``checker`` to plan against instead."""
        last, i = self.last, k - self.last[0] if self.last else 0
        ahead = last is not None and i + 1 < len(last[1].state_list)
        same_path = ahead and last[4] is self.coords
        if same_path and k % REPLAN_EVERY:
            return [self.centre(s) for s in last[1].state_list[i + 1 :]]
        x, y, h, v = ego
        if ahead and math.dist(self.centre(last[1].state_list[i])[:2], (x, y)) < 0.05:
            # On the plan: start from the planned state, keeping its acceleration and steering (and its
            # Frenet state, on the same reference path).
            x0, x0_cl = last[1].state_list[i], ((last[2][i], last[3][i]) if same_path else None)
        else:
            x0, x0_cl = ReactivePlannerState(
                time_step=k, position=np.array(rear_axle_from_centre(x, y, h, self.rear)),
                orientation=h, velocity=v, acceleration=0.0, yaw_rate=0.0, steering_angle=0.0), None
        x0.time_step, result = k, None
        try:
            self.planner.reset(initial_state_cart=x0, initial_state_curv=x0_cl, coordinate_system=self.coords,
                               collision_checker=checker or predict(agents, k))
            # A current speed of exactly 0 makes the planner read its planning problem, which it has none of.
            self.planner.set_desired_velocity(self.desired, current_speed=x0.velocity or None)
            result = self.planner.plan()
        except PROJECTION_ERRORS:  # the ego or a sample outside the reference path's projection domain: no plan
            pass
        self.plans, self.failed = self.plans + 1, self.failed + (result is None)
        if result is not None:
            self.last, i = (k, result[0], result[1], result[2], self.coords), 0
        elif not ahead:  # nothing to follow: give up, as the planner's own run_planner.py does
            raise NoPlan(f"no feasible trajectory at step {k} and no earlier plan left to follow")
        return [self.centre(s) for s in self.last[1].state_list[i + 1 :]]
