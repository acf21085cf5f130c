"""The bridge's ROS 2 command topics (``position_commands``, ``velocity_commands``, ``effort_commands``).

Each message (``std_msgs/msg/Float64MultiArray``, one value per joint, SI at the
joint) is checked value by value by its row of :mod:`drempower.actions` and by
every bus's safety gate before any bus is sent anything; a refusal is told
through ``refuse(topic, why)``. A topic that drove the joints idles them when it
falls silent for the command timeout, or when its last publisher goes.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..client.engine.commands import make_angles, make_speeds, make_torques
from ..errors import DrEmpowerError
from ..protocol.messages import Message
from ..robot.config import JointSpec
from ..robot.joint import Gearing
from . import rmw, rosmsg
from .bus_face import COMMAND_TOPICS, BusFace, check_joint_value, pass_face_gate

__all__ = ["CommandTopics"]

_log = logging.getLogger("drempower.bridge")


@dataclass
class _Stream:
    """A ROS 2 command topic: which motors it drives, when it last spoke, who publishes it."""

    last: float = 0.0
    driven: bool = False
    count: int = 0
    publishers: set[str] = field(default_factory=set)
    """Liveliness tokens (key expressions) of the topic's live ``MP`` publishers."""
    lock: threading.Lock = field(default_factory=threading.Lock)


