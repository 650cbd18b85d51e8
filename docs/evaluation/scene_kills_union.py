#!/usr/bin/env python3
"""The faults each method catches per recorded scene when every scene is
tested with more than one ego-CBV pairing, as a suite that lists a folder
once with its own pairs and once with `roles: leader` tests it.

    scene_kills_union.py REPORT.json [REPORT.json ...]

Each REPORT is the `--json` report of one `safer evaluate --mutants` run
over the same scenes and seeds, with a different `--roles`. A scene counts
for a method where some variant of it, in any report, was passed by the
planner; a fault is caught in the scene where some such variant was failed
by the mutant. Prints, per method, each report's count and the union's:
scenes where the fault was caught / scenes with a passed variant; then the
union's again on the held-out scenes and on the rest. The held-out scenes
are every tenth by sorted id (the 10th, 20th, ...) of the scenes in any
report, the rule of `safer evaluate`'s held-out rows (each run applies it to
its own scenes, so a run whose pairing leaves scenes out holds out others).
Standard library only.
"""
import json
import sys
from collections import defaultdict

OPERATORS = ["no-brake", "weak-brake", "late", "blind-cbv", "blind-side", "no-evade", "speeding"]


def scene_kills(path):
    """(every scene, scenes with a passed variant per method, scenes where
    each fault was caught per method)."""
    with open(path) as f:
        report = json.load(f)
    scenes = {variant["scenario"] for variant in report["variants"]}
    passed = defaultdict(set)
    caught = defaultdict(lambda: defaultdict(set))
    for variant in report["variants"]:
        mutation = variant.get("mutation")
        if variant.get("error") or not mutation or mutation.get("base_failure") is not None:
            continue
        method, scene = variant["method"], variant["scenario"]
        passed[method].add(scene)
        for mutant in mutation["mutants"]:
            if mutant["killed"]:
                caught[method][mutant["operator"]].add(scene)
    return scenes, passed, caught


def held_out_scenes(scenes):
    """Every tenth scene by sorted id, as `safer evaluate` holds them out."""
    return set(sorted(scenes)[9::10])


def row(label, passed, caught):
    n = len(passed)
    cells = [f"{len(caught[op])}/{n} ({100 * len(caught[op]) / n:.0f} %)" if n else "–" for op in OPERATORS]
    fewest = min(OPERATORS, key=lambda op: len(caught[op]))
    return f"| {label} | " + " | ".join(cells) + f" | {fewest} |"


def main(paths):
    if not paths:
        sys.exit(__doc__)
    reports = []
    scenes = set()
    for path in paths:
        in_report, passed, caught = scene_kills(path)
        scenes |= in_report
        reports.append((path, passed, caught))
    held = held_out_scenes(scenes)
    methods = list(dict.fromkeys(m for _, passed, _ in reports for m in passed))
    print("| method | pairing | " + " | ".join(OPERATORS) + " | fewest |")
    print("| --- | --- | " + " | ".join("---" for _ in OPERATORS) + " | --- |")
    for method in methods:
        for path, passed, caught in reports:
            label = path.rsplit("/", 1)[-1].removesuffix(".json")
            print(row(f"`{method}` | {label}", passed[method], caught[method]))
        union_passed = set().union(*(passed[method] for _, passed, _ in reports))
        union_caught = {op: set().union(*(caught[method][op] for _, _, caught in reports)) for op in OPERATORS}
        parts = (("either", scenes), (f"either, held out ({len(held)} scenes)", held), ("either, the rest", scenes - held))
        for label, part in parts:
            part_caught = {op: union_caught[op] & part for op in OPERATORS}
            print(row(f"`{method}` | {label}", union_passed & part, part_caught))


if __name__ == "__main__":
    main(sys.argv[1:])
