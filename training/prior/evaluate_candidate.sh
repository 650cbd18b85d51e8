#!/usr/bin/env bash
# Scores an exported realism-prior candidate the way docs/research/2026-11-realism-prior-and-adversary.md
# compares priors, on the three shared recorded sets (WOMD interactive,
# WOMD JSON, NGSIM), and writes every printed table into OUT:
#
#   prior-fit-SET.txt          safer prior-fit (NLL, recorded token in the top 20)
#   eval-SET.txt / .json       safer evaluate --methods safer,prior --seeds 10
#   realism-womd-json-8.txt    safer realism --policy prior --rollouts 8
#   realism-womd-interactive-8.txt
#   trust-region-womd-interactive.txt   safer trust-region --seeds 3
#
# Then `training/prior/candidate_table.py OUT...` prints one table row per
# candidate (and, for several, each column's mean and range: compare
# priors over seeds, not one run each).
#
# usage: training/prior/evaluate_candidate.sh MODELS OUT [--force]
#   MODELS  a models folder holding the candidate (export.py --out)
#   OUT     a new folder for the outputs (--force: replace its files)
# 2.5 minutes on a quiet 2-core machine, 7 beside a training run; the
# recorded sets are read through `data:` ($SAFER_DATA_DIR).
set -euo pipefail
: "${SAFER_DATA_DIR:?set SAFER_DATA_DIR to the folder of the recorded datasets}"
if [[ $# -lt 2 || $# -gt 3 || ( $# -eq 3 && $3 != --force ) ]]; then
    # The usage is the comment block at the top of this file.
    awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0" >&2
    exit 2
fi
models=$(realpath "$1")
out=$(realpath -m "$2")
[[ -f $models/prior-decoder.onnx ]] || { echo "error: $models holds no prior-decoder.onnx" >&2; exit 2; }
if [[ -d $out && -n $(ls -A "$out") && ${3:-} != --force ]]; then
    echo "error: $out is not empty (pass --force to replace its files)" >&2
    exit 2
fi
mkdir -p "$out"
cd "$(dirname "$0")/../.."
cargo build --release --quiet
# A copy, so that a rebuild while this runs cannot change the binary halfway.
safer="$out/.safer"
cp target/release/safer "$safer"
export SAFER_MODELS="$models"
for set in womd-interactive womd-json commonroad-ngsim; do
    echo "== $set"
    "$safer" prior-fit --scenes "data:$set" >"$out/prior-fit-$set.txt"
    "$safer" evaluate --scenes "data:$set" --seeds 10 --jobs 2 --methods safer,prior \
        --json "$out/eval-$set.json" >"$out/eval-$set.txt" 2>&1
done
for set in womd-json womd-interactive; do
    "$safer" realism --policy prior --rollouts 8 --scenes "data:$set" >"$out/realism-$set-8.txt"
done
"$safer" trust-region --scenes data:womd-interactive --seeds 3 >"$out/trust-region-womd-interactive.txt"
rm "$safer"
echo "wrote $out"
