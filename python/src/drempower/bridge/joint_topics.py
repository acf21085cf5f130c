"""The interface of ``topic_based_ros2_control``'s ``TopicBasedSystem``: joint commands and states as JointState.

ros2_control with the ``topic_based_ros2_control/TopicBasedSystem`` hardware
plugin publishes each joint's command on ``/robot_joint_commands`` and reads
the joints from ``/robot_joint_states``, both ``sensor_msgs/msg/JointState``.
:class:`JointTopics` serves that pair on a :class:`~drempower.bridge.server.Bridge`:

* each command message's ``name`` entries are mapped to the bridge's joints (a
  name it does not serve refuses the whole message, nothing sent, with one
  rate-limited warning); the values are SI at the joint (rad, rad/s, Nm);
* the joints' ``command_interfaces`` (those the URDF's ``<ros2_control>`` block
  declares; ``TopicBasedSystem`` fills all three arrays, 0 for an interface
  not declared, so the bridge uses only the declared ones) say what a command is:

  ================================  ==============================================
  ``position``                      filtered position (T mode, ``bandwidth``)
  ``velocity``                      speed
  ``effort``                        torque
  ``position, velocity``            position with speed feed-forward (P mode)
  ``position, effort``              position with torque feed-forward (P mode)
  ``position, velocity, effort``    impedance: ``kp``, ``kd`` with both feed-forwards
  ================================  ==============================================

* commands pass the safety gate of the bridge's bus (soft limits of the robot
  file, a motor not in closed loop refused: call the ``enable`` service first);
* ``TopicBasedSystem`` publishes only when a position changes by more than
  1e-5: silence from a publisher whose rmw_zenoh liveliness token is alive holds
  the last command (:class:`~drempower.client.engine.watchdog.Watchdog`); when its token
  is gone each joint does its ``on_timeout`` (``hold``: speed 0 in closed loop,
  ``idle``). A publisher without a token (not rmw_zenoh) is gone after
  ``timeout`` s of silence.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from ..client.engine.commands import PositionMode, make_angle, make_impedance, make_speed, make_torque
from ..client.engine.watchdog import Watchdog, stop_messages
from ..errors import DrEmpowerError
from ..protocol.messages import Message, StartImpedance
from . import rmw, rosmsg
from .bus_face import check_joint_value, pass_face_gate

if TYPE_CHECKING:
    from .bus_face import BusFace
    from .server import Bridge

__all__ = [
    "COMMAND_INTERFACES",
    "DEFAULT_COMMANDS_TOPIC",
    "DEFAULT_STATES_TOPIC",
    "JointTopics",
    "check_interfaces",
]

_log = logging.getLogger("drempower.bridge")

DEFAULT_COMMANDS_TOPIC = "/robot_joint_commands"
"""``TopicBasedSystem``'s ``joint_commands_topic`` default."""
DEFAULT_STATES_TOPIC = "/robot_joint_states"
"""``TopicBasedSystem``'s ``joint_states_topic`` default."""
COMMAND_INTERFACES = ("position", "velocity", "effort")
_CONTROLLER = "joint_commands"
"""The watchdog's name of the command topic's publishers."""


def check_interfaces(interfaces: Sequence[str]) -> tuple[str, ...]:
    """``interfaces`` as a checked tuple in :data:`COMMAND_INTERFACES` order; ValueError naming what is wrong."""
    got = [str(i).strip() for i in interfaces if str(i).strip()]
    for name in got:
        if name not in COMMAND_INTERFACES:
            raise ValueError(f"command_interfaces: {name!r}: expected some of {', '.join(COMMAND_INTERFACES)}")
    out = tuple(i for i in COMMAND_INTERFACES if i in got)
    if not out:
        raise ValueError("command_interfaces: none given: expected some of position, velocity, effort")
    if out == ("velocity", "effort"):
        raise ValueError("command_interfaces: velocity and effort without position: give one of them, or position too")
    return out


