"""Random smoke-test shards for the realism prior (NOT training data).

    training/.venv/bin/python training/prior/make_random_shards.py --out /tmp/prior-smoke --shards 2 --samples 4000

Writes `shard-*.safetensors` files with every tensor of the feature contract
(docs/prior-features.md, version 2) at the contract's shapes and dtypes, plus
`next_token` (i64 [B]) and `scene` (i64 [B]), and the metadata keys
`contract_version` = "2" and `scenes` (JSON list of {id, source, split}), i.e.
what `safer prior-dataset` (src/datasets/prior_shards.rs) writes, plus
`generator` naming this script: `export.py` reads it, labels the card's
training data as random and refuses to write such a model into `models/`. Values are
random but keep the contract's structure: padded rows are all zeros where
their mask is 0, one-hot fields are one-hot, the current history point is
always valid. `next_token` is the grid token nearest to the current
acceleration and yaw rate (history index 5) plus noise, so a smoke run can
show that the loss falls. Use it to test `train.py`, `export.py` and
`bench_latency.py` without the real data; never ship a model trained on it.
"""
import argparse
import json
import os

import numpy as np
from safetensors.numpy import save_file

BINS = 63
MAX_ACCEL_MPS2 = 5.0
MAX_YAW_RATE_RADPS = 1.5
HISTORY_POINTS, NEIGHBOURS, MAP_TOKENS = 6, 16, 48


def one_hot(rng, n, k):
    """[n, k] rows with a single 1 at a random index."""
    out = np.zeros((n, k), np.float32)
    out[np.arange(n), rng.integers(0, k, n)] = 1.0
    return out


def token_of(accel_mps2, yaw_rate_radps):
    """Token id (i_accel * 63 + i_yaw_rate) of the bin centre nearest to each action."""
    ia = np.clip(np.rint((accel_mps2 + MAX_ACCEL_MPS2) / (2 * MAX_ACCEL_MPS2) * (BINS - 1)), 0, BINS - 1)
    ip = np.clip(np.rint((yaw_rate_radps + MAX_YAW_RATE_RADPS) / (2 * MAX_YAW_RATE_RADPS) * (BINS - 1)), 0, BINS - 1)
    return (ia * BINS + ip).astype(np.int64)


