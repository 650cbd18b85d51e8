"""Checks of the training loss (run with the training environment:
`training/.venv/bin/python -m unittest discover -s training/prior`)."""
import os
import sys
import unittest

import torch
import torch.nn.functional as F

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from train import BINS, bin_spread, token_loss  # noqa: E402


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


if __name__ == "__main__":
    unittest.main()