class JointTopics:
    """Serve ``TopicBasedSystem``'s command and state topics on ``bridge`` until :meth:`close` (or the bridge's).

    ``commands``/``states``: topic names (relative ones in the bridge's namespace);
    ``interfaces``: the joints' command interfaces (see the module); ``kp``/``kd``:
    impedance gains (Nm/rad at the motor, Nm/(rad/s)); ``timeout``: s of silence
    that end a publisher without a liveliness token.
    """

    def __init__(
        self,
        bridge: Bridge,
        commands: str = DEFAULT_COMMANDS_TOPIC,
        states: str = DEFAULT_STATES_TOPIC,
        *,
        interfaces: Sequence[str] = ("position",),
        kp: float = 20.0,
        kd: float = 1.0,
        timeout: float = 0.5,
    ) -> None:
        import zenoh

        self.bridge = bridge
        self.interfaces = check_interfaces(interfaces)
        if not (0 <= kp <= 1000 and 0 <= kd <= 1000):
            raise ValueError(f"kp={kp!r}, kd={kd!r}: impedance gains are 0..1000")
        self.kp, self.kd = float(kp), float(kd)
        self._zenoh = zenoh
        o, s = bridge.options, bridge.session
        ns = bridge.namespace
        zid = str(s.zid())
        self._faces = {j.name: (j, g, f) for j, g, f in bridge.joints}
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._decls: list[Any] = []
        self.received = 0
        """Command messages that reached the motors."""
        self.refused = 0
        """Command messages refused (unknown names, bad values, the safety gate)."""
        self.fired = 0
        """Times the publisher was found gone and the joints did their ``on_timeout``."""
        self.busy: Callable[[], str | None] = lambda: None
        """Says why commands are refused now, if they are (a trajectory goal executing), else None."""
        self._dogs: dict[str, Watchdog] = {}
        for name, face in bridge.faces.items():
            on = {j.id: getattr(j, "on_timeout", "hold") for j in face.joints}
            self._dogs[name] = Watchdog(timeout, on)
            for j in face.joints:
                lim = getattr(j, "limits", None)
                if lim:
                    face.bus.set_limits(j.id, **_gearing(j).motor_limits(lim), where=f"joint {j.name!r} limits")
        self._driven: dict[str, set[int]] = {}
        """Per bus, the motors the commands named (those the publisher's watch stops)."""
        self._registered: bool | None = None
        """None: no command yet; else whether the publisher was registered with a liveness signal."""
        self._publishers: set[str] = set()
        jst = rosmsg.JOINT_STATE
        dds, h = rosmsg.dds_type_name(jst), rosmsg.ros_type_hash(jst)
        self.commands_topic = rmw.qualify(ns, commands)
        self.states_topic = rmw.qualify(ns, states)
        base = 1000  # entity ids of their own, after the bridge's

        def token(entity: int, kind: rmw.EntityKind, fq: str) -> str:
            return rmw.entity_token(o.domain_id, zid, 0, base + entity, kind, ns, o.node_name, fq, dds, h)

        self.commands_key = rmw.topic_key(o.domain_id, self.commands_topic, dds, h)
        self.states_key = rmw.topic_key(o.domain_id, self.states_topic, dds, h)
        sub_token = token(1, "MS", self.commands_topic)
        pub_token = token(2, "MP", self.states_topic)
        self._gid = rmw.make_gid(pub_token)
        self._seq = 0
        self._mangled = (rmw.mangle(self.commands_topic), dds)
        try:
            self._decls.append(s.liveliness().declare_token(sub_token))
            self._decls.append(s.liveliness().declare_token(pub_token))
            self._pub = s.declare_publisher(self.states_key)
            self._decls.append(self._pub)
            self._decls.append(
                s.liveliness().declare_subscriber(f"{rmw.ADMIN_SPACE}/{o.domain_id}/**", self._on_entity, history=True)
            )
            self._decls.append(s.declare_subscriber(self.commands_key, self._on_command))
        except BaseException:
            self.close()
            raise
        bridge.state_outputs.append(self._publish_states)
        self._thread = threading.Thread(target=self._tick_loop, name="drempower bridge joint topics", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ states

    def _publish_states(self, payload: bytes) -> None:
        """Publish the bridge's JointState (every joint, SI at the joint) on the states topic too."""
        self._seq += 1
        self._pub.put(payload, attachment=rmw.Attachment(self._seq, time.time_ns(), self._gid).encode())

    # ------------------------------------------------------------------ commands

    def _messages(self, msg: Any) -> dict[str, list[Message]]:
        """Each bus's messages for JointState ``msg``; ValueError naming the joint and value (nothing sent)."""
        names = [str(n) for n in msg.name]
        unknown = [n for n in names if n not in self._faces]
        if unknown:
            raise ValueError(f"unknown joint {unknown[0]!r}: the joints are {', '.join(self._faces)}")
        if len(set(names)) != len(names):
            raise ValueError("a joint is named twice")
        arrays = {"position": msg.position, "velocity": msg.velocity, "effort": msg.effort}
        used = self.interfaces
        for key in used:
            n = len(arrays[key])
            allowed = (len(names),) if key == "position" else (0, len(names))
            if n not in allowed:
                raise ValueError(f"{key}: {n} values for {len(names)} names")
        out: dict[str, list[Message]] = {}
        for k, name in enumerate(names):
            j, g, face = self._faces[name]
            vals = {key: float(arrays[key][k]) if len(arrays[key]) else 0.0 for key in used}
            for key, x in vals.items():  # each value by its row of the actions table, in the table's words
                check_joint_value(face, f"{key}_commands", j, g, x)
            try:
                msgs = out.setdefault(face.name, [])
                if used == ("position",):
                    msgs.append(make_angle(j.id, g.motor_angle(vals["position"]), 0.0, self.bridge.options.bandwidth))
                elif used == ("velocity",):
                    msgs.append(make_speed(j.id, g.motor_speed(vals["velocity"])))
                elif used == ("effort",):
                    msgs.append(make_torque(j.id, g.motor_torque(vals["effort"])))
                elif len(used) == 2:
                    speed = g.motor_speed(vals.get("velocity", 0.0))
                    torque = g.motor_torque(vals.get("effort", 0.0))
                    angle = g.motor_angle(vals["position"])
                    msgs.append(make_angle(j.id, angle, speed, torque, PositionMode.P))
                else:
                    preset, _ = make_impedance(
                        j.id,
                        g.motor_angle(vals["position"]),
                        g.motor_speed(vals["velocity"]),
                        g.motor_torque(vals["effort"]),
                        self.kp,
                        self.kd,
                    )
                    msgs.append(preset)
            except (DrEmpowerError, ValueError) as exc:
                raise ValueError(f"joint {name!r}: {exc}") from exc
        return out

    def _send(self, batches: dict[str, list[Message]]) -> None:
        """Every bus's messages through its safety gate first, then sent (nothing sent if one bus refuses)."""
        faces = self.bridge.faces
        for name, msgs in batches.items():
            pass_face_gate(faces[name], msgs)
        for name, msgs in batches.items():
            bus = faces[name].bus
            if self.interfaces == COMMAND_INTERFACES:
                bus.send_batch(msgs, StartImpedance(0, self.kp, self.kd))
            else:
                bus.send_many(msgs)

    def _on_command(self, sample: Any) -> None:
        try:
            msg = rosmsg.decode(sample.payload.to_bytes(), rosmsg.JOINT_STATE)
        except Exception as exc:
            _log.warning("%s: not a sensor_msgs/msg/JointState (%s)", self.commands_topic, exc)
            self.refused += 1
            return
        with self._lock:
            if self._closed.is_set():
                return
            try:
                why = self.busy()
                if why:
                    raise ValueError(why)
                batches = self._messages(msg)
                self._send(batches)
            except (DrEmpowerError, ValueError) as exc:
                self.bridge.refuse(self.commands_topic, str(exc))  # logged, and told on /rosout
                self.refused += 1  # after the words: a reader of the count finds them said
                return
            now = time.monotonic()
            live = bool(self._publishers)  # a token now (one gone and a later publisher without: none)
            for name, msgs in batches.items():  # only the joints the command names are the publisher's
                driven = self._driven.setdefault(name, set())
                driven.update(m.node for m in msgs if m.node)
                self._dogs[name].update(_CONTROLLER, sorted(driven), now=now, liveness=live)
                self._dogs[name].feed(_CONTROLLER, now)
            if batches:
                self._registered = live
            self.received += 1

    # ------------------------------------------------------------------ the publisher's life

    def _on_entity(self, sample: Any) -> None:
        """Track the command topic's rmw_zenoh publishers; the last one gone fires the joints' ``on_timeout``."""
        key = str(sample.key_expr)
        parts = key.split("/")
        if len(parts) < 12 or parts[5] != "MP" or (parts[9], parts[10]) != self._mangled:
            return
        with self._lock:
            if sample.kind != self._zenoh.SampleKind.DELETE:
                self._publishers.add(key)
                if self._registered is False:  # its token came after its first command: its liveness counts now
                    now = time.monotonic()
                    for name, dog in self._dogs.items():
                        if self._driven.get(name):
                            dog.update(_CONTROLLER, sorted(self._driven[name]), now=now, liveness=True)
                    self._registered = True
                elif self._registered:
                    for dog in self._dogs.values():
                        if _CONTROLLER in dog.controllers():
                            dog.alive(_CONTROLLER, True)
                return
            self._publishers.discard(key)
            if self._publishers or not self._registered:
                return
            _log.info("%s: its last publisher %s left", self.commands_topic, parts[2])
            for dog in self._dogs.values():
                if _CONTROLLER in dog.controllers():
                    dog.alive(_CONTROLLER, False)
            self._fire(time.monotonic())

    def _fire(self, now: float) -> None:
        """Carry out what the watchdogs find gone (caller holds the lock)."""
        if self.bridge.closed:  # the bridge idles what was driven
            return
        for name, dog in self._dogs.items():
            fired = dog.tick(now)
            if not fired:
                continue
            self.fired += 1
            face: BusFace = self.bridge.faces[name]
            actions = sorted({f"{n}: {a}" for f in fired for n, a in f.actions.items()})
            _log.info("%s: its publisher is gone; motors %s", self.commands_topic, ", ".join(actions))
            try:
                msgs = stop_messages(fired)
                face.bus.send_many(msgs)
            except Exception as exc:  # a Zenoh callback must not raise
                _log.error("stopping the motors of %s failed: %s", face.prefix, exc)

    def _tick_loop(self) -> None:
        period = min(dog.timeout for dog in self._dogs.values()) / 4
        while not self._closed.wait(period) and not self.bridge.closed:
            with self._lock:
                if self._registered is False:
                    self._fire(time.monotonic())

    def close(self) -> None:
        """Stop serving the two topics. Idempotent (the bridge's close idles what was driven)."""
        with self._lock:
            if self._closed.is_set():
                return
            self._closed.set()
        if self._publish_states in self.bridge.state_outputs:
            self.bridge.state_outputs.remove(self._publish_states)
        for d in reversed(self._decls):
            try:
                d.undeclare()
            except Exception as exc:
                _log.debug("undeclare: %s", exc)


def _gearing(j: Any) -> Any:
    from ..robot.joint import Gearing

    return Gearing(j)
