#!/bin/bash
# Train realism priors on a GPU machine that has PyTorch but not the
# repository's build: write the shards there from a carried `safer` release
# binary and recorded scenes (the public-domain NGSIM ones for the shipped
# recipe), then train one prior per named run at once on the one GPU (a
# 500 k-parameter model leaves the GPU mostly idle, so side-by-side runs
# cost little more than one).
#
#   training/prior/gpu_run.sh BINARY RECORDED OUT NAME:ATTENTION[:EXTRA_ARGS] ...
#
# BINARY: the `safer` release binary (or an .xz of it); RECORDED: the
# recorded scenes' folder, `commonroad-ngsim` for the shipped recipe (or a
# .tar.xz holding one folder); OUT: where each run's
# `best.pt`, `log.csv`, `summary.json` and training log go (`OUT/NAME/`), and
# `run.log`. Every run trains with `--device cuda --batch 1024 --threads 4`
# and `STEPS` steps (default 6648, the shipped priors' count); EXTRA_ARGS,
# comma-separated, are passed to train.py as they are. Shards written
# elsewhere are the same (the dataset is deterministic), so the runs come
# back to `training/prior/export.py --run OUT/NAME --train-data /tmp/shards`.
# PACK=1 packs each finished run's folder into `OUT/NAME.tar` (and removes
# the folder), for a device runner that returns only a few files per
# command. SHARDS=DIR trains on shards already written there instead (BINARY and
# RECORDED are then not read); DATASET_ARGS are passed to `safer
# prior-dataset` as they are (`--evaluation-only` for recorded scenes under
# a non-commercial licence: such a prior is measured, never shipped);
# DEVICE=cpu runs the same plumbing without a GPU (a smoke test, with
# random shards from make_random_shards.py). TRAIN_LIMIT_S=N stops each
# training run N seconds after it started (a device call has a hard
# limit): what the run saved by then (`best.pt` at its last evaluation,
# every `--eval-every` steps) is still packed, and the script exits 1.
# Stop runs by their process ids, never with `pkill -f train.py`: that
# pattern also matches a shell whose command line names train.py and
# kills it.
#
# Example (the shipped recipe trained twice as long, both attentions):
#   STEPS=13296 training/prior/gpu_run.sh safer.xz ngsim.tar.xz $OUT long:differential long-plain:plain
# The evaluation-only in-domain prior (WOMD JSON scenes, never committed):
#   DATASET_ARGS=--evaluation-only training/prior/gpu_run.sh safer.xz womd-json.tar.xz $OUT \
#     womd-eval:differential:--recorded-weight,10
set -u
if [ $# -lt 4 ]; then
  sed -n 2,39p "$0" >&2
  exit 2
fi
binary=$1 recorded=$2 out=$3
shift 3
t0=$(date +%s)
cd "$(dirname "$0")/../.."
mkdir -p "$out" /tmp/data
log="$out/run.log"
say() { echo "$@" | tee -a "$log"; }

shards=${SHARDS:-}
if [ -z "$shards" ]; then
  case "$binary" in
    *.xz) xz -dc "$binary" > /tmp/safer ;;
    *) cp "$binary" /tmp/safer ;;
  esac
  chmod +x /tmp/safer
  case "$recorded" in
    *.tar.xz)
      top=$(xz -dc "$recorded" | tar tf - | head -1 | cut -d/ -f1)
      xz -dc "$recorded" | tar xf - -C /tmp/data
      recorded=/tmp/data/$top ;;
  esac
  say "$(nvidia-smi --query-gpu=name,memory.total --format=csv,noheader 2>&1)"
  shards=/tmp/shards
  # shellcheck disable=SC2086  # DATASET_ARGS are separate words on purpose
  /tmp/safer prior-dataset --recorded "$recorded" ${DATASET_ARGS:-} --out "$shards" --force 2>&1 | grep -v wrote | tail -3 | tee -a "$log"
  say "shards ready after $(( $(date +%s) - t0 )) s"
fi

export PYTHONUNBUFFERED=1
pids=()
for spec in "$@"; do
  IFS=: read -r name attention extra <<< "$spec"
  mkdir -p "$out/$name"
  # shellcheck disable=SC2086  # EXTRA_ARGS are separate words on purpose
  ${TRAIN_LIMIT_S:+timeout "$TRAIN_LIMIT_S"} "${PYTHON:-python3}" training/prior/train.py --data "$shards" --device "${DEVICE:-cuda}" --batch 1024 --threads 4 \
    --steps "${STEPS:-6648}" --attention "$attention" --eval-every 2000 ${extra//,/ } \
    --out "$out/$name" > "$out/$name/train.log" 2>&1 &
  pids+=($!)
done
status=0
for pid in "${pids[@]}"; do
  wait "$pid" || status=1
done
for spec in "$@"; do
  name=${spec%%:*}
  say "== $name"
  tail -2 "$out/$name/train.log" | tee -a "$log"
  if [ -n "${PACK:-}" ]; then
    tar cf "$out/$name.tar" -C "$out" "$name" && rm -r "${out:?}/$name"
  fi
done
say "done after $(( $(date +%s) - t0 )) s"
exit $status
