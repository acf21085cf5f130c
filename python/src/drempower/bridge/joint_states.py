"""The bridge's ``joint_states`` stream: every joint's state in SI units at the joint, at the bridge's rate.

``sensor_msgs/msg/JointState`` (NaN for a joint whose motor did not answer),
read bus after bus in one exchange per bus, published and handed to the other
outputs of the same states (``state_outputs``: the ros2_control topics).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..protocol.messages import FastRead
from ..robot.config import JointSpec
from ..robot.joint import Gearing
from . import rmw, rosmsg
from .bus_face import BusFace

__all__ = ["StateStream"]

_log = logging.getLogger("drempower.bridge")


class StateStream:
    """Publishes the states of ``joints`` (joint, gearing, its bus's face), read from ``faces`` in turn,
    through ``publisher`` (gid ``gid``) ``rate`` times a second from :meth:`start` to :meth:`close`.

    ``saw(bus, states)``: told each bus's fresh states (the diagnostics watch their
    error bits); ``outputs``: called with each payload after it is published.
    """

    def __init__(
        self,
        joints: Sequence[tuple[JointSpec, Gearing, BusFace]],
        faces: Sequence[BusFace],
        publisher: Any,
        gid: bytes,
        rate: float,
        saw: Callable[[str, Sequence[Any]], None],
        outputs: list[Callable[[bytes], None]],
    ) -> None:
        self._joints = list(joints)
        self._names = [j.name for j, _, _ in joints]
        self._faces = list(faces)
        self._pub = publisher
        self._gid = gid
        self._period = 1.0 / rate
        self._saw = saw
        self._outputs = outputs
        self._seq = 0
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="drempower bridge state", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def close(self, wait: float = 2.0) -> None:
        """Stop the stream (waits ``wait`` s at most for the message being published). Idempotent."""
        self._closed.set()
        if self._thread.is_alive():
            self._thread.join(wait)

    def message(self, states: Mapping[str, Any]) -> bytes:
        """The JointState of ``states`` (joint name -> state in wire units, or None), CDR."""
        import numpy as np

        t = rosmsg.typestore().types
        now = time.time_ns()
        nan = math.nan
        at_joint = [None if states.get(j.name) is None else g.joint_state(states[j.name]) for j, g, _ in self._joints]
        msg = t[rosmsg.JOINT_STATE](
            header=t["std_msgs/msg/Header"](
                stamp=t["builtin_interfaces/msg/Time"](sec=now // 1_000_000_000, nanosec=now % 1_000_000_000),
                frame_id="",
            ),
            name=list(self._names),
            position=np.array([s.position if s else nan for s in at_joint], dtype=np.float64),
            velocity=np.array([s.velocity if s else nan for s in at_joint], dtype=np.float64),
            effort=np.array([s.torque if s else nan for s in at_joint], dtype=np.float64),
        )
        return rosmsg.encode(msg, rosmsg.JOINT_STATE)

    def read(self) -> dict[str, Any]:
        """Every joint's state (wire units; None when its motor did not answer), bus after bus."""
        out: dict[str, Any] = {}
        for face in self._faces:
            try:
                got = face.bus.request([FastRead(i) for i in face.ids], missing_ok=True)
            except Exception as exc:
                if self._closed.is_set():
                    raise
                _log.warning("state stream of %s: %s", face.prefix, exc)
                continue
            for j, st in zip(face.joints, got, strict=True):
                out[j.name] = st
            self._saw(face.name, got)
        return out

    def _loop(self) -> None:
        next_at = time.monotonic()
        while not self._closed.is_set():
            try:
                payload = self.message(self.read())
                self._seq += 1
                att = rmw.Attachment(self._seq, time.time_ns(), self._gid).encode()
                self._pub.put(payload, attachment=att)
                for out in list(self._outputs):
                    out(payload)
            except Exception as exc:
                if self._closed.is_set():
                    return
                _log.warning("state stream: %s", exc)
            next_at += self._period
            delay = next_at - time.monotonic()
            if delay < 0:
                next_at = time.monotonic()
                delay = 0.0
            if self._closed.wait(delay):
                return
