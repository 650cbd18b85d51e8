"""Replay against closed-loop rows of `safer evaluate --json` reports, as
the Markdown table of the closed-loop comparison (docs/benchmarks.md,
docs/research/2026-11-realism-prior-and-adversary.md).

    python3 docs/benchmarks/closed_loop_table.py SET:PLANNER:REPORT.json ...

Each report must come from `safer evaluate --stage2-cbv replay,closed-loop`
with a `log` row among its methods (the failures beyond log replay's).
"""
import json
import sys


def rate(x):
    return "–" if x is None else f"{x:.3f}"


def main(args):
    print("| set | planner | method | stage-2 CBV | SR | SR-crit | reach | reach-crit | SR-avoid | avoid-fail | no-escape (refuted pre-check) | failures (beyond `log`) | held out: reach-crit / SR-avoid |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for arg in args:
        name, planner, path = arg.split(":", 2)
        report = json.load(open(path))
        rows = {(r["method"], r["stage2_cbv"]): r for r in report["rows"]}
        held = {(r["method"], r["stage2_cbv"]): r for r in report["held_out"]["held_out"]}
        log = rows[("log", "replay")]["failures"]
        methods = [m for (m, mode) in rows if m != "log" and mode == "replay"]
        for method in methods:
            beyond = {}
            for mode in ["replay", "closed-loop"]:
                r, h = rows[(method, mode)], held[(method, mode)]
                beyond[mode] = r["failures"] - log
                print(
                    f"| {name} | {planner} | `{method}` | {mode} | {rate(r['sr'])} | {rate(r['sr_critical'])} "
                    f"| {rate(r['conflict_reach'])} | {rate(r['conflict_reach_critical'])} | {rate(r['sr_avoidable'])} "
                    f"| {r['avoidable_failures']} | {r['no_escape_collisions']} ({r['precheck_refuted']}) "
                    f"| {r['failures']} ({beyond[mode]}) | {rate(h['conflict_reach_critical'])} / {rate(h['sr_avoidable'])} |"
                )
            # A ratio only where both counts are failures beyond log replay's:
            # fewer failures than the recorded CBV causes has no ratio.
            if beyond["replay"] > 0 and beyond["closed-loop"] >= 0:
                ratio = f"{beyond['closed-loop'] / beyond['replay']:.2f}×"
            else:
                ratio = "–"
            print(f"| {name} | {planner} | `{method}` | closed loop / replay, beyond `log` ({log}) | {ratio} | | | | | | | | |")


if __name__ == "__main__":
    main(sys.argv[1:])
