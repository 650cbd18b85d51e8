"""The protocol loop: :class:`Planner` to override and :func:`run` to serve it.

``run`` reads the harness's JSON lines from stdin and answers on stdout:
``hello`` -> ``ready``, ``prepare`` -> ``prepared`` (1.1+), each
``observation`` -> one ``control``/``trajectory`` naming its ``step`` (1.2),
``bye`` -> exit 0. While it runs, ``sys.stdout`` (and, for a real process,
file descriptor 1 itself) points at stderr, so a stray ``print`` in planner
code (or in a library it calls, or a child process) lands in the log instead
of corrupting the protocol.
"""

from __future__ import annotations

import json
import os
import sys
import time
import traceback
from typing import IO, Any, Dict, List, Optional, Tuple, Type, Union

from .messages import PROTOCOL, PROTOCOL_MINOR, Control, Hello, Observation, Trajectory
from .roadmap import RoadMap, Route
from .seen import SEEN_LOG_ENV, SeenLog

DEBUG_ENV = "SAFER_PLANNER_DEBUG"
"""Set to ``1`` to log every message, the time each plan took and where the
kit was imported from (stderr)."""


class PlannerError(Exception):
    """Raise from a hook to give up: the kit answers ``error`` with this
    message (no traceback), and the harness fails the rollout with it."""


class Planner:
    """Base class of a planner. Override :meth:`plan` (required) and any of
    :meth:`on_hello`, :meth:`on_prepare`, :meth:`on_route`, :meth:`on_bye`.

    Class attributes to set:

    - ``name``: sent in ``ready`` (the harness logs it).
    - ``protocol_minor``: the revision to speak, 2 by default (1.2: the whole
      map once in ``prepare``, the stable route, step-tagged replies). 0 asks
      for 1.0 (the map near the ego in every observation, the route hint);
      replies are step-tagged in every revision.
    - ``min_protocol_minor``: the lowest revision the planner can work with;
      against an older harness the kit answers ``error`` and exits 1.
    - ``log_name``: the prefix of :meth:`log` lines (default: ``name``).
    - ``dt_s``: the step the planner is built for, s; against a harness
      stepping another (``hello.dt_s``) the kit answers ``error``. ``None``
      (default): any step.
    - ``plan_time_s``: how long a plan can take, s; the kit logs a warning
      when the harness's step timeout (1.3 ``hello``) is shorter.
    - ``route_required``: ``True`` for a planner that cannot plan without
      the route: the kit answers ``error`` to an observation without one.
    - ``seen_log``: a folder to log what the planner saw in each variant
      under (:mod:`safer_planner.seen`; default: the
      ``SAFER_PLANNER_SEEN_LOG`` environment variable, unset: no log).

    Set by the kit: ``self.hello`` (:class:`Hello`), ``self.map`` (the whole
    :class:`RoadMap` from ``prepare``, 1.1+; ``None`` before and in 1.0) and
    ``self.revision`` (the minor revision agreed on).
    """

    name: str = "python-planner"
    protocol_minor: int = PROTOCOL_MINOR
    min_protocol_minor: int = 0
    log_name: Optional[str] = None
    dt_s: Optional[float] = None
    plan_time_s: Optional[float] = None
    route_required: bool = False
    seen_log: Optional[str] = None

    hello: Optional[Hello] = None
    map: Optional[RoadMap] = None
    revision: int = 0

    def on_hello(self, hello: Hello) -> None:
        """Called with ``hello``, before ``ready`` is sent (the startup
        timeout runs: 10 s by default from the process start)."""

    def on_prepare(self, road_map: RoadMap) -> None:
        """1.1+: called once with the whole map before ``prepared`` is sent
        (within what is left of the startup timeout); also in ``self.map``."""

    def on_route(self, route: Route) -> None:
        """Called before :meth:`plan` with each new route: a non-empty route
        of a revision not given before (1.1+), or every non-empty route in
        1.0 (a hint near the ego, new at each step)."""

    def plan(self, obs: Observation) -> Union[Control, Trajectory]:
        """The reply to one observation (within the step timeout, 1 s by
        default). Raise :class:`PlannerError` to give up."""
        raise NotImplementedError(f"{type(self).__name__} must override plan()")

    def on_bye(self) -> None:
        """Called when the rollout is over (``bye``, or end of stdin)."""

    def log(self, *args: Any) -> None:
        """Prints one line to stderr, prefixed with ``log_name`` (or
        ``name``). The harness keeps stderr as an artefact and shows its last
        lines when the planner fails."""
        print(f"{self.log_name or self.name}:", *args, file=sys.stderr, flush=True)


