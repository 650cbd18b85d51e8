"""Tests of the reactive planner's driver (planner.py) and the outcome
measure reproduce.py compares: run in the environment requirements.txt
describes (`python -m unittest discover -s examples/commonroad-reactive`)."""
import math
import os
import sys
import unittest
import warnings

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from planner import REPLAN_EVERY, Driver  # noqa: E402
from reproduce import agent  # noqa: E402
from reproduce import outcome  # noqa: E402

warnings.filterwarnings("ignore", category=RuntimeWarning)  # commonroad-clcs on a straight path
ROUTE = [(float(x), 0.0) for x in range(-20, 400, 2)]


def drive(agents_at, steps, speed=15.0):
    """The ego's states ``{k: (x, y, heading)}`` and the driver, closed loop on a straight road."""
    driver, ego, states = Driver(4.5, 2.0, speed), (0.0, 0.0, 0.0, speed), {}
    driver.set_route(ROUTE)
    for k in range(steps):
        states[k] = ego[:3]
        ego = driver.step(k, ego, agents_at(k))[0]
    return states, driver


class DriverTest(unittest.TestCase):
    def test_plans_on_schedule_and_follows_the_plan_between(self):
        states, driver = drive(lambda k: [], 2 * REPLAN_EVERY)
        self.assertEqual(driver.schedule.plans, 2)
        self.assertEqual(driver.schedule.failed, 0)
        self.assertAlmostEqual(states[9][0], 9 * 0.1 * 15.0, delta=0.5)  # keeps about 15 m/s along the route
        self.assertLess(max(abs(s[1]) for s in states.values()), 0.05)

    def test_stays_clear_of_a_stopped_car_ahead(self):
        stopped = (45.0, 0.0, 0.0, 0.0, 4.5, 2.0)
        states, _ = drive(lambda k: [agent("car", *stopped)], 60)
        hit, clearance = outcome(states, (4.5, 2.0), [("car", 4.5, 2.0, {k: stopped[:4] for k in range(60)})])
        self.assertIsNone(hit)
        self.assertGreater(clearance, 0.0)


class OutcomeTest(unittest.TestCase):
    def test_first_collision_and_clearance(self):
        ego = {k: (k * 1.0, 0.0, 0.0) for k in range(10)}
        other = ("7", 4.0, 2.0, {k: (12.0, 0.5, math.pi, 0.0) for k in range(10)})
        hit, clearance = outcome(ego, (4.0, 2.0), [other], ids={"7": "agent-7"})
        self.assertEqual(hit, ("agent-7", 0.8))  # fronts meet at x = 10: ego centre 8
        self.assertEqual(clearance, 0.0)
        hit, clearance = outcome({0: (0.0, 0.0, 0.0)}, (4.0, 2.0), [other])
        self.assertIsNone(hit)
        self.assertAlmostEqual(clearance, 8.0)


if __name__ == "__main__":
    unittest.main()
