"""Checks of the candidate table's readers (standard library only: CI runs
them with the system python3; `python3 -m unittest discover -s
training/prior -p test_candidate_table.py`)."""
import io
import json
import os
import sys
import tempfile
import unittest
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from candidate_table import (SETS, CandidateError, candidate, main, realism_overall,  # noqa: E402
                             recorded_turns_in_top_n, trust_region_safer)

PRIOR_FIT = """history         scenes     samples     NLL   top-1  in top n  accel m/s²  yaw rad/s
at boundary     all           6227   5.504   0.030     0.361        2.52      0.086

recorded turns (|yaw rate| of the token >= 0.1 rad/s):
scenes     samples     NLL  in top n
all            443   6.898     0.122
held out        44   7.060     0.068
"""

PRIOR_FIT_WITH_KINDS = """history         scenes     samples     NLL   top-1  in top n  accel m/s²  yaw rad/s
at boundary     all           6227   5.529   0.030     0.357        2.62      0.078
recorded tokens that turn (...) and that begin a turn (...)
kind             scenes     samples     NLL  in top n  miss mean    0 bins  1-2 bins  3-5 bins   6+ bins
turning          all            443   7.014     0.120       2.80     0.395     0.262     0.165     0.178
turn onset       all            102   6.500     0.150       2.10     0.400     0.300     0.150     0.150
"""

REALISM = """WOSAC 2025 realism, policy prior, 8 rollouts per scene, seed 0
format       scenes  kinematic  interactive  map-based     meta   minADE  collision  off-road
womd-json        67     0.5507       0.7931     0.8767   0.7739     1.53      0.070     0.455
overall          67     0.5507       0.7931     0.8767   0.7739     1.53      0.070     0.455
"""

TRUST_REGION = """55 scenes × 3 seeds; trust region n = 20
all scenes:
method             boundaries   mass accel m/s²  a-bins   yaw rad/s y-bins  no-steer behaviours plausible  none-pl.   rank  outside
safer                    2398  0.630       3.33    15.5       0.103    2.5     0.383        5.0     0.933     0.019   13.1    0.020
held out (every tenth scene by id: 5 of 55):
method             boundaries   mass accel m/s²  a-bins   yaw rad/s y-bins  no-steer behaviours plausible  none-pl.   rank  outside
safer                     220  0.627       3.70    16.6       0.094    9.9     0.500        5.4     0.887     0.032   14.2    0.034
"""


def row(method, cr, at_fault=0.0, off_road=0.0):
    return {"method": method, "cr": cr, "sr": 0.99, "sr_critical": 0.98,
            "cbv_at_fault_background_collision_rate": at_fault, "cbv_off_road_rate": off_road}


def write_candidate(folder: Path, safer_cr: float, prior_cr: float):
    for s in SETS:
        (folder / f"prior-fit-{s}.txt").write_text(PRIOR_FIT)
        report = {"rows": [row("safer", safer_cr), row("prior", prior_cr, 0.03, 0.05)],
                  "held_out": {"held_out": [row("safer", 0.5)]}}
        (folder / f"eval-{s}.json").write_text(json.dumps(report))
    for s in ("womd-json", "womd-interactive"):
        (folder / f"realism-{s}-8.txt").write_text(REALISM)
    (folder / "trust-region-womd-interactive.txt").write_text(TRUST_REGION)


class ReadersTest(unittest.TestCase):
    def test_the_turn_table_not_the_boundary_table_gives_the_top_n_share(self):
        self.assertEqual(recorded_turns_in_top_n(PRIOR_FIT, Path("x")), 0.122)
        with self.assertRaises(CandidateError):
            recorded_turns_in_top_n(PRIOR_FIT.split("recorded turns")[0], Path("x"))

    def test_the_table_of_token_kinds_gives_the_turning_row_not_the_turn_onsets(self):
        self.assertEqual(recorded_turns_in_top_n(PRIOR_FIT_WITH_KINDS, Path("x")), 0.120)
        with self.assertRaises(CandidateError):
            recorded_turns_in_top_n(PRIOR_FIT_WITH_KINDS.split("turning ")[0], Path("x"))

    def test_realism_reads_the_overall_row_by_heading(self):
        self.assertEqual(realism_overall(REALISM, Path("x")), {"meta": 0.7739, "map-based": 0.8767, "collision": 0.070})
        with self.assertRaises(CandidateError):
            realism_overall(REALISM.replace("overall", "total"), Path("x"))

    def test_trust_region_reads_safer_over_all_scenes_not_the_held_out_ones(self):
        self.assertEqual(trust_region_safer(TRUST_REGION, Path("x")),
                         {"y-bins": 2.5, "behaviours": 5.0, "plausible": 0.933})


class TableTest(unittest.TestCase):
    def test_two_candidates_give_each_columns_mean_and_range(self):
        with tempfile.TemporaryDirectory() as tmp:
            a, b = Path(tmp, "seed0"), Path(tmp, "seed1")
            a.mkdir()
            b.mkdir()
            write_candidate(a, 0.30, 0.10)
            write_candidate(b, 0.20, 0.10)
            self.assertAlmostEqual(candidate(a)["ratio int."], 3.0)
            out = io.StringIO()
            with redirect_stdout(out):
                self.assertEqual(main([str(a), str(b)]), 0)
            line = next(x for x in out.getvalue().splitlines() if x.startswith("safer_cr int."))
            self.assertIn("0.250 (0.200–0.300)", line)

    def test_a_missing_output_is_named(self):
        with tempfile.TemporaryDirectory() as tmp:
            write_candidate(Path(tmp), 0.3, 0.1)
            os.remove(Path(tmp, "eval-womd-json.json"))
            err = io.StringIO()
            with redirect_stderr(err):
                self.assertEqual(main([tmp]), 2)
            self.assertIn("eval-womd-json.json: missing", err.getvalue())


if __name__ == "__main__":
    unittest.main()
