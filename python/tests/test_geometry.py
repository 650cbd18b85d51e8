import math
import unittest

from _kit import straight_lane
from safer_planner import (
    Lane,
    Path,
    RoadMap,
    Route,
    box_corners,
    polyline_length,
    resample,
    resample_spacing,
    wrap_angle,
)


class PathTest(unittest.TestCase):
    def setUp(self):
        # An L: 10 m along +x, then 10 m along +y.
        self.path = Path([(0, 0), (10, 0), (10, 10)])

    def test_arc_length(self):
        self.assertEqual(self.path.s, [0.0, 10.0, 20.0])
        self.assertEqual(self.path.length, 20.0)
        self.assertEqual(polyline_length([(0, 0), (3, 4)]), 5.0)

    def test_point_at_clamps_before_the_start_and_extends_past_the_end(self):
        self.assertEqual(self.path.point_at(-5.0), (0.0, 0.0))
        self.assertEqual(self.path.point_at(5.0), (5.0, 0.0))
        self.assertEqual(self.path.point_at(15.0), (10.0, 5.0))
        self.assertEqual(self.path.point_at(25.0), (10.0, 15.0))

    def test_point_at_extrapolates_before_the_start_when_asked(self):
        self.assertEqual(self.path.point_at(-5.0, extrapolate=True), (-5.0, 0.0))
        self.assertEqual(self.path.point_at(5.0, extrapolate=True), (5.0, 0.0))
        self.assertEqual(self.path.point_at(25.0, extrapolate=True), (10.0, 15.0))
        # A zero-length first segment does not stop the extension.
        p = Path([(0, 0), (0, 0), (0, 10)])
        self.assertEqual(p.point_at(-2.0, extrapolate=True), (0.0, -2.0))
        self.assertAlmostEqual(self.path.heading_at(-5.0, extrapolate=True), 0.0)
        up = Path([(0, 0), (0, 10)])
        self.assertAlmostEqual(up.heading_at(-5.0, extrapolate=True), math.pi / 2)
        self.assertEqual(Route([[0, 0], [0, 10]]).point_at(-3.0, extrapolate=True), (0.0, -3.0))

    def test_extended_continues_the_end_segments(self):
        p = self.path.extended(before_m=5.0, after_m=3.0)
        self.assertEqual(p.points[0], (-5.0, 0.0))
        self.assertEqual(p.points[-1], (10.0, 13.0))
        self.assertEqual(p.length, 28.0)
        # Arc length s on the original is s + before_m on the extended path.
        self.assertEqual(p.point_at(12.0 + 5.0), self.path.point_at(12.0))
        self.assertAlmostEqual(p.project(-2.0, 1.0).s, 3.0)
        self.assertEqual(self.path.extended().points, self.path.points)
        self.assertEqual(self.path.points[0], (0.0, 0.0))  # the original is unchanged
        diagonal = Path([(0, 0), (3, 4), (3, 4)]).extended(before_m=5.0, after_m=10.0)
        self.assertEqual(diagonal.points[0], (-3.0, -4.0))
        self.assertEqual(diagonal.points[-1], (9.0, 12.0))
        with self.assertRaises(ValueError):
            self.path.extended(before_m=-1.0)
        with self.assertRaises(ValueError):
            self.path.extended(after_m=float("nan"))
        with self.assertRaises(ValueError):
            Path([(1, 1), (1, 1)]).extended(1.0, 1.0)

    def test_heading_at(self):
        self.assertAlmostEqual(self.path.heading_at(2.0), 0.0)
        self.assertAlmostEqual(self.path.heading_at(12.0), math.pi / 2)
        self.assertAlmostEqual(self.path.curvature_at(8.0, window_m=4.0), (math.pi / 2) / 4.0)

    def test_project_gives_arc_length_and_signed_lateral_offset(self):
        s, lateral = self.path.project(4.0, 1.5)
        self.assertAlmostEqual(s, 4.0)
        self.assertAlmostEqual(lateral, 1.5)  # left of +x
        p = self.path.project(11.0, 6.0)
        self.assertAlmostEqual(p.s, 16.0)
        self.assertAlmostEqual(p.lateral, -1.0)  # right of +y

    def test_project_extends_the_ends(self):
        self.assertAlmostEqual(self.path.project(-3.0, 0.5).s, -3.0)
        self.assertAlmostEqual(self.path.project(10.0, 14.0).s, 24.0)

    def test_project_searches_only_the_window(self):
        # (9, 9) is nearest to the second leg; only the first one searched.
        p = self.path.project(9.0, 9.0, s_from=0.0, s_to=5.0)
        self.assertAlmostEqual(p.s, 9.0)
        self.assertAlmostEqual(p.lateral, 9.0)

    def test_degenerate_paths(self):
        with self.assertRaises(ValueError):
            Path([(0, 0)])
        self.assertIsNone(Path([(1, 1), (1, 1)]).project(0.0, 0.0))

    def test_box_corners(self):
        corners = box_corners(10.0, 5.0, 0.0, 4.0, 2.0)
        self.assertEqual(corners, [(12.0, 4.0), (12.0, 6.0), (8.0, 6.0), (8.0, 4.0)])
        turned = box_corners(0.0, 0.0, math.pi / 2, 4.0, 2.0)
        expected = [(1.0, 2.0), (-1.0, 2.0), (-1.0, -2.0), (1.0, -2.0)]  # front right is +x when facing +y
        for (x, y), (ex, ey) in zip(turned, expected):
            self.assertAlmostEqual(x, ex)
            self.assertAlmostEqual(y, ey)

    def test_wrap_angle(self):
        self.assertAlmostEqual(wrap_angle(3 * math.pi / 2), -math.pi / 2)
        self.assertAlmostEqual(wrap_angle(-3 * math.pi / 2), math.pi / 2)


