"""What the prior reads, per source of samples: how the query features of one
shard folder are distributed, to compare the shipped training data with the
scenes the prior drives at run time.

    training/.venv/bin/python training/prior/input_shift.py training/data/prior [MORE_DIRS ...]

Each folder is a `safer prior-dataset` output (for WOMD scenes: `prior-dataset
--evaluation-only --recorded data:womd-json`, never shipped). Samples are
grouped by their scene's source (ngsim, synthetic, womd, ...). Per group:
map tokens per query and the share of each kind (lane centre, road edge,
road line, area such as crosswalks), the share of lane tokens flagged in an
intersection and with a speed limit, the share of map tokens with a known
signal, neighbours per query and the share that are pedestrians or
cyclists, queries whose own agent is not a vehicle, the mean speed at
the query, and how far ahead a moving vehicle's map tokens reach (the
median over vehicles faster than 3 m/s of the furthest token midpoint
ahead within 6 m to either side, in the query's frame: the 48 nearest
tokens of a dense junction reach less far). Features the run-time scenes
have and training never showed (or the reverse) are inputs the prior was
not trained to read.
"""
import argparse
import glob
import json
import os

import numpy as np
from safetensors import safe_open
from safetensors.numpy import load_file

# Column layout of the contract (docs/prior-features.md).
MAP_KIND = slice(0, 4)  # lane centre, road edge, road line, area
MAP_IN_INTERSECTION, MAP_SPEED_LIMIT = 5, 6
NEIGHBOUR_KIND = slice(5, 9)  # vehicle, pedestrian, cyclist, other
SELF_KIND = slice(2, 6)
SIGNAL_NONE = 3
HISTORY_SPEED = 4
POSE_X, POSE_Y = 0, 1
REACH_MIN_SPEED_MPS, REACH_HALF_WIDTH_M = 3.0, 6.0


class Sums:
    """Running sums over the samples of one source."""

    def __init__(self):
        self.queries = 0
        self.map_tokens = 0
        self.kinds = np.zeros(4)
        self.lanes = 0
        self.lanes_in_intersection = 0
        self.lanes_with_limit = 0
        self.signal_known = 0
        self.neighbours = 0
        self.neighbour_kinds = np.zeros(4)
        self.not_vehicle = 0
        self.speed = 0.0
        self.reach_ahead_m = []

    def add(self, d, rows):
        m = d["map_mask"][rows] > 0
        tokens = d["map_tokens"][rows][m]
        lane = tokens[:, 0] > 0
        nm = d["neighbour_mask"][rows] > 0
        self.queries += int(rows.sum())
        self.map_tokens += int(m.sum())
        self.kinds += tokens[:, MAP_KIND].sum(0)
        self.lanes += int(lane.sum())
        self.lanes_in_intersection += int((tokens[lane, MAP_IN_INTERSECTION] > 0).sum())
        self.lanes_with_limit += int((tokens[lane, MAP_SPEED_LIMIT] > 0).sum())
        self.signal_known += int((d["map_signal"][rows][m][:, SIGNAL_NONE] == 0).sum())
        self.neighbours += int(nm.sum())
        self.neighbour_kinds += d["neighbours"][rows][nm][:, NEIGHBOUR_KIND].sum(0)
        self.not_vehicle += int((d["agent_self"][rows][:, SELF_KIND][:, 0] == 0).sum())
        self.speed += float(d["history"][rows][:, -1, HISTORY_SPEED].sum())
        self.reach_ahead_m.append(reach_ahead_m(d, rows))

    def row(self, name):
        share = lambda a, b: a / b if b else float("nan")
        k = self.kinds / max(self.map_tokens, 1)
        nk = self.neighbour_kinds / max(self.neighbours, 1)
        ahead = np.concatenate(self.reach_ahead_m) if self.reach_ahead_m else np.zeros(0)
        reach = float(np.median(ahead)) if len(ahead) else float("nan")
        return (f"| {name} | {self.queries} | {share(self.map_tokens, self.queries):.1f} | "
                f"{k[0]:.3f} / {k[1]:.3f} / {k[2]:.3f} / {k[3]:.3f} | "
                f"{share(self.lanes_in_intersection, self.lanes):.3f} | {share(self.lanes_with_limit, self.lanes):.3f} | "
                f"{share(self.signal_known, self.map_tokens):.3f} | {share(self.neighbours, self.queries):.1f} | "
                f"{nk[1]:.3f} / {nk[2]:.3f} | {share(self.not_vehicle, self.queries):.3f} | "
                f"{share(self.speed, self.queries):.2f} | {reach:.1f} |")


def reach_ahead_m(d, rows):
    """Per moving vehicle query of `rows`: the furthest map token midpoint
    ahead of it within the corridor (0 when none is)."""
    vehicle = d["agent_self"][rows][:, SELF_KIND][:, 0] > 0
    moving = d["history"][rows][:, -1, HISTORY_SPEED] > REACH_MIN_SPEED_MPS
    pose = d["map_pose"][rows]
    m = d["map_mask"][rows] > 0
    x, y = pose[:, :, POSE_X], pose[:, :, POSE_Y]
    ahead = np.where(m & (x > 0) & (np.abs(y) < REACH_HALF_WIDTH_M), x, 0.0).max(1)
    return ahead[vehicle & moving]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folders", nargs="+", help="shard folders written by `safer prior-dataset`")
    args = ap.parse_args()
    print("| folder: source | queries | map tokens / query | lane / edge / line / area | lanes in intersection | "
          "lanes with a speed limit | tokens with a signal | neighbours / query | pedestrian / cyclist neighbours | "
          "queries not a vehicle | speed m/s | map reach ahead, moving vehicles (median m) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for folder in args.folders:
        groups = {}
        for path in sorted(glob.glob(os.path.join(folder, "*.safetensors"))):
            with safe_open(path, "np") as f:
                scenes = json.loads(f.metadata()["scenes"])
            d = load_file(path)
            source = np.array([s["source"] for s in scenes])
            for name in sorted(set(source)):
                rows = np.isin(d["scene"], np.where(source == name)[0])
                if rows.any():
                    groups.setdefault(name, Sums()).add(d, rows)
        for name, sums in groups.items():
            print(sums.row(f"{os.path.basename(os.path.normpath(folder))}: {name}"))


if __name__ == "__main__":
    main()
