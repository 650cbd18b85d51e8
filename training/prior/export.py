"""Export a trained prior to ONNX for tract, with model cards and golden files.

    training/.venv/bin/python training/prior/export.py --run training/runs/prior-mda --out models

Writes `prior-map-encoder[-plain].onnx` (map_tokens [256, 7] -> map_embedding
[256, D]) and `prior-decoder[-plain].onnx` (the contract's query tensors with a
symbolic batch -> logits [batch, 3969]; the decoder as its inference graph,
inference_graph.py, which tract runs about 3x faster at batch 32 than the
training formulation) with the TorchScript exporter at opset
17 and fixed feature shapes, checks them with onnx.checker and onnxruntime
against PyTorch (NaN fails), and writes a golden file of 4 real held-out
queries plus a model card (contract version 1) beside each.

The card's training-data lines come from the shards: a run trained or checked
on `make_random_shards.py` output is labelled as random, and writing it into
the repository's `models/` folder is refused.

    training/.venv/bin/python training/prior/export.py --run /tmp/prior-smoke-runs/mda \
        --data /tmp/prior-smoke --out /tmp/prior-smoke-models     # smoke test
"""
import argparse, datetime, glob, hashlib, json, os, sys

import numpy as np
import onnx
import onnxruntime as ort
import torch
from safetensors import safe_open
from safetensors.numpy import save_file

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from inference_graph import InferenceDecoder  # noqa: E402
from model import Prior  # noqa: E402
from train import KEYS, load_shards  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEC_INPUTS = ["history", "agent_self", "neighbours", "neighbour_pose", "neighbour_mask",
              "map_embedding", "map_pose", "map_signal", "map_mask"]
# train.py flags that change the model, with their defaults: the card's command names those that differ.
RECIPE_DEFAULTS = {"d": 64, "heads": 8, "layers": 3, "seed": 0, "ngsim_weight": 3.0, "map_feature_dropout": 0.0,
                   "turning_weight": 1.0, "vulnerable_ahead_weight": 1.0, "map_token_features": 7,
                   "turn_only_lane_weight": 1.0, "lane_change_weight": 1.0}
MEANING = {
    "history": "6 history points (t-2.5 s .. t) in the agent's frame: x_m, y_m, cos dh, sin dh, speed_mps, accel_mps2, yaw_rate_radps, valid",
    "agent_self": "length_m, width_m, kind one-hot (vehicle, pedestrian, cyclist, other)",
    "neighbours": "16 nearest agents within 50 m: speed_mps, vx_mps, vy_mps (query frame), length_m, width_m, kind one-hot, dx_m, dy_m over the last 0.5 s, prev_valid",
    "neighbour_pose": "relative pose d_ij: x_m, y_m, distance_m, cos dh, sin dh",
    "neighbour_mask": "1 = neighbour, 0 = padding",
    "map_embedding": "rows of the map encoder's output for the 48 nearest map tokens within 60 m (zeros = padding)",
    "map_pose": "relative pose of each map token: midpoint x_m, y_m, distance_m, cos, sin of its direction vs the query heading",
    "map_signal": "signal state of the token's lane: stop, caution, go, none (one-hot)",
    "map_mask": "1 = map token, 0 = padding",
    "map_tokens": "pose-free map token features: kind one-hot (lane centreline, road edge, road line, other), length_m, in_intersection, speed_limit_mps (0 = unknown)",
    "map_tokens_turn_ahead": "pose-free map token features: kind one-hot (lane centreline, road edge, road line, other), length_m, in_intersection, speed_limit_mps (0 = unknown), then for lane tokens the turn ahead along the lane graph over 40 m: rightmost_rad, leftmost_rad (heading change, left positive), reach_m (0 for other tokens)",
}