class ResampleTest(unittest.TestCase):
    def test_equal_steps_keep_both_ends(self):
        pts = resample([(0, 0), (1, 0), (10, 0)], 6)
        self.assertEqual(len(pts), 6)
        for i, (x, y) in enumerate(pts):
            self.assertAlmostEqual(x, 2.0 * i)
            self.assertEqual(y, 0.0)
        self.assertEqual(pts[-1], (10.0, 0.0))

    def test_spacing(self):
        pts = resample_spacing([(0, 0), (0, 9)], 2.0)
        self.assertEqual(len(pts), 6)  # 5 steps of 1.8 m
        self.assertAlmostEqual(pts[1][1], 1.8)

    def test_single_point_and_bad_count(self):
        self.assertEqual(resample([(1, 2)], 3), [(1.0, 2.0)] * 3)
        with self.assertRaises(ValueError):
            resample([(0, 0), (1, 0)], 1)


class LaneTest(unittest.TestCase):
    def test_boundaries_are_resampled_to_equal_counts(self):
        lane = Lane.from_json(straight_lane(length=100.0))
        self.assertEqual(len(lane.left_boundary), 51)
        self.assertEqual(len(lane.right_boundary), 5)
        left, right = lane.boundaries()
        self.assertEqual(len(left), len(right))
        self.assertEqual(len(left), 51)
        for (lx, ly), (rx, ry) in zip(left, right):
            self.assertAlmostEqual(lx, rx)  # facing each other across the lane
            self.assertAlmostEqual(ly - ry, 3.5)
        left, right = lane.boundaries(count=11)
        self.assertEqual((len(left), len(right)), (11, 11))
        self.assertEqual(len(lane.polygon(count=3)), 6)

    def test_lane_without_boundaries(self):
        lane = Lane.from_json({"id": 7, "centreline": [[0, 0], [2, 0]], "speed_limit_mps": None})
        self.assertIsNone(lane.boundaries())
        self.assertIsNone(lane.speed_limit_mps)
        self.assertEqual(lane.successors, [])
        self.assertEqual(lane.path.length, 2.0)
        self.assertIsNone(Lane.from_json({"id": 8, "centreline": [[0, 0]]}).path)

    def test_nearest_lane(self):
        m = RoadMap.from_json({"lanes": [straight_lane(0, y=0.0), straight_lane(1, y=3.5, speed_limit_mps=20.0)],
                               "road_edges": [[[0, -1.75], [100, -1.75]]], "stop_signs": [], "signal_stops": []})
        self.assertEqual(list(m.lanes), [0, 1])
        lane, p = m.nearest_lane(50.0, 3.0)
        self.assertEqual(lane.id, 1)
        self.assertAlmostEqual(p.lateral, -0.5)
        lane, _ = m.nearest_lane(50.0, 3.0, among=[0, 99])
        self.assertEqual(lane.id, 0)
        self.assertIsNone(m.nearest_lane(0.0, 0.0, among=[]))
        self.assertEqual(m.road_edges, [[(0.0, -1.75), (100.0, -1.75)]])


class RouteTest(unittest.TestCase):
    def test_route_as_reference_path(self):
        route = Route([[0, 0], [10, 0], [20, 0]], [3, 4], 2)
        self.assertTrue(route)
        self.assertEqual(route.length, 20.0)
        self.assertEqual(route.point_at(5.0), (5.0, 0.0))
        self.assertAlmostEqual(route.heading_at(5.0), 0.0)
        s, lateral = route.project(12.0, -1.0)
        self.assertAlmostEqual(s, 12.0)
        self.assertAlmostEqual(lateral, -1.0)
        self.assertEqual((route.lane_ids, route.revision), ([3, 4], 2))

    def test_empty_route(self):
        route = Route([])
        self.assertFalse(route)
        self.assertEqual(route.length, 0.0)
        self.assertIsNone(route.project(0.0, 0.0))
        with self.assertRaises(ValueError):
            route.point_at(1.0)


if __name__ == "__main__":
    unittest.main()
