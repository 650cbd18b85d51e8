import math
import unittest

from _kit import observation, straight_lane
from safer_planner import AMBER_STATES, RED_STATES, Observation, Path, RoadMap, Signal, curve_speed_limit, next_signal_stop


def road_map(signal_stops=None, **lane0):
    """Lane 0 along y = 0 (x 0 to 100) into lane 2 (x 100 to 200), lane 1 beside lane 0 at y = 3.5."""
    lane2 = straight_lane(2, length=100.0)
    lane2["centreline"] = [[100.0 + x, y] for x, y in lane2["centreline"]]
    lane2["left_boundary"] = [[100.0 + x, y] for x, y in lane2["left_boundary"]]
    lane2["right_boundary"] = [[100.0 + x, y] for x, y in lane2["right_boundary"]]
    lanes = [straight_lane(0, successors=[2], **lane0), straight_lane(1, y=3.5), lane2]
    if signal_stops is None:
        signal_stops = [{"lane": 0, "stop_point": [60.0, 0.0]}, {"lane": 1, "stop_point": [60.0, 3.5]},
                        {"lane": 2, "stop_point": [150.0, 0.0]}]
    return RoadMap.from_json({"lanes": lanes, "road_edges": [], "stop_signs": [], "signal_stops": signal_stops})


def obs(signals, x=10.0, **extra):
    msg = observation(0, x=x, route_len=200.0, route_lanes=[0, 2], **extra)
    msg["signals"] = [{"lane": lane, "state": state} for lane, state in signals]
    return Observation.from_json(msg)


class NextSignalStopTest(unittest.TestCase):
    def setUp(self):
        self.map = road_map()

    def test_red_on_the_route(self):
        stop = next_signal_stop(obs([(0, "stop"), (1, "go")]), self.map)
        self.assertEqual((stop.lane, stop.state, stop.point), (0, "stop", (60.0, 0.0)))
        self.assertAlmostEqual(stop.s_m, 60.0)
        self.assertAlmostEqual(stop.distance_m, 50.0)
        self.assertTrue(all(Signal(0, s).is_stop for s in RED_STATES))

    def test_green_or_a_neighbours_red_is_no_stop(self):
        self.assertIsNone(next_signal_stop(obs([(0, "go"), (1, "stop")]), self.map))
        self.assertIsNone(next_signal_stop(obs([]), self.map))

    def test_amber_only_when_asked(self):
        o = obs([(0, "caution")])
        self.assertIsNone(next_signal_stop(o, self.map))
        self.assertEqual(next_signal_stop(o, self.map, amber=True).state, "caution")
        self.assertIn("arrow_caution", AMBER_STATES)
        self.assertIsNone(next_signal_stop(obs([(0, "flashing_caution")]), self.map, amber=True))

    def test_the_nearest_stop_ahead_counts(self):
        both = obs([(0, "stop"), (2, "arrow_stop")])
        self.assertEqual(next_signal_stop(both, self.map).lane, 0)
        # Once the ego's centre has passed lane 0's stop point, lane 2's is next.
        stop = next_signal_stop(obs([(0, "stop"), (2, "arrow_stop")], x=61.0), self.map)
        self.assertEqual(stop.lane, 2)
        self.assertAlmostEqual(stop.distance_m, 89.0)
        self.assertIsNone(next_signal_stop(obs([(0, "stop")], x=61.0), self.map))

    def test_range(self):
        o = obs([(0, "stop")])
        self.assertIsNone(next_signal_stop(o, self.map, range_m=30.0))
        self.assertIsNotNone(next_signal_stop(o, self.map, range_m=60.0))

    def test_stop_line_or_lane_end_without_a_signal_stop(self):
        with_line = road_map(signal_stops=[], stop_line=[70.0, 0.0])
        self.assertEqual(next_signal_stop(obs([(0, "stop")]), with_line).point, (70.0, 0.0))
        bare = road_map(signal_stops=[])
        self.assertEqual(next_signal_stop(obs([(0, "stop")]), bare).point, (100.0, 0.0))

    def test_protocol_1_0_uses_the_observations_map_and_the_offset(self):
        msg = observation(0, x=10.0, route_len=100.0, map={"lanes": [
            {"id": 5, "centreline": [[0.0, 0.0], [80.0, 0.0]], "speed_limit_mps": None},
            {"id": 6, "centreline": [[0.0, 3.5], [50.0, 3.5]], "speed_limit_mps": None}]})
        for key in ("route_lanes", "route_revision", "route_s_m"):
            del msg[key]
        msg["signals"] = [{"lane": 6, "state": "stop"}]
        self.assertIsNone(next_signal_stop(Observation.from_json(msg)))  # a lane width off the route
        msg["signals"] = [{"lane": 6, "state": "stop"}, {"lane": 5, "state": "stop"}]
        stop = next_signal_stop(Observation.from_json(msg))
        self.assertEqual(stop.lane, 5)
        self.assertAlmostEqual(stop.distance_m, 70.0)
        self.assertIsNotNone(next_signal_stop(Observation.from_json(dict(msg, signals=[
            {"lane": 6, "state": "stop"}])), max_offset_m=4.0))

    def test_no_map_or_no_route(self):
        self.assertIsNone(next_signal_stop(obs([(0, "stop")])))  # 1.1+: no map in the observation
        empty = obs([(0, "stop")], route=[])
        self.assertIsNone(next_signal_stop(empty, self.map))


