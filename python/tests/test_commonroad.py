"""safer_planner.commonroad against the real commonroad-io (the kit's
``commonroad`` extra). Without it these tests skip, except where
SAFER_REQUIRE_COMMONROAD=1 (CI installs the extra and sets it): there a
missing commonroad-io fails them."""

import os
import subprocess
import sys
import tempfile
import textwrap
import unittest
import warnings

from _kit import KIT_DIR, straight_lane
from safer_planner import RoadMap, Signal

try:
    # commonroad-io's generated protobuf modules warn of deprecations on import.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import commonroad.common.file_reader  # noqa: F401
        import commonroad.common.file_writer  # noqa: F401
        import safer_planner.commonroad  # noqa: F401
except ImportError:
    if os.environ.get("SAFER_REQUIRE_COMMONROAD") == "1":
        raise
    HAVE_COMMONROAD = False
else:
    HAVE_COMMONROAD = True


def shifted(lane, dx=0.0, reverse=False):
    """`lane` moved `dx` along x, or driven the other way (its centreline and
    boundaries reversed, left and right swapped)."""
    for key in ("centreline", "left_boundary", "right_boundary"):
        if lane.get(key) is not None:
            lane[key] = [[x + dx, y] for x, y in lane[key]]
    if reverse:
        left, right = lane["left_boundary"], lane["right_boundary"]
        lane["centreline"] = lane["centreline"][::-1]
        lane["left_boundary"], lane["right_boundary"] = right[::-1], left[::-1]
    return lane


def fixture_map():
    """Lanes 1 and 2 side by side (y 0 and 3.5, +x), lane 3 oncoming beside
    lane 2 (y 7, -x), lane 4 in an intersection after lane 1, lane 5 without
    boundaries (WOMD) far off, lane 6 of one point."""
    lanes = [
        straight_lane(1, y=0.0, left_neighbours=[2], successors=[4, 99], stop_line=[50.0, 0.0]),
        straight_lane(2, y=3.5, right_neighbours=[1]),
        shifted(straight_lane(3, y=7.0), reverse=True),
        shifted(straight_lane(4, y=0.0, length=20.0, predecessors=[1], in_intersection=True), dx=100.0),
        {"id": 5, "centreline": [[0.0, -20.0], [10.0, -20.0], [20.0, -20.0]], "speed_limit_mps": None},
        {"id": 6, "centreline": [[0.0, 50.0]], "speed_limit_mps": None},
    ]
    return RoadMap.from_json({
        "lanes": lanes,
        "road_edges": [],
        "stop_signs": [{"position": [40.0, 6.0], "lanes": [2, 77]}],
        "signal_stops": [{"lane": 1, "stop_point": [60.0, 0.0]}],
    })


class ImportHintTest(unittest.TestCase):
    def test_without_commonroad_io_the_error_names_the_pip_command(self):
        code = textwrap.dedent(f"""
            import sys
            sys.path.insert(0, {KIT_DIR!r})
            sys.modules["commonroad"] = None  # as if commonroad-io were not installed
            import safer_planner  # the kit itself needs none of it
            import safer_planner.commonroad
        """)
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
        self.assertNotEqual(proc.returncode, 0)
        self.assertIn("ImportError: safer_planner.commonroad needs commonroad-io", proc.stderr)
        self.assertIn('pip install "./python[commonroad]"', proc.stderr)


