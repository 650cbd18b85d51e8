"""Train the realism prior on the shards that `safer prior-dataset` wrote.

    training/.venv/bin/python training/prior/train.py --attention differential --minutes 30 --out training/runs/prior-mda

Cross-entropy on the next token; AdamW with warm-up and cosine decay over the
step budget; the checkpoint with the best held-out NLL is kept. NGSIM samples
(recorded) are drawn three times as often as synthetic ones, so the recorded
behaviour is not drowned by the synthetic traffic. Held-out = the scenes the
Rust side marked `held-out` (every 10th scene of each source).

    training/.venv/bin/python training/prior/train.py --data training/data/prior --attention differential \
        --minutes 30 --threads 1 --out training/runs/prior-mda

`--out` receives `best.pt` (state dict + arguments + step), `log.csv` (one row
per evaluation on a fixed 20k held-out probe: step, samples seen, running
train loss, held-out NLL, top-1, top-5, elapsed seconds, learning rate; every
`--eval-every` steps and once when the budget ends) and `summary.json` (the
best checkpoint on the whole held-out set, also printed as one JSON line).
`samples_per_s` counts wall-clock time including evaluations;
`optimiser_samples_per_s` excludes them. For a smoke test without the real
data, see `make_random_shards.py`.
"""
import argparse, csv, glob, json, math, os, sys, time

import numpy as np
import torch
import torch.nn.functional as F
from safetensors import safe_open

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from model import Prior  # noqa: E402

KEYS = ["history", "agent_self", "neighbours", "neighbour_pose", "neighbour_mask",
        "map_tokens", "map_pose", "map_signal", "map_mask"]


# Values per map token in the shards of each feature contract version.
SHARD_MAP_TOKEN_FEATURES = {"1": 7, "2": 10}


def load_shards(folder, held_out_only=False, map_token_features=7):
    """The shards' tensors, held-out mask, recorded mask and files; exits on
    a contract mismatch or on shards that disagree about their purpose.
    `held_out_only` keeps the held-out samples alone, in the same order (the
    golden files need no more, and the whole set does not fit in memory
    beside a training run). `map_token_features` keeps the first 7 values
    of each map token (contract 1) or all 10 (contract 2: the lane's turn
    ahead), which needs shards of contract 2."""
    parts = {k: [] for k in KEYS + ["next_token"]}
    lane_change = []  # optional: shards written before the column have none
    split, source = [], []
    purposes, recipes = set(), set()
    files = sorted(glob.glob(os.path.join(folder, "shard-*.safetensors")))
    if not files:
        sys.exit(f"no shards in {folder}: run `cargo run --release -- prior-dataset` first")
    for f in files:
        with safe_open(f, "np") as st:
            meta = st.metadata()
            have = SHARD_MAP_TOKEN_FEATURES.get(meta.get("contract_version"))
            if have is None:
                sys.exit(f"{f}: contract version {meta.get('contract_version')}, this trainer reads 1 and 2")
            if have < map_token_features:
                sys.exit(f"{f}: contract version {meta.get('contract_version')} has {have} values per map token, "
                         f"--map-token-features {map_token_features} needs shards of contract 2 "
                         "(write them again with `safer prior-dataset`)")
            scenes = json.loads(meta["scenes"])
            purposes.add(meta.get("purpose", "shipped"))
            recipes.add(meta.get("recipe", ""))
            sc = st.get_tensor("scene")
            held = np.array([scenes[i]["split"] == "held-out" for i in sc], dtype=bool)
            keep = held if held_out_only else slice(None)
            for k in parts:
                t = st.get_tensor(k)[keep]
                parts[k].append(t[..., :map_token_features] if k == "map_tokens" else t)
            if "lane_change" in st.keys():
                lane_change.append(st.get_tensor("lane_change")[keep])
            split.append(held[keep])
            source.append(np.array([scenes[i]["source"] != "synthetic" for i in sc])[keep])
    if len(purposes) > 1 or len(recipes) > 1:
        sys.exit(f"{folder}: shards of different datasets (purposes {sorted(purposes)}, recipes {sorted(recipes)})")
    data = {k: torch.from_numpy(np.concatenate(v)) for k, v in parts.items()}
    if len(lane_change) == len(files):
        data["lane_change"] = torch.from_numpy(np.concatenate(lane_change))
    return data, np.concatenate(split), np.concatenate(source), files


