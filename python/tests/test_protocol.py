import io
import json
import os
import subprocess
import sys
import textwrap
import unittest

from _kit import KIT_DIR, REPO, agent, hello, observation, straight_lane
from safer_planner import Control, Planner, PlannerError, Trajectory, TrajectoryPoint, serve

PREPARE = {"type": "prepare", "map": {"lanes": [straight_lane(0)], "road_edges": [], "stop_signs": [],
                                      "signal_stops": []}}


def session(planner, *messages, raw_lines=()):
    """Serves `messages` (dicts, then `raw_lines`) to `planner`; returns
    (exit status, the reply objects, stderr text)."""
    text = "".join(json.dumps(m) + "\n" for m in messages) + "".join(raw_lines)
    out, err = io.StringIO(), io.StringIO()
    status = serve(planner, io.StringIO(text), out, err)
    return status, [json.loads(line) for line in out.getvalue().splitlines()], err.getvalue()


class Recorder(Planner):
    name = "recorder"

    def __init__(self):
        self.seen = []

    def on_hello(self, hello):
        self.seen.append(("hello", hello.protocol_minor))

    def on_prepare(self, road_map):
        self.seen.append(("prepare", list(road_map.lanes)))

    def plan(self, obs):
        self.seen.append(("plan", obs.step, obs.route))
        print("a stray print from planner code")  # must not reach the harness
        return Control(accel_mps2=0.5, yaw_rate_radps=-0.1)

    def on_bye(self):
        self.seen.append(("bye",))