class CommandTopics:
    """The command topics of ``joints`` (joint, gearing, its bus's face) in namespace ``ns``.

    ``bandwidth``: T-mode filter bandwidth (1/s) of position commands;
    ``refuse(topic, why)``: told each refusal (nothing was sent).
    """

    def __init__(
        self,
        joints: Sequence[tuple[JointSpec, Gearing, BusFace]],
        faces: Mapping[str, BusFace],
        ns: str,
        bandwidth: float,
        refuse: Callable[[str, str], None],
    ) -> None:
        import zenoh

        self._zenoh = zenoh
        self._joints = list(joints)
        self._names = [j.name for j, _, _ in joints]
        self._faces = dict(faces)
        self._bandwidth = bandwidth
        self._refuse = refuse
        self._closed = threading.Event()
        self._streams = {topic: _Stream() for topic in COMMAND_TOPICS}
        self._publisher_topics = {
            (rmw.mangle(rmw.qualify(ns, topic)), rosmsg.dds_type_name(rosmsg.FLOAT64_MULTI_ARRAY)): topic
            for topic in COMMAND_TOPICS
        }
        self.busy: Callable[[], str | None] = lambda: None
        """Says why the command topics are refused now (a trajectory goal executing: its action sets it),
        else None: a stray command then neither moves the joints nor starts the topic's watch."""

    @property
    def driven(self) -> bool:
        """Whether a topic drives the joints now."""
        return any(stream.driven for stream in self._streams.values())

    def forget_driven(self) -> None:
        """The joints were stopped (an estop): no topic drives them now."""
        for stream in self._streams.values():
            stream.driven = False

    def close(self) -> None:
        """Take no more commands (those arriving now are dropped)."""
        self._closed.set()

    def idle_all(self) -> None:
        """Idle every motor served, bus after bus (a bus that fails does not keep the others from idling)."""
        for face in self._faces.values():
            try:
                face.idle()
            except Exception as exc:
                _log.error("idling the motors of %s failed: %s", face.prefix, exc)

    def on_ros_entity(self, sample: Any) -> None:
        """Count the live publishers of each command topic; when the last one goes, idle what the topic drove at once.

        While another publisher of the topic is alive the motors stay driven
        (the command timeout still idles them if it falls silent).
        """
        key = str(sample.key_expr)
        parts = key.split("/")
        if len(parts) < 12 or parts[5] != "MP":
            return
        topic = self._publisher_topics.get((parts[9], parts[10]))
        if topic is None:
            return
        stream = self._streams[topic]
        with stream.lock:
            if sample.kind != self._zenoh.SampleKind.DELETE:
                stream.publishers.add(key)
                return
            stream.publishers.discard(key)
            left = len(stream.publishers)
            if left:
                _log.info("%s: its publisher %s left; %d still publish", topic, parts[2], left)
            elif stream.driven:
                stream.driven = False
                _log.info("%s: its last publisher %s left; idling %s", topic, parts[2], ", ".join(self._names))
                self.idle_all()

    def check_silent(self, timeout: float) -> None:
        """Idle the joints a topic drove when it was silent for ``timeout`` s."""
        now = time.monotonic()
        for topic, stream in self._streams.items():
            if stream.driven and now - stream.last > timeout:
                with stream.lock:
                    if stream.driven and time.monotonic() - stream.last > timeout:
                        stream.driven = False
                        _log.info("%s silent for %.3f s: idling %s", topic, timeout, ", ".join(self._names))
                        self.idle_all()

    def _commands(self, topic: str, data: Sequence[float]) -> list[tuple[BusFace, list[int], list[float]]]:
        """Each bus's motors and values (motor units) for ``data`` (one value per joint, SI at the joint),
        every value checked by the topic's row through its bus's command service first (the table's words,
        naming the joint)."""
        groups: dict[str, tuple[list[int], list[float]]] = {}
        for (j, g, face), x in zip(self._joints, data, strict=True):
            v = check_joint_value(face, topic, j, g, x)
            ids, values = groups.setdefault(j.bus, ([], []))
            ids.append(j.id)
            values.append(v)
        return [(self._faces[bus], ids, values) for bus, (ids, values) in groups.items()]

    def _presets(self, topic: str, ids: list[int], values: list[float]) -> list[Message]:
        """The presets of one bus's command (what its safety gate checks)."""
        if topic == "position_commands":
            return make_angles(ids, values, 0.0, self._bandwidth, 0)[0]
        if topic == "velocity_commands":
            return make_speeds(ids, values)[0]
        return make_torques(ids, values)[0]

    def _pass_gates(self, topic: str, batches: Sequence[tuple[BusFace, list[int], list[float]]]) -> None:
        """Every bus's safety gate for its part of a command, before any bus is sent anything: soft limits,
        and motors in closed loop (refused with :class:`MotorIdleError`'s words, the fix a ROS 2 caller's)."""
        for face, ids, values in batches:
            pass_face_gate(face, self._presets(topic, ids, values))

    def on_command(self, topic: str, sample: Any) -> None:
        """A message of command topic ``topic``: checked, gated, sent to every bus (or refused, nothing sent)."""
        try:
            msg = rosmsg.decode(sample.payload.to_bytes(), rosmsg.FLOAT64_MULTI_ARRAY)
        except Exception as exc:
            _log.warning("%s: not a std_msgs/msg/Float64MultiArray (%s)", topic, exc)
            return
        data = [float(x) for x in msg.data]
        if len(data) != len(self._joints):
            _log.warning(
                "%s: %d values, the joints are %d (%s)", topic, len(data), len(self._joints), ", ".join(self._names)
            )
            return
        stream = self._streams[topic]
        with stream.lock:
            if self._closed.is_set():
                return
            try:
                why = self.busy()
                if why:
                    raise ValueError(why)
                batches = self._commands(topic, data)  # nothing is sent on any bus if a value is invalid
                self._pass_gates(topic, batches)  # nor if a bus's gate refuses
                for face, ids, values in batches:
                    if topic == "position_commands":
                        face.bus.set_angles(ids, values, 0.0, self._bandwidth, 0)
                    elif topic == "velocity_commands":
                        face.bus.set_speeds(ids, values)
                    else:
                        face.bus.set_torques(ids, values)
            except (DrEmpowerError, ValueError) as exc:
                self._refuse(topic, str(exc))
                return
            stream.last = time.monotonic()
            stream.driven = True
            stream.count += 1