def shard_metadata(files):
    """The dataset-wide metadata of the shards: purpose (shipped or evaluation-only), recipe and the
    `safer prior-dataset` arguments that made them (empty for shards written before they were kept)."""
    with safe_open(files[0], "np") as st:
        meta = st.metadata() or {}
    return {"purpose": meta.get("purpose", "shipped"), "recipe": meta.get("recipe", ""),
            "arguments": meta.get("arguments", "")}


def batch_of(data, idx):
    return {k: data[k][idx] for k in KEYS}


# Columns of a map token (docs/prior-features.md): the lane's intersection flag and speed limit.
MAP_IN_INTERSECTION, MAP_SPEED_LIMIT = 5, 6


def drop_map_features(batch, p, generator=None):
    """With probability `p` per sample, zero the speed limit of all its map
    tokens (0 is what a map without limits gives), and, drawn apart, their
    intersection flags. Changes `batch["map_tokens"]` (a copy made by
    `batch_of`) in place; returns it."""
    if p <= 0.0:
        return batch
    tokens = batch["map_tokens"]
    for column in (MAP_SPEED_LIMIT, MAP_IN_INTERSECTION):
        drop = torch.rand(tokens.shape[0], device=tokens.device, generator=generator) < p
        tokens[drop, :, column] = 0.0
    return batch


# History layout (docs/prior-features.md): 6 points, the last one now; a point's yaw rate column.
HISTORY_NOW, HISTORY_YAW_RATE = 5, 6


def drop_lateral_history(batch, p, generator=None):
    """With probability `p` per sample, hide how the agent has been
    steering: the history points before now are made invalid (all zeros)
    and the yaw rate of the last period is zeroed; the current speed and
    acceleration stay. A prior that reads its own yaw rate and continues it
    never starts a turn its history has not started (in closed loop the
    CBV drives straight on where its lane bends away); without that cue the
    sample's steering has to be read from the lanes around it, as past-motion
    dropout does for driving policies (ChauffeurNet). Changes
    `batch["history"]` (a copy made by `batch_of`) in place; returns it."""
    if p <= 0.0:
        return batch
    history = batch["history"]
    drop = torch.rand(history.shape[0], device=history.device, generator=generator) < p
    history[drop, :HISTORY_NOW, :] = 0.0
    history[drop, HISTORY_NOW, HISTORY_YAW_RATE] = 0.0
    return batch


@torch.no_grad()
def evaluate(model, data, idx, bs=2048):
    model.eval()
    nll, top1, top5, n = 0.0, 0, 0, 0
    device = data["next_token"].device
    for i in range(0, len(idx), bs):
        j = torch.as_tensor(idx[i:i + bs], device=device)
        logits = model(batch_of(data, j))
        y = data["next_token"][j]
        nll += F.cross_entropy(logits, y, reduction="sum").item()
        top = logits.topk(5, dim=-1).indices
        top1 += (top[:, 0] == y).sum().item()
        top5 += (top == y[:, None]).any(dim=-1).sum().item()
        n += len(j)
    model.train()
    return {"nll": nll / n, "top1": top1 / n, "top5": top5 / n, "n": n}


BINS = 63  # per axis; token id = accel_bin * 63 + yaw_rate_bin (motion::tokens)
MAX_YAW_RATE_RADPS = 1.5  # the grid's yaw-rate bound (motion::tokens)
TURNING_YAW_RATE_RADPS = 0.3  # from here a token turns (eval::prior_fit)


def yaw_rate_centre(tokens):
    """Each token id's yaw-rate bin centre, rad/s (motion::tokens::TokenGrid::yaw_rate_centre)."""
    width = 2 * MAX_YAW_RATE_RADPS / BINS
    return -MAX_YAW_RATE_RADPS + (np.asarray(tokens) % BINS + 0.5) * width