class _Session:
    """One run of the loop over given streams."""

    def __init__(self, planner: Planner, stdin: IO[str], out: IO[str], err: IO[str]) -> None:
        self.planner = planner
        self.stdin = stdin
        self.out = out
        self.err = err
        self.debug = os.environ.get(DEBUG_ENV, "") not in ("", "0")
        self.route_key: Optional[Tuple[Any, ...]] = None
        self.route: Optional[Route] = None
        self.failed = False
        self.seen: Optional[SeenLog] = None
        self.route_given: Optional[Route] = None

    def note(self, *args: Any) -> None:
        print("safer_planner:", *args, file=self.err, flush=True)

    def send(self, message: Dict[str, Any]) -> None:
        self.out.write(json.dumps(message, allow_nan=False) + "\n")
        self.out.flush()

    def give_up(self, message: str, step: Optional[int] = None, exc: Optional[BaseException] = None) -> None:
        """Answers ``error`` and logs why (with the traceback of ``exc``)."""
        self.failed = True
        if exc is not None and not isinstance(exc, PlannerError):
            self.err.write("".join(traceback.format_exception(type(exc), exc, exc.__traceback__)))
        self.note("giving up:", message)
        reply: Dict[str, Any] = {"type": "error", "message": message}
        if step is not None:
            reply["step"] = step
        self.send(reply)

    def serve(self) -> int:
        if self.debug:
            from . import __file__ as kit_file, __version__

            self.note(f"safer_planner {__version__} from {os.path.dirname(os.path.abspath(kit_file))}")
        line_no = 0
        while True:
            line = self.stdin.readline()
            if not line:
                # End of stdin without bye: the harness is gone.
                self.bye()
                return 1 if self.failed else 0
            line_no += 1
            if not line.strip():
                continue
            try:
                message = json.loads(line)
                if not isinstance(message, dict):
                    raise ValueError("not a JSON object")
            except ValueError as e:
                self.note(f"line {line_no} from the harness is not a JSON object ({e}): {line.strip()[:200]}")
                return 2
            kind = message.get("type")
            if self.debug:
                self.note(f"< {kind}" + (f" step {message.get('step')}" if kind == "observation" else ""))
            if kind == "hello":
                if not self.on_hello(message):
                    return 1
            elif kind == "prepare":
                self.on_prepare(message)
            elif kind == "observation":
                self.on_observation(message)
            elif kind == "bye":
                self.bye()
                return 1 if self.failed else 0
            else:
                self.note(f"ignoring a message of unknown type {kind!r}")

    def bye(self) -> None:
        """The rollout is over: the planner's ``on_bye``, then the seen log."""
        try:
            self.planner.on_bye()
        finally:
            if self.seen is not None:
                try:
                    self.seen.write()
                except OSError as e:  # the rollout is over: a log that cannot be written is no reason to fail it
                    self.note(f"cannot write the seen log {self.seen.path}: {e}")

    def on_hello(self, message: Dict[str, Any]) -> bool:
        p = self.planner
        try:
            hello = Hello.from_json(message)
        except (KeyError, TypeError, ValueError) as e:
            self.give_up(f"{p.name}: cannot read hello ({type(e).__name__}: {e})")
            return False
        if hello.protocol != PROTOCOL:
            self.give_up(f"protocol {hello.protocol} is not supported; {p.name} speaks protocol {PROTOCOL}")
            return False
        revision = min(p.protocol_minor, hello.protocol_minor)
        if revision < p.min_protocol_minor:
            self.give_up(
                f"{p.name} needs protocol 1.{p.min_protocol_minor} or later; the harness speaks 1.{hello.protocol_minor}"
            )
            return False
        if p.dt_s is not None and abs(hello.dt_s - p.dt_s) > 1e-9:
            self.give_up(f"{p.name} steps {p.dt_s} s; the harness steps {hello.dt_s} s")
            return False
        if p.plan_time_s is not None and hello.step_timeout_s is not None and hello.step_timeout_s < p.plan_time_s:
            p.log(
                f"a plan can take {p.plan_time_s} s; the harness's step timeout is {hello.step_timeout_s} s"
                " (the planner spec's step_timeout_ms)"
            )
        p.hello = hello
        p.revision = revision
        self.seen = SeenLog.open(p.seen_log or os.environ.get(SEEN_LOG_ENV), hello)
        try:
            p.on_hello(hello)
        except Exception as e:
            self.give_up(f"hello: {type(e).__name__}: {e}", exc=e)
            return False
        ready: Dict[str, Any] = {"type": "ready", "protocol": PROTOCOL}
        if p.protocol_minor > 0:
            ready["protocol_minor"] = p.protocol_minor
        ready["name"] = p.name
        self.send(ready)
        return True

    def on_prepare(self, message: Dict[str, Any]) -> None:
        try:
            road_map = RoadMap.from_json(message["map"])
            self.planner.map = road_map
            self.planner.on_prepare(road_map)
        except Exception as e:
            self.give_up(f"prepare: {type(e).__name__}: {e}", exc=e)
            return
        self.send({"type": "prepared"})

    def cached_route(self, message: Dict[str, Any]) -> Optional[Route]:
        """The route of the last observation when this one's is the same
        revision with the same ends (1.1+ sends it unchanged), else None."""
        revision = message.get("route_revision")
        points = message.get("route") or []
        if revision is None or len(points) < 2:
            return None
        key = (revision, len(points), tuple(points[0]), tuple(points[-1]))
        if key == self.route_key and self.route is not None:
            return self.route
        self.route_key = key
        self.route = Route(points, message.get("route_lanes") or [], revision)
        return self.route

    def on_observation(self, message: Dict[str, Any]) -> None:
        p = self.planner
        step = message.get("step")
        t0 = time.perf_counter()
        try:
            obs = Observation.from_json(message, self.cached_route(message))
        except (KeyError, TypeError, ValueError) as e:
            self.give_up(f"cannot read observation ({type(e).__name__}: {e})", step=step)
            return
        try:
            route = obs.route
            if p.route_required and not route:
                raise PlannerError(f"no route at step {obs.step}: {p.name} needs the route to plan")
            if route and (route.revision is None or self.route_given is None or route.revision != self.route_given.revision):
                self.route_given = route
                p.on_route(route)
            reply = p.plan(obs)
            if isinstance(reply, (Control, Trajectory)):
                out = reply.to_json(obs.step)
            else:
                raise TypeError(f"plan() returned {type(reply).__name__}; expected Control or Trajectory")
        except PlannerError as e:
            self.give_up(str(e), step=obs.step, exc=e)
            return
        except Exception as e:
            self.give_up(f"{type(e).__name__}: {e}", step=obs.step, exc=e)
            return
        self.send(out)
        if self.seen is not None:
            self.seen.observed(obs, reply)
        if self.debug:
            self.note(f"> {out['type']} step {obs.step} in {1000.0 * (time.perf_counter() - t0):.1f} ms")


