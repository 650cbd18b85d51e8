"""Tables of realism-prior candidates from `evaluate_candidate.sh` outputs.

One row per candidate folder: the figures docs/research/2026-11-realism-prior-and-adversary.md compares
priors by, and, for two or more folders (seeds of one recipe), each
column's mean and range. One run of a recipe says little: three seeds of
one recipe gave `safer` CR 0.281-0.322 on WOMD interactive, a prior CBV
at fault in 0.020-0.052 of the variants and `safer` / `prior` CR on NGSIM
of 0.72-1.41, so compare recipes by their seeds' means and ranges.

usage: python training/prior/candidate_table.py OUT [OUT...]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from pathlib import Path

SETS = ("womd-interactive", "womd-json", "commonroad-ngsim")
SET_LABELS = {"womd-interactive": "int.", "womd-json": "JSON", "commonroad-ngsim": "NGSIM"}


class CandidateError(Exception):
    """A candidate folder lacks an output or holds one of the wrong shape."""


def _read(path: Path) -> str:
    if not path.is_file():
        raise CandidateError(f"{path}: missing (run training/prior/evaluate_candidate.sh first)")
    return path.read_text()


def recorded_turns_in_top_n(text: str, path: Path) -> float:
    """The share of recorded turns whose token is in the top 20 (`safer prior-fit`, all scenes)."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        row = lines[i + 1].split() if i + 1 < len(lines) else []
        # The table of recorded token kinds: "kind scenes samples NLL in top n ..." then "turning all ...".
        if line.split()[:7] == ["kind", "scenes", "samples", "NLL", "in", "top", "n"]:
            if len(row) >= 5 and row[:2] == ["turning", "all"]:
                return float(row[4])
        # Outputs written before turn onsets were scored: "scenes samples NLL in top n" then "all ...".
        if line.split() == ["scenes", "samples", "NLL", "in", "top", "n"]:
            if len(row) == 4 and row[0] == "all":
                return float(row[3])
    raise CandidateError(f"{path}: no turn table (a line 'kind scenes samples NLL in top n ...' then "
                         "'turning all ...')")


def realism_overall(text: str, path: Path) -> dict[str, float]:
    """Meta, map-based and collision figures of `safer realism`'s `overall` row."""
    header = next((line.split() for line in text.splitlines() if line.startswith("format")), None)
    overall = next((line.split() for line in text.splitlines() if line.startswith("overall")), None)
    if header is None or overall is None or len(header) != len(overall):
        raise CandidateError(f"{path}: no 'format' header with a matching 'overall' row")
    row = dict(zip(header, overall))
    try:
        return {k: float(row[k]) for k in ("meta", "map-based", "collision")}
    except (KeyError, ValueError) as e:
        raise CandidateError(f"{path}: the 'overall' row lacks {e}") from None


def trust_region_safer(text: str, path: Path) -> dict[str, float]:
    """Yaw-rate bins, behaviours and the plausible share of `safer`'s region, all scenes."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("method") and i > 0 and lines[i - 1].startswith("all scenes"):
            # Two headings carry their unit after a space.
            header = line.replace("accel m/s²", "accel_m/s²").replace("yaw rad/s", "yaw_rad/s").split()
            for row in lines[i + 1 :]:
                cells = row.split()
                if cells and cells[0] == "safer" and len(cells) == len(header):
                    values = dict(zip(header, cells))
                    return {k: float(values[k]) for k in ("y-bins", "behaviours", "plausible")}
    raise CandidateError(f"{path}: no 'safer' row under 'all scenes'")


def evaluation(report: dict, path: Path) -> dict[str, float]:
    """`safer` and `prior` figures of one `safer evaluate --json` report."""
    rows = {r.get("method"): r for r in report.get("rows", [])}
    if "safer" not in rows or "prior" not in rows:
        raise CandidateError(f"{path}: needs the rows of --methods safer,prior")
    held = {r.get("method"): r for r in report.get("held_out", {}).get("held_out", [])}
    s, p = rows["safer"], rows["prior"]
    return {
        "safer_cr": s["cr"],
        "safer_sr": s["sr"],
        "safer_sr_crit": s["sr_critical"] if s["sr_critical"] is not None else float("nan"),
        "prior_cr": p["cr"],
        "ratio": s["cr"] / p["cr"] if p["cr"] > 0 else float("inf"),
        "prior_at_fault": p["cbv_at_fault_background_collision_rate"],
        "prior_off_road": p["cbv_off_road_rate"],
        "held_out_safer_cr": held["safer"]["cr"] if "safer" in held else float("nan"),
    }


def candidate(folder: Path) -> dict[str, float]:
    """Every compared figure of one candidate folder, by column name."""
    figures: dict[str, float] = {}
    for s in SETS:
        label = SET_LABELS[s]
        path = folder / f"prior-fit-{s}.txt"
        figures[f"turns {label}"] = recorded_turns_in_top_n(_read(path), path)
        path = folder / f"eval-{s}.json"
        try:
            report = json.loads(_read(path))
        except json.JSONDecodeError as e:
            raise CandidateError(f"{path}: not JSON ({e})") from None
        for k, v in evaluation(report, path).items():
            figures[f"{k} {label}"] = v
    for s in ("womd-json", "womd-interactive"):
        path = folder / f"realism-{s}-8.txt"
        for k, v in realism_overall(_read(path), path).items():
            figures[f"realism {k} {SET_LABELS[s]}-8"] = v
    path = folder / "trust-region-womd-interactive.txt"
    for k, v in trust_region_safer(_read(path), path).items():
        figures[f"region {k} int."] = v
    return figures


def summary(values: list[float]) -> str:
    """Mean and range of one column over candidates."""
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return "–"
    return f"{statistics.fmean(finite):.3f} ({min(finite):.3f}–{max(finite):.3f})"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folders", nargs="+", type=Path, help="outputs of evaluate_candidate.sh, one per candidate")
    args = parser.parse_args(argv)
    try:
        table = {str(f): candidate(f) for f in args.folders}
    except CandidateError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    columns = list(next(iter(table.values())))
    names = list(table)
    width = max(len(c) for c in columns)
    print(f"{'':{width}}  " + "  ".join(f"{Path(n).name:>14}" for n in names) + ("  mean (range)" if len(names) > 1 else ""))
    for c in columns:
        cells = "  ".join(f"{table[n][c]:>14.3f}" for n in names)
        tail = f"  {summary([table[n][c] for n in names])}" if len(names) > 1 else ""
        print(f"{c:{width}}  {cells}{tail}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
