#!/usr/bin/env python3
"""A randomised probe of bad input against the `safer` binary.

Usage: tests/probe/bad_input_probe.py [--count N] [--seed S] [--binary PATH]

Makes N bad inputs (default 520) in four families and runs the binary on
each with a deadline:

  spec      a suite or authored scenario spec with one mutation (an extreme
            or non-numeric number, a deleted or repeated line, a path that
            climbs out of its root, shell syntax, a huge or odd string)
  recorded  a shipped NGSIM CommonRoad scene or a WOMD JSON fixture with
            one mutation (an extreme number, a deleted line, a changed type)
  planner   an external planner that answers one observation with a random
            bad reply (extreme numbers, wrong types, huge strings, raw
            bytes, an early exit)
  flags     a command with an out-of-range or odd flag value

Each run must end within its deadline, exit 0, 1 or 2, print no Rust panic
and no Rust debug text, print under 200 KB, and leave every input file as
it was. The summary counts each kind of finding; the findings are listed
with the input that caused them. Standard library only.
"""

import argparse
import hashlib
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
NGSIM = REPO / "scenes/ngsim/USA_US101-4_3_T-1.xml"
WOMD_JSON = REPO / "tests/fixtures/bad-input/hangs/folder-with-one-bad-scene/a-good-scene.json"
OVERTAKE = REPO / "specs/scenarios/highway-overtake.yaml"

EXTREME_NUMBERS = ["1e308", "-1e308", "1e-320", "-0", ".nan", ".inf", "-.inf", "0", "-1", "99999999999999999999",
                   "3.5e38", "1e19", "-7", "0.0000001"]
XML_NUMBERS = ["1e308", "-1e308", "NaN", "inf", "-inf", "0", "-1", "1e19", "99999999999999999999", "1e-320", "x", ""]
ODD_STRINGS = ["../../etc/passwd", "safer:../../../../etc/passwd", "data:../../..", "safer:/etc/passwd",
               "$(touch PWNED)", "`id`", "a" * 70000, "\u202e\u0000", "", ".", "..", "/", "-", "{scenario}",
               "{unknown}", "CON", "a/b", "\t", "\ufeffname"]

# Rust debug text: `Name { field: …`, `Some(…)`, `Ok(…)`, `Err(…)`.
DEBUG_TEXT = re.compile(r"\b[A-Z][A-Za-z]+ \{ [a-z_]+: |\bSome\(|\bOk\(|\bErr\(")


def digest(paths):
    out = {}
    for p in paths:
        try:
            out[str(p)] = hashlib.sha256(Path(p).read_bytes()).hexdigest()
        except OSError:
            out[str(p)] = None
    return out


def run(binary, args, cwd, timeout):
    started = time.monotonic()
    try:
        proc = subprocess.run([binary, *args], cwd=cwd, capture_output=True, timeout=timeout,
                              env=dict(os.environ, RUST_BACKTRACE="0"))
        return proc.returncode, proc.stdout + proc.stderr, time.monotonic() - started, False
    except subprocess.TimeoutExpired as e:
        return None, (e.stdout or b"") + (e.stderr or b""), time.monotonic() - started, True


def judge(case, code, output, hung, before, after):
    findings = []
    text = output.decode("utf-8", "replace")
    if hung:
        findings.append("hang")
    elif code not in (0, 1, 2):
        findings.append(f"exit {code}")
    if "panicked" in text or "RUST_BACKTRACE" in text:
        findings.append("panic")
    if len(output) > 200_000:
        findings.append(f"unbounded output ({len(output)} bytes)")
    m = DEBUG_TEXT.search(text)
    if m:
        findings.append(f"debug text: {text[max(0, m.start() - 40):m.end() + 40]!r}")
    harmed = [p for p in before if before[p] != after[p]]
    if harmed:
        findings.append(f"harm: {harmed}")
    return findings


def mutate_yaml(text, rng):
    lines = text.split("\n")
    i = rng.randrange(len(lines))
    op = rng.randrange(6)
    if op == 0:
        numbers = [(k, m) for k, l in enumerate(lines) for m in re.finditer(r"-?\d+(\.\d+)?", l)]
        if numbers:
            k, m = rng.choice(numbers)
            lines[k] = lines[k][:m.start()] + rng.choice(EXTREME_NUMBERS) + lines[k][m.end():]
    elif op == 1:
        del lines[i]
    elif op == 2:
        lines.insert(i, lines[i])
    elif op == 3:
        values = [(k, m) for k, l in enumerate(lines) for m in re.finditer(r"(?<=: )[A-Za-z][\w.-]*", l)]
        if values:
            k, m = rng.choice(values)
            lines[k] = lines[k][:m.start()] + json.dumps(rng.choice(ODD_STRINGS)) + lines[k][m.end():]
    elif op == 4:
        lines[i] = lines[i] + rng.choice(["\t", " #", ": x", " [", "{", "\ufeff", " &a", " *a", " !!binary x"])
    else:
        lines[i] = rng.choice(["- x", "? y", "<<: *z", "%YAML 1.2", "---", "...", "key: [1, 2", "x" * 5000])
    return "\n".join(lines)