class LoopTest(unittest.TestCase):
    def test_a_1_2_session(self):
        p = Recorder()
        status, replies, err = session(p, hello(), PREPARE, observation(10), observation(11), {"type": "bye"})
        self.assertEqual(status, 0)
        self.assertEqual(replies, [
            {"type": "ready", "protocol": 1, "protocol_minor": 2, "name": "recorder"},
            {"type": "prepared"},
            {"type": "control", "accel_mps2": 0.5, "yaw_rate_radps": -0.1, "step": 10},
            {"type": "control", "accel_mps2": 0.5, "yaw_rate_radps": -0.1, "step": 11},
        ])
        self.assertEqual(err.count("a stray print from planner code"), 2)
        self.assertEqual([s[0] for s in p.seen], ["hello", "prepare", "plan", "plan", "bye"])
        self.assertEqual(p.seen[1], ("prepare", [0]))
        self.assertEqual(p.map.lane(0).speed_limit_mps, 13.9)
        self.assertEqual(p.revision, 2)
        # The stable route is built once per revision.
        self.assertIs(p.seen[2][2], p.seen[3][2])

    def test_a_new_route_revision_gives_a_new_route(self):
        p = Recorder()
        session(p, hello(), PREPARE, observation(0, revision=0), observation(1, revision=1))
        self.assertIsNot(p.seen[2][2], p.seen[3][2])
        self.assertEqual(p.seen[3][2].revision, 1)

    def test_sys_stdout_is_restored(self):
        before = sys.stdout
        session(Recorder(), hello(), observation(0))
        self.assertIs(sys.stdout, before)

    def test_a_1_0_planner(self):
        class Old(Recorder):
            protocol_minor = 0

        p = Old()
        status, replies, _ = session(p, hello(), observation(3))
        self.assertEqual(status, 0)  # end of input without bye is fine
        self.assertEqual(replies[0], {"type": "ready", "protocol": 1, "name": "recorder"})
        self.assertEqual(replies[1]["step"], 3)  # step tags in every revision
        self.assertEqual(p.revision, 0)

    def test_a_1_1_harness_gets_1_1(self):
        p = Recorder()
        session(p, hello(minor=1))
        self.assertEqual(p.revision, 1)

    def test_a_planner_needing_1_1_refuses_a_1_0_harness(self):
        class Needs(Recorder):
            min_protocol_minor = 1

        status, replies, err = session(Needs(), hello(minor=0), observation(0))
        self.assertEqual(status, 1)
        self.assertEqual(replies, [{"type": "error", "message": "recorder needs protocol 1.1 or later; the harness speaks 1.0"}])
        self.assertIn("giving up", err)

    def test_another_protocol_version_is_refused(self):
        status, replies, _ = session(Recorder(), dict(hello(), protocol=2))
        self.assertEqual(status, 1)
        self.assertEqual(replies[0]["type"], "error")
        self.assertIn("protocol 2 is not supported", replies[0]["message"])

    def test_an_exception_in_plan_is_an_error_reply_with_the_traceback_on_stderr(self):
        class Broken(Planner):
            name = "broken"

            def plan(self, obs):
                return {"x": 1}["y"]

        status, replies, err = session(Broken(), hello(), PREPARE, observation(7))
        self.assertEqual(status, 1)
        self.assertEqual(replies[-1], {"type": "error", "message": "KeyError: 'y'", "step": 7})
        self.assertIn("Traceback (most recent call last)", err)

    def test_planner_error_gives_up_with_its_message(self):
        class GivesUp(Planner):
            def plan(self, obs):
                raise PlannerError("no route to follow")

        status, replies, err = session(GivesUp(), hello(), PREPARE, observation(1))
        self.assertEqual(replies[-1], {"type": "error", "message": "no route to follow", "step": 1})
        self.assertNotIn("Traceback", err)
        self.assertEqual(status, 1)

    def test_a_non_finite_number_is_an_error_not_a_broken_line(self):
        class Nan(Planner):
            def plan(self, obs):
                return Control(float("nan"), 0.0)

        _, replies, _ = session(Nan(), hello(), PREPARE, observation(2))
        self.assertEqual(replies[-1]["type"], "error")
        self.assertIn("accel_mps2 is nan", replies[-1]["message"])

    def test_a_wrong_return_type_is_an_error(self):
        class Wrong(Planner):
            def plan(self, obs):
                return {"type": "control"}

        _, replies, _ = session(Wrong(), hello(), PREPARE, observation(2))
        self.assertIn("expected Control or Trajectory", replies[-1]["message"])

    def test_an_error_in_prepare(self):
        class BadPrepare(Recorder):
            def on_prepare(self, road_map):
                raise RuntimeError("model file missing")

        status, replies, _ = session(BadPrepare(), hello(), PREPARE)
        self.assertEqual(replies[-1], {"type": "error", "message": "prepare: RuntimeError: model file missing"})
        self.assertEqual(status, 1)

    def test_trajectory_reply(self):
        class Traj(Planner):
            def plan(self, obs):
                e = obs.ego
                return Trajectory([TrajectoryPoint(0.1, e.x + 1.0, e.y, 0.0, 10.0)])

        _, replies, _ = session(Traj(), hello(), PREPARE, observation(4, x=10.0))
        self.assertEqual(replies[-1], {"type": "trajectory", "step": 4,
                                       "points": [{"t": 0.1, "x": 11.0, "y": 0.0, "heading_rad": 0.0, "speed_mps": 10.0}]})

    def test_blank_lines_and_unknown_types_are_skipped(self):
        status, replies, err = session(Recorder(), hello(), raw_lines=["\n", "  \r\n", '{"type":"later_message"}\n'])
        self.assertEqual(status, 0)
        self.assertEqual(len(replies), 1)
        self.assertIn("ignoring a message of unknown type 'later_message'", err)

    def test_a_line_that_is_not_json_ends_the_process(self):
        status, replies, err = session(Recorder(), hello(), raw_lines=["{not json\n"])
        self.assertEqual(status, 2)
        self.assertIn("line 2 from the harness is not a JSON object", err)

    def test_log_goes_to_stderr_with_the_name(self):
        class Logs(Recorder):
            log_name = "my_planner"

            def on_hello(self, hello):
                self.log("hello:", hello.dt_s)

        old = sys.stderr
        sys.stderr = io.StringIO()
        try:
            _, replies, _ = session(Logs(), hello())
            logged = sys.stderr.getvalue()
        finally:
            sys.stderr = old
        self.assertEqual(logged, "my_planner: hello: 0.1\n")
        self.assertEqual(len(replies), 1)


