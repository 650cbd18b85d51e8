import json
import math
import unittest

from _kit import agent, hello, observation, straight_lane
from safer_planner import (
    Control,
    Hello,
    Observation,
    RoadMap,
    Route,
    Trajectory,
    TrajectoryPoint,
)


class HelloTest(unittest.TestCase):
    def test_a_1_2_hello_with_every_field(self):
        h = Hello.from_json(hello(
            scenario={"id": "USA_US101-21_1_T-1", "format": "common-road", "source_file": "/d/s.xml",
                      "variant": "s::USA_US101-21_1_T-1::seed-0", "seed": 5205677778720444924},
            origin_world=[47.0, -35.0],
            horizon={"start_step": 10, "steps": 70, "dt_s": 0.1, "duration_s": 7.0},
            goal={"x": 62.0, "y": -52.5, "heading_rad": -0.7, "step": 55},
            some_later_field=True,
        ))
        self.assertEqual((h.protocol, h.protocol_minor, h.dt_s), (1, 2, 0.1))
        self.assertEqual((h.ego.length_m, h.ego.width_m), (4.5, 2.0))
        self.assertEqual(h.scenario.variant, "s::USA_US101-21_1_T-1::seed-0")
        self.assertEqual(h.scenario.seed, 5205677778720444924)
        self.assertEqual(h.origin_world, (47.0, -35.0))
        self.assertEqual((h.horizon.start_step, h.horizon.steps), (10, 70))
        self.assertEqual(h.goal.step, 55)
        self.assertTrue(h.raw["some_later_field"])  # unknown fields kept aside, not an error

    def test_a_1_3_hello_carries_the_timeouts(self):
        h = Hello.from_json(hello(minor=3, step_timeout_s=1.0, first_step_timeout_s=5.0, startup_timeout_s=30.0))
        self.assertEqual((h.step_timeout_s, h.first_step_timeout_s, h.startup_timeout_s), (1.0, 5.0, 30.0))
        self.assertIsNone(Hello.from_json(hello(minor=2)).step_timeout_s)

    def test_a_1_0_hello(self):
        h = Hello.from_json({"type": "hello", "protocol": 1, "dt_s": 0.1, "ego": {"length_m": 4.5, "width_m": 2}})
        self.assertEqual(h.protocol_minor, 0)
        self.assertIsNone(h.scenario)
        self.assertIsNone(h.horizon)
        self.assertIsInstance(h.ego.width_m, float)


class ObservationTest(unittest.TestCase):
    def test_a_1_1_observation(self):
        o = Observation.from_json(observation(12, x=10.0, agents=[agent("417", 30.0, vx=5.0)],
                                              signals=[{"lane": 0, "state": "arrow_stop"}]))
        self.assertEqual((o.step, o.ego.x, o.ego.speed_mps), (12, 10.0, 10.0))
        self.assertEqual(o.agents[0].id, "417")
        self.assertEqual(o.agents[0].kind, "vehicle")
        self.assertAlmostEqual(o.agents[0].speed_mps, 5.0)
        self.assertTrue(o.signals[0].is_stop)
        self.assertEqual(o.route.lane_ids, [0])
        self.assertEqual(o.route.revision, 0)
        self.assertEqual(o.route.length, 100.0)
        self.assertEqual(o.route_s_m, 10.0)
        self.assertEqual(o.ego_route_s(), 10.0)
        self.assertIsNone(o.map)

    def test_a_1_3_ego_state_carries_acceleration_yaw_rate_and_steering(self):
        raw = observation(3)
        raw["ego"].update(accel_mps2=-2.5, yaw_rate_radps=0.1, steering_angle_rad=0.0298)
        ego = Observation.from_json(raw).ego
        self.assertEqual((ego.accel_mps2, ego.yaw_rate_radps, ego.steering_angle_rad), (-2.5, 0.1, 0.0298))
        older = Observation.from_json(observation(3)).ego
        self.assertIsNone(older.accel_mps2)
        self.assertIsNone(older.steering_angle_rad)

    def test_a_1_0_observation_with_the_map_near_the_ego(self):
        raw = observation(0, x=4.0, map={"lanes": [{"id": 0, "centreline": [[0, 0], [2, 0]], "speed_limit_mps": 13.9}],
                                         "road_edges": [[[0, -1.75], [2, -1.75]]]})
        for key in ("route_lanes", "route_revision", "route_s_m"):
            del raw[key]
        raw["route"] = [[4.0, 0.0], [6.0, 0.0], [8.0, 0.0]]
        o = Observation.from_json(raw)
        self.assertIsNone(o.route.revision)
        self.assertEqual(o.route.lane_ids, [])
        self.assertEqual(o.ego_route_s(), 0.0)  # projected: the hint starts at the ego
        self.assertEqual(o.map.lanes[0].speed_limit_mps, 13.9)
        self.assertIsNone(o.map.lanes[0].left_boundary)

    def test_an_empty_route(self):
        o = Observation.from_json(observation(0, route=[], route_lanes=[]))
        self.assertFalse(o.route)
        self.assertIsNone(o.ego_route_s())
        self.assertIsNone(o.leader())

    def test_leader_is_the_nearest_agent_ahead_in_the_corridor(self):
        o = Observation.from_json(observation(0, x=10.0, agents=[
            agent("behind", 2.0),
            agent("next-lane", 25.0, y=3.5),
            agent("far", 60.0, vx=8.0),
            agent("near", 40.0, y=0.8, vx=6.0),
            agent("across", 80.0, heading=math.pi / 2, length=4.0, width=2.0),
        ]))
        lead = o.leader()
        self.assertEqual(lead.agent.id, "near")
        self.assertAlmostEqual(lead.gap_m, 30.0 - 4.5)
        self.assertAlmostEqual(lead.speed_mps, 6.0)
        self.assertAlmostEqual(lead.lateral_m, 0.8)
        self.assertIsNone(Observation.from_json(observation(0, agents=[agent("x", 200.0)])).leader(range_m=50.0))

    def test_a_car_cutting_in_is_the_leader_when_anticipated(self):
        def cutting_in(vy):
            return dict(agent("next-lane", 25.0, y=3.5, vx=8.0), vy=vy)

        def leader(vy, anticipate_s):
            return Observation.from_json(observation(0, x=10.0, agents=[cutting_in(vy)])).leader(anticipate_s=anticipate_s)

        # 3.5 m across, the corridor 2.4 m wide each side: not in it yet.
        self.assertIsNone(leader(-1.5, 0.0))
        # Moving in at 1.5 m/s, it is 2.0 m across in 1 s: a leader now.
        lead = leader(-1.5, 1.0)
        self.assertEqual(lead.agent.id, "next-lane")
        self.assertAlmostEqual(lead.lateral_m, 3.5)
        self.assertAlmostEqual(lead.speed_mps, 8.0)
        self.assertIsNone(leader(-1.5, 0.5), "2.75 m across in 0.5 s: still outside")
        self.assertIsNone(leader(1.5, 1.0), "moving away")
        self.assertIsNotNone(leader(-4.0, 1.0), "across the route within the time")
        # A car crossing the route (90° to it, its half length across) counts only
        # once it is in: 3.65 m across.
        crossing = dict(agent("crossing", 25.0, y=5.0, heading=-math.pi / 2), vx=0.0, vy=-3.0)
        o = Observation.from_json(observation(0, x=10.0, agents=[crossing]))
        self.assertIsNone(o.leader(anticipate_s=1.0))

    def test_a_map_from_prepare(self):
        m = RoadMap.from_json({"lanes": [straight_lane(5, successors=[6], stop_line=[100.0, 0.0])], "road_edges": [],
                               "stop_signs": [{"position": [99.0, -2.0], "lanes": [5]}],
                               "signal_stops": [{"lane": 5, "stop_point": [100.0, 0.0]}]})
        lane = m.lane(5)
        self.assertEqual((lane.successors, lane.stop_line, lane.width_m), ([6], (100.0, 0.0), 3.5))
        self.assertEqual(m.stop_signs[0].lanes, [5])
        self.assertEqual(m.signal_stops[0].stop_point, (100.0, 0.0))
        self.assertIsNone(m.lane(6))


