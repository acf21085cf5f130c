"""The dashboard's samples: state frames by subscription, the polling that asks for them within a budget of
the bus, the parameter plots, and the bus load."""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from ..client import MotorState
from ..errors import DrEmpowerError, ValidationError
from ..protocol import FastRead
from ..protocol.parameters import find_parameter
from .keys import KEYS_PER_BUS, MotorKeys
from .targets import Targets
from .watchdog import Watchdog

__all__ = ["ASSUMED_BITRATE", "BITS_PER_FRAME", "POLL_BUDGET", "Sample", "Sampler"]

Sample = tuple[int, float, float, float, float, int, float | None, float | None, float | None]
"""(key, t s, angle deg, speed r/min, torque Nm, flags (1 = T, 2 = E), target angle, speed, torque)."""

BITS_PER_FRAME = 130
"""Bits on the wire of one 8-byte standard CAN frame with stuffing (about), for the bus load."""
ASSUMED_BITRATE = 1_000_000
"""The CAN bit rate (bit/s) the bus load is reckoned against when the transport does not know it."""
POLL_BUDGET = 0.30
"""Share of a bus the dashboard's polling (state fast reads and parameter plots of every browser
together, request and reply frames) may take."""


class Sampler:
    """Samples of every motor of ``keys`` (at the joint for a robot joint, with the ``targets``), polled
    ``poll_hz`` times a second while the motors send no heartbeat; parameter plots; the bus load."""

    def __init__(self, keys: MotorKeys, targets: Targets, watchdog: Watchdog, poll_hz: float) -> None:
        self._keys = keys
        self._targets = targets
        self._watchdog = watchdog
        self.poll_hz = poll_hz
        self.t0 = time.monotonic()
        self.samples: deque[Sample] = deque()
        self.samples_total = 0
        self.heartbeat_ms = 0
        self.scanning = False
        self.param_samples: deque[tuple[int, str, float, float]] = deque()
        self.load = 0.0
        self.frame_rate = 0.0
        self._watch: dict[tuple[int, str], tuple[float, float]] = {}
        self._tokens = [0.0 for _ in keys.buses]
        self._frames_mark = [(time.monotonic(), b.stats["frames_received"]) for _, b in keys.buses]
        self._stop = threading.Event()
        self._subs = [b.subscribe(self._sink(k * KEYS_PER_BUS)) for k, (_, b) in enumerate(keys.buses)]
        self._poller = threading.Thread(target=self._poll_loop, name="dash poll", daemon=True)
        self._poller.start()

    def close(self) -> None:
        """Stop the polling and the subscriptions."""
        self._stop.set()
        for sub in self._subs:
            sub.cancel()
        self._poller.join(2.0)

    def _sink(self, off: int) -> Callable[[MotorState], None]:
        """The subscriber of the bus whose keys start at ``off``."""
        return lambda st: self._on_state(st, off)

    def _on_state(self, st: MotorState, off: int = 0) -> None:
        key = off + st.node
        tg = self._targets.targets.get(key)
        flags = int(st.trajectory_done) | (int(st.error) << 1)
        t = st.timestamp - self.t0
        u = self._keys.units.get(key)  # a joint's samples and targets at the joint
        if u is None:
            angle, speed, torque = st.angle, st.speed, st.torque
        else:
            angle, speed, torque = u.angle(st.angle), u.speed(st.speed), u.torque(st.torque)
        if tg is None:
            self.samples.append((key, t, angle, speed, torque, flags, None, None, None))
        elif u is None:
            self.samples.append((key, t, angle, speed, torque, flags, tg[0], tg[1], tg[2]))
        else:
            a, v, q = (None if x is None else f(x) for x, f in zip(tg, (u.angle, u.speed, u.torque), strict=True))
            self.samples.append((key, t, angle, speed, torque, flags, a, v, q))
        self.samples_total += 1

    def take_samples(self) -> list[Sample]:
        """Every sample that arrived since the last call, oldest first (none is dropped)."""
        q = self.samples
        return [q.popleft() for _ in range(len(q))]

    def budget(self, k: int = 0) -> float:
        """Requests per second the dashboard's polling may send on bus ``k`` (each has a reply):
        POLL_BUDGET of its bit rate (ASSUMED_BITRATE when unknown) in frames of BITS_PER_FRAME."""
        rate = self._keys.buses[k][1].transport.wire_bitrate or ASSUMED_BITRATE
        return POLL_BUDGET * rate / BITS_PER_FRAME / 2

    def budget_text(self) -> str:
        """The polling budget as the page and the docs word it."""
        return f"{POLL_BUDGET * 100:.0f} % of the bus ({self.budget():.0f} requests/s with their replies)"

    def _planned(self, k: int) -> float:
        """Requests per second bus ``k``'s polling asks for: the state fast reads and the parameter plots."""
        ids = [key for key in self._keys.found if key // KEYS_PER_BUS == k]
        state = 0.0 if self.heartbeat_ms else len(ids) * self.poll_hz
        plots = sum(1.0 / period for (i, _), (period, _) in self._watch.items() if i // KEYS_PER_BUS == k)
        return state + plots

    def _spend(self, k: int, n: int) -> bool:
        """Take ``n`` requests from bus ``k``'s polling budget; False (nothing taken) when it lacks them."""
        if self._tokens[k] < n:
            return False
        self._tokens[k] -= n
        return True

    def _poll_loop(self) -> None:
        next_t = last = time.monotonic()
        keep_alive = 0.0
        buses = self._keys.buses
        while not self._stop.is_set():
            now = time.monotonic()
            for k in range(len(buses)):  # the budget refills; at most 0.1 s of it is saved up
                self._tokens[k] = min(self._tokens[k] + (now - last) * self.budget(k), self.budget(k) * 0.1)
            last = now
            # with --watchdog and heartbeats on, a fast read every third of the timeout keeps the motors going
            armed = self._watchdog.before
            alive = bool(armed) and now >= keep_alive
            if alive:
                keep_alive = now + (self._watchdog.ms or 0) / 3000.0
            found = self._keys.found
            if found and (alive or (not self.heartbeat_ms and not self.scanning)):
                keys = sorted(set(found) | set(armed))
                for k, (_, bus) in enumerate(buses):
                    ids = [key % KEYS_PER_BUS for key in keys if key // KEYS_PER_BUS == k]
                    if ids and not bus.closed and (self._spend(k, len(ids)) or alive):
                        try:
                            bus.request([FastRead(i) for i in ids], missing_ok=True)
                        except DrEmpowerError:
                            pass
            if self._watch and not self.scanning:
                self._read_watched()
            next_t = max(next_t + 1.0 / self.poll_hz, time.monotonic())
            self._stop.wait(max(0.0, next_t - time.monotonic()))

    def watch(self, i: int, name: str, hz: float) -> None:
        """Read parameter ``name`` of motor ``i`` ``hz`` times a second (0 stops) into :attr:`param_samples`."""
        p = find_parameter(name)
        if p is None:
            raise ValidationError(f"parameter {name!r}: no such parameter")
        self._keys.key({"id": i})
        if not 0 <= hz <= self.poll_hz:
            raise ValidationError(f"rate={hz!r}: 0 (stop) or up to {self.poll_hz:g} readings/s")
        if hz == 0:
            self._watch.pop((i, p.name), None)
            return
        k = i // KEYS_PER_BUS
        old = self._watch.get((i, p.name))
        planned = self._planned(k) - (1.0 / old[0] if old else 0.0) + hz
        if planned > self.budget(k):
            raise ValidationError(
                f"rate={hz:g}: plotting {p.name} would take this dashboard's polling to {planned:.0f} requests/s, "
                f"over its budget of {self.budget_text()} for every browser together; "
                "stop another parameter plot or choose a lower rate"
            )
        self._watch[(i, p.name)] = (1.0 / hz, time.monotonic())

    def _read_watched(self) -> None:
        now = time.monotonic()
        for key, (period, due) in list(self._watch.items()):
            if now < due:
                continue
            i, name = key
            if not self._spend(i // KEYS_PER_BUS, 1):
                continue  # over budget: this reading waits for a later round
            try:
                value = self._keys.motor(i).read_property(name, timeout=0.1)
            except DrEmpowerError:
                continue
            finally:
                if key in self._watch:
                    self._watch[key] = (period, max(due + period, now))
            self.param_samples.append((i, name, time.monotonic() - self.t0, value))

    def watched(self) -> list[list[Any]]:
        """``[id, name, rate]`` of every watched parameter."""
        return [[i, n, round(1.0 / period, 3)] for (i, n), (period, _) in sorted(self._watch.items())]

    def take_param_samples(self) -> list[tuple[int, str, float, float]]:
        q = self.param_samples
        return [q.popleft() for _ in range(len(q))]

    def measure_load(self) -> None:
        """Update :attr:`load` (fraction of a 1 Mbit/s bus; the busiest bus) and :attr:`frame_rate`
        (received frames/s, every bus) from received frames."""
        now = time.monotonic()
        if now - self._frames_mark[0][0] < 0.2:
            return
        rates = []
        for k, (_, bus) in enumerate(self._keys.buses):
            t, f = self._frames_mark[k]
            frames = bus.stats["frames_received"]
            rates.append((frames - f) / (now - t))
            self._frames_mark[k] = (now, frames)
        self.frame_rate = sum(rates)
        self.load = max(
            r * BITS_PER_FRAME / (b.transport.wire_bitrate or ASSUMED_BITRATE)
            for r, (_, b) in zip(rates, self._keys.buses, strict=True)
        )
