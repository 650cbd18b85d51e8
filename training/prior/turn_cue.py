"""How strongly the training labels tie a vehicle's yaw rate to its lane's
turn ahead (feature contract 2), on shards written by `safer prior-dataset`:

    training/.venv/bin/python training/prior/turn_cue.py training/data/prior-ped-rtl-turn [--shards 4,12,20]

Takes the moving vehicles (faster than 3 m/s at the query) whose own lane
(`train.own_lane_turn`'s rule: the nearest aligned lane token within
6 m ahead or behind and 1.5 m to the side) is found, and splits them into
those on a lane that turns right only (every way ahead turns right by
0.5 rad or more) and on a lane that only goes straight (both ends of the
span within 0.1 rad). Per split (train, held out) and lane: the samples,
their share of the moving vehicles, the mean |label yaw rate - history
yaw rate| (what the next token changes), and the share of labels turning
right at 0.1 rad/s or more. Training scenes carry token drift, held-out
scenes none: the two splits show how much of the label's yaw rate the
drift decides and how much the lane does.
"""
import argparse
import glob
import json
import os
import sys

import numpy as np
from safetensors import safe_open

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from train import TURN_ONLY_RAD, own_lane_turn, yaw_rate_centre  # noqa: E402

HISTORY_SPEED, HISTORY_YAW_RATE, SELF_VEHICLE = 4, 6, 2
MIN_SPEED_MPS, STRAIGHT_RAD, RIGHT_LABEL_RADPS = 3.0, 0.1, -0.1


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder")
    ap.add_argument("--shards", default="", help="shard numbers to read, comma-separated (default: all)")
    a = ap.parse_args()
    files = sorted(glob.glob(os.path.join(a.folder, "shard-*.safetensors")))
    if a.shards:
        wanted = {int(s) for s in a.shards.split(",")}
        files = [f for f in files if int(os.path.basename(f)[6:9]) in wanted]
    if not files:
        sys.exit(f"no shards in {a.folder}")
    sums = {}
    for f in files:
        with safe_open(f, "np") as st:
            meta = st.metadata()
            if meta.get("contract_version") != "2":
                sys.exit(f"{f}: contract version {meta.get('contract_version')}; the turn ahead needs 2")
            scenes = json.loads(meta["scenes"])
            held = np.array([scenes[i]["split"] == "held-out" for i in st.get_tensor("scene")])
            found, right, left = own_lane_turn(st.get_tensor("map_tokens"), st.get_tensor("map_pose"),
                                               st.get_tensor("map_mask"))
            history = st.get_tensor("history")
            vehicle = st.get_tensor("agent_self")[:, SELF_VEHICLE] > 0.5
            label = yaw_rate_centre(st.get_tensor("next_token"))
        moving = vehicle & (history[:, -1, HISTORY_SPEED] > MIN_SPEED_MPS)
        change = np.abs(label - history[:, -1, HISTORY_YAW_RATE])
        lanes = {"right only": found & (left <= -TURN_ONLY_RAD),
                 "straight only": found & (np.abs(left) < STRAIGHT_RAD) & (np.abs(right) < STRAIGHT_RAD)}
        for split, in_split in (("train", ~held), ("held out", held)):
            for lane, on in lanes.items():
                m = moving & in_split & on
                s = sums.setdefault((split, lane), np.zeros(4))
                s += (m.sum(), (moving & in_split).sum(), change[m].sum(), (label[m] <= RIGHT_LABEL_RADPS).sum())
    print(f"{len(files)} shards of {a.folder}; moving vehicles (> {MIN_SPEED_MPS} m/s) by their own lane")
    print("| split | own lane | samples | share of moving vehicles | mean abs(label - history yaw rate), rad/s "
          "| labels turning right (<= -0.1 rad/s) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for (split, lane), (n, total, change, right) in sums.items():
        print(f"| {split} | {lane} | {int(n)} | {n / max(total, 1):.3f} | {change / max(n, 1):.3f} "
              f"| {right / max(n, 1):.3f} |")


if __name__ == "__main__":
    main()
