"""The bridge's node on ``/rosout`` (``rcl_interfaces/msg/Log``): what ``ros2 topic echo /rosout`` and
rqt_console show, and the refusals of its command topics told there."""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

from ..logline import RateLimit
from . import rmw, rosmsg

__all__ = ["ROSOUT_WARN", "RosOut"]

_log = logging.getLogger("drempower.bridge")

ROSOUT_WARN = 30
"""``rcl_interfaces/msg/Log``'s WARN level."""


class RosOut:
    """Says things on ``/rosout`` through ``publisher`` (its gid ``gid``) as node ``node`` (its dotted name)."""

    def __init__(self, publisher: Any, gid: bytes, node: str) -> None:
        self._pub = publisher
        self._gid = gid
        self.node = node
        self._seq = 0
        self._lock = threading.Lock()
        self._limit = RateLimit()
        self.refused = 0
        """Commands of the ROS 2 topics refused (a value out of range, the safety gate); nothing was sent."""
        self.last_refusal: str | None = None
        """The words of the last refusal (those of :mod:`drempower.actions` and the safety gate)."""

    def refuse(self, topic: str, why: str) -> None:
        """A command of ``topic`` refused (nothing sent): counted, kept (:attr:`last_refusal`), logged, and
        told the ROS 2 side (one message per topic and second, the next one saying how many were held back)."""
        self.refused += 1
        self.last_refusal = text = f"{topic} refused: {why}"
        _log.warning("%s refused: %s", topic, why)
        kind = logging.LogRecord(_log.name, logging.WARNING, __file__, 0, f"{topic} refused", None, None)
        if self._limit.filter(kind):
            self.say(ROSOUT_WARN, text + str(kind.msg)[len(f"{topic} refused") :])

    def say(self, level: int, text: str) -> None:
        """Say ``text`` on ``/rosout`` at ``level`` (``rcl_interfaces/msg/Log``'s constants)."""
        t = rosmsg.typestore().types
        now = time.time_ns()
        msg = t[rosmsg.LOG](
            stamp=t["builtin_interfaces/msg/Time"](sec=now // 1_000_000_000, nanosec=now % 1_000_000_000),
            level=level,
            name=self.node,
            msg=text,
            file="",
            function="",
            line=0,
        )
        try:
            with self._lock:
                self._seq += 1
                att = rmw.Attachment(self._seq, now, self._gid).encode()
                self._pub.put(rosmsg.encode(msg, rosmsg.LOG), attachment=att)
        except Exception as exc:  # a closing session: the log line is there
            _log.debug("/rosout: %s", exc)
