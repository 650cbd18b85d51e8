#!/usr/bin/env python3
"""A deliberately broken external planner, for testing how the harness
handles planner failures. Standard library only.

Usage: misbehaving_planner.py MODE [N [MINOR]]

It handshakes normally (except in the startup modes), speaking protocol
1.MINOR (default 1.0; from 1.1 it answers `prepare`, from 1.2 its replies
name their step), answers the first N observations (default 0) with a
gentle braking control, then misbehaves:

  crash          writes a traceback-like message to stderr and exits with status 3
  hang           stops answering (sleeps forever, reading nothing)
  garbage        prints a line that is not JSON
  nan            prints a control whose acceleration is NaN (json.dumps's default)
  unknown        prints a JSON object of an unknown message type
  missing        prints a control without `yaw_rate_radps`
  error          sends {"type": "error"} with a message
  chatty         prints a debug line on stdout where its reply should be
  deaf           answers hello, then sleeps without reading (ignores bye)
  slow-start     sleeps 60 s before answering hello
  bad-version    answers hello with protocol 2
  exit-at-start  exits with status 7 before answering hello
  spawn-child    starts a `sleep 600` child at hello (its pid in the `ready`
                 name, `misbehaving-spawn-child child=PID`), then answers
                 every observation and exits on bye, leaving the child behind
  huge           answers with a finite but absurd control, accel_mps2 = 1e100
  untagged       answers every observation with a control naming no step
                 (what 1.0 and 1.1 planners send)
  wrong-step     answers with a control naming the next observation's step
  blind          after `ready`, writes 100 controls at once without reading a
                 thing (a planner that never looks at its input), then sleeps
  crab           answers with a trajectory 1 m ahead and 0.35 m sideways a
                 step, heading held: each step passes the position check,
                 the drift adds up
  swerve         answers with a control of yaw rate 1.4 rad/s (14 m/s² of
                 lateral acceleration at 10 m/s)
  huge-yaw       answers with a control of yaw rate 1e308 rad/s
  long-error     sends {"type": "error"} with a 15 MiB message
  endless-line   writes one line without end (until its stdout closes)
  extra-reply    answers one observation twice (both replies name its step
                 in 1.2), then answers each later one once: every later
                 reply the harness reads is one step late
"""

import json
import subprocess
import sys
import time


def send_raw(line):
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def send(message):
    send_raw(json.dumps(message))


