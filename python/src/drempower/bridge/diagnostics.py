"""``/diagnostics``: each joint's health as ``diagnostic_msgs/msg/DiagnosticArray``, at 1 Hz and on change.

One ``DiagnosticStatus`` per joint: ``name`` ``drempower/<joint>``, ``hardware_id``
``<bus>/motor <id>`` (``motor <id>`` for a bus served alone), ``level`` OK (0), WARN
(1: hot, derating, stalled), ERROR (2: an error flag) or STALE (3: no answer), a
``message`` (the worst condition, a fault with its fix) and the key-values
``motor_temp_c``, ``driver_temp_c``, ``current_limit_a``, ``derating`` and ``errors``.

Each second one supervisor step per bus (:mod:`drempower.client.engine.supervisor`)
reads every joint's state and health in one exchange, 12 frames per motor. Without a
policy it only warns (the bridge acts on nothing). With a robot file whose ``[health]``
asks for the supervisor (``drempower bridge --robot FILE``), each bus's policy sets the
period of the steps (its ``period``; the array still goes out each second) and the
actions: a joint's ``on_overheat`` and ``on_stall`` hold or idle it, the event is
logged (``drempower.health``) and the array goes out at once. The state stream's E
bits are watched too: when one changes, the array goes out at once with a fresh reading.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ..client.engine.supervisor import HealthEvent, HealthPolicy, Watch, prepare, supervise
from . import rmw, rosmsg

if TYPE_CHECKING:
    from .bus_face import BusFace

__all__ = ["DIAGNOSTIC_ARRAY", "Diagnostics", "OK", "WARN", "ERROR", "STALE", "PERIOD"]

DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
OK, WARN, ERROR, STALE = 0, 1, 2, 3
"""``diagnostic_msgs/msg/DiagnosticStatus`` levels."""
PERIOD = 1.0
"""Seconds between two arrays when nothing changes."""
_LEVEL = {"ok": OK, "warn": WARN, "error": ERROR}
_log = logging.getLogger("drempower.bridge")
_health_log = logging.getLogger("drempower.health")
_LOG_LEVEL = {"ok": logging.INFO, "warn": logging.WARNING, "error": logging.ERROR}


class _Row:
    __slots__ = ("hardware_id", "level", "message", "name", "values")

    def __init__(self, name: str, hardware_id: str) -> None:
        self.name = name
        self.hardware_id = hardware_id
        self.level = STALE
        self.message = "not read yet"
        self.values: list[tuple[str, str]] = []


class Diagnostics:
    """Publishes ``/diagnostics`` for the joints of ``faces`` through ``put(payload, attachment)``."""

    def __init__(
        self,
        faces: Mapping[str, BusFace],
        put: Callable[[bytes, bytes], None],
        gid: bytes,
        policies: Mapping[str, HealthPolicy] | None = None,
    ) -> None:
        self._faces = dict(faces)
        self._put = put
        self._gid = gid
        self._seq = 0
        self.policies = dict(policies or {})
        """Each bus's supervisor policy (a robot file's ``[health]``); a bus without one: warn only, each second."""
        self.period = min([PERIOD, *(p.period for p in self.policies.values())])
        """Seconds between two supervisor steps."""
        self.events: list[HealthEvent] = []
        """Every event the steps saw (and what they did)."""
        self._watches: dict[str, list[Watch]] = {}
        self._rows: dict[tuple[str, int], _Row] = {}
        for bus, face in self._faces.items():
            names = {j.id: j.name for j in face.joints}
            policy = self.policies.get(bus, HealthPolicy())
            self._watches[bus] = [Watch(i, policy, names.get(i)) for i in face.ids]
            for j in face.joints:
                hw = f"{bus}/motor {j.id}" if bus else f"motor {j.id}"
                self._rows[(bus, j.id)] = _Row(f"drempower/{j.name}", hw)
        self._errors: dict[tuple[str, int], bool] = {}
        self._wake = threading.Event()
        self._closed = threading.Event()
        self.published = 0
        """Arrays published so far."""
        self._thread = threading.Thread(target=self._loop, name="drempower bridge diagnostics", daemon=True)
        self._thread.start()

    def saw_states(self, bus: str, states: Sequence[Any]) -> None:
        """The state stream's latest states of bus ``bus``: a changed E bit publishes at once."""
        changed = False
        for st in states:
            if st is None:
                continue
            key = (bus, st.node)
            if self._errors.get(key, st.error) != st.error:
                changed = True
            self._errors[key] = st.error
        if changed:
            self._wake.set()

    def _read(self) -> bool:
        """One supervisor step per bus; True when an event began (the array goes out at once)."""
        seen = False
        for bus, face in self._faces.items():
            watches = self._watches[bus]
            try:
                fresh = [w for w in watches if w.limits.kt != w.limits.kt]
                if fresh:
                    face.bus.run(prepare(fresh))
                events: list[HealthEvent] = face.bus.run(supervise(watches, face.bus.now()))
                face.bus.health_acted(events)  # a joint idled is refused motion until enabled again
            except Exception as exc:
                for w in watches:
                    row = self._rows[(bus, w.node)]
                    row.level, row.message, row.values = STALE, f"no answer: {exc}", []
                continue
            for e in events:
                _health_log.log(_LOG_LEVEL[e.level], "bus %s: %s", bus or "-", e)
            self.events.extend(events)
            seen = seen or bool(events)
            worst: dict[int, HealthEvent] = {}
            for e in events:
                if e.motor not in worst or _LEVEL[e.level] > _LEVEL[worst[e.motor].level]:
                    worst[e.motor] = e
            for w in watches:
                row = self._rows[(bus, w.node)]
                h = w.last
                if h is None:
                    continue
                row.level = _LEVEL[w.level]
                event = worst.get(w.node)
                faults = sorted(h.faults, key=lambda f: f.word == "axis0.error")  # the specific words first
                if faults:
                    row.message = str(faults[0])
                elif event is not None:
                    row.message = str(event)
                elif w.level == "ok":
                    row.message = "OK"
                d = h.as_dict()
                row.values = [
                    ("motor_temp_c", f"{h.motor_temp_c:.1f}"),
                    ("driver_temp_c", f"{h.driver_temp_c:.1f}"),
                    ("current_limit_a", f"{h.current_limit_a:.2f}"),
                    ("derating", f"{h.derating:.3f}"),
                    ("errors", " ".join(d["errors"]) or "none"),
                ]
        return seen

    def message(self) -> bytes:
        """The DiagnosticArray of the rows as they stand (CDR)."""
        t = rosmsg.typestore().types
        now = time.time_ns()
        stamp = t["builtin_interfaces/msg/Time"](sec=now // 1_000_000_000, nanosec=now % 1_000_000_000)
        status = [
            t["diagnostic_msgs/msg/DiagnosticStatus"](
                level=r.level,
                name=r.name,
                message=r.message,
                hardware_id=r.hardware_id,
                values=[t["diagnostic_msgs/msg/KeyValue"](key=k, value=v) for k, v in r.values],
            )
            for r in self._rows.values()
        ]
        msg = t[DIAGNOSTIC_ARRAY](header=t["std_msgs/msg/Header"](stamp=stamp, frame_id=""), status=status)
        return rosmsg.encode(msg, DIAGNOSTIC_ARRAY)

    def publish(self) -> None:
        """Read every joint's health and publish the array."""
        self._read()
        self._send()

    def _send(self) -> None:
        self._seq += 1
        self._put(self.message(), rmw.Attachment(self._seq, time.time_ns(), self._gid).encode())
        self.published += 1

    def _loop(self) -> None:
        due = 0.0  # the next array's time when nothing changes (time.monotonic s)
        while not self._closed.is_set():
            try:
                changed = self._read()
                now = time.monotonic()
                if changed or self._wake.is_set() or now >= due:
                    self._wake.clear()
                    self._send()
                    due = now + PERIOD
            except Exception as exc:
                if self._closed.is_set():
                    return
                _log.warning("/diagnostics: %s", exc)
            self._wake.wait(self.period)

    def close(self) -> None:
        self._closed.set()
        self._wake.set()
        self._thread.join(timeout=5.0)
