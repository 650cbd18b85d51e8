"""The replanning schedule and the kit's planner options: dt_s, plan_time_s,
route_required, on_route, and the seen log."""

import contextlib
import io
import json
import os
import tempfile
import unittest

from _kit import hello, observation
from safer_planner import NoPlanLeft, Planner, ReplanSchedule, Trajectory, TrajectoryPoint, serve


def plan_from(step, n=6, y=0.0):
    """A plan of ``n`` states ``(x, y)`` one metre apart, the first at x = step."""
    return [(float(step + i), y) for i in range(n)]


class ReplanScheduleTest(unittest.TestCase):
    def test_plans_every_n_steps_and_follows_in_between(self):
        s = ReplanSchedule(3)
        self.assertTrue(s.due(0))
        self.assertEqual(s.planned(0, plan_from(0)), plan_from(0)[1:])
        self.assertFalse(s.due(1))
        self.assertEqual(s.following(1), plan_from(0)[2:])
        self.assertFalse(s.due(2))
        self.assertTrue(s.due(3))
        self.assertEqual((s.plans, s.failed, s.plan_step), (1, 0, 0))

    def test_a_plan_is_due_when_the_last_runs_out_or_expires(self):
        s = ReplanSchedule(10)
        s.planned(0, plan_from(0, n=3))
        self.assertFalse(s.due(1))
        self.assertTrue(s.due(2))  # no state after step 2 left
        s.planned(2, plan_from(2))
        s.expire()
        self.assertTrue(s.due(3))
        s.planned(3, None)  # nothing found: still stale, follows what is left
        self.assertTrue(s.due(4))
        s.planned(4, plan_from(4))
        self.assertFalse(s.due(5))

    def test_starts_from_the_planned_state_only_on_the_plan(self):
        s = ReplanSchedule(2, on_plan_m=0.05)
        s.planned(0, plan_from(0), kept="frenet")
        self.assertEqual(s.start(2, 2.0, 0.01), 2)
        self.assertIsNone(s.start(2, 2.0, 0.2))
        self.assertIsNone(s.start(9, 9.0, 0.0))  # past the plan
        self.assertEqual(s.kept, "frenet")

    def test_no_plan_follows_the_last_then_gives_up(self):
        s = ReplanSchedule(1)
        s.planned(0, plan_from(0, n=3), kept=1)
        self.assertEqual(s.planned(1, None), [(2.0, 0.0)])
        self.assertEqual(s.kept, 1)
        with self.assertRaises(NoPlanLeft):
            s.planned(2, None)
        self.assertEqual((s.plans, s.failed), (3, 2))

    def test_bad_arguments(self):
        for bad in (0, -1, 2.5):
            with self.assertRaises(ValueError):
                ReplanSchedule(bad)
        with self.assertRaises(ValueError):
            ReplanSchedule(1, on_plan_m=float("nan"))


class Straight(Planner):
    """Drives on along x at its speed; counts the routes it is given."""

    name = "straight"
    protocol_minor = 3

    def __init__(self):
        self.routes = []

    def on_route(self, route):
        self.routes.append(route.revision)

    def plan(self, obs):
        e = obs.ego
        return Trajectory([TrajectoryPoint(0.1, e.x + 0.1 * e.speed_mps, e.y, 0.0, e.speed_mps)], debug={"n": obs.step})


def session(planner, *messages):
    out, err = io.StringIO(), io.StringIO()
    status = serve(planner, io.StringIO("".join(json.dumps(m) + "\n" for m in messages)), out, err)
    return status, [json.loads(line) for line in out.getvalue().splitlines()], err.getvalue()


BYE = {"type": "bye"}


class PlannerOptionsTest(unittest.TestCase):
    def test_on_route_once_per_revision(self):
        p = Straight()
        status, _, _ = session(p, hello(), observation(0), observation(1), observation(2, revision=1), BYE)
        self.assertEqual((status, p.routes), (0, [0, 1]))

    def test_dt_s_refuses_another_step(self):
        class Fixed(Straight):
            dt_s = 0.05

        status, replies, _ = session(Fixed(), hello(), BYE)
        self.assertEqual(status, 1)
        self.assertEqual(replies[0]["type"], "error")
        self.assertIn("0.05 s", replies[0]["message"])

    def test_plan_time_s_warns_of_a_shorter_step_timeout(self):
        class Slow(Straight):
            plan_time_s = 5.0

        with contextlib.redirect_stderr(io.StringIO()) as err:  # Planner.log writes to sys.stderr
            _, replies, _ = session(Slow(), hello(minor=3, step_timeout_s=1.0), BYE)
        self.assertEqual(replies[0]["type"], "ready")
        self.assertIn("a plan can take 5.0 s", err.getvalue())
        with contextlib.redirect_stderr(io.StringIO()) as err:
            session(Slow(), hello(minor=3, step_timeout_s=30.0), BYE)
        self.assertNotIn("a plan can take", err.getvalue())

    def test_route_required(self):
        class Needs(Straight):
            route_required = True

        status, replies, _ = session(Needs(), hello(), observation(0, route=[]), BYE)
        self.assertEqual(status, 1)
        self.assertEqual(replies[-1]["type"], "error")
        self.assertIn("needs the route", replies[-1]["message"])

    def test_seen_log(self):
        with tempfile.TemporaryDirectory() as folder:
            p = Straight()
            p.seen_log = folder
            h = hello(minor=3, scenario={"id": "s", "variant": "suite::scene::seed-1"},
                      horizon={"start_step": 10, "steps": 5, "dt_s": 0.1, "duration_s": 0.5}, origin_world=[5.0, 6.0])
            session(p, h, observation(10, x=10.0), observation(11, x=11.0), observation(12, x=12.0, revision=1), BYE)
            with open(os.path.join(folder, "suite", "scene", "seed-1.json")) as f:
                log = json.load(f)
        self.assertEqual(log["hello"]["scenario"]["variant"], "suite::scene::seed-1")
        self.assertEqual(log["first"]["step"], 10)
        self.assertEqual(log["first"]["origin_world"], [5.0, 6.0])
        self.assertEqual([r["step"] for r in log["routes"]], [0, 2])
        self.assertEqual(log["ego"]["0"], [10.0, 0.0, 0.0])
        self.assertAlmostEqual(log["ego"]["3"][0], 13.0)  # the last reply's first point
        self.assertEqual(log["debug"], {"n": 12})

    def test_no_seen_log_without_a_variant(self):
        with tempfile.TemporaryDirectory() as folder:
            p = Straight()
            p.seen_log = folder
            session(p, hello(), observation(0), BYE)
            self.assertEqual(os.listdir(folder), [])


if __name__ == "__main__":
    unittest.main()