@unittest.skipUnless(HAVE_COMMONROAD, "commonroad-io is not installed (pip install \"./python[commonroad]\")")
class LaneletNetworkTest(unittest.TestCase):
    def setUp(self):
        from commonroad.scenario.lanelet import LaneletType
        from commonroad.scenario.traffic_light import TrafficLightState

        from safer_planner.commonroad import lanelet_network

        self.LaneletType, self.TrafficLightState = LaneletType, TrafficLightState
        self.convert = lanelet_network
        self.net = lanelet_network(fixture_map(), signals=[Signal(1, "stop"), Signal(2, "go")])
        self.by_id = {lanelet.lanelet_id: lanelet for lanelet in self.net.lanelets}

    def test_lanelets_and_bounds(self):
        self.assertEqual(sorted(self.by_id), [1, 2, 3, 4, 5])  # lane 6 has one point
        for lanelet in self.net.lanelets:
            left, centre, right = lanelet.left_vertices, lanelet.center_vertices, lanelet.right_vertices
            self.assertEqual(len(left), len(right))
            self.assertEqual(len(centre), len(left))
            for (lx, ly), (cx, cy), (rx, ry) in zip(left, centre, right):
                self.assertAlmostEqual(cx, (lx + rx) / 2)
                self.assertAlmostEqual(cy, (ly + ry) / 2)
        one = self.by_id[1]
        self.assertEqual(len(one.left_vertices), 51)  # the denser boundary's count
        self.assertEqual(tuple(one.left_vertices[0]), (0.0, 1.75))
        self.assertEqual(tuple(one.right_vertices[-1]), (100.0, -1.75))
        womd = self.by_id[5]  # no boundaries: half the default width either side
        self.assertEqual([tuple(p) for p in womd.left_vertices], [(0.0, -18.25), (10.0, -18.25), (20.0, -18.25)])
        self.assertEqual([tuple(p) for p in womd.right_vertices], [(0.0, -21.75), (10.0, -21.75), (20.0, -21.75)])
        narrow = self.convert(fixture_map(), default_width_m=3.0).find_lanelet_by_id(5)
        self.assertAlmostEqual(narrow.left_vertices[0][1], -18.5)

    def test_links_and_adjacency(self):
        one, two, three, four = (self.by_id[i] for i in (1, 2, 3, 4))
        self.assertEqual(one.successor, [4])  # 99 is not on the map
        self.assertEqual(four.predecessor, [1])
        self.assertEqual((one.adj_left, one.adj_left_same_direction), (2, True))
        self.assertIsNone(one.adj_right)
        self.assertEqual((two.adj_right, two.adj_right_same_direction), (1, True))
        # Lane 3 comes the other way along lane 2's left border.
        self.assertEqual((two.adj_left, two.adj_left_same_direction), (3, False))
        self.assertEqual((three.adj_left, three.adj_left_same_direction), (2, False))
        self.assertIsNone(three.adj_right)
        self.assertIsNone(self.by_id[5].adj_left)

    def test_lanelet_types(self):
        urban, crossing = self.LaneletType.URBAN, self.LaneletType.INTERSECTION
        self.assertEqual(self.by_id[1].lanelet_type, {urban})
        self.assertEqual(self.by_id[4].lanelet_type, {urban, crossing})
        highway = self.convert(fixture_map(), road_type="highway")
        self.assertEqual(highway.find_lanelet_by_id(2).lanelet_type, {self.LaneletType.HIGHWAY})

    def test_traffic_lights_stop_lines_and_signs(self):
        [light] = self.net.traffic_lights
        self.assertNotIn(light.traffic_light_id, self.by_id)
        self.assertEqual(tuple(light.position), (60.0, 0.0))
        self.assertEqual(light.get_state_at_time_step(0), self.TrafficLightState.RED)
        one = self.by_id[1]
        self.assertEqual(one.traffic_lights, {light.traffic_light_id})
        # The signal stop point (60 m), not the lane's own stop line (50 m), stops the light's traffic.
        self.assertEqual(tuple(one.stop_line.start), (60.0, 1.75))
        self.assertEqual(tuple(one.stop_line.end), (60.0, -1.75))
        self.assertEqual(one.stop_line.traffic_light_ref, {light.traffic_light_id})
        [sign] = self.net.traffic_signs
        self.assertEqual(sign.first_occurrence, {2})
        self.assertEqual(self.by_id[2].traffic_signs, {sign.traffic_sign_id})
        self.assertEqual(sign.traffic_sign_elements[0].traffic_sign_element_id.value, "206")
        self.assertEqual(len({light.traffic_light_id, sign.traffic_sign_id} | set(self.by_id)), 7)
        unknown = self.convert(fixture_map()).traffic_lights[0]
        self.assertEqual(unknown.get_state_at_time_step(3), self.TrafficLightState.INACTIVE)

    def test_stop_line_without_a_signal(self):
        m = fixture_map()
        m.signal_stops = []
        one = self.convert(m).find_lanelet_by_id(1)
        self.assertEqual(tuple(one.stop_line.start), (50.0, 1.75))
        self.assertIsNone(one.stop_line.traffic_light_ref)
        self.assertEqual(one.traffic_lights, set())

    def test_signal_states(self):
        from safer_planner.commonroad import traffic_light_state

        S = self.TrafficLightState
        expected = {"stop": S.RED, "arrow_stop": S.RED, "flashing_stop": S.RED, "caution": S.YELLOW,
                    "arrow_caution": S.YELLOW, "go": S.GREEN, "arrow_go": S.GREEN, "unknown": S.INACTIVE}
        for state, light in expected.items():
            self.assertEqual(traffic_light_state(state), light, state)

    def test_what_commonroad_cannot_take(self):
        from safer_planner.commonroad import ConversionError

        m = RoadMap.from_json({"lanes": [straight_lane(-3)]})
        with self.assertRaisesRegex(ConversionError, "lane -3"):
            self.convert(m)
        with self.assertRaisesRegex(ConversionError, "not a CommonRoad lanelet type"):
            self.convert(fixture_map(), road_type="motorway")
        with self.assertRaises(ConversionError):
            self.convert(fixture_map(), default_width_m=0.0)

    def test_a_scenario_file_with_the_network_validates_and_reads_back(self):
        from commonroad.common.file_reader import CommonRoadFileReader
        from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile
        from commonroad.planning.planning_problem import PlanningProblemSet
        from commonroad.scenario.scenario import Location, Scenario, ScenarioID, Tag

        scenario = Scenario(0.1, ScenarioID(country_id="ZAM", map_name="Kit", map_id=1))
        scenario.add_objects(self.net)
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "ZAM_Kit-1_1_T-1.xml")
            writer = CommonRoadFileWriter(scenario, PlanningProblemSet(), "safer", "safer", "safer-planner",
                                          {Tag.URBAN}, Location())
            writer.write_to_file(path, OverwriteExistingFile.ALWAYS, check_validity=True)
            back, _ = CommonRoadFileReader(path).open()
        net = back.lanelet_network
        self.assertEqual(sorted(la.lanelet_id for la in net.lanelets), [1, 2, 3, 4, 5])
        two = net.find_lanelet_by_id(2)
        self.assertEqual((two.adj_left, two.adj_left_same_direction, two.adj_right), (3, False, 1))
        self.assertEqual(net.find_lanelet_by_id(1).successor, [4])
        self.assertEqual(net.traffic_lights[0].get_state_at_time_step(0), self.TrafficLightState.RED)


