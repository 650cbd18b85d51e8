#!/usr/bin/env bash
# The mutation table of every shipped suite (docs/benchmarks.md, "Mutation
# testing"): each suite with its own planner and criteria, under each
# adversary method, with every fault operator planted. Suites are copied
# into a scratch folder with `method:` replaced (and their relative paths
# made absolute), so nothing under specs/ is touched.
#
#   docs/benchmarks/mutation_tables.sh [SAFER-BINARY [SUITE...]]
#
# SUITE: a suite's name under specs/suites (default: every suite; the
# cost table then times adversarial-ngsim, external-lane-follower and
# authored-evasive, else the suites named).
#
# METHODS="M ..." runs only these methods (written as below, METHOD or
# METHOD:RULE) for each suite, with the along-the-lanes row where a suite
# holds its CBV along the lanes; COST=0 leaves out the cost table.
#
# Prints one Markdown row per (suite, method): the variants the planner
# passes, the score, the killed mutants (with the variants that killed
# each) and the survivors; then the cost of a mutation run against the
# suite's own run, side by side. The benchmarks quote the printed tables
# kept in docs/evaluation/shipped-suites/ (mutation-tables.txt: every
# suite; cost.txt: METHODS=log with the five suites the cost table names).
set -euo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
safer="${1:-$repo/target/release/safer}"
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT

# A scratch copy of a suite with its relative paths made absolute, and
# these further sed expressions applied.
scratch_copy() { # suite-file out.yaml [sed-option...]
    local src="$1" out="$2"
    shift 2
    sed -e "s#\.\./\.\./#$repo/#g; s#\.\./scenarios/#$repo/specs/scenarios/#g" "$@" "$src" >"$out"
}

# One suite under one method: the JSON report of `safer run --mutants`. A
# method written METHOD:RULE runs METHOD with `ego_contact: RULE`, and
# METHOD:RULE:WAY with `wrong_way: WAY` too; the suite's own `ego_contact`
# and `wrong_way` are dropped (the methods without a CBV rule refuse them).
run_suite() { # suite-file method out.json
    local src="$1" method="${2%%:*}" out="$3" copy="$scratch/$(basename "$1" .yaml)-$2.yaml" rules="" rest
    if [[ "$2" == *:* ]]; then
        rest="${2#*:}"
        rules="\\n  ego_contact: ${rest%%:*}"
        [[ "$rest" == *:* ]] && rules="$rules\\n  wrong_way: ${rest#*:}"
    fi
    scratch_copy "$src" "$copy" -e '/^  ego_contact:/d; /^  wrong_way:/d' -e "s#^\(  method:\).*#\1 $method$rules#"
    grep -q "^adversary:" "$copy" || printf 'adversary:\n  method: %s\n' "$method" >>"$copy"
    # The log replays one variant whatever the seed: one per scene.
    [[ "$method" == log ]] && sed -i "s#^variants: .*#variants: 1#" "$copy"
    (cd "$repo" && "$safer" run "$copy" --mutants --no-shrink --json "$out" >/dev/null 2>&1) || true
}

echo "| suite | planner | method | passed | score | killed (variants) | survived |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
shift || true
suites=("$@")
for suite in "$repo"/specs/suites/*.yaml; do
    name="$(basename "$suite" .yaml)"
    [[ ${#suites[@]} -eq 0 || " ${suites[*]} " == *" $name "* ]] || continue
    if grep -q "method: safer" "$suite"; then methods="log prior safer safer-in-path safer-in-path:not-from-behind safer-cut-in safer-in-path-lookahead safer-in-path-lookahead:not-from-behind safer-distinct safer-lookahead no-lfr"; else methods="log"; fi
    if [[ -n "${METHODS:-}" ]]; then grep -q "method: safer" "$suite" && methods="$METHODS" || continue; fi
    # A suite holding its CBV along the lanes: that rule's row too.
    grep -q "wrong_way: along-the-lanes" "$suite" && methods="$methods safer-in-path-lookahead:not-from-behind:along-the-lanes"
    for method in $methods; do
        out="$scratch/$name-$method.json"
        run_suite "$suite" "$method" "$out"
        python3 - "$out" "$name" "$method" <<'EOF'
import json, sys
path, name, method = sys.argv[1:]
try:
    report = json.load(open(path))
except (OSError, ValueError) as e:
    print(f"| {name} | ? | `{method}` | could not run: {e} | | | |")
    sys.exit()
s = report["suites"][0]
m = s.get("mutation")
if m is None:
    print(f"| {name} | {s['planner']} | `{method}` | no mutation report | | | |")
    sys.exit()
killed = ", ".join(f"{o['operator']} ({len(o['kills'])})" for o in m["operators"] if o["killed"]) or "none"
survived = ", ".join(o["operator"] for o in m["operators"] if not o["killed"]) or "none"
score = "–" if m["score"] is None else f"{m['score']:.3f}"
method = method.replace(":", "`, `")
print(f"| {name} | {s['planner']} | `{method}` | {m['variants_passed']}/{m['variants']} | {score} | {killed} | {survived} |")
EOF
    done
done

[[ "${COST:-1}" == 0 ]] && exit 0

# The cost of a mutation run, side by side with the suite's own run. Each
# suite is timed from a scratch copy without its mutation floor, so that
# "own run" plays the variants alone (a suite whose floor runs every
# operator would otherwise pay for the mutants in both columns).
echo
echo "| suite | own run, s | with 7 mutants, s | ratio | bound (1 + 7) |"
echo "| --- | --- | --- | --- | --- |"
timed=(adversarial-ngsim external-lane-follower authored-evasive)
[[ ${#suites[@]} -eq 0 ]] || timed=("${suites[@]}")
for name in "${timed[@]}"; do
    copy="$scratch/cost-$name.yaml"
    scratch_copy "$repo/specs/suites/$name.yaml" "$copy" -e '/^ *mutation_score_min:/d; /^ *mutation_operators:/d'
    # Best of three of each, alternating, so a slower moment hits both.
    python3 - "$safer" "$repo" "$copy" "$name" <<'EOF'
import subprocess, sys, time
safer, repo, copy, name = sys.argv[1:]
def once(*extra):
    t = time.perf_counter()
    subprocess.run([safer, "run", copy, "--no-shrink", *extra], cwd=repo,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t
own, mut = [], []
for _ in range(3):
    own.append(once())
    mut.append(once("--mutants"))
print(f"| {name} | {min(own):.2f} | {min(mut):.2f} | {min(mut) / min(own):.2f} | 8 |")
EOF
done
