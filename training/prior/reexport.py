"""Re-export a trained prior decoder as its tract-friendly inference graph.

    git show 25206ef:models/prior-decoder.onnx > /tmp/prior-decoder.trained.onnx
    training/.venv/bin/python training/prior/reexport.py --trained /tmp/prior-decoder.trained.onnx \
        --models models --name prior-decoder

(and the same with `prior-decoder-plain`). Commit 25206ef holds the decoders
as export.py first wrote them, in the training formulation of model.py. Their
checkpoints are not kept (training/runs/ is ignored), so this reads the
weights back from that ONNX file (onnx_weights.py), checks the recovered
`Decoder` against the golden file,
rewrites it as `inference_graph.InferenceDecoder` (same weights, same
arithmetic up to float rounding), exports that at opset 17, checks it in
onnxruntime against the golden file (NaN fails), and rewrites the card's
sha256. The golden file itself is not touched: the new graph must reproduce
the outputs the trained model gave. `--out DIR` writes to another folder
(with copies of the card and golden) instead of replacing the files in place.
"""
import argparse, hashlib, json, os, re, shutil, sys

import numpy as np
import onnx
import onnxruntime as ort
import torch
from safetensors.numpy import load_file

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from inference_graph import InferenceDecoder  # noqa: E402
from onnx_weights import DEC_INPUTS, check_against_golden, decoder_from_onnx, golden_inputs, heads_from_card  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trained", required=True, help="the decoder ONNX file in the training formulation")
    ap.add_argument("--models", default="models")
    ap.add_argument("--name", default="prior-decoder")
    ap.add_argument("--out", help="folder for the re-exported graph, card and golden (default: in place)")
    a = ap.parse_args()
    torch.set_num_threads(1)
    src = os.path.join(a.models, a.name)
    card = open(src + ".card.yaml").read()
    tolerance = float(re.search(r"^golden_tolerance: (\S+)$", card, re.M).group(1))
    golden = load_file(src + ".golden.safetensors")
    dec, hp = decoder_from_onnx(a.trained, heads_from_card(card, src + ".card.yaml"))
    recovered = check_against_golden(dec, golden, tolerance)
    fast = InferenceDecoder(dec).eval()
    rewritten = check_against_golden(fast, golden, tolerance)

    out_dir = a.out or a.models
    os.makedirs(out_dir, exist_ok=True)
    dst = os.path.join(out_dir, a.name)
    tmp = dst + ".onnx.tmp"
    with torch.no_grad():
        torch.onnx.export(fast, tuple(golden_inputs(golden)), tmp, input_names=DEC_INPUTS, output_names=["logits"],
                          dynamic_axes={n: {0: "batch"} for n in DEC_INPUTS + ["logits"]}, opset_version=17,
                          dynamo=False)
    onnx.checker.check_model(onnx.load(tmp))
    sess = ort.InferenceSession(tmp, providers=["CPUExecutionProvider"])
    got = sess.run(None, {n: golden["input." + n] for n in DEC_INPUTS})[0]
    if not np.isfinite(got).all():
        sys.exit(f"{tmp}: onnxruntime produced NaN/inf")
    exported = float(np.abs(got - golden["output.logits"]).max())
    if exported > tolerance:
        sys.exit(f"{tmp}: differs from the golden by {exported} > {tolerance}")
    os.replace(tmp, dst + ".onnx")
    digest = hashlib.sha256(open(dst + ".onnx", "rb").read()).hexdigest()
    card = re.sub(r'^sha256: "[0-9a-f]+"$', f'sha256: "{digest}"', card, flags=re.M)
    open(dst + ".card.yaml", "w").write(card)
    if a.out:
        shutil.copyfile(src + ".golden.safetensors", dst + ".golden.safetensors")
    print(json.dumps({"model": dst + ".onnx", "hyper_parameters": hp, "sha256": digest,
                      "max_abs_diff_vs_golden": {"recovered_torch": recovered, "inference_graph_torch": rewritten,
                                                 "inference_graph_onnxruntime": exported}}))


if __name__ == "__main__":
    main()
