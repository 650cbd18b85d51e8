"""Train the feasibility value V_h offline (FREA / FISOR style) and export it.

    training/.venv/bin/python training/feasibility/train.py --data training/data/feasibility --out models

Data: transitions (s, a, h(s), s', done) written by `safer feasibility-dataset`
(h = -1 if the ego-CBV box distance > 0.3 m else M = 16), including the
witness branches (escapes found by the witness search from close states), so
that the expectile can learn escapes the collection's ego policies never drove.

Losses (FISOR, Zheng et al. 2024, eqs. for the feasible value; FREA uses the same):
  Q_h(s, a) regresses onto the reachability target
      y = (1 - gamma) h(s) + gamma * max(h(s), V_h'(s'))      (y = h(s) at episode end)
  with V_h' a slowly updated copy of V_h (Polyak 0.005);
  V_h(s) is the tau-expectile of Q_h(s, a) taken on the *lower* side,
      L_V = E[ |tau - 1(Q_h - V_h > 0)| (Q_h - V_h)^2 ],  tau = 0.8,
  so V_h tends to the best (smallest) Q_h among the ego actions in the data:
  the value of the best avoidance the ego policies showed. gamma = 0.99.

Calibration against the witness (`--calibration LABELS`): the expectile
can only be as good as the escapes the data shows, and on held-out states it
raised false alarms (states the witness search can escape from). With a file
of training-split states labelled by the witness search
(`safer feasibility-eval --split train --labels LABELS`), each step also
takes a class-balanced batch of them and adds a logistic loss on sign(V_h)
(weight --calibration-weight): V_h > 0 where the search finds no escape,
V_h <= 0 where it finds one. A fifth of the labelled states (every fifth
block of 100, so an episode's states stay together) is kept out of that
loss; on it the decision threshold is chosen: the highest precision of
"infeasible" at recall >= --target-recall. The exported graph subtracts that
threshold, so sign(V_h) stays the decision the adversary reads. The held-out
scenes are never used: `safer feasibility-eval` reports on them.
`--init RUN/v.pt` starts from an earlier run's V_h and Q_h (fine-tuning).

V_h <= 0: the ego can keep the CBV out of d_th; > 0: it cannot.
Writes models/feasibility-value.onnx (state [20, 13] -> value [20, 1]), its
card and golden file, training curves (training/runs/feasibility/log.csv and
docs/feasibility-training.svg).
"""
import argparse, copy, csv, hashlib, json, os, sys, time

import numpy as np
import onnx
import onnxruntime as ort
import torch
import torch.nn as nn
from safetensors import safe_open
from safetensors.numpy import save_file

FEATURES = 13
# Physical units in; fixed scales inside the graph.
SCALE = [20.0, 20.0, 1.0, 1.0, 10.0, 10.0, 10.0, 10.0, 5.0, 2.0, 5.0, 2.0, 10.0]


class Net(nn.Module):
    def __init__(self, inp, hidden=256):
        super().__init__()
        self.register_buffer("scale", torch.tensor(SCALE + [5.0, 1.5][: inp - FEATURES], dtype=torch.float32))
        self.net = nn.Sequential(nn.Linear(inp, hidden), nn.GELU(), nn.Linear(hidden, hidden), nn.GELU(),
                                 nn.Linear(hidden, 1))

    def forward(self, x):
        return self.net(x / self.scale)


def svg_curves(path, rows, keys, title):
    w, h, pad = 720, 300, 40
    xs = [r["epoch"] for r in rows]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h * len(keys)}" font-family="sans-serif" font-size="12">']
    for i, k in enumerate(keys):
        ys = [r[k] for r in rows]
        lo, hi = min(ys), max(ys)
        hi = hi if hi > lo else lo + 1
        pts = " ".join(f"{pad + (x - xs[0]) / max(1, xs[-1] - xs[0]) * (w - 2 * pad):.1f},"
                       f"{i * h + h - pad - (y - lo) / (hi - lo) * (h - 2 * pad):.1f}" for x, y in zip(xs, ys))
        out.append(f'<text x="{pad}" y="{i * h + 20}">{title}: {k} (min {lo:.4g}, max {hi:.4g}) vs epoch</text>')
        out.append(f'<rect x="{pad}" y="{i * h + pad}" width="{w - 2 * pad}" height="{h - 2 * pad}" fill="none" stroke="#ccc"/>')
        out.append(f'<polyline points="{pts}" fill="none" stroke="#1f77b4" stroke-width="2"/>')
    out.append("</svg>")
    open(path, "w").write("\n".join(out))


class Shifted(nn.Module):
    """V_h minus the calibrated decision threshold."""

    def __init__(self, v, threshold):
        super().__init__()
        self.v = v
        self.register_buffer("threshold", torch.tensor(float(threshold)))

    def forward(self, x):
        return self.v(x) - self.threshold