def is_turning(tokens):
    """Whether each token id's yaw-rate bin centre is at least 0.3 rad/s either way."""
    return np.abs(yaw_rate_centre(tokens)) >= TURNING_YAW_RATE_RADPS


# Neighbour feature columns of a pedestrian's and a cyclist's kind flag, and
# the ahead / beside window in the agent's frame (prior_features.rs).
NEIGHBOUR_PEDESTRIAN, NEIGHBOUR_CYCLIST = 6, 7
VULNERABLE_AHEAD_M, VULNERABLE_BESIDE_M = 25.0, 5.0


def has_vulnerable_ahead(neighbours, pose, mask):
    """Whether each sample sees a pedestrian or cyclist ahead of it: within
    25 m in front and 5 m to either side, in its own frame."""
    kind = (neighbours[:, :, NEIGHBOUR_PEDESTRIAN] > 0.5) | (neighbours[:, :, NEIGHBOUR_CYCLIST] > 0.5)
    x, y = pose[:, :, 0], pose[:, :, 1]
    ahead = (x > 0) & (x < VULNERABLE_AHEAD_M) & (np.abs(y) < VULNERABLE_BESIDE_M)
    return (kind & ahead & (mask > 0.5)).any(axis=1)


# The sample's own lane: an aligned lane token (within ~18 deg of its heading) whose midpoint lies
# within 6 m ahead or behind and 1.5 m to either side. Turn-only: every way ahead turns by 0.5 rad or more.
OWN_LANE_AHEAD_M, OWN_LANE_BESIDE_M, OWN_LANE_MIN_COS, TURN_ONLY_RAD = 6.0, 1.5, 0.95, 0.5
MAP_RIGHTMOST, MAP_LEFTMOST = 7, 8


def own_lane_turn(map_tokens, map_pose, map_mask):
    """(found, rightmost, leftmost) of each sample's own lane: its nearest
    aligned lane token (by the order the tokens come in: nearest first)
    within 6 m ahead or behind and 1.5 m to either side. Needs the 10-value
    map tokens of feature contract 2."""
    if map_tokens.shape[-1] <= MAP_LEFTMOST:
        raise ValueError("the turn ahead needs map tokens of 10 values (--map-token-features 10)")
    x, y, cos = map_pose[:, :, 0], map_pose[:, :, 1], map_pose[:, :, 3]
    own = ((map_tokens[:, :, 0] > 0.5) & (map_mask > 0.5) & (cos > OWN_LANE_MIN_COS)
           & (np.abs(x) < OWN_LANE_AHEAD_M) & (np.abs(y) < OWN_LANE_BESIDE_M))
    first = np.argmax(own, axis=1)
    rows = np.arange(len(first))
    return own.any(axis=1), map_tokens[rows, first, MAP_RIGHTMOST], map_tokens[rows, first, MAP_LEFTMOST]


def on_turn_only_lane(map_tokens, map_pose, map_mask):
    """Whether each sample's own lane (`own_lane_turn`) turns one way only
    within the look-ahead: all its ways turn right by 0.5 rad or more, or
    all left."""
    found, right, left = own_lane_turn(map_tokens, map_pose, map_mask)
    return found & ((left <= -TURN_ONLY_RAD) | (right >= TURN_ONLY_RAD))


def bin_spread(sigma_bins):
    """[63, 63]: row i is how a label in bin i of the smoothed axis spreads
    its smoothed share over that axis's other bins (Gaussian in bins, none on
    i itself, rows summing to 1)."""
    j = torch.arange(BINS, dtype=torch.float32)
    w = torch.exp(-0.5 * ((j[None, :] - j[:, None]) / max(sigma_bins, 1e-6)) ** 2)
    w.fill_diagonal_(0.0)
    return w / w.sum(dim=1, keepdim=True)


