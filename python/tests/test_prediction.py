import math
import unittest

from _kit import agent, observation
from safer_planner import Agent, Observation, horizon_times, predict_agent, predict_constant_velocity


class PredictionTest(unittest.TestCase):
    def setUp(self):
        self.obs = Observation.from_json(observation(
            0,
            agents=[agent("a", 20.0, vx=5.0), agent("b", 40.0, y=3.5, vx=0.0),
                    {"id": "c", "kind": "cyclist", "x": 0.0, "y": 10.0, "heading_rad": -math.pi / 2,
                     "vx": 0.0, "vy": -2.0, "length_m": 2.0, "width_m": 1.0}],
        ))

    def test_horizon_times(self):
        times = horizon_times(1.0, 0.1)
        self.assertEqual(len(times), 10)
        self.assertAlmostEqual(times[0], 0.1)
        self.assertAlmostEqual(times[-1], 1.0)  # 1.0 / 0.1 is 9.999...: still ten steps
        self.assertEqual(horizon_times(0.25, 0.1, include_now=True), [0.0, 0.1, 0.2])
        self.assertEqual(horizon_times(0.0, 0.1), [])
        for bad in ((1.0, 0.0), (1.0, -0.1), (-1.0, 0.1), (float("nan"), 0.1)):
            with self.assertRaises(ValueError):
                horizon_times(*bad)

    def test_agents_keep_their_velocity_and_heading(self):
        pred = predict_constant_velocity(self.obs, [0.0, 1.0, 2.5])
        self.assertEqual(list(pred), ["a", "b", "c"])
        a = pred["a"]
        self.assertEqual([p.t for p in a], [0.0, 1.0, 2.5])
        self.assertEqual([p.position for p in a], [(20.0, 0.0), (25.0, 0.0), (32.5, 0.0)])
        self.assertEqual(pred["b"][-1].position, (40.0, 3.5))  # stopped: stays
        c = pred["c"][-1]
        self.assertEqual(c.position, (0.0, 5.0))
        self.assertEqual((c.heading_rad, c.speed_mps, c.length_m, c.width_m), (-math.pi / 2, 2.0, 2.0, 1.0))

    def test_boxes_move_with_the_agent(self):
        box = predict_constant_velocity(self.obs, [2.0])["a"][0].box()
        self.assertEqual(box, [(32.25, -1.0), (32.25, 1.0), (27.75, 1.0), (27.75, -1.0)])

    def test_over_a_horizon(self):
        pred = predict_constant_velocity(self.obs.agents, horizon_s=3.0, dt_s=0.5)
        self.assertEqual(len(pred["a"]), 6)
        self.assertAlmostEqual(pred["a"][-1].x, 35.0)
        self.assertAlmostEqual(pred["a"][0].t, 0.5)

    def test_bad_arguments(self):
        with self.assertRaises(ValueError):
            predict_constant_velocity(self.obs)
        with self.assertRaises(ValueError):
            predict_constant_velocity(self.obs, [1.0], horizon_s=1.0, dt_s=0.1)
        with self.assertRaises(ValueError):
            predict_agent(self.obs.agents[0], [-0.1])
        self.assertEqual(predict_constant_velocity([], [1.0]), {})
        self.assertIsInstance(self.obs.agents[0], Agent)


if __name__ == "__main__":
    unittest.main()