def spec_case(binary, rng, work):
    suite = (f"name: probe\nscenarios:\n  - overtake.yaml\nplanner: {{ builtin: idm }}\nadversary:\n  method: log\n"
             f"variants: 1\nacceptance:\n  variant: {{ no_collision: true, min_gap_m: 0.1, min_progress: 0.3 }}\n")
    scenario = OVERTAKE.read_text()
    if rng.random() < 0.5:
        suite = mutate_yaml(suite, rng)
        what = "suite"
    else:
        scenario = mutate_yaml(scenario, rng)
        what = "scenario"
    (work / "suite.yaml").write_text(suite)
    (work / "overtake.yaml").write_text(scenario)
    inputs = [work / "suite.yaml", work / "overtake.yaml"]
    return ["run", "suite.yaml", "--json", "report.json"], inputs, f"{what} mutated", 90


def mutate_xml(text, rng):
    lines = text.split("\n")
    op = rng.randrange(3)
    if op == 0:
        numbers = [(k, m) for k, l in enumerate(lines) for m in re.finditer(r"(?<=>)-?\d+(\.\d+)?(?=<)", l)]
        k, m = rng.choice(numbers)
        lines[k] = lines[k][:m.start()] + rng.choice(XML_NUMBERS) + lines[k][m.end():]
    elif op == 1:
        del lines[rng.randrange(len(lines))]
    else:
        k = rng.randrange(len(lines))
        lines.insert(k, lines[k])
    return "\n".join(lines)


def mutate_json(value, rng, depth=0):
    if isinstance(value, dict) and value:
        key = rng.choice(list(value))
        if rng.random() < 0.3 or depth > 4:
            choice = rng.randrange(4)
            if choice == 0:
                del value[key]
            elif choice == 1:
                value[key] = rng.choice([None, "x", [], {}, 1e308, -1, True, "1e400"])
            elif choice == 2:
                value[key + "_extra"] = 1
            else:
                value[key] = rng.choice([float("1e308"), -1e308, 0, -0.0, 1e-320])
        else:
            value[key] = mutate_json(value[key], rng, depth + 1)
    elif isinstance(value, list) and value:
        k = rng.randrange(len(value))
        if rng.random() < 0.3:
            rng.choice([lambda: value.pop(k), lambda: value.insert(k, value[k]), lambda: value.clear()])()
        else:
            value[k] = mutate_json(value[k], rng, depth + 1)
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        return rng.choice([1e308, -1e308, 0, -1, 1e-320, 123456789012, 0.5])
    return value


def recorded_case(binary, rng, work):
    if rng.random() < 0.5:
        path = work / "scene.xml"
        path.write_text(mutate_xml(NGSIM.read_text(), rng))
        what = "NGSIM XML mutated"
    else:
        path = work / "scene.json"
        path.write_text(json.dumps(mutate_json(json.loads(WOMD_JSON.read_text()), rng)))
        what = "WOMD JSON mutated"
    command = rng.choice([["inspect", path.name], ["simulate", path.name, "--planner", "idm"],
                          ["render", path.name, "--out", "picture.svg"]])
    return command, [path], what, 60


PLANNER = r'''
import json, sys, random
rng = random.Random(int(sys.argv[1]))
def send(text):
    sys.stdout.write(text + "\n"); sys.stdout.flush()
def bad_reply(step):
    numbers = [1e308, -1e308, 0, -1, 1e-320, 1e19, 12345678901234567890]
    choice = rng.randrange(12)
    if choice == 0: return json.dumps({"type": "control", "accel_mps2": rng.choice(numbers), "yaw_rate_radps": rng.choice(numbers), "step": step})
    if choice == 1: return json.dumps({"type": "trajectory", "step": step, "points": [{"t": rng.choice([0.1, 0, -1, 1e308]), "x": rng.choice(numbers), "y": 0, "heading_rad": rng.choice(numbers), "speed_mps": rng.choice(numbers)}]})
    if choice == 2: return json.dumps({"type": "trajectory", "step": step, "points": []})
    if choice == 3: return json.dumps({"type": "error", "message": "x" * rng.choice([0, 10, 100000])})
    if choice == 4: return json.dumps({"type": rng.choice(["ready", "prepared", "control", "", None, 5]), "step": step})
    if choice == 5: return '{"type": "control", "accel_mps2": NaN, "yaw_rate_radps": Infinity}'
    if choice == 6: return "\x00\xff garbage"
    if choice == 7: return json.dumps({"type": "control", "accel_mps2": "1", "yaw_rate_radps": [], "step": str(step)})
    if choice == 8: return json.dumps({"type": "trajectory", "step": step, "points": [{"t": 0.1 * (k + 1), "x": k, "y": 0, "heading_rad": 0, "speed_mps": 10} for k in range(rng.choice([1, 100000]))]})
    if choice == 9: sys.exit(rng.choice([0, 1, 137]))
    if choice == 10: return json.dumps({"type": "control", "accel_mps2": 0, "yaw_rate_radps": 0, "step": step + rng.choice([-1, 1, 10**18])})
    return json.dumps([1, 2, 3])
bad_at = rng.randrange(4)
answered = 0
for line in sys.stdin:
    m = json.loads(line)
    if m["type"] == "hello":
        send(json.dumps({"type": "ready", "protocol": 1, "protocol_minor": 2, "name": "probe"}))
    elif m["type"] == "prepare":
        send(json.dumps({"type": "prepared"}))
    elif m["type"] == "bye":
        break
    elif m["type"] == "observation":
        if answered == bad_at:
            send(bad_reply(m["step"]))
        else:
            send(json.dumps({"type": "control", "accel_mps2": -1.0, "yaw_rate_radps": 0.0, "step": m["step"]}))
        answered += 1
'''


