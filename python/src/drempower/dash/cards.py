"""The motor cards: supply, axis state, temperatures, decoded errors, and the health supervisor's say."""

from __future__ import annotations

import time
from collections import deque
from typing import TYPE_CHECKING, Any

from ..errors import DrEmpowerError
from ..naming import state_name
from ..protocol import ERROR_WORDS, flag_info
from .keys import MotorKeys
from .limits import MotorLimits
from .logline import log

if TYPE_CHECKING:
    from ..client.engine.supervisor import HealthEvent
    from ..robot.health_run import HealthRun

__all__ = ["HEALTH_EVENTS_SHOWN", "TREND_POINTS", "Cards"]

TREND_POINTS = 600
"""Health readings kept per motor for the Health view's trends (one per card refresh: 10 minutes at 1 s)."""
HEALTH_EVENTS_SHOWN = 5
"""The latest supervisor events a card (and its row of the Health view) shows."""
_CARD_READS = (
    ("vbus", "vbus_voltage"),
    ("state", "axis0.current_state"),
)
_LABEL = {w.name: w.label for w in ERROR_WORDS}


class Cards:
    """The cards of the motors found (``keys.found``), with their limits as shown, their health trends and
    the events of the robot's health supervisor (``health_run``, when the robot file has ``[health]``)."""

    def __init__(self, keys: MotorKeys, limits: MotorLimits, health_run: HealthRun | None) -> None:
        self._keys = keys
        self._limits = limits
        self._t0 = time.monotonic()
        self.trends: dict[int, deque[tuple[float, float, float, float]]] = {}
        """Per motor key, its health readings (s since start, winding degC, board degC, derating 0..1)."""
        self.health_events: deque[tuple[int, float, HealthEvent]] = deque(maxlen=500)
        """The supervisor's events (key, wall s since start, event)."""
        self._health_run = health_run
        self._health_seen: set[HealthEvent] = set()
        if health_run is not None:
            health_run.add_listener(self._on_health)
            for e in list(health_run.events):  # those of its steps before this dashboard listened
                self._on_health(e)

    def close(self) -> None:
        if self._health_run is not None:
            self._health_run.remove_listener(self._on_health)

    def _on_health(self, event: HealthEvent) -> None:
        """An event of the robot's health supervisor: kept for the cards and the Health view, logged (once)."""
        key = next((k for k, j in self._keys.joints.items() if j["joint"] == event.joint), None)
        if key is None or event in self._health_seen:
            return
        self._health_seen.add(event)
        self.health_events.append((key, round(time.monotonic() - self._t0, 2), event))
        log(f"health: {event}")

    def read(self) -> dict[int, dict[str, Any]]:
        """Supply voltage, axis state, temperatures and decoded error flags of every known motor."""
        cards: dict[int, dict[str, Any]] = {}
        for i in sorted(self._keys.found):
            cards[i] = self._card(i)
        return cards

    def _card(self, i: int) -> dict[str, Any]:
        m = self._keys.motor(i)
        found = self._keys.found.get(i, {})
        card: dict[str, Any] = {"id": i, "fw": found.get("fw"), "hw": found.get("hw")}
        for key, name in _CARD_READS:
            try:
                card[key] = m.read_property(name, timeout=0.2)
            except DrEmpowerError:
                card[key] = None
        card["state_name"] = state_name(card["state"])
        card["limits"] = self._limits.shown(i)
        st = m.state
        card["errors"] = []
        try:  # temperatures, effective current limit, derating and errors with their fixes (5 reads, +7 faulted)
            h = m.health(timeout=0.2)
        except DrEmpowerError:
            h = None
        if h is not None:
            card.update(
                fet_temp=h.driver_temp_c,
                motor_temp=h.motor_temp_c,
                current_limit=h.current_limit_a,
                derating=h.derating,
            )
            trend = self.trends.setdefault(i, deque(maxlen=TREND_POINTS))
            trend.append((round(time.monotonic() - self._t0, 2), round(h.motor_temp_c, 2),
                          round(h.driver_temp_c, 2), round(h.derating, 4)))  # fmt: skip
            card["trend"] = list(trend)
            card["errors"] = [{"word": f.word, "flag": f.flag, "meaning": f.meaning, "advice": f.fix} for f in h.faults]
        else:
            card.update(fet_temp=None, motor_temp=None, current_limit=None, derating=None)
        if h is None and st is not None and st.error:
            try:
                report = m.dump_error(timeout=0.2)
                card["errors"] = []
                for w, names in report.flags.items():
                    for f in names:
                        info = flag_info(_LABEL[w], f)
                        card["errors"].append({"word": w, "flag": f, "meaning": info.meaning, "advice": info.action})
            except DrEmpowerError:
                card["errors"] = [{"word": "?", "flag": "error (unread)", "advice": "read again"}]
        self._card_health(i, card)
        return card

    def _card_health(self, key: int, card: dict[str, Any]) -> None:
        """The robot's health supervisor's say on motor ``key``: its level and latest events (with what it did)."""
        run = self._health_run
        if run is None:
            return
        j = self._keys.joints.get(key)
        card["level"] = None if j is None else run.levels().get((j["bus"], j["id"]))
        card["events"] = [
            {"t": t, "kind": e.kind, "level": e.level, "action": e.action, "text": str(e)}
            for k, t, e in list(self.health_events)
            if k == key
        ][-HEALTH_EVENTS_SHOWN:]