def run_process(args, messages, cwd=None):
    """Runs a planner process on `messages`; (status, reply objects, stderr)."""
    env = dict(os.environ, PYTHONPATH=KIT_DIR, PYTHONDONTWRITEBYTECODE="1")
    text = "".join(json.dumps(m) + "\n" for m in messages)
    p = subprocess.run([sys.executable] + args, input=text, capture_output=True, text=True, timeout=60,
                       env=env, cwd=cwd)
    return p.returncode, [json.loads(line) for line in p.stdout.splitlines()], p.stderr


class ProcessTest(unittest.TestCase):
    def test_stray_output_below_python_reaches_stderr_not_the_harness(self):
        script = textwrap.dedent("""
            import os, sys
            from safer_planner import Control, Planner, run

            class Noisy(Planner):
                name = "noisy"

                def plan(self, obs):
                    print("print")
                    sys.__stdout__.write("sys.__stdout__\\n"); sys.__stdout__.flush()
                    os.write(1, b"file descriptor 1\\n")
                    os.system("echo a child process")
                    return Control(0.0, 0.0)

            run(Noisy)
        """)
        status, replies, err = run_process(["-c", script], [hello(), PREPARE, observation(5), {"type": "bye"}])
        self.assertEqual(status, 0, err)
        self.assertEqual([r["type"] for r in replies], ["ready", "prepared", "control"])
        for stray in ("print", "sys.__stdout__", "file descriptor 1", "a child process"):
            self.assertIn(stray, err)

    def test_the_twenty_line_planner_brakes_for_a_stopped_car(self):
        script = os.path.join(REPO, "python", "examples", "twenty_line_planner.py")
        free = observation(0, x=10.0, speed=10.0)
        blocked = observation(1, x=10.0, speed=10.0, agents=[agent("stopped", 25.0)])
        status, replies, err = run_process([script], [hello(), PREPARE, free, blocked, {"type": "bye"}])
        self.assertEqual(status, 0, err)
        self.assertEqual(replies[0]["name"], "twenty-line-planner")
        self.assertEqual([r.get("step") for r in replies[2:]], [0, 1])
        self.assertGreater(replies[2]["accel_mps2"], 0.0)  # below the 13.9 m/s limit
        self.assertEqual(replies[3]["accel_mps2"], -8.0)  # 10.5 m to a stopped car
        self.assertAlmostEqual(replies[2]["yaw_rate_radps"], 0.0)

    @unittest.skipUnless(os.path.isdir(os.path.join(REPO, "planners")), "not in the SaFeR repository")
    def test_the_repository_planners_speak_through_the_kit(self):
        lf = os.path.join(REPO, "planners", "lane_follower.py")
        status, replies, err = run_process([lf], [hello(), PREPARE, observation(3, agents=[agent("a", 25.0)])])
        self.assertEqual(status, 0, err)
        self.assertEqual(replies[0], {"type": "ready", "protocol": 1, "protocol_minor": 2, "name": "lane-follower"})
        self.assertLess(replies[2]["accel_mps2"], 0.0)
        self.assertEqual(replies[2]["step"], 3)
        self.assertIn("lane_follower: prepared: 1 lanes", err)
        ex = os.path.join(REPO, "planners", "example_planner.py")
        one_oh = dict(observation(0), map={"lanes": [], "road_edges": []})
        status, replies, err = run_process([ex], [hello(), one_oh])
        self.assertEqual(status, 0, err)
        self.assertEqual(replies[0], {"type": "ready", "protocol": 1, "name": "example-pure-pursuit-idm"})
        self.assertEqual(replies[1]["type"], "control")
        self.assertIn("example_planner: hello: ego", err)


if __name__ == "__main__":
    unittest.main()
