"""``drempower demo``: the README's main job, a synchronised move of simulated motors shown live."""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass, field
from typing import Any

from .. import open_bus
from ..client import Bus, MotorState, PositionMode
from ..naming import motor_name
from ..protocol import FastRead
from ._connect import positive, sim_time_scale
from ._output import LiveView, fmt, is_terminal, json_line, number_text

GROUP = "simulator"
"""Where ``drempower --help`` lists this module's subcommands."""

TARGETS = (90.0, -45.0, 180.0, -120.0, 60.0, -180.0, 135.0, -90.0)
"""Target angles (deg) of motors 1, 2, 3...; more motors reuse them."""
SPEED = 10.0
"""Cruise speed (r/min) of the motor moving furthest."""
ACCEL = 20.0
"""Acceleration ((r/min)/s) of every motor."""
TOLERANCE = 0.5
"""How close (deg) a motor must end to its target."""
_POLL = 0.02
_PLAIN_EVERY = 0.5
_BAR = 24


def register(sub: Any) -> None:
    p = sub.add_parser(
        "demo",
        help="drive simulated motors through a synchronised move, shown live (no hardware needed)",
        description=(
            "Start an in-process simulator, move its motors together to different angles (Q mode: every "
            "motor gets the same move time, one broadcast start), show the move live and report how well "
            "they kept together."
        ),
    )
    p.add_argument(
        "--motors", type=int, choices=range(1, 9), default=3, metavar="N", help="motors 1..N (1-8, default 3)"
    )
    p.add_argument("--time-scale", type=positive, metavar="X", help="simulated time runs X times faster (default 1)")
    p.add_argument("--json", action="store_true", help="print only the summary, as one JSON object")
    p.set_defaults(func=run)


@dataclass(frozen=True, slots=True)
class Plan:
    """The trapezoid one motor follows in a synchronised Q move: ``distance`` deg in ``duration`` s.

    Every motor gets the same duration and acceleration (``accel`` deg/s^2), so each
    cruises at its own speed (PROTOCOL.md 3.4.3, solved for the cruise speed).
    """

    distance: float
    duration: float
    accel: float

    @property
    def cruise(self) -> float:
        """Cruise speed (deg/s)."""
        a, t, d = self.accel, self.duration, self.distance
        return a * t / 2 - math.sqrt(max(0.0, (a * t) ** 2 / 4 - a * d))

    def _ramp(self) -> tuple[float, float, float]:
        v = self.cruise
        ta = v / self.accel
        return v, ta, self.accel * ta * ta / 2

    def travelled(self, t: float) -> float:
        """Distance (deg) covered ``t`` s after the start."""
        v, ta, ramp = self._ramp()
        t = min(max(t, 0.0), self.duration)
        if t <= ta:
            return self.accel * t * t / 2
        if t <= self.duration - ta:
            return ramp + v * (t - ta)
        return self.distance - self.accel * (self.duration - t) ** 2 / 2

    def time_at(self, travelled: float) -> float:
        """When (s after the start) the plan has covered ``travelled`` deg."""
        v, ta, ramp = self._ramp()
        x = min(max(travelled, 0.0), self.distance)
        if x <= ramp:
            return math.sqrt(2 * x / self.accel)
        if x <= self.distance - ramp:
            return ta + (x - ramp) / v
        return self.duration - math.sqrt(2 * (self.distance - x) / self.accel)


@dataclass
class Tracker:
    """How far the motors drift apart during a synchronised move.

    At each sample the group's progress is the mean time along the motors' own
    plans; a motor's sync error is its distance (deg) from where its plan puts it
    at that time. The positions are taken at one simulated instant (see :func:`_positions_now`).
    """

    starts: dict[int, float]
    targets: dict[int, float]
    plans: dict[int, Plan] = field(default_factory=dict)
    max_sync_error: float = 0.0

    def plan(self, duration: float, accel: float) -> None:
        for node, start in self.starts.items():
            distance = abs(self.targets[node] - start)
            if distance > 0:
                self.plans[node] = Plan(distance, duration, accel)

    def travelled(self, st: MotorState) -> float:
        return abs(st.angle - self.starts[st.node])

    def add(self, positions: dict[int, float]) -> None:
        """Take one sample: every motor's position (deg) at the same instant."""
        moving = {n: abs(a - self.starts[n]) for n, a in positions.items() if n in self.plans}
        if not moving:
            return
        when = sum(self.plans[n].time_at(d) for n, d in moving.items()) / len(moving)
        for n, d in moving.items():
            self.max_sync_error = max(self.max_sync_error, abs(d - self.plans[n].travelled(when)))

    def bar(self, st: MotorState) -> str:
        span = abs(self.targets[st.node] - self.starts[st.node])
        done = 1.0 if span == 0 else min(self.travelled(st) / span, 1.0)
        filled = round(_BAR * done)
        return "#" * filled + "." * (_BAR - filled)