def arc(radius, start_x=0.0, straight_m=0.0, step=0.5):
    """`straight_m` along +x, then a left turn of `radius` through a half circle."""
    pts = [(start_x + i * step, 0.0) for i in range(int(straight_m / step) + 1)]
    x0 = pts[-1][0]
    n = int(math.pi * radius / step)
    pts += [(x0 + radius * math.sin(i * step / radius), radius - radius * math.cos(i * step / radius))
            for i in range(1, n + 1)]
    return Path(pts)


class CurveSpeedLimitTest(unittest.TestCase):
    def test_straight_road_keeps_the_allowed_speed(self):
        self.assertEqual(curve_speed_limit(Path([(0, 0), (500, 0)]), 10.0, 20.0), 20.0)

    def test_in_a_curve_the_lateral_acceleration_bounds(self):
        v = curve_speed_limit(arc(20.0), 5.0, 30.0)  # kappa 0.05: sqrt(2 / 0.05)
        self.assertAlmostEqual(v, math.sqrt(40.0), delta=0.1)
        v = curve_speed_limit(arc(20.0), 5.0, 30.0, max_yaw_rate_radps=0.1)  # 0.1 / 0.05
        self.assertAlmostEqual(v, 2.0, delta=0.05)
        v = curve_speed_limit(arc(20.0), 5.0, 30.0, max_lateral_accel_mps2=8.0)  # sqrt(8 / 0.05)
        self.assertAlmostEqual(v, math.sqrt(160.0), delta=0.3)

    def test_a_curve_ahead_allows_braking_distance(self):
        path = arc(20.0, straight_m=40.0)
        v = curve_speed_limit(path, 10.0, 30.0)
        # The curve starts 30 m ahead (its 4 m windows see it from 26 m).
        self.assertGreater(v, math.sqrt(40.0 + 2.0 * 2.5 * 24.0))
        self.assertLess(v, math.sqrt(40.0 + 2.0 * 2.5 * 30.0) + 0.1)
        self.assertEqual(curve_speed_limit(path, 10.0, 30.0, preview_m=20.0), 30.0)
        self.assertLess(curve_speed_limit(path, 10.0, 30.0, comfort_decel_mps2=1.0), v)

    def test_floor_and_bad_arguments(self):
        self.assertEqual(curve_speed_limit(Path([(0, 0), (500, 0)]), 0.0, 0.5), 1.0)
        self.assertEqual(curve_speed_limit(Path([(0, 0), (500, 0)]), 0.0, 0.5, min_speed_mps=0.0), 0.5)
        with self.assertRaises(ValueError):
            curve_speed_limit(Path([(0, 0), (500, 0)]), 0.0, 10.0, step_m=0.0)
        with self.assertRaises(ValueError):
            curve_speed_limit(Path([(0, 0), (500, 0)]), 0.0, 10.0, max_lateral_accel_mps2=float("nan"))


if __name__ == "__main__":
    unittest.main()