def sha256(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


def check_ort(path, feeds, expected):
    sess = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    got = sess.run(None, feeds)[0]
    if not np.isfinite(got).all():
        sys.exit(f"{path}: onnxruntime produced NaN/inf")
    return float(np.abs(got - expected).max())


def yaml_str(s):
    return json.dumps(s, ensure_ascii=False)


REAL_DATA = [
    "NGSIM US-101, Lankershim and Peachtree (CommonRoad 2020a conversion, ../shared/data/commonroad-ngsim, 84 scenes)",
    "synthetic traffic from `safer prior-dataset`: IDM drivers calibrated to the NGSIM speeds, on procedural "
    "straight roads, merges and crossings and on the NGSIM maps",
    "not trained on Waymo or Argoverse data (non-commercial licences; used for evaluation only)",
]
REAL_LICENCE = "US public domain (NGSIM) + project (synthetic)"
EVALUATION_ONLY_DATA = [
    "EVALUATION ONLY: recorded scenes under a non-commercial licence (Waymo / Argoverse) plus synthetic traffic; "
    "measured beside the shipped prior, never committed or shipped",
]
EVALUATION_ONLY_LICENCE = "non-commercial (evaluation only): never commit or ship"
RANDOM_DATA = ["RANDOM smoke-test shards from training/prior/make_random_shards.py: not a usable model, never ship it"]
RANDOM_LICENCE = "none (random data, smoke test only)"


def shards_are_random(files):
    """True when any shard was written by make_random_shards.py (its `generator` metadata key)."""
    for f in files:
        with safe_open(f, "np") as st:
            if "make_random_shards" in (st.metadata() or {}).get("generator", ""):
                return True
    return False


def write_card(path, *, name, kind, inputs, outputs, tokens, summary, args, golden, tolerance, command, arch,
               data_lines, licence):
    lines = [
        "# Model card (contract version 1): see src/models/card.rs and docs/prior-features.md.",
        "contract_version: 1",
        f"name: {name}",
        f"kind: {kind}",
        f"file: {name}.onnx",
        f"sha256: \"{sha256(os.path.join(os.path.dirname(path), name + '.onnx'))}\"",
        "opset: 17",
        "inputs:",
    ]
    for n, shape in inputs:
        meaning = MEANING["map_tokens_turn_ahead"] if n == "map_tokens" and shape[-1] == 10 else MEANING[n]
        lines.append(f"  - {{name: {n}, dtype: f32, shape: [{', '.join(map(str, shape))}], meaning: {yaml_str(meaning)}}}")
    lines.append("outputs:")
    for n, shape, meaning in outputs:
        lines.append(f"  - {{name: {n}, dtype: f32, shape: [{', '.join(map(str, shape))}], meaning: {yaml_str(meaning)}}}")
    lines.append("normalisation: " + yaml_str(
        "Inputs in physical units (m, m/s, m/s^2, rad, rad/s); the graph divides by fixed constants "
        "(positions /20 m, distances /50 m, speeds /10 m/s, accelerations /5, yaw rates /1.5, sizes /5 m, "
        "map token length /8 m, speed limit /30 m/s; in the decoder the neighbour and pose divisions are folded "
        "into the weights of the first layers that read them). Logits are unnormalised; softmax gives P(token)."))
    lines.append("architecture: " + yaml_str(arch))
    if tokens:
        lines += ["token_grid: {bins_per_axis: 63, max_accel_mps2: 5.0, max_yaw_rate_radps: 1.5}", "token_period_s: 0.5"]
    lines += [
        "training:",
        "  data:",
    ]
    lines += ["    - " + yaml_str(x) for x in data_lines]
    lines += [
        "  licence: " + yaml_str(licence),
        "  command: " + yaml_str(command),
        "metrics:",
    ]
    for k in ["held_out_nll", "held_out_top1", "held_out_top5", "held_out_ngsim_nll", "held_out_ngsim_top1",
              "held_out_synthetic_nll", "held_out_synthetic_top1", "uniform_nll", "params", "steps", "samples_per_s",
              "train_minutes", "held_out_samples"]:
        if summary.get(k) is not None:
            lines.append(f"  {k}: {float(summary[k]):.6g}")
    lines += [f"golden: {golden}", f"golden_tolerance: {tolerance}"]
    open(path, "w").write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--run", required=True)
    ap.add_argument("--data", default="training/data/prior")
    ap.add_argument("--out", default="models")
    ap.add_argument("--train-data", help="the shards' folder named in the card's command, when training ran on "
                    "another machine (default: the folder the run trained on)")
    a = ap.parse_args()
    torch.set_num_threads(1)
    ck = torch.load(os.path.join(a.run, "best.pt"), map_location="cpu")
    args = ck["args"]
    summary = json.load(open(os.path.join(a.run, "summary.json")))
    width = args.get("map_token_features", 7)
    model = Prior(args["d"], args["heads"], args["layers"], args["attention"], width)
    model.load_state_dict(ck["model"])
    model.eval()
    suffix = "" if args["attention"] == "differential" else "-plain"
    enc_name, dec_name = f"prior-map-encoder{suffix}", f"prior-decoder{suffix}"
    d = args["d"]
    os.makedirs(a.out, exist_ok=True)
    train_data = a.train_data or args.get("data", a.data)
    budget = f"--steps {args['steps']}" if args.get("steps") else f"--minutes {args['minutes']}"
    dataset = ck.get("dataset", {"purpose": "shipped", "recipe": ""})
    data_arguments = dataset["arguments"] + " " if dataset.get("arguments") else ""
    command = (f"cargo run --release -- prior-dataset {data_arguments}--out {train_data} && training/.venv/bin/python "
               f"training/prior/train.py --data {train_data} --attention {args['attention']} {budget} "
               f"--threads {args['threads']} --batch {args['batch']} --lr {args['lr']} "
               f"--device {args.get('device', 'cpu')} "
               + (f"--label-smoothing {args['label_smoothing']} --label-smoothing-axis "
                  f"{args['label_smoothing_axis']} --label-smoothing-bins {args['label_smoothing_bins']} "
                  if args.get("label_smoothing") else "")
               + "".join(f"--{flag.replace('_', '-')} {args[flag]} " for flag, default in RECIPE_DEFAULTS.items()
                         if args.get(flag, default) != default)
               + f"--out {a.run} && "
               f"training/.venv/bin/python training/prior/export.py --run {a.run} --data {a.data} --out {a.out}")
    arch = (f"{args['attention']} attention; D = {d}, H = {args['heads']} heads, L = {args['layers']} layers of "
            f"temporal / agent-agent / agent-map attention for the query token, pre-LayerNorm, FFN 2D; "
            f"{summary['params']} parameters, trained at {summary['samples_per_s']:.0f} samples/s on "
            f"{'one GPU' if summary.get('device', 'cpu').startswith('cuda') else str(args['threads']) + ' CPU thread(s)'} "
            f"({summary['train_minutes']:.1f} min budget). D = {d} so that tract answers a CBV query in well under a "
            f"millisecond; see docs/prior-features.md. Exported as the inference graph of "
            f"training/prior/inference_graph.py: the same weights, with each attention written as products with "
            f"constant matrices (query folded into the key weights, value projection after the weighted sum, no "
            f"per-head einsums), which tract runs about 3x faster at batch 32.")

    # Real held-out queries for the goldens.
    data, held, _, files = load_shards(a.data, held_out_only=True, map_token_features=width)
    train_files = sorted(glob.glob(os.path.join(train_data, "shard-*.safetensors")))
    random = shards_are_random(files + train_files)
    if random and os.path.realpath(a.out) == os.path.realpath(os.path.join(REPO, "models")):
        sys.exit("refusing to write a model trained or checked on random smoke-test shards into models/")
    evaluation_only = dataset["purpose"] == "evaluation-only"
    into_models = os.path.realpath(a.out) == os.path.realpath(os.path.join(REPO, "models"))
    if evaluation_only and into_models:
        sys.exit("refusing to write an evaluation-only model (trained on non-commercial data) into models/")
    data_lines, licence = (RANDOM_DATA, RANDOM_LICENCE) if random else (REAL_DATA, REAL_LICENCE)
    if evaluation_only:
        data_lines, licence = EVALUATION_ONLY_DATA, EVALUATION_ONLY_LICENCE
    if dataset["recipe"]:
        data_lines = data_lines + ["recipe: " + dataset["recipe"]]
    if random:
        command = command.replace(f"cargo run --release -- prior-dataset {data_arguments}--out {train_data}",
                                  f"training/.venv/bin/python training/prior/make_random_shards.py --out {train_data}")
    held_idx = np.flatnonzero(held)
    if len(held_idx) == 0:
        sys.exit(f"{a.data}: no held-out samples for the golden files")
    # Fixed picks spread over the held-out set (modulo its size for small smoke data).
    idx = held_idx[[p % len(held_idx) for p in (0, 101, 2002, 30003)]]
    batch = {k: data[k][idx] for k in KEYS}

    with torch.no_grad():
        # Map encoder: a chunk of 256 map tokens from the golden queries.
        many = held_idx[:8]
        tok = data["map_tokens"][many].reshape(-1, width)[:256]
        emb = model.map_encoder(tok)
        enc_path = os.path.join(a.out, enc_name + ".onnx")
        torch.onnx.export(model.map_encoder, (tok,), enc_path, input_names=["map_tokens"],
                          output_names=["map_embedding"], opset_version=17, dynamo=False)
        onnx.checker.check_model(onnx.load(enc_path))
        diff_enc = check_ort(enc_path, {"map_tokens": tok.numpy()}, emb.numpy())
        save_file({"input.map_tokens": tok.numpy(), "output.map_embedding": emb.numpy()},
                  os.path.join(a.out, enc_name + ".golden.safetensors"))

        dec_in = [batch["history"], batch["agent_self"], batch["neighbours"], batch["neighbour_pose"],
                  batch["neighbour_mask"], model.map_encoder(batch["map_tokens"]) * batch["map_mask"][..., None],
                  batch["map_pose"], batch["map_signal"], batch["map_mask"]]
        logits = model.decoder(*dec_in)
        inference = InferenceDecoder(model.decoder).eval()
        rewrite_diff = float((inference(*dec_in) - logits).abs().max())
        if not rewrite_diff <= 1e-3:
            sys.exit(f"the inference graph differs from the trained decoder by {rewrite_diff}")
        dec_path = os.path.join(a.out, dec_name + ".onnx")
        torch.onnx.export(inference, tuple(dec_in), dec_path, input_names=DEC_INPUTS, output_names=["logits"],
                          dynamic_axes={n: {0: "batch"} for n in DEC_INPUTS + ["logits"]}, opset_version=17,
                          dynamo=False)
        onnx.checker.check_model(onnx.load(dec_path))
        diff_dec = check_ort(dec_path, {n: t.numpy() for n, t in zip(DEC_INPUTS, dec_in)}, logits.numpy())
        golden = {f"input.{n}": t.numpy() for n, t in zip(DEC_INPUTS, dec_in)}
        golden["output.logits"] = logits.numpy()
        save_file(golden, os.path.join(a.out, dec_name + ".golden.safetensors"))

    write_card(os.path.join(a.out, enc_name + ".card.yaml"), name=enc_name, kind="realism-prior-map-encoder",
               inputs=[("map_tokens", [256, width])], outputs=[("map_embedding", [256, d], f"{d}-wide embedding per map token")],
               tokens=False, summary=summary, args=args, golden=enc_name + ".golden.safetensors", tolerance="1.0e-4",
               command=command, arch=arch, data_lines=data_lines, licence=licence)
    shapes = {"history": ["batch", 6, 8], "agent_self": ["batch", 6], "neighbours": ["batch", 16, 12],
              "neighbour_pose": ["batch", 16, 5], "neighbour_mask": ["batch", 16], "map_embedding": ["batch", 48, d],
              "map_pose": ["batch", 48, 5], "map_signal": ["batch", 48, 4], "map_mask": ["batch", 48]}
    write_card(os.path.join(a.out, dec_name + ".card.yaml"), name=dec_name, kind="realism-prior-decoder",
               inputs=[(n, shapes[n]) for n in DEC_INPUTS],
               outputs=[("logits", ["batch", 3969], "unnormalised log-probability of each next token (id = i_accel * 63 + i_yaw_rate)")],
               tokens=True, summary=summary, args=args, golden=dec_name + ".golden.safetensors", tolerance="1.0e-3",
               command=command, arch=arch, data_lines=data_lines, licence=licence)
    print(json.dumps({"map_encoder": enc_path, "decoder": dec_path, "ort_vs_torch_max_abs_diff":
                      {"map_encoder": diff_enc, "decoder": diff_dec},
                      "inference_graph_vs_trained_decoder_max_abs_diff": rewrite_diff}))


if __name__ == "__main__":
    main()
