"""Checks of the training loss (run with the training environment:
`training/.venv/bin/python -m unittest discover -s training/prior`)."""
import os
import sys
import unittest

import torch
import torch.nn.functional as F

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from train import (BINS, MAP_IN_INTERSECTION, MAP_SPEED_LIMIT, NEIGHBOUR_CYCLIST, NEIGHBOUR_PEDESTRIAN,  # noqa: E402
                   bin_spread, drop_lateral_history, drop_map_features, has_vulnerable_ahead, is_turning, token_loss)


def explicit_target(target, smoothing, axis, spread):
    """The smoothed target written out token by token."""
    out = torch.zeros(len(target), BINS * BINS)
    for b, y in enumerate(target.tolist()):
        accel, yaw = divmod(y, BINS)
        out[b, y] += 1.0 - smoothing
        for k in range(BINS):
            if axis == "accel":
                out[b, k * BINS + yaw] += smoothing * spread[accel, k]
            else:
                out[b, accel * BINS + k] += smoothing * spread[yaw, k]
    return out


class TokenLossTest(unittest.TestCase):
    def setUp(self):
        torch.manual_seed(0)
        self.logits = torch.randn(6, BINS * BINS)
        # Corners and edges of the grid, where the spread is cut off.
        self.target = torch.tensor([0, BINS - 1, BINS * BINS - 1, BINS * (BINS - 1), 100, 2000])

    def test_no_smoothing_is_cross_entropy(self):
        loss = token_loss(self.logits, self.target, 0.0, "accel", bin_spread(3.0))
        self.assertAlmostEqual(loss.item(), F.cross_entropy(self.logits, self.target).item(), places=5)

    def test_smoothed_loss_is_cross_entropy_against_the_soft_target(self):
        spread = bin_spread(2.5)
        logp = F.log_softmax(self.logits, dim=-1)
        for axis in ["accel", "yaw-rate"]:
            soft = explicit_target(self.target, 0.4, axis, spread)
            torch.testing.assert_close(soft.sum(dim=1), torch.ones(len(self.target)))
            expected = -(soft * logp).sum(dim=1).mean()
            got = token_loss(self.logits, self.target, 0.4, axis, spread)
            self.assertAlmostEqual(got.item(), expected.item(), places=4, msg=axis)

    def test_spread_rows_leave_the_label_bin_out_and_sum_to_one(self):
        spread = bin_spread(4.0)
        torch.testing.assert_close(spread.sum(dim=1), torch.ones(BINS))
        self.assertTrue(torch.all(spread.diagonal() == 0))
        self.assertGreater(spread[30, 31].item(), spread[30, 35].item())



class TurningTest(unittest.TestCase):
    def test_a_token_turns_from_0_3_rad_per_s_either_way_whatever_its_acceleration(self):
        import numpy as np
        yaw_bins = np.arange(BINS)
        centres = -1.5 + (yaw_bins + 0.5) * 3.0 / BINS
        for accel_bin in (0, 31, 62):
            got = is_turning(accel_bin * BINS + yaw_bins)
            self.assertTrue(np.array_equal(got, np.abs(centres) >= 0.3))
        self.assertFalse(is_turning(np.array([31 * BINS + 31]))[0])  # zero yaw rate
        self.assertEqual(int(is_turning(yaw_bins).sum()) % 2, 0)  # as many left as right



class MapFeatureDropoutTest(unittest.TestCase):
    def test_dropped_samples_lose_speed_limits_and_intersection_flags_and_nothing_else(self):
        tokens = torch.rand(2000, 48, 7) + 0.5
        before = tokens.clone()
        batch = drop_map_features({"map_tokens": tokens}, 0.3, torch.Generator().manual_seed(0))
        after = batch["map_tokens"]
        limit_gone = (after[:, :, MAP_SPEED_LIMIT] == 0).all(dim=1)
        flag_gone = (after[:, :, MAP_IN_INTERSECTION] == 0).all(dim=1)
        # About 30 % of the samples each, drawn apart, whole samples at a time.
        self.assertAlmostEqual(limit_gone.float().mean().item(), 0.3, delta=0.04)
        self.assertAlmostEqual(flag_gone.float().mean().item(), 0.3, delta=0.04)
        self.assertFalse(torch.equal(limit_gone, flag_gone))
        self.assertTrue(((after[:, :, MAP_SPEED_LIMIT] == 0) == limit_gone[:, None]).all())
        kept = [c for c in range(7) if c not in (MAP_SPEED_LIMIT, MAP_IN_INTERSECTION)]
        self.assertTrue(torch.equal(after[:, :, kept], before[:, :, kept]))

    def test_no_dropout_changes_nothing(self):
        tokens = torch.rand(10, 48, 7)
        self.assertTrue(torch.equal(drop_map_features({"map_tokens": tokens.clone()}, 0.0)["map_tokens"], tokens))