@unittest.skipUnless(HAVE_COMMONROAD, "commonroad-io is not installed (pip install \"./python[commonroad]\")")
class StatesAndCheckerTest(unittest.TestCase):
    def test_rear_axle_state_and_back(self):
        import math

        from commonroad.scenario.state import InitialState, KSState
        from safer_planner.commonroad import centre_of, rear_axle_state

        s = rear_axle_state(10.0, 5.0, math.pi / 2, 8.0, time_step=3, offset_m=1.5, accel_mps2=0.5,
                            yaw_rate_radps=0.1, steering_angle_rad=0.2)
        self.assertIsInstance(s, InitialState)
        self.assertAlmostEqual(s.position[0], 10.0)
        self.assertAlmostEqual(s.position[1], 3.5)
        self.assertEqual((s.time_step, s.velocity, s.acceleration, s.yaw_rate), (3, 8.0, 0.5, 0.1))
        ks = rear_axle_state(0.0, 0.0, 0.0, 1.0, time_step=0, steering_angle_rad=0.2, state_type=KSState)
        self.assertEqual(ks.steering_angle, 0.2)
        back = centre_of(s, 1.5)
        for got, want in zip(back, (10.0, 5.0, math.pi / 2, 8.0)):
            self.assertAlmostEqual(got, want)

    def test_ego_initial_state_with_and_without_motion(self):
        from safer_planner import EgoState
        from safer_planner.commonroad import ego_initial_state

        ego = EgoState(1.0, 2.0, 0.0, 5.0, 5.0, 0.0, 4.5, 2.0, accel_mps2=-1.0, yaw_rate_radps=0.2)
        moving = ego_initial_state(ego, 7)
        self.assertEqual((moving.acceleration, moving.yaw_rate, moving.time_step), (-1.0, 0.2, 7))
        self.assertAlmostEqual(moving.position[0], 1.0 - 1.5)
        still = ego_initial_state(ego, 7, motion=False)
        self.assertEqual((still.acceleration, still.yaw_rate), (0.0, 0.0))

    def test_collision_checker_predicts_at_constant_velocity(self):
        import math

        import commonroad_dc.pycrcc as pycrcc
        from safer_planner import Agent
        from safer_planner.commonroad import collision_checker

        car = Agent("a", "vehicle", 0.0, 0.0, 0.0, 10.0, 0.0, 4.0, 2.0)
        checker = collision_checker([car], 5, 10, 0.1)

        def hits(step, x, y):
            """Whether a 1 m square at ``(x, y)`` at ``step`` meets the checker's boxes."""
            tvo = pycrcc.TimeVariantCollisionObject(step)
            tvo.append_obstacle(pycrcc.RectOBB(0.5, 0.5, 0.0, x, y))
            return checker.collide(tvo)

        # One second later (step 15) the car is 10 m ahead, no longer at its start.
        self.assertTrue(hits(15, 10.0, 0.0))
        self.assertFalse(hits(15, 0.0, 0.0))
        self.assertTrue(hits(5, 0.0, 0.0))
        # Along its heading instead of its velocity: heading +y, moving +x.
        sideways = Agent("b", "vehicle", 0.0, 0.0, math.pi / 2, 10.0, 0.0, 4.0, 2.0)
        checker = collision_checker([sideways], 0, 10, 0.1, along_heading=True)
        self.assertTrue(hits(10, 0.0, 10.0))
        self.assertFalse(hits(10, 10.0, 0.0))
        with self.assertRaises(ValueError):
            collision_checker([car], 0, -1, 0.1)


if __name__ == "__main__":
    unittest.main()