def random_shard(rng, b, n_scenes):
    """One shard's tensors for `b` random queries over `n_scenes` scenes."""
    f32 = np.float32
    # History: the agent drives roughly along x; older points may be invalid.
    speed = rng.uniform(0, 25, (b, 1)).astype(f32)
    t = np.arange(-5, 1, dtype=f32)[None, :] * 0.5  # -2.5 s .. 0 s
    dh = rng.normal(0, 0.05, (b, HISTORY_POINTS)).astype(f32)
    accel = rng.normal(0, 1.0, (b, HISTORY_POINTS)).astype(f32)
    yaw_rate = rng.normal(0, 0.1, (b, HISTORY_POINTS)).astype(f32)
    history = np.stack([
        speed * t + rng.normal(0, 0.3, (b, HISTORY_POINTS)),
        rng.normal(0, 0.3, (b, HISTORY_POINTS)),
        np.cos(dh), np.sin(dh),
        np.clip(speed + accel * t, 0, None),
        accel, yaw_rate,
        np.ones((b, HISTORY_POINTS)),
    ], axis=-1).astype(f32)
    first_valid = rng.integers(0, HISTORY_POINTS, b)  # index 5 (now) is always valid
    history[np.arange(HISTORY_POINTS)[None, :] < first_valid[:, None]] = 0.0

    agent_self = np.concatenate([rng.uniform(3.5, 6, (b, 1)), rng.uniform(1.6, 2.2, (b, 1)), one_hot(rng, b, 4)],
                                axis=1).astype(f32)

    n_nb = rng.integers(0, NEIGHBOURS + 1, b)
    neighbour_mask = (np.arange(NEIGHBOURS)[None, :] < n_nb[:, None]).astype(f32)
    nb_xy = rng.uniform(-50, 50, (b, NEIGHBOURS, 2)).astype(f32)
    nb_dist = np.sort(np.linalg.norm(nb_xy, axis=-1), axis=1)  # sorted by distance as the contract says
    ang = rng.uniform(-np.pi, np.pi, (b, NEIGHBOURS))
    nb_xy = np.stack([nb_dist * np.cos(ang), nb_dist * np.sin(ang)], axis=-1)
    nb_dh = rng.normal(0, 0.3, (b, NEIGHBOURS))
    nb_speed = rng.uniform(0, 25, (b, NEIGHBOURS))
    neighbours = np.concatenate([
        nb_speed[..., None], (nb_speed * np.cos(nb_dh))[..., None], (nb_speed * np.sin(nb_dh))[..., None],
        rng.uniform(3.5, 6, (b, NEIGHBOURS, 1)), rng.uniform(1.6, 2.2, (b, NEIGHBOURS, 1)),
        one_hot(rng, b * NEIGHBOURS, 4).reshape(b, NEIGHBOURS, 4),
        (nb_speed * 0.5 * np.cos(nb_dh))[..., None], (nb_speed * 0.5 * np.sin(nb_dh))[..., None],
        np.ones((b, NEIGHBOURS, 1)),
    ], axis=-1).astype(f32)
    neighbour_pose = np.concatenate([nb_xy, nb_dist[..., None], np.cos(nb_dh)[..., None], np.sin(nb_dh)[..., None]],
                                    axis=-1).astype(f32)
    neighbours *= neighbour_mask[..., None]
    neighbour_pose *= neighbour_mask[..., None]

    n_map = rng.integers(1, MAP_TOKENS + 1, b)
    map_mask = (np.arange(MAP_TOKENS)[None, :] < n_map[:, None]).astype(f32)
    map_tokens = np.concatenate([
        one_hot(rng, b * MAP_TOKENS, 4).reshape(b, MAP_TOKENS, 4), rng.uniform(0.5, 8, (b, MAP_TOKENS, 1)),
        (rng.random((b, MAP_TOKENS, 1)) < 0.2), rng.choice([0.0, 13.4, 20.1, 29.1], (b, MAP_TOKENS, 1)),
    ], axis=-1).astype(f32)
    mp_xy = rng.uniform(-42, 42, (b, MAP_TOKENS, 2))
    mp_dist = np.sort(np.linalg.norm(mp_xy, axis=-1), axis=1)
    mp_dir = rng.normal(0, 0.5, (b, MAP_TOKENS))
    map_pose = np.concatenate([mp_xy, mp_dist[..., None], np.cos(mp_dir)[..., None], np.sin(mp_dir)[..., None]],
                              axis=-1).astype(f32)
    map_signal = one_hot(rng, b * MAP_TOKENS, 4).reshape(b, MAP_TOKENS, 4)
    for x in (map_tokens, map_pose, map_signal):
        x *= map_mask[..., None]

    next_token = token_of(history[:, 5, 5] + rng.normal(0, 0.3, b), history[:, 5, 6] + rng.normal(0, 0.05, b))
    scene = rng.integers(0, n_scenes, b).astype(np.int64)
    # Contract 2: each lane token's turn ahead (rightmost, leftmost heading change, reach), zeros elsewhere.
    rightmost = -rng.uniform(0, 1.6, (b, MAP_TOKENS, 1))
    leftmost = rightmost + rng.uniform(0, 3.2, (b, MAP_TOKENS, 1))
    reach = rng.choice([40.0, 12.5, 30.0], (b, MAP_TOKENS, 1))
    lane = map_tokens[..., :1] * map_mask[..., None]
    map_tokens = np.concatenate([map_tokens, (np.concatenate([rightmost, leftmost, reach], axis=-1) * lane)],
                                axis=-1).astype(f32)
    return {
        "history": history, "agent_self": agent_self, "neighbours": neighbours, "neighbour_pose": neighbour_pose,
        "neighbour_mask": neighbour_mask, "map_tokens": map_tokens, "map_pose": map_pose, "map_signal": map_signal,
        "map_mask": map_mask, "next_token": next_token, "scene": scene,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="folder for shard-*.safetensors (not training/data/prior)")
    ap.add_argument("--shards", type=int, default=2)
    ap.add_argument("--samples", type=int, default=4000, help="queries per shard")
    ap.add_argument("--scenes", type=int, default=40, help="scenes per shard; every 10th is held out")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    os.makedirs(a.out, exist_ok=True)
    for s in range(a.shards):
        scenes = [{"id": f"random-{s}-{i}", "source": "ngsim" if i % 4 == 0 else "synthetic",
                   "split": "held-out" if i % 10 == 0 else "train"} for i in range(a.scenes)]
        tensors = random_shard(rng, a.samples, a.scenes)
        meta = {"contract_version": "2", "scenes": json.dumps(scenes, separators=(",", ":")),
                "generator": "make_random_shards.py (random smoke-test data)"}
        save_file(tensors, os.path.join(a.out, f"shard-{s:03d}.safetensors"), metadata=meta)
    print(f"wrote {a.shards} random shards of {a.samples} queries to {a.out}")


if __name__ == "__main__":
    main()
