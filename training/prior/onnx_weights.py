"""Recover a trained `Decoder`'s weights from a shipped decoder ONNX file.

The checkpoints behind `models/prior-decoder[-plain].onnx` are not kept in the
repository (training/runs/ is ignored); the ONNX files are the artifacts of
record. The TorchScript exporter keeps every module's scope in the node names
(`/decoder/blocks.0/map/k/MatMul`) and names most initializers after the
state-dict keys, so the weights can be read back exactly:

- named initializers (`decoder.x0.0.weight`, LayerNorm, biases, `norm_w`,
  `time_emb`) are state-dict entries as they are;
- a bias-free `Linear` or the first matmul of a biased one became a `MatMul`
  whose weight initializer (`onnx::MatMul_N`) holds the transposed weight;
- `null` rows became the two `Expand` constants of `/decoder/Expand[_1]`;
- the differential-attention λ parameters were constant-folded to the
  products `lq1 * lk1` and `lq2 * lk2` (inputs of `ReduceSum_1` / `_2`); only
  their sums enter the graph, so `lq = product, lk = 1` is the same model.

`decoder_from_onnx` rebuilds the `Decoder` and `check_against_golden` proves
the recovery by replaying the model's golden file.
"""
import os
import re
import sys

import numpy as np
import onnx
import torch
from onnx import numpy_helper

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from model import Decoder  # noqa: E402

DEC_INPUTS = ["history", "agent_self", "neighbours", "neighbour_pose", "neighbour_mask",
              "map_embedding", "map_pose", "map_signal", "map_mask"]

_MATMUL = re.compile(r"^/decoder/(.+)/MatMul$")
_LAMBDA = re.compile(r"^/decoder/(blocks\.\d+/(?:temporal|agents|map))/ReduceSum_([12])$")


def _module_key(scope):
    """`/decoder/blocks.0/map/k` scope -> `decoder.blocks.0.map.k`; `hist_emb/hist_emb.0` -> `hist_emb.0`."""
    parts = scope.split("/")
    # Sequential children repeat the parent's name: hist_emb/hist_emb.0 -> hist_emb.0
    out = []
    for p in parts:
        if out and p.startswith(out[-1] + "."):
            out[-1] = p
        else:
            out.append(p)
    return "decoder." + ".".join(out)


def decoder_from_onnx(path, heads):
    """The `Decoder` (eval mode) with `heads` heads whose exported graph is `path` (as export.py wrote it
    before it exported the inference graph), and its hyper-parameters."""
    m = onnx.load(path)
    init = {i.name: numpy_helper.to_array(i) for i in m.graph.initializer}
    state = {k: v for k, v in init.items() if k.startswith("decoder.")}
    lambdas = {}
    for n in m.graph.node:
        consts = [x for x in n.input if x.startswith("onnx::") and x in init]
        mm = _MATMUL.match(n.name)
        if mm and n.op_type == "MatMul" and consts:
            state[_module_key(mm.group(1)) + ".weight"] = init[consts[0]].T
        elif n.op_type == "Expand" and n.name in ("/decoder/Expand", "/decoder/Expand_1") and consts:
            lambdas.setdefault("null", {})[n.name] = init[consts[0]]
        lm = _LAMBDA.match(n.name)
        if lm and consts:
            lambdas[(lm.group(1), lm.group(2))] = init[consts[0]]
    if "null" not in lambdas or not any(n.name.endswith("/q/MatMul") for n in m.graph.node):
        raise SystemExit(f"{path}: not a decoder in the trained formulation (already an inference graph?); "
                         "recover the weights from the export of the trained model")
    null = lambdas.pop("null")
    state["decoder.null"] = np.stack([null["/decoder/Expand"], null["/decoder/Expand_1"]])
    attention = "differential" if any(k.endswith(".norm_w") for k in state) else "plain"
    d = state["decoder.x0.2.weight"].shape[0]
    layers = 1 + max(int(k.split(".")[2]) for k in state if k.startswith("decoder.blocks."))
    for (scope, which), prod in lambdas.items():
        key = "decoder." + scope.replace("/", ".")
        state[f"{key}.lq{which}"] = prod
        state[f"{key}.lk{which}"] = np.ones_like(prod)
    state = {k[len("decoder."):]: v for k, v in state.items()}
    dec = Decoder(d, heads, layers, attention)
    missing = set(dec.state_dict()) - set(state)
    extra = set(state) - set(dec.state_dict())
    if missing or extra:
        raise SystemExit(f"{path}: could not map weights (missing {sorted(missing)}, unexpected {sorted(extra)})")
    dec.load_state_dict({k: torch.from_numpy(np.array(v, dtype=np.float32)) for k, v in state.items()})
    dec.eval()
    return dec, {"d": d, "heads": heads, "layers": layers, "attention": attention}


def heads_from_card(card_text, card_path):
    """The head count H a model card's architecture line states (`H = 8 heads`)."""
    found = re.search(r"H = (\d+) heads", card_text)
    if not found:
        raise SystemExit(f"{card_path}: the card does not say the head count (`H = N heads`)")
    return int(found.group(1))


def golden_inputs(golden):
    """The decoder inputs of a golden file, as torch tensors in contract order."""
    return [torch.from_numpy(golden["input." + n]) for n in DEC_INPUTS]


def check_against_golden(module, golden, tolerance):
    """Max |logits - golden| of `module` on the golden inputs; exits when over `tolerance` or not finite."""
    with torch.no_grad():
        got = module(*golden_inputs(golden)).numpy()
    want = golden["output.logits"]
    if not np.isfinite(got).all():
        raise SystemExit("recovered decoder produced NaN/inf on the golden inputs")
    diff = float(np.abs(got - want).max())
    if diff > tolerance:
        raise SystemExit(f"recovered decoder differs from the golden by {diff} > {tolerance}")
    return diff
