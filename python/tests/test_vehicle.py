import math
import os
import re
import unittest

from _kit import REPO
from safer_planner import CENTRE_TO_REAR_AXLE_M, WHEELBASE_M, centre_from_rear_axle, rear_axle_from_centre


class RearAxleTest(unittest.TestCase):
    def test_defaults_are_the_simulators(self):
        # The simulator's vehicle limits put a car's rear axle this far behind its centre.
        source = os.path.join(REPO, "src", "motion", "vehicle_limits.rs")
        if not os.path.isfile(source):
            self.skipTest("not run from a SaFeR checkout")
        with open(source, encoding="utf-8") as f:
            m = re.search(r"const CENTRE_TO_REAR_AXLE_M: f64 = ([0-9.]+);", f.read())
        self.assertIsNotNone(m, "vehicle_limits.rs no longer defines CENTRE_TO_REAR_AXLE_M")
        self.assertEqual(CENTRE_TO_REAR_AXLE_M, float(m.group(1)))
        self.assertEqual(WHEELBASE_M, 2.0 * CENTRE_TO_REAR_AXLE_M)

    def test_rear_axle_lies_behind_the_centre_along_the_heading(self):
        self.assertEqual(rear_axle_from_centre(10.0, 5.0, 0.0), (8.5, 5.0))
        x, y = rear_axle_from_centre(10.0, 5.0, math.pi / 2)
        self.assertAlmostEqual(x, 10.0)
        self.assertAlmostEqual(y, 3.5)
        x, y = rear_axle_from_centre(0.0, 0.0, math.pi, offset_m=1.2)
        self.assertAlmostEqual(x, 1.2)
        self.assertAlmostEqual(y, 0.0)

    def test_round_trip(self):
        for heading in (-3.0, -1.0, 0.0, 0.7, 2.5):
            for offset in (0.0, 1.5, 1.42):
                rx, ry = rear_axle_from_centre(3.0, -4.0, heading, offset)
                self.assertAlmostEqual(math.hypot(rx - 3.0, ry + 4.0), offset)
                cx, cy = centre_from_rear_axle(rx, ry, heading, offset)
                self.assertAlmostEqual(cx, 3.0)
                self.assertAlmostEqual(cy, -4.0)

    def test_offset_must_be_finite(self):
        with self.assertRaises(ValueError):
            rear_axle_from_centre(0.0, 0.0, 0.0, offset_m=float("nan"))
        with self.assertRaises(ValueError):
            centre_from_rear_axle(0.0, 0.0, 0.0, offset_m=float("inf"))


if __name__ == "__main__":
    unittest.main()