class ReplyTest(unittest.TestCase):
    def test_control(self):
        self.assertEqual(Control(-8.0, 0.1).to_json(step=5),
                         {"type": "control", "accel_mps2": -8.0, "yaw_rate_radps": 0.1, "step": 5})
        with self.assertRaisesRegex(ValueError, "accel_mps2 is nan"):
            Control(float("nan")).to_json(0)
        with self.assertRaisesRegex(ValueError, "yaw_rate_radps is inf"):
            Control(0.0, math.inf).to_json(0)

    def test_trajectory(self):
        t = Trajectory([TrajectoryPoint(0.1, 2.92, 1.75, 0.0, 9.2), TrajectoryPoint(0.2, 3.76, 1.75, 0.0, 8.4)])
        out = t.to_json(step=3)
        self.assertEqual(out["type"], "trajectory")
        self.assertEqual(out["step"], 3)
        self.assertEqual(out["points"][1], {"t": 0.2, "x": 3.76, "y": 1.75, "heading_rad": 0.0, "speed_mps": 8.4})
        json.dumps(out, allow_nan=False)
        with self.assertRaisesRegex(ValueError, "positive and increasing"):
            Trajectory([TrajectoryPoint(0.2, 0, 0, 0, 1), TrajectoryPoint(0.1, 0, 0, 0, 1)]).to_json(0)
        with self.assertRaises(ValueError):
            Trajectory([]).to_json(0)

    def test_debug_rides_along_checked(self):
        out = Control(-1.0, debug={"cost": 3.5, "why": "leader braking"}).to_json(step=2)
        self.assertEqual(out["debug"], {"cost": 3.5, "why": "leader braking"})
        self.assertNotIn("debug", Control(-1.0).to_json(step=2))
        t = Trajectory([TrajectoryPoint(0.1, 1.0, 0.0, 0.0, 10.0)], debug=[1, 2, 3]).to_json(step=0)
        self.assertEqual(t["debug"], [1, 2, 3])
        with self.assertRaisesRegex(ValueError, "trajectory.debug is 70010 bytes"):
            Trajectory([TrajectoryPoint(0.1, 1.0, 0.0, 0.0, 10.0)], debug="x" * 70008).to_json(0)
        with self.assertRaisesRegex(ValueError, "control.debug is not JSON"):
            Control(0.0, debug={"cost": float("nan")}).to_json(0)
        with self.assertRaisesRegex(ValueError, "control.debug is not JSON"):
            Control(0.0, debug=object()).to_json(0)

    def test_route_points_are_tuples(self):
        self.assertEqual(Route([[1, 2], [3, 4]]).points, [(1.0, 2.0), (3.0, 4.0)])


if __name__ == "__main__":
    unittest.main()