def load_calibration(path):
    """Witness-labelled states, split into the part the loss fits ("fit") and
    every fifth block of 100 states ("pick"), where the threshold is chosen.
    Label 1 = infeasible (the witness search found no escape)."""
    with safe_open(path, "np") as f:
        x = torch.from_numpy(f.get_tensor("state"))
        y = torch.from_numpy((f.get_tensor("witness_found") < 0.5).astype(np.float32))
        split = json.loads(f.metadata()["split"])
    assert split == "train", f"{path} labels the {split} split: calibrate on training states only"
    pick = (np.arange(len(y)) // 100) % 5 == 4
    fit = ~pick
    out = {"fit": (x[fit], y[fit]), "pick": (x[pick], y[pick])}
    fy = y[fit]
    out["fit_pos"], out["fit_neg"] = np.flatnonzero(fy.numpy() > 0.5), np.flatnonzero(fy.numpy() < 0.5)
    print(f"calibration states: {int(fit.sum())} fit ({len(out['fit_pos'])} infeasible), "
          f"{int(pick.sum())} pick ({int(y[pick].sum())} infeasible)", flush=True)
    return out


def calibration_loss(v, cal, n, rng):
    """Logistic loss on sign(V_h) over a class-balanced batch of n labelled states."""
    idx = np.concatenate([rng.choice(cal["fit_pos"], n // 2), rng.choice(cal["fit_neg"], n - n // 2)])
    x, y = cal["fit"][0][idx], cal["fit"][1][idx]
    # V_h is in units of h (-1 .. M): a unit of V_h is a decisive margin.
    return nn.functional.binary_cross_entropy_with_logits(4.0 * v(x).squeeze(-1), y)


def confusion(value, infeasible, threshold):
    """(precision, recall) of "infeasible" when value > threshold predicts it."""
    pred = value > threshold
    tp = int((pred & infeasible).sum())
    prec = tp / max(1, int(pred.sum()))
    rec = tp / max(1, int(infeasible.sum()))
    return prec, rec


def best_threshold(value, infeasible, target_recall):
    """The threshold with the highest precision among those with recall >=
    target_recall (the highest such threshold on ties), as (t, precision, recall)."""
    order = np.argsort(-value)
    tp = np.cumsum(infeasible[order])
    fp = np.cumsum(~infeasible[order])
    recall = tp / max(1, int(infeasible.sum()))
    precision = tp / np.maximum(1, tp + fp)
    best = None
    for k in range(len(order)):
        if recall[k] + 1e-12 < target_recall:
            continue
        # Predict infeasible for value >= value[order[k]]: threshold just below it.
        if k + 1 < len(order) and value[order[k + 1]] == value[order[k]]:
            continue
        if best is None or precision[k] > best[1]:
            t = float(value[order[k + 1]] + value[order[k]]) / 2 if k + 1 < len(order) else float(value[order[k]]) - 1e-3
            best = (t, float(precision[k]), float(recall[k]))
    return best if best is not None else (0.0, float("nan"), float("nan"))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default="training/data/feasibility")
    ap.add_argument("--out", default="models")
    ap.add_argument("--run", default="training/runs/feasibility")
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--batch", type=int, default=1024)
    ap.add_argument("--tau", type=float, default=0.8)
    ap.add_argument("--gamma", type=float, default=0.99)
    ap.add_argument("--lr", type=float, default=3e-4)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--calibration", help="witness-labelled training-split states (safer feasibility-eval --split train --labels)")
    ap.add_argument("--calibration-weight", type=float, default=1.0)
    ap.add_argument("--target-recall", type=float, default=0.9)
    ap.add_argument("--init", help="start from this run's v.pt (V_h and Q_h)")
    ap.add_argument("--curves", help="also draw the training curves here (e.g. docs/feasibility-training.svg)")
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(a.seed)
    rng = np.random.default_rng(a.seed)
    os.makedirs(a.run, exist_ok=True)
    path = os.path.join(a.data, "transitions.safetensors")
    with safe_open(path, "np") as f:
        d = {k: torch.from_numpy(f.get_tensor(k)) for k in ["state", "action", "cost", "next_state", "done", "scene"]}
        scenes = json.loads(f.metadata()["scenes"])
    held = np.array([scenes[i]["split"] == "held-out" for i in d["scene"].numpy()])
    tr, te = np.flatnonzero(~held), np.flatnonzero(held)
    print(f"transitions: {len(tr)} train, {len(te)} held out; violating {int((d['cost'] > 0).sum())}", flush=True)
    q = Net(FEATURES + 2)
    v = Net(FEATURES)
    if a.init:
        saved = torch.load(a.init)
        v.load_state_dict(saved["v"])
        q.load_state_dict(saved["q"])
    v_target = copy.deepcopy(v)
    cal = load_calibration(a.calibration) if a.calibration else None
    opt = torch.optim.Adam(list(q.parameters()) + list(v.parameters()), lr=a.lr)
    sa = torch.cat([d["state"], d["action"]], dim=1)
    rows = []
    t0 = time.time()

    def losses(idx):
        s, h, s2, done = d["state"][idx], d["cost"][idx], d["next_state"][idx], d["done"][idx]
        with torch.no_grad():
            v_next = v_target(s2).squeeze(-1)
            y = torch.where(done > 0, h, (1 - a.gamma) * h + a.gamma * torch.maximum(h, v_next))
        qv = q(sa[idx]).squeeze(-1)
        lq = ((qv - y) ** 2).mean()
        vv = v(s).squeeze(-1)
        u = qv.detach() - vv
        weight = torch.abs(a.tau - (u > 0).float())
        lv = (weight * u ** 2).mean()
        return lq, lv, vv

    # --epochs 0 with --init: no training, only the figures and the export
    # (e.g. to pick the threshold at another target recall).
    for epoch in range(0 if a.epochs == 0 else 1, a.epochs + 1):
        perm = rng.permutation(tr) if epoch > 0 else tr[:0]
        tot = [0.0, 0.0, 0]
        for i in range(0, len(perm), a.batch):
            idx = perm[i:i + a.batch]
            lq, lv, _ = losses(idx)
            loss = lq + lv
            if cal is not None:
                loss = loss + a.calibration_weight * calibration_loss(v, cal, len(idx), rng)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            with torch.no_grad():
                for p, pt in zip(v.parameters(), v_target.parameters()):
                    pt.mul_(0.995).add_(0.005 * p)
            tot[0] += lq.item() * len(idx)
            tot[1] += lv.item() * len(idx)
            tot[2] += len(idx)
        with torch.no_grad():
            lq_te, lv_te, v_te = losses(te)
            h_te = d["cost"][te]
            infeasible_now = (h_te > 0)
            row = {"epoch": epoch, "train_q_loss": tot[0] / max(1, tot[2]), "train_v_loss": tot[1] / max(1, tot[2]),
                   "held_out_q_loss": lq_te.item(), "held_out_v_loss": lv_te.item(), "mean_v": v_te.mean().item(),
                   "share_v_positive": (v_te > 0).float().mean().item(),
                   "v_positive_on_violations": (v_te[infeasible_now] > 0).float().mean().item() if infeasible_now.any() else float("nan"),
                   "elapsed_s": time.time() - t0}
            if cal is not None:
                for part in ["fit", "pick"]:
                    value = v(cal[part][0]).squeeze(-1).numpy()
                    t, prec, rec = best_threshold(value, cal[part][1].numpy() > 0.5, a.target_recall)
                    at0 = confusion(value, cal[part][1].numpy() > 0.5, 0.0)
                    row[f"{part}_precision_at_0"], row[f"{part}_recall_at_0"] = at0
                    row[f"{part}_best_precision"] = prec
        rows.append(row)
        print(json.dumps(row), flush=True)
    with open(os.path.join(a.run, "log.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    for curves in [os.path.join(a.run, "training-curves.svg")] + ([a.curves] if a.curves else []):
        os.makedirs(os.path.dirname(curves) or ".", exist_ok=True)
        svg_curves(curves, rows, ["train_q_loss", "train_v_loss", "mean_v"], "V_h training")
    torch.save({"v": v.state_dict(), "q": q.state_dict(), "args": vars(a)}, os.path.join(a.run, "v.pt"))

    # The decision threshold, picked on the calibration states kept out of
    # the loss, is folded into the graph: sign(V_h) stays the decision.
    threshold = 0.0
    if cal is not None:
        with torch.no_grad():
            value = v(cal["pick"][0]).squeeze(-1).numpy()
        threshold, prec, rec = best_threshold(value, cal["pick"][1].numpy() > 0.5, a.target_recall)
        print(json.dumps({"threshold": threshold, "pick_precision": prec, "pick_recall": rec}), flush=True)
    v = Shifted(v, threshold)
    # Export V_h: fixed batch 20.
    v.eval()
    os.makedirs(a.out, exist_ok=True)
    onnx_path = os.path.join(a.out, "feasibility-value.onnx")
    golden_idx = te[np.linspace(0, len(te) - 1, 20).astype(int)]
    x = d["state"][golden_idx]
    with torch.no_grad():
        y = v(x)
    torch.onnx.export(v, (x,), onnx_path, input_names=["state"], output_names=["value"], opset_version=17, dynamo=False)
    onnx.checker.check_model(onnx.load(onnx_path))
    got = ort.InferenceSession(onnx_path, providers=["CPUExecutionProvider"]).run(None, {"state": x.numpy()})[0]
    assert np.isfinite(got).all()
    diff = float(np.abs(got - y.numpy()).max())
    save_file({"input.state": x.numpy(), "output.value": y.numpy()}, os.path.join(a.out, "feasibility-value.golden.safetensors"))
    last = rows[-1]
    sha = hashlib.sha256(open(onnx_path, "rb").read()).hexdigest()
    meaning_state = ("ego-frame ego-CBV state: CBV x_m, y_m, cos dh, sin dh, ego speed_mps, CBV speed_mps, "
                     "CBV vx_mps, vy_mps (ego frame), ego length_m, width_m, CBV length_m, width_m, box distance_m")
    calibrated = ""
    calibration_metrics = ""
    command = f"training/.venv/bin/python training/feasibility/train.py --epochs {a.epochs}"
    if cal is not None:
        calibrated = (f" Calibrated against the witness: a logistic loss on sign(V_h) over class-balanced batches of "
                      f"{len(cal['fit'][1])} witness-labelled training-split states (weight {a.calibration_weight}); "
                      f"the decision threshold {threshold:.4g}, the best precision at recall >= {a.target_recall} on "
                      f"{len(cal['pick'][1])} labelled states kept out of the loss, is subtracted in the graph.")
        calibration_metrics = (f"  calibration_threshold: {threshold:.6g}\n  calibration_pick_precision: {prec:.6g}\n"
                               f"  calibration_pick_recall: {rec:.6g}\n")
        base = (f"training/.venv/bin/python training/feasibility/train.py --epochs 30 --run {os.path.dirname(a.init)} && "
                if a.init else "")
        command = (f"{base}cargo run --release -- feasibility-eval --split train --states 1000000 --labels "
                   f"{a.calibration} && {command} --calibration {a.calibration} --calibration-weight "
                   f"{a.calibration_weight} --target-recall {a.target_recall} --run {a.run}"
                   + (f" --init {a.init}" if a.init else ""))
        calibration_metrics += f"  held_out_mean_v_after_threshold: {last['mean_v'] - threshold:.6g}\n"
    card = f"""# Model card (contract version 1): see src/models/card.rs and src/models/feasibility.rs.
contract_version: 1
name: feasibility-value
kind: feasibility-value
file: feasibility-value.onnx
sha256: "{sha}"
opset: 17
inputs:
  - {{name: state, dtype: f32, shape: [20, 13], meaning: "{meaning_state}"}}
outputs:
  - {{name: value, dtype: f32, shape: [20, 1], meaning: "V_h: <= 0 the ego can still keep the CBV beyond d_th = 0.3 m; > 0 it cannot"}}
normalisation: "Physical units in; the graph divides by fixed scales (positions /20 m, speeds and velocities /10 m/s, lengths /5 m, widths /2 m, box distance /10 m)."
architecture: "MLP 13 -> 256 -> 256 -> 1 (GELU); trained with a Q_h(s, a) MLP of the same size. Offline RL on transitions: Q_h regresses onto (1 - gamma) h(s) + gamma max(h(s), V_h'(s')), V_h is the lower tau-expectile of Q_h (tau = {a.tau}, gamma = {a.gamma}, Polyak 0.005 target), h = -1 / M = 16 at d_th = 0.3 m.{calibrated}"
training:
  data:
    - "closed-loop rollouts from `safer feasibility-dataset`: NGSIM scenes (US public domain) and synthetic traffic, ego = IDM / evasive / constant velocity, CBV = aggressive pursuit (3 random aim styles), IDM, constant velocity, SaFeR adversary without the feasibility constraint"
    - "witness branches: from states of those rollouts with the CBV within 10 m, the witness search's escape (every agent replaying the rollout, 4 s, margin d_th), up to 4 per episode, agents within 60 m as obstacles"
    - "not trained on Waymo or Argoverse data (non-commercial licences)"
  licence: "US public domain (NGSIM) + project (synthetic)"
  command: "cargo run --release -- feasibility-dataset && {command}"
metrics:
  # held_out_*: the transitions of held-out scenes, V_h before any threshold.
  held_out_q_loss: {last['held_out_q_loss']:.6g}
  held_out_v_loss: {last['held_out_v_loss']:.6g}
  held_out_mean_v: {last['mean_v']:.6g}
  held_out_share_v_positive: {last['share_v_positive']:.6g}
  held_out_v_positive_on_violations: {last['v_positive_on_violations']:.6g}
  held_out_transitions: {len(te)}
  train_transitions: {len(tr)}
  onnxruntime_vs_torch_max_abs_diff: {diff:.3g}
{calibration_metrics}golden: feasibility-value.golden.safetensors
golden_tolerance: 1.0e-4
"""
    open(os.path.join(a.out, "feasibility-value.card.yaml"), "w").write(card)
    print(json.dumps({"onnx": onnx_path, "ort_vs_torch": diff, **last}))


if __name__ == "__main__":
    main()