def token_loss(logits, target, smoothing, axis, spread):
    """Cross-entropy against the label token, with `smoothing` of its mass
    moved along one axis of the grid (`spread` rows): to neighbouring
    acceleration bins at the label's yaw rate (`axis` "accel"), or to
    neighbouring yaw-rate bins at its acceleration ("yaw-rate")."""
    if smoothing <= 0.0:
        return F.cross_entropy(logits, target)
    logp = F.log_softmax(logits, dim=-1).view(-1, BINS, BINS)  # [B, accel bin, yaw-rate bin]
    accel, yaw = target // BINS, target % BINS
    rows = torch.arange(len(target), device=logits.device)
    line, own_bin = (logp[rows, :, yaw], accel) if axis == "accel" else (logp[rows, accel], yaw)  # [B, 63]
    own = line.gather(1, own_bin[:, None])[:, 0]
    spread_part = (spread[own_bin] * line).sum(dim=1)
    return -((1.0 - smoothing) * own + smoothing * spread_part).mean()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default="training/data/prior")
    ap.add_argument("--attention", choices=["differential", "plain"], default="differential")
    ap.add_argument("--minutes", type=float, default=30.0, help="wall-clock budget")
    ap.add_argument("--steps", type=int, default=0, help="fixed step budget instead of --minutes (reproducible)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--batch", type=int, default=256)
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--d", type=int, default=64)
    ap.add_argument("--heads", type=int, default=8)
    ap.add_argument("--layers", type=int, default=3)
    ap.add_argument("--recorded-weight", "--ngsim-weight", dest="ngsim_weight", type=float, default=3.0,
                    help="sampling weight of a recorded sample against a synthetic one")
    ap.add_argument("--device", default="cpu", help="cpu, or cuda where a GPU is present")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--eval-every", type=int, default=500)
    ap.add_argument("--label-smoothing", type=float, default=0.0,
                    help="share of each label's probability spread over neighbouring bins of one axis of the "
                         "token grid, the other axis held (0: plain cross-entropy on the token)")
    ap.add_argument("--label-smoothing-axis", choices=["accel", "yaw-rate"], default="accel",
                    help="the axis the smoothed share spreads along")
    ap.add_argument("--label-smoothing-bins", type=float, default=3.0,
                    help="width (standard deviation, in bins) of that spread")
    ap.add_argument("--map-feature-dropout", type=float, default=0.0,
                    help="per training sample, the probability that its map tokens lose their speed limits, and "
                         "(drawn apart) their intersection flags: run-time maps without them (WOMD JSON keeps "
                         "neither) are then familiar; 0 (the shipped priors) keeps every feature")
    ap.add_argument("--history-dropout", type=float, default=0.0,
                    help="per training sample, the probability that its history before now and its last yaw rate "
                         "are hidden, so that its steering is learned from the map around it (past-motion "
                         "dropout); 0 (the shipped priors) keeps the whole history")
    ap.add_argument("--turning-weight", type=float, default=1.0,
                    help="draw training samples whose label turns (yaw rate of at least 0.3 rad/s either way) "
                         "this many times as often")
    ap.add_argument("--vulnerable-ahead-weight", type=float, default=1.0,
                    help="draw training samples that see a pedestrian or cyclist ahead (within 25 m in front and "
                         "5 m to either side) this many times as often")
    ap.add_argument("--init", help="start from this checkpoint's weights (a best.pt of the same architecture) "
                                   "instead of a random initialisation")
    ap.add_argument("--turn-only-lane-weight", type=float, default=1.0,
                    help="draw the training samples whose own lane turns one way only (every way ahead turns right, "
                         "or every way left, by 0.5 rad or more) this many times as often; needs --map-token-features 10")
    ap.add_argument("--lane-change-weight", type=float, default=1.0,
                    help="draw the samples whose agent is in another lane 3 s later (a lane change under way "
                         "or about to start: the shards' lane_change column) W times as often")
    ap.add_argument("--map-token-features", type=int, choices=[7, 10], default=7,
                    help="values per map token the map encoder reads: 7 (feature contract 1, the shipped prior's) or "
                         "10 (contract 2: also the lane's turn ahead along the lane graph)")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(a.seed)
    rng = np.random.default_rng(a.seed)
    os.makedirs(a.out, exist_ok=True)

    data, held, ngsim, files = load_shards(a.data, map_token_features=a.map_token_features)
    dataset = shard_metadata(files)
    data = {k: v.to(a.device) for k, v in data.items()}
    train_idx = np.flatnonzero(~held)
    held_idx = np.flatnonzero(held)
    # A fixed evaluation subset during training; the whole held-out set at the end.
    probe = np.sort(rng.choice(held_idx, size=min(20000, len(held_idx)), replace=False))
    weights = np.where(ngsim[train_idx], a.ngsim_weight, 1.0)
    if a.turning_weight != 1.0:
        turning = is_turning(data["next_token"][train_idx].cpu().numpy())
        weights = weights * np.where(turning, a.turning_weight, 1.0)
        print(f"turning labels: {turning.mean():.3f} of the training samples, drawn {a.turning_weight}x as often",
              flush=True)
    if a.turn_only_lane_weight != 1.0:
        # In chunks: a copy of every sample's map tokens would double the memory the run needs.
        turn_only = np.concatenate([
            on_turn_only_lane(*(data[k][i:i + 100_000].cpu().numpy() for k in ("map_tokens", "map_pose", "map_mask")))
            for i in range(0, len(data["map_mask"]), 100_000)])[train_idx]
        weights = weights * np.where(turn_only, a.turn_only_lane_weight, 1.0)
        print(f"on a turn-only lane: {turn_only.mean():.4f} of the training samples, drawn "
              f"{a.turn_only_lane_weight}x as often", flush=True)
    if a.lane_change_weight != 1.0:
        if "lane_change" not in data:
            sys.exit(f"{a.data}: the shards have no lane_change column (write them again with `safer prior-dataset`)")
        changing = data["lane_change"][train_idx].cpu().numpy() > 0
        weights = weights * np.where(changing, a.lane_change_weight, 1.0)
        print(f"in a lane change: {changing.mean():.4f} of the training samples, drawn "
              f"{a.lane_change_weight}x as often", flush=True)
    if a.vulnerable_ahead_weight != 1.0:
        ahead = has_vulnerable_ahead(*(data[k][train_idx].cpu().numpy()
                                       for k in ("neighbours", "neighbour_pose", "neighbour_mask")))
        weights = weights * np.where(ahead, a.vulnerable_ahead_weight, 1.0)
        print(f"a pedestrian or cyclist ahead: {ahead.mean():.4f} of the training samples, drawn "
              f"{a.vulnerable_ahead_weight}x as often", flush=True)
    weights /= weights.sum()
    # rng.choice(train_idx, p=weights) rebuilds this CDF on every call (O(samples)
    # a step); drawing through it once made is the same draw, without the cost.
    cdf = weights.cumsum()
    cdf /= cdf[-1]
    if a.device.startswith("cuda"):
        torch.set_float32_matmul_precision("high")
    print(f"samples: {len(train_idx)} train ({ngsim[train_idx].sum()} recorded), {len(held_idx)} held out "
          f"({ngsim[held_idx].sum()} recorded) from {len(files)} shards", flush=True)

    spread = bin_spread(a.label_smoothing_bins).to(a.device)
    model = Prior(a.d, a.heads, a.layers, a.attention, a.map_token_features).to(a.device)
    if a.init:
        model.load_state_dict(torch.load(a.init, map_location=a.device)["model"])
    params = sum(p.numel() for p in model.parameters())
    opt = torch.optim.AdamW(model.parameters(), lr=a.lr, weight_decay=0.01)
    budget_s = a.minutes * 60
    warmup = 200
    t0 = time.time()
    best = math.inf
    log = open(os.path.join(a.out, "log.csv"), "w", newline="")
    w = csv.writer(log)
    w.writerow(["step", "samples", "train_loss", "held_out_nll", "held_out_top1", "held_out_top5", "elapsed_s", "lr"])
    best_path = os.path.join(a.out, "best.pt")
    if os.path.exists(best_path):
        os.remove(best_path)  # never report a previous run's checkpoint
    step, running, eval_s = 0, None, 0.0
    while True:
        elapsed = time.time() - t0
        progress = step / a.steps if a.steps else elapsed / budget_s
        lr = a.lr * min(1.0, (step + 1) / warmup) * 0.5 * (1 + math.cos(math.pi * min(progress, 1.0)))
        for g in opt.param_groups:
            g["lr"] = lr
        idx = torch.as_tensor(train_idx[cdf.searchsorted(rng.random(a.batch), side="right")], device=a.device)
        batch = drop_lateral_history(drop_map_features(batch_of(data, idx), a.map_feature_dropout),
                                     a.history_dropout)
        loss = token_loss(model(batch), data["next_token"][idx], a.label_smoothing,
                          a.label_smoothing_axis, spread)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        running = loss.item() if running is None else 0.98 * running + 0.02 * loss.item()
        step += 1
        elapsed = time.time() - t0
        last = (step >= a.steps) if a.steps else elapsed >= budget_s
        # Evaluate every `eval_every` steps and once more when the budget ends, so that
        # a short run still logs a row and the final weights compete for `best.pt`.
        if step % a.eval_every == 0 or last:
            te = time.time()
            ev = evaluate(model, data, probe)
            w.writerow([step, step * a.batch, f"{running:.4f}", f"{ev['nll']:.4f}", f"{ev['top1']:.4f}",
                        f"{ev['top5']:.4f}", f"{time.time() - t0:.0f}", f"{lr:.2e}"])
            log.flush()
            print(f"step {step} train {running:.3f} held-out nll {ev['nll']:.3f} top1 {ev['top1']:.3f} "
                  f"top5 {ev['top5']:.3f} ({time.time() - t0:.0f} s)", flush=True)
            if ev["nll"] < best:
                best = ev["nll"]
                state = {k: v.detach().cpu() for k, v in model.state_dict().items()}
                torch.save({"model": state, "args": vars(a), "step": step, "dataset": dataset}, best_path)
            eval_s += time.time() - te
        if last:
            break
    train_s = time.time() - t0
    if not os.path.exists(best_path):  # held-out NLL was never finite
        sys.exit(f"held-out NLL was not finite at any evaluation: no checkpoint written to {best_path}")
    ck = torch.load(best_path, map_location=a.device)
    model.load_state_dict(ck["model"])
    full = evaluate(model, data, held_idx)
    ng = evaluate(model, data, held_idx[ngsim[held_idx]]) if ngsim[held_idx].any() else None
    syn = evaluate(model, data, held_idx[~ngsim[held_idx]])
    summary = {
        "attention": a.attention, "params": params, "steps": step, "best_step": ck["step"],
        "samples_per_s": step * a.batch / train_s, "train_minutes": train_s / 60,
        "optimiser_samples_per_s": step * a.batch / max(train_s - eval_s, 1e-9),
        "held_out_nll": full["nll"], "held_out_top1": full["top1"], "held_out_top5": full["top5"],
        "held_out_samples": full["n"],
        "held_out_ngsim_nll": ng and ng["nll"], "held_out_ngsim_top1": ng and ng["top1"],
        "held_out_synthetic_nll": syn["nll"], "held_out_synthetic_top1": syn["top1"],
        "uniform_nll": math.log(3969), "device": a.device, "batch": a.batch,
        "purpose": dataset["purpose"], "recipe": dataset["recipe"],
        "label_smoothing": a.label_smoothing, "label_smoothing_axis": a.label_smoothing_axis,
        "label_smoothing_bins": a.label_smoothing_bins, "map_feature_dropout": a.map_feature_dropout,
        "history_dropout": a.history_dropout,
        "turn_only_lane_weight": a.turn_only_lane_weight,
        "turning_weight": a.turning_weight,
        "lane_change_weight": a.lane_change_weight,
        "vulnerable_ahead_weight": a.vulnerable_ahead_weight,
    }
    json.dump(summary, open(os.path.join(a.out, "summary.json"), "w"), indent=2)
    print(json.dumps(summary), flush=True)


if __name__ == "__main__":
    main()