def serve(
    planner: Planner,
    stdin: Optional[IO[str]] = None,
    stdout: Optional[IO[str]] = None,
    stderr: Optional[IO[str]] = None,
) -> int:
    """Serves one rollout over the given streams (default: the process's
    own) and returns the exit status: 0 after ``bye`` or end of input, 1
    when the planner gave up (an ``error`` was sent) or the protocol
    versions do not match, 2 when the harness sent a line that is not JSON.

    While it runs, ``sys.stdout`` is stderr. With the process's own stdout
    (``stdout`` left out) file descriptor 1 is pointed at stderr too, and the
    protocol goes to a duplicate of the original descriptor, so output from
    C extensions and child processes cannot reach the harness either.
    """
    err = stderr if stderr is not None else sys.stderr
    inp = stdin if stdin is not None else sys.stdin
    saved_stdout = sys.stdout
    out: IO[str]
    restore_fd: Optional[int] = None
    if stdout is not None:
        out = stdout
    else:
        try:
            saved_stdout.flush()
            proto_fd = os.dup(1)
            restore_fd = os.dup(1)
            os.dup2(2, 1)
            out = os.fdopen(proto_fd, "w", encoding="utf-8", newline="\n")
        except (OSError, ValueError):
            out, restore_fd = saved_stdout, None
    sys.stdout = err
    try:
        return _Session(planner, inp, out, err).serve()
    except BrokenPipeError:
        print("safer_planner: the harness closed its end of the pipe", file=err, flush=True)
        return 1
    finally:
        sys.stdout = saved_stdout
        if restore_fd is not None:
            try:
                out.close()
            except OSError:
                pass
            os.dup2(restore_fd, 1)
            os.close(restore_fd)


def run(planner: Union[Planner, Type[Planner]]) -> None:
    """Serves ``planner`` (an instance, or a class to instantiate) on
    stdin/stdout and exits the process with :func:`serve`'s status."""
    instance = planner() if isinstance(planner, type) else planner
    sys.exit(serve(instance))


__all__: List[str] = ["Planner", "PlannerError", "run", "serve", "DEBUG_ENV"]
