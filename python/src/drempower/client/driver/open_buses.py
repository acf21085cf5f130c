"""The buses still open: each is closed (applying its ``stop_on_close``) when Python exits, and those
with ``stop_on_close`` when a termination signal arrives (see :mod:`.signals`)."""

from __future__ import annotations

import atexit
import weakref
from typing import TYPE_CHECKING

from . import signals

if TYPE_CHECKING:
    from .bus_driver import BusDriver

__all__ = ["SIGNAL_LOCK_WAIT", "forget", "register"]

SIGNAL_LOCK_WAIT = 0.2
"""Longest wait (s) for a lock when a signal handler closes a bus or sends an estop: the
interrupted code may hold it."""


_open: weakref.WeakSet[BusDriver] = weakref.WeakSet()


def register(bus: BusDriver) -> None:
    """Count ``bus`` as open until :func:`forget`."""
    _open.add(bus)


def forget(bus: BusDriver) -> None:
    """``bus`` closed."""
    _open.discard(bus)


@atexit.register
def _close_open_buses() -> None:
    """Close (and so apply ``stop_on_close`` to) every bus still open when Python exits."""
    for bus in list(_open):
        try:
            bus.close()
        except BaseException:  # a signal's handler cut this close short, handing it to a thread: wait for that
            bus.close()


def _close_stopping_buses() -> None:
    """From a signal handler: close every open bus with ``stop_on_close``, never waiting long on a lock."""
    for bus in list(_open):
        if bus.session.stop_on_close:
            bus.close(lock_timeout=SIGNAL_LOCK_WAIT)


signals.register_stopper(_close_stopping_buses)
