"""The dashboard's watchdog: with ``--watchdog`` each motor found idles by itself when the dashboard is gone."""

from __future__ import annotations

from collections.abc import Sequence

from ..errors import DrEmpowerError
from .keys import MotorKeys
from .logline import log

__all__ = ["TIMEOUT_MS", "Watchdog"]

TIMEOUT_MS = "can.config.timeout_ms"
"""The motor's CAN timeout (ms): with ``--watchdog`` a motor idles by itself when the dashboard is gone."""


class Watchdog:
    """The CAN timeout ``ms`` given to each motor found while the dashboard runs (None: none), and what
    each armed motor held before (put back by :meth:`restore`)."""

    def __init__(self, keys: MotorKeys, ms: int | None) -> None:
        self._keys = keys
        self.ms = ms
        self.before: dict[int, int] = {}
        """The CAN timeout each armed motor held before, by key."""

    def arm(self, keys: Sequence[int]) -> None:
        """Give each motor of ``keys`` not yet armed the CAN timeout :attr:`ms`, keeping what it held
        before: killed or cut off, the dashboard leaves no motor driving for longer than that."""
        for i in keys:
            if i in self.before or self.ms is None:
                continue
            m = self._keys.motor(i)
            try:
                before = int(m.read_property(TIMEOUT_MS))
                m.write_property(TIMEOUT_MS, self.ms, verify=True)
            except DrEmpowerError as exc:
                log(f"{self._keys.label(i)}: could not arm the watchdog ({TIMEOUT_MS} = {self.ms}): {exc}")
                continue
            self.before[i] = before
            log(f"{self._keys.label(i)}: watchdog armed: {TIMEOUT_MS} = {self.ms} (was {before})")

    def restore(self) -> None:
        """Put back the CAN timeout each armed motor held before."""
        for i, ms in sorted(self.before.items()):
            if self._keys.where(i)[0].closed:
                continue
            try:
                self._keys.motor(i).write_property(TIMEOUT_MS, ms, verify=True)
            except DrEmpowerError as exc:
                log(f"{self._keys.label(i)}: could not restore {TIMEOUT_MS} to {ms}: {exc}")
        self.before.clear()
