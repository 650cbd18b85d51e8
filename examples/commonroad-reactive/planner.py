#!/usr/bin/env python3
"""The CommonRoad reactive planner behind safer (README.md): the route, extended, as its reference path; the road
users at constant velocity in its collision checker; a plan every 0.5 s (``Driver``, shared with reproduce.py)."""
import commonroad_clcs.pycrccosy as crccosy
import numpy as np
from commonroad.scenario.scenario import Scenario
from commonroad_rp.reactive_planner import ReactivePlanner as CommonRoadReactivePlanner
from commonroad_rp.state import ReactivePlannerState
from commonroad_rp.utility.config import ReactivePlannerConfiguration
from commonroad_rp.utility.utils_coordinate_system import create_coordinate_system
from safer_planner import Path, Planner, ReplanSchedule, Trajectory, TrajectoryPoint, run
from safer_planner.commonroad import centre_of, collision_checker, rear_axle_state

DT, HORIZON_STEPS = 0.1, 30  # a 3 s plan: long enough to brake from highway speed, short enough to plan fast
REPLAN_EVERY, EXTEND_M = 5, 50.0  # plan every 0.5 s; the reference path runs 50 m past the route's ends
PROJECTION_ERRORS = (ValueError, crccosy.CartesianProjectionDomainError,  # a point the path cannot project
                     crccosy.CurvilinearProjectionDomainLateralError,
                     crccosy.CurvilinearProjectionDomainLongitudinalError)


class Driver:
    """The reactive planner on the kit's replanning schedule."""
    def __init__(self, length_m, width_m, desired_speed_mps=None):
        config = ReactivePlannerConfiguration()
        config.planning.time_steps_computation, config.planning.planning_horizon = HORIZON_STEPS, HORIZON_STEPS * DT
        config.debug.multiproc, config.debug.logging_level = False, "ERROR"
        config.vehicle.length, config.vehicle.width = length_m, width_m
        config.scenario = Scenario(DT)  # used only for forbidden lanelets and a default checker reset() replaces
        self.planner, self.rear = CommonRoadReactivePlanner(config), config.vehicle.wb_rear_axle
        self.desired, self.coords = desired_speed_mps, None
        self.schedule = ReplanSchedule(REPLAN_EVERY, position=lambda s, rear=self.rear: centre_of(s, rear)[:2])

    def set_route(self, points):
        """A new route: the reference path from now on (the last plan stays, to follow if none is found)."""
        self.coords = create_coordinate_system(np.array(Path(points).extended(EXTEND_M, EXTEND_M).points))
        self.schedule.expire()

    def step(self, k, ego, agents, checker=None):
        """The ego's states ``(x, y, heading, speed)`` from step ``k + 1`` on, given them and the agents at ``k``."""
        schedule, result = self.schedule, None
        if not schedule.due(k):
            return [centre_of(s, self.rear) for s in schedule.following(k)]
        i = schedule.start(k, *ego[:2])  # on the plan: its state (and Frenet state, same path) keeps its motion
        x0 = schedule.plan[i] if i is not None else rear_axle_state(
            *ego, time_step=k, offset_m=self.rear, state_type=ReactivePlannerState)
        x0.time_step, x0_cl = k, None if i is None or schedule.stale else (schedule.kept[0][i], schedule.kept[1][i])
        try:
            checker = checker or collision_checker(agents, k, HORIZON_STEPS, DT, along_heading=True)
            self.planner.reset(initial_state_cart=x0, initial_state_curv=x0_cl, coordinate_system=self.coords,
                               collision_checker=checker)
            # A current speed of exactly 0 makes the planner read its planning problem, which it has none of.
            self.planner.set_desired_velocity(self.desired, current_speed=x0.velocity or None)
            result = self.planner.plan()
        except PROJECTION_ERRORS:  # the ego or a sample outside the reference path's projection domain: no plan
            pass
        states = schedule.planned(k, result and result[0].state_list, result and result[1:3])  # and its Frenet states
        return [centre_of(s, self.rear) for s in states]


class ReactivePlanner(Planner):
    """The safer planner: a ``Driver`` for the ego, given each new route."""
    name, protocol_minor, min_protocol_minor, route_required = "commonroad-reactive", 3, 1, True  # the stable route
    dt_s, plan_time_s = DT, 5.0  # a plan takes seconds at worst: the spec's step timeouts allow for it

    def on_hello(self, hello):
        self.driver = Driver(hello.ego.length_m, hello.ego.width_m)

    def on_route(self, route):
        self.driver.set_route(route.points)

    def plan(self, obs):
        ego, k = obs.ego, obs.step - (self.hello.horizon.start_step if self.hello.horizon else 0)
        self.driver.desired = self.driver.desired or max(ego.speed_mps, 1.0)  # the ego's speed at the start
        s, plan = self.driver.schedule, self.driver.step(k, (ego.x, ego.y, ego.heading_rad, ego.speed_mps), obs.agents)
        points = [TrajectoryPoint(DT * (i + 1), x, y, h, max(v, 0.0)) for i, (x, y, h, v) in enumerate(plan)]
        return Trajectory(points, debug={"plan_step": s.plan_step, "plans": s.plans})  # 1.3: in the recording


if __name__ == "__main__":
    run(ReactivePlanner)