def planner_case(binary, rng, work):
    (work / "planner.py").write_text(PLANNER)
    seed = rng.randrange(1 << 30)
    (work / "planner.yaml").write_text(
        f"name: probe\nexternal:\n  command: {sys.executable}\n  args: [planner.py, '{seed}']\n  step_timeout_ms: 5000\n")
    shutil.copy(OVERTAKE, work / "overtake.yaml")
    (work / "suite.yaml").write_text(
        "name: probe\nscenarios:\n  - overtake.yaml\nplanner: planner.yaml\nadversary:\n  method: log\nvariants: 1\n")
    inputs = [work / "suite.yaml", work / "planner.yaml", work / "planner.py", work / "overtake.yaml"]
    return ["run", "suite.yaml", "--json", "report.json", "--junit", "junit.xml", "--html", "page"], inputs, \
        f"planner seed {seed}", 90


def flags_case(binary, rng, work):
    shutil.copy(OVERTAKE, work / "overtake.yaml")
    odd = rng.choice(["0", "-1", "1e400", "nan", "99999999999", "", "x", "1/0", "0/0", "3/2", "-", "/dev/full",
                      "/nonexistent/x", "overtake.yaml", ".", "18446744073709551616"])
    command = rng.choice([
        ["evaluate", "--scenes", str(REPO / "scenes/ngsim"), "--max-scenes", "1", "--seeds", "1", "--methods", "log"],
        ["render", "overtake.yaml"],
        ["simulate", str(NGSIM), "--planner", "idm"],
        ["inspect", str(NGSIM)],
        ["schema", "suite"],
    ])
    flag = rng.choice({
        "evaluate": ["--seeds", "--jobs", "--horizon-s", "--trust-region", "--partition", "--json", "--scenes",
                     "--max-scenes", "--seed", "--methods", "--mutants"],
        "render": ["--step", "--out"],
        "simulate": ["--planner", "--horizon-s"],
        "inspect": ["--json"],
        "schema": ["--out"],
    }[command[0]])
    args = command + [flag, odd] if flag not in ("--json",) or command[0] != "inspect" else command + [flag]
    return args, [work / "overtake.yaml", NGSIM], f"{flag} {odd!r}", 120


FAMILIES = [("spec", spec_case, 0.4), ("recorded", recorded_case, 0.3), ("planner", planner_case, 0.2),
            ("flags", flags_case, 0.1)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=520)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--binary", default=str(REPO / "target/release/safer"))
    args = parser.parse_args()
    rng = random.Random(args.seed)
    findings = []
    per_family = {}
    started = time.monotonic()
    for k in range(args.count):
        name, make, _ = rng.choices(FAMILIES, weights=[w for *_, w in FAMILIES])[0]
        with tempfile.TemporaryDirectory(prefix="safer-probe-") as tmp:
            work = Path(tmp)
            command, inputs, what, timeout = make(args.binary, rng, work)
            before = digest(inputs)
            code, output, took, hung = run(args.binary, command, work, timeout)
            after = digest(inputs)
            found = judge(what, code, output, hung, before, after)
            pwned = (work / "PWNED").exists() or Path("PWNED").exists()
            if pwned:
                found.append("harm: shell syntax ran")
            tally = per_family.setdefault(name, {"runs": 0, "exit": {}})
            tally["runs"] += 1
            tally["exit"][str(code)] = tally["exit"].get(str(code), 0) + 1
            for f in found:
                findings.append((name, what, " ".join(command)[:200], f))
                print(f"FINDING {name} #{k}: {what}: {f}", flush=True)
    print(f"\n{args.count} inputs in {time.monotonic() - started:.0f} s (seed {args.seed})")
    for name, tally in per_family.items():
        print(f"  {name:9} {tally['runs']:4} runs, exit codes {dict(sorted(tally['exit'].items()))}")
    kinds = {}
    for *_, f in findings:
        kind = f.split(":")[0].split(" (")[0]
        kinds[kind] = kinds.get(kind, 0) + 1
    print(f"findings: {len(findings)} {kinds}")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
