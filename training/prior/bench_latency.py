"""Reference latency of the prior's decoder, for `safer bench-models`.

    training/.venv/bin/python training/prior/bench_latency.py --models models --batches 1,64 --repeat 200

Times the shipped decoder ONNX graph in onnxruntime (one intra-op thread) and
the same weights in PyTorch eager (one thread; the checkpoint named in the
card's training command), on the golden inputs tiled to each batch size.
Prints one JSON line: {"onnxruntime": {"1": µs, ...}, "torch": {...}}, with
"torch_missing_because" instead of torch figures when the checkpoint is not
on this machine (training/runs/ is not part of the repository).
"""
import argparse, json, os, re, sys, time

import numpy as np
import onnxruntime as ort
import torch
from safetensors.numpy import load_file

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from model import Prior  # noqa: E402

NAMES = ["history", "agent_self", "neighbours", "neighbour_pose", "neighbour_mask",
         "map_embedding", "map_pose", "map_signal", "map_mask"]


def median_us(f, repeat):
    f()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return float(np.median(times) * 1e6)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", default="models")
    ap.add_argument("--name", default="prior-decoder")
    ap.add_argument("--batches", default="1,64")
    ap.add_argument("--repeat", type=int, default=200)
    a = ap.parse_args()
    torch.set_num_threads(1)
    golden = load_file(os.path.join(a.models, a.name + ".golden.safetensors"))
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1
    opts.inter_op_num_threads = 1
    sess = ort.InferenceSession(os.path.join(a.models, a.name + ".onnx"), opts, providers=["CPUExecutionProvider"])
    card = open(os.path.join(a.models, a.name + ".card.yaml")).read()
    run = re.search(r"train\.py[^&]*--out (\S+)", card)  # the run folder in the card's training command
    model = None
    torch_missing = None
    if not run:
        torch_missing = "the card's training command names no run folder"
    elif not os.path.exists(os.path.join(run.group(1), "best.pt")):
        torch_missing = f"no checkpoint {os.path.join(run.group(1), 'best.pt')} on this machine (training/runs/ is not kept)"
    else:
        ck = torch.load(os.path.join(run.group(1), "best.pt"))
        args = ck["args"]
        model = Prior(args["d"], args["heads"], args["layers"], args["attention"], args.get("map_token_features", 7))
        model.load_state_dict(ck["model"])
        model.eval()
    out = {"onnxruntime": {}, "torch": {}}
    if torch_missing:
        out["torch_missing_because"] = torch_missing
    for b in [int(x) for x in a.batches.split(",")]:
        feeds = {}
        for n in NAMES:
            g = golden["input." + n]
            reps = -(-b // g.shape[0])
            feeds[n] = np.concatenate([g] * reps)[:b]
        out["onnxruntime"][str(b)] = median_us(lambda: sess.run(None, feeds), a.repeat)
        if model is not None:
            xs = [torch.from_numpy(feeds[n]) for n in NAMES]
            with torch.no_grad():
                out["torch"][str(b)] = median_us(lambda: model.decoder(*xs), a.repeat)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