class HistoryDropoutTest(unittest.TestCase):
    def test_dropped_samples_keep_only_the_current_speed_and_acceleration(self):
        history = torch.rand(2000, 6, 8) + 0.5
        before = history.clone()
        after = drop_lateral_history({"history": history}, 0.3, torch.Generator().manual_seed(0))["history"]
        dropped = (after[:, :5] == 0).all(dim=2).all(dim=1)
        self.assertAlmostEqual(dropped.float().mean().item(), 0.3, delta=0.04)
        # A dropped sample: no past point, no yaw rate now; everything else of now is kept.
        self.assertTrue((after[dropped, 5, 6] == 0).all())
        now_kept = [c for c in range(8) if c != 6]
        self.assertTrue(torch.equal(after[:, 5, now_kept], before[:, 5, now_kept]))
        # A kept sample is untouched.
        self.assertTrue(torch.equal(after[~dropped], before[~dropped]))

    def test_no_dropout_changes_nothing(self):
        history = torch.rand(10, 6, 8)
        self.assertTrue(torch.equal(drop_lateral_history({"history": history.clone()}, 0.0)["history"], history))


class VulnerableAheadTest(unittest.TestCase):
    def test_a_pedestrian_or_cyclist_counts_only_ahead_within_the_window_and_unmasked(self):
        import numpy as np
        n = 6
        neighbours = np.zeros((n, 16, 12), dtype=np.float32)
        pose = np.zeros((n, 16, 5), dtype=np.float32)
        mask = np.zeros((n, 16), dtype=np.float32)
        cases = [  # (kind column, x, y, mask)
            (NEIGHBOUR_PEDESTRIAN, 10.0, 1.0, 1.0),  # ahead: yes
            (NEIGHBOUR_CYCLIST, 20.0, -4.0, 1.0),  # a cyclist ahead, to the right: yes
            (NEIGHBOUR_PEDESTRIAN, -5.0, 0.0, 1.0),  # behind
            (NEIGHBOUR_PEDESTRIAN, 10.0, 7.0, 1.0),  # too far to the side
            (NEIGHBOUR_PEDESTRIAN, 10.0, 0.0, 0.0),  # padding
            (5, 10.0, 0.0, 1.0),  # a vehicle ahead
        ]
        for i, (kind, x, y, m) in enumerate(cases):
            neighbours[i, 3, kind] = 1.0
            pose[i, 3, :2] = (x, y)
            mask[i, 3] = m
        got = has_vulnerable_ahead(neighbours, pose, mask)
        self.assertEqual(got.tolist(), [True, True, False, False, False, False])


class MapReachAheadTest(unittest.TestCase):
    """`input_shift.reach_ahead_m`: the furthest map token ahead within the
    corridor, for moving vehicles only."""

    def test_counts_tokens_ahead_in_the_corridor_of_moving_vehicles(self):
        import numpy as np
        from input_shift import reach_ahead_m
        n = 3
        d = {
            "agent_self": np.zeros((n, 6), np.float32),
            "history": np.zeros((n, 6, 8), np.float32),
            "map_pose": np.zeros((n, 48, 5), np.float32),
            "map_mask": np.zeros((n, 48), np.float32),
        }
        d["agent_self"][[0, 1], 2] = 1.0  # vehicles; query 2 is a pedestrian
        d["agent_self"][2, 3] = 1.0
        d["history"][:, -1, 4] = [10.0, 1.0, 10.0]  # query 1 is too slow
        # Query 0: a token 12 m ahead in the corridor, one 30 m ahead but
        # 8 m to the side, one 40 m behind, and a padded row 50 m ahead.
        d["map_pose"][0, :4, :2] = [[12.0, 1.0], [30.0, 8.0], [-40.0, 0.0], [50.0, 0.0]]
        d["map_mask"][0, :3] = 1.0
        d["map_pose"][[1, 2], 0, :2] = [20.0, 0.0]
        d["map_mask"][[1, 2], 0] = 1.0
        reach = reach_ahead_m(d, np.ones(n, bool))
        self.assertEqual(reach.tolist(), [12.0])