def _states(bus: Bus, ids: list[int]) -> list[MotorState]:
    states: list[MotorState] = bus.request([FastRead(i) for i in ids])
    return states


def _positions_now(bus: Bus) -> dict[int, float]:
    """Every simulated motor's position (deg) at one simulated instant.

    Fast reads are answered one after the other, so positions read over the bus
    are apart by the time between the answers (times the time scale); the sync
    error is measured on the simulator's own clock instead.
    """
    sim = bus.transport.bus  # type: ignore[attr-defined]
    with sim.lock:
        return {m.node_id: m.position for m in sim.motors.values()}


def _table(tracker: Tracker, states: list[MotorState], t: float) -> list[str]:
    lines = [f"t = {t:5.2f} s"]
    for st in states:
        target = tracker.targets[st.node]
        done = "done" if st.trajectory_done else ""
        lines.append(
            f"{motor_name(st.node)}  [{tracker.bar(st)}] {number_text(st.angle, 2, 8)} / "
            f"{number_text(target, 2, 7)} deg  {number_text(st.speed, 2, 6)} rpm  {done}"
        )
    return lines


def run(args: argparse.Namespace) -> int:
    ids = list(range(1, args.motors + 1))
    targets = [TARGETS[(i - 1) % len(TARGETS)] for i in ids]
    scale = args.time_scale or sim_time_scale(args) or 1.0
    out = sys.stdout
    live = LiveView(out) if is_terminal(out) and not args.json else None

    def say(text: str) -> None:
        if not args.json:
            print(text)

    say(
        f"{len(ids)} simulated motors (time x{scale:g}): a synchronised Q move to "
        f"{', '.join(f'{a:g}' for a in targets)} deg at up to {SPEED:g} rpm, accel {ACCEL:g} rpm/s"
    )
    with open_bus("sim", motors=ids, time_scale=scale, stop_on_close=False) as bus:
        tracker = Tracker({st.node: st.angle for st in _states(bus, ids)}, dict(zip(ids, targets, strict=True)))
        planned = bus.set_angles(ids, targets, SPEED, ACCEL, PositionMode.Q) or 0.0
        tracker.plan(planned, 6 * ACCEL)
        say(f"presets sent, then one broadcast start; every motor takes {planned:g} s")
        start = time.monotonic()
        shown = -_PLAIN_EVERY
        while True:
            t = (time.monotonic() - start) * scale
            states = _states(bus, ids)
            tracker.add(_positions_now(bus))
            finished = all(st.trajectory_done for st in states)
            if live is not None:
                live.draw(_table(tracker, states, t))
            elif finished or t - shown >= _PLAIN_EVERY * scale:
                shown = t
                say(f"t = {t:5.2f} s  " + "  ".join(f"{motor_name(st.node)} {fmt(st.angle):>7} deg" for st in states))
            if finished:
                break
            if t > 2 * planned + 5:
                print("drempower: error: the motors did not finish in time", file=sys.stderr)
                return 1
            time.sleep(_POLL)
    misses = [abs(st.angle - tracker.targets[st.node]) for st in states]
    reached = sum(m <= TOLERANCE for m in misses)
    if args.json:
        summary = {
            "motors": ids,
            "targets_deg": targets,
            "move_time_s": planned,
            "reached": reached,
            "largest_miss_deg": round(max(misses), 4),
            "max_sync_error_deg": round(tracker.max_sync_error, 4),
        }
        print(json_line(summary))
    else:
        print(f"targets reached: {reached}/{len(ids)} (largest miss {max(misses):.3f} deg)")
        print(
            f"max sync error: {tracker.max_sync_error:.3f} deg "
            "(the furthest any motor strayed from its planned profile at the group's progress)"
        )
    return 0 if reached == len(ids) else 1