def main():
    mode = sys.argv[1] if len(sys.argv) > 1 else "crash"
    good_steps = int(sys.argv[2]) if len(sys.argv) > 2 else 0
    minor = int(sys.argv[3]) if len(sys.argv) > 3 else 0
    answered = 0

    def reply(message, step):
        if minor >= 2:
            message = dict(message, step=step)
        send(message)

    for line in sys.stdin:
        message = json.loads(line)
        kind = message["type"]
        if kind == "hello":
            if mode == "slow-start":
                time.sleep(60)
            if mode == "exit-at-start":
                print("misbehaving_planner: giving up before hello", file=sys.stderr, flush=True)
                return 7
            version = 2 if mode == "bad-version" else 1
            name = f"misbehaving-{mode}"
            if mode == "spawn-child":
                # Not waited for, not killed: an orphan once this process exits.
                child = subprocess.Popen(["sleep", "600"])
                name += f" child={child.pid}"
                good_steps = float("inf")
            send({"type": "ready", "protocol": version, "protocol_minor": minor, "name": name})
            if mode == "deaf":
                while True:
                    time.sleep(3600)
            if mode == "blind":
                # One write: the lines are all waiting before the harness
                # asks its second question, however fast it asks (written a
                # line at a time they could trickle in as fast as it asks,
                # each then read as the answer to a question).
                control = json.dumps({"type": "control", "accel_mps2": 0.0, "yaw_rate_radps": 0.0})
                sys.stdout.write((control + "\n") * 100)
                sys.stdout.flush()
                while True:
                    time.sleep(3600)
            continue
        if kind == "bye":
            return 0
        if kind == "prepare":
            send({"type": "prepared"})
            continue
        step = message["step"]
        if answered < good_steps:
            answered += 1
            reply({"type": "control", "accel_mps2": -1.0, "yaw_rate_radps": 0.0}, step)
            continue
        if mode == "crash":
            print("Traceback (most recent call last):", file=sys.stderr)
            print(f"misbehaving_planner: crashing at step {message['step']}", file=sys.stderr, flush=True)
            return 3
        if mode == "hang":
            while True:
                time.sleep(3600)
        if mode == "garbage":
            send_raw("this is not JSON, it is a planner talking to itself")
        elif mode == "nan":
            send({"type": "control", "accel_mps2": float("nan"), "yaw_rate_radps": 0.0})
        elif mode == "unknown":
            send({"type": "steer", "angle": 0.1})
        elif mode == "missing":
            send({"type": "control", "accel_mps2": 0.0})
        elif mode == "huge":
            send({"type": "control", "accel_mps2": 1e100, "yaw_rate_radps": 0.0})
        elif mode == "teleport":
            # 70 m ahead in 0.1 s, at the speed it had.
            ego = message["ego"]
            send({"type": "trajectory", "points": [{"t": 0.1, "x": ego["x"] + 70.0, "y": ego["y"],
                                                    "heading_rad": ego["heading_rad"], "speed_mps": ego["speed_mps"]}]})
        elif mode == "crab":
            ego = message["ego"]
            send({"type": "trajectory", "points": [{"t": 0.1, "x": ego["x"] + 1.0, "y": ego["y"] + 0.35,
                                                    "heading_rad": ego["heading_rad"], "speed_mps": 10.0}]})
        elif mode == "swerve":
            send({"type": "control", "accel_mps2": 0.0, "yaw_rate_radps": 1.4})
        elif mode == "huge-yaw":
            send({"type": "control", "accel_mps2": 0.0, "yaw_rate_radps": 1e308})
        elif mode == "long-error":
            send({"type": "error", "message": "lost " + "x" * (15 * 1024 * 1024)})
        elif mode == "endless-line":
            chunk = "x" * (1024 * 1024)
            try:
                while True:
                    sys.stdout.write(chunk)
            except (BrokenPipeError, OSError):
                return 0
        elif mode == "instant-stop":
            send({"type": "control", "accel_mps2": -1e6, "yaw_rate_radps": 0.0})
        elif mode == "reverse-reporting-standstill":
            # 15 m/s backwards, reported as standing.
            ego = message["ego"]
            send({"type": "trajectory", "points": [{"t": 0.1, "x": ego["x"] - 1.5, "y": ego["y"],
                                                    "heading_rad": ego["heading_rad"], "speed_mps": 0.0}]})
        elif mode == "error":
            send({"type": "error", "message": "planner lost its localisation"})
        elif mode == "untagged":
            send({"type": "control", "accel_mps2": -1.0, "yaw_rate_radps": 0.0})
        elif mode == "wrong-step":
            send({"type": "control", "accel_mps2": -1.0, "yaw_rate_radps": 0.0, "step": step + 1})
        elif mode == "extra-reply":
            if answered == good_steps:
                reply({"type": "control", "accel_mps2": -1.0, "yaw_rate_radps": 0.0}, step)
            answered += 1
            reply({"type": "control", "accel_mps2": -1.0, "yaw_rate_radps": 0.0}, step)
        elif mode == "chatty":
            send_raw("debug: thinking...")
            send({"type": "control", "accel_mps2": 0.0, "yaw_rate_radps": 0.0})
        else:
            send({"type": "control", "accel_mps2": 0.0, "yaw_rate_radps": 0.0})
    return 0


if __name__ == "__main__":
    sys.exit(main())