if __name__ == "__main__":
    unittest.main()


class MapTokenWidthTest(unittest.TestCase):
    """Shards of contract 2 carry 10 values per map token; the trainer keeps
    the first 7 for a contract-1 prior and refuses 10 from contract-1 shards."""

    def write(self, folder, version):
        import json
        import numpy as np
        from safetensors.numpy import save_file
        from make_random_shards import random_shard
        tensors = random_shard(np.random.default_rng(0), 200, 10)
        if version == "1":
            tensors["map_tokens"] = np.ascontiguousarray(tensors["map_tokens"][..., :7])
        scenes = [{"id": f"s{i}", "source": "synthetic", "split": "held-out" if i % 2 else "train"} for i in range(10)]
        save_file(tensors, os.path.join(folder, "shard-000.safetensors"),
                  metadata={"contract_version": version, "scenes": json.dumps(scenes)})
        return tensors

    def test_widths(self):
        import tempfile
        from model import Prior
        from train import load_shards
        with tempfile.TemporaryDirectory() as v2:
            written = self.write(v2, "2")
            self.assertEqual(written["map_tokens"].shape[-1], 10)
            for width in (7, 10):
                data, _, _, _ = load_shards(v2, map_token_features=width)
                self.assertEqual(tuple(data["map_tokens"].shape[1:]), (48, width))
                self.assertTrue(torch.equal(data["map_tokens"], torch.from_numpy(written["map_tokens"][..., :width])))
                logits = Prior(16, 8, 1, "differential", width)({k: data[k][:3] for k in data if k != "next_token"})
                self.assertEqual(tuple(logits.shape), (3, BINS * BINS))
        with tempfile.TemporaryDirectory() as v1:
            self.write(v1, "1")
            self.assertEqual(load_shards(v1)[0]["map_tokens"].shape[-1], 7)
            with self.assertRaises(SystemExit) as refused:
                load_shards(v1, map_token_features=10)
            self.assertIn("needs shards of contract 2", str(refused.exception))


class TurnOnlyLaneTest(unittest.TestCase):
    def test_the_own_lane_is_the_first_aligned_lane_token_beside_the_agent_and_it_must_turn_one_way(self):
        import numpy as np
        from train import on_turn_only_lane
        b, n = 5, 4
        tokens = np.zeros((b, n, 10), np.float32)
        pose = np.zeros((b, n, 5), np.float32)
        mask = np.ones((b, n), np.float32)
        tokens[:, :, 0] = 1.0  # lane centrelines
        pose[:, :, 3] = 1.0  # aligned
        pose[:, :, 0] = 2.0  # 2 m ahead
        # 0: right only. 1: right or straight. 2: left only, but 3 m to the side (a neighbour lane).
        # 3: the first token is a road edge, the second (its lane) turns left only. 4: no lane token at all.
        tokens[0, :, 7:9] = (-1.5, -1.4)
        tokens[1, :, 7:9] = (-1.5, 0.0)
        tokens[2, :, 7:9] = (1.5, 1.5)
        pose[2, :, 1] = 3.0
        tokens[3, 0, 0], tokens[3, 0, 1] = 0.0, 1.0
        tokens[3, 0, 7:9] = (-1.5, -1.5)
        tokens[3, 1:, 7:9] = (0.9, 1.2)
        mask[4] = 0.0
        self.assertEqual(on_turn_only_lane(tokens, pose, mask).tolist(), [True, False, False, True, False])
        with self.assertRaises(ValueError):
            on_turn_only_lane(tokens[..., :7], pose, mask)
