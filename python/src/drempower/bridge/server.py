"""The bridge: one bus or a whole robot on Zenoh, for drempower clients (frames tunnelled) and ROS 2 (rmw_zenoh).

The drempower face is one per bus (:class:`BusFace`): a bus served alone under
the key prefix, each bus of a robot under ``<prefix>/<bus>``. The ROS 2 face is
one for all: ``joint_states`` holds every joint in SI units at the joint (after
the robot file's gear and offset), and each value of a command goes to its
joint's bus and motor through the same gear.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from .. import actions
from ..client.api.bus_sync import Bus
from ..client.engine.commands import make_angles, make_speeds, make_torques
from ..client.engine.supervisor import HealthPolicy
from ..errors import DrEmpowerError
from ..logline import RateLimit
from ..naming import motor_name
from ..protocol.messages import FastRead, Message
from ..robot.config import JOINT_NAME, JointSpec, RobotSpec
from ..robot.joint import Gearing
from ..transports.base import Transport
from . import rmw, rosmsg
from .bus_face import (
    _FENCED,
    COMMAND_TOPICS,
    DEFAULT_BANDWIDTH,
    DEFAULT_COMMAND_TIMEOUT,
    DEFAULT_RATE,
    NODE_NAME,
    ROSOUT_WARN,
    SERVICE_ROWS,
    BridgeOptions,
    BusFace,
    check_joint_value,
    motor_joints,
    pass_face_gate,
)
from .diagnostics import DIAGNOSTIC_ARRAY, Diagnostics
from .hub import BusHub
from .order import ServiceOrder

__all__ = [
    "Bridge",
    "BridgeOptions",
    "BusFace",
    "DEFAULT_RATE",
    "DEFAULT_COMMAND_TIMEOUT",
    "DEFAULT_BANDWIDTH",
    "NODE_NAME",
    "motor_joints",
]

_log = logging.getLogger("drempower.bridge")
_log.addFilter(RateLimit())  # a flood of malformed samples or commands logs one line per kind per second


@dataclass
class _Stream:
    """A ROS 2 command topic: which motors it drives, when it last spoke, who publishes it."""

    last: float = 0.0
    driven: bool = False
    count: int = 0
    publishers: set[str] = field(default_factory=set)
    """Liveliness tokens (key expressions) of the topic's live ``MP`` publishers."""
    lock: threading.Lock = field(default_factory=threading.Lock)


class Bridge:
    """Serve ``transport`` (one bus) or ``{bus name: transport}`` (a robot) on Zenoh ``session`` until :meth:`close`.

    One bus is served under ``options.prefix``; each bus of a robot under
    ``<prefix>/<bus>`` (``options.joints`` then maps names to the robot file's
    joints). The bridge owns neither the session nor the transports: the caller
    closes them after :meth:`close`, which idles every motor the bridge or its
    clients set moving.
    """

    def __init__(self, transport: Transport | Mapping[str, Transport], session: Any, options: BridgeOptions) -> None:
        import zenoh

        self.options = o = options
        self.session = session
        self._zenoh = zenoh
        specs = o.specs()
        transports: dict[str, Transport] = dict(transport) if isinstance(transport, Mapping) else {"": transport}
        if not transports:
            raise ValueError("transport: no bus to serve")
        for j in specs:
            if j.bus not in transports:
                where = f"bus {j.bus!r}" if j.bus else "no bus (a bare motor id)"
                raise ValueError(f"joint {j.name!r}: {where}; the buses are {', '.join(map(repr, transports))}")
        for name in transports:
            if name and not JOINT_NAME.match(name):
                raise ValueError(f"bus {name!r}: letters, digits, '_', '.' or '-', starting with a letter or '_'")
            if not any(j.bus == name for j in specs):
                raise ValueError(f"bus {name!r}: no joint is on it")
        self._closed = threading.Event()
        self._order = ServiceOrder()
        self.refused = 0
        """Commands of the ROS 2 topics refused (a value out of range, the safety gate); nothing was sent."""
        self.last_refusal: str | None = None
        """The words of the last refusal (those of :mod:`drempower.actions` and the safety gate)."""
        self.busy: Callable[[], str | None] = lambda: None
        """Says why the command topics are refused now (a trajectory goal executing: its action sets it),
        else None: a stray command then neither moves the joints nor starts the topic's watch."""
        self._rosout_limit = RateLimit()
        self._rosout_lock = threading.Lock()
        self.faces: dict[str, BusFace] = {}
        """The drempower face of each bus by name (``""`` for a bus served alone)."""
        self._joints: list[tuple[JointSpec, Gearing, BusFace]] = []
        self._decls: list[Any] = []
        self._tokens: list[Any] = []
        self.state_outputs: list[Callable[[bytes], None]] = []
        """Called with each JointState payload after ``joint_states`` (other topics of the same states)."""
        try:
            for name, t in transports.items():
                prefix = o.prefix if not name else f"{o.prefix.strip('/')}/{name}"
                self.faces[name] = BusFace(
                    name, t, session, prefix, [j for j in specs if j.bus == name], o.command_timeout, o.timeout, o.robot
                )
            self._joints = [(j, Gearing(j), self.faces[j.bus]) for j in specs]
            self._names = [j.name for j in specs]
            self._declare_ros()
        except BaseException:
            self.close()
            raise
        self._threads = [
            threading.Thread(target=self._state_loop, name="drempower bridge state", daemon=True),
            threading.Thread(target=self._watchdog_loop, name="drempower bridge watchdog", daemon=True),
        ]
        for th in self._threads:
            th.start()

    # ------------------------------------------------------------------ one bus (its face's parts)

    @property
    def _face(self) -> BusFace:
        return next(iter(self.faces.values()))

    @property
    def hub(self) -> BusHub:
        """The hub of the first (or only) bus."""
        return self._face.hub

    @property
    def bus(self) -> Bus:
        """The bridge's own client of the first (or only) bus."""
        return self._face.bus

    @property
    def clients_idled(self) -> int:
        """Remote clients that went away while driving motors (every bus)."""
        return sum(f.clients_idled for f in self.faces.values())

    @property
    def dropped_by_estop(self) -> int:
        """Client frames dropped because an estop overtook them (every bus)."""
        return sum(f.dropped_by_estop for f in self.faces.values())

    def _on_tx(self, sample: Any) -> None:
        self._face._on_tx(sample)

    def _on_estop(self, sample: Any) -> None:
        self._face._on_estop(sample)

    @property
    def _write_lock(self) -> threading.Lock:
        return self._face._write_lock

    # ------------------------------------------------------------------ ROS 2 face

    def _declare_ros(self) -> None:
        o, s = self.options, self.session
        zid = str(s.zid())
        ns = o.namespace if o.namespace.startswith("/") or not o.namespace else "/" + o.namespace
        self.namespace = ns
        self._tokens.append(s.liveliness().declare_token(rmw.node_token(o.domain_id, zid, 0, ns, o.node_name)))
        entity = 0

        def declare(kind: rmw.EntityKind, name: str, typename: str) -> tuple[str, bytes]:
            nonlocal entity
            entity += 1
            fq = rmw.qualify(ns, name)
            dds, h = rosmsg.dds_type_name(typename), rosmsg.ros_type_hash(typename)
            token = rmw.entity_token(o.domain_id, zid, 0, entity, kind, ns, o.node_name, fq, dds, h)
            self._tokens.append(s.liveliness().declare_token(token))
            return rmw.topic_key(o.domain_id, fq, dds, h), rmw.make_gid(token)

        self.joint_states_key, self._gid = declare("MP", "joint_states", rosmsg.JOINT_STATE)
        self._js_pub = s.declare_publisher(self.joint_states_key)
        self._js_seq = 0
        self._streams: dict[str, _Stream] = {}
        self.command_keys: dict[str, str] = {}
        for topic in COMMAND_TOPICS:
            key, _ = declare("MS", topic, rosmsg.FLOAT64_MULTI_ARRAY)
            self.command_keys[topic] = key
            self._streams[topic] = _Stream()
            self._decls.append(s.declare_subscriber(key, lambda sample, t=topic: self._on_command(t, sample)))
        self.service_keys: dict[str, str] = {}
        for name in ("estop", "clear_errors", "enable"):
            key, _ = declare("SS", name, rosmsg.TRIGGER)
            self.service_keys[name] = key
            self._decls.append(s.declare_queryable(key, lambda q, n=name: self._serve(q, n), complete=True))
        self._rosout_key, self._rosout_gid = declare("MP", "/rosout", rosmsg.LOG)
        self._rosout_pub = s.declare_publisher(self._rosout_key)
        self._decls.append(self._rosout_pub)
        self._rosout_seq = 0
        diag_key, diag_gid = declare("MP", "/diagnostics", DIAGNOSTIC_ARRAY)
        self.diagnostics_key = diag_key
        self._diag_pub = s.declare_publisher(diag_key)
        self._decls.append(self._diag_pub)
        self.diagnostics = Diagnostics(
            self.faces, lambda p, a: self._diag_pub.put(p, attachment=a), diag_gid, _health_policies(o.robot)
        )
        """``/diagnostics``: each joint's health at 1 Hz and on change (:mod:`drempower.bridge.diagnostics`)."""
        self._publisher_topics = {
            (rmw.mangle(rmw.qualify(ns, topic)), rosmsg.dds_type_name(rosmsg.FLOAT64_MULTI_ARRAY)): topic
            for topic in COMMAND_TOPICS
        }
        self._decls.append(
            s.liveliness().declare_subscriber(f"{rmw.ADMIN_SPACE}/{o.domain_id}/**", self._on_ros_entity, history=True)
        )

    def _idle_all(self) -> None:
        """Idle every motor served, bus after bus (a bus that fails does not keep the others from idling)."""
        for face in self.faces.values():
            try:
                face.idle()
            except Exception as exc:
                _log.error("idling the motors of %s failed: %s", face.prefix, exc)

    def _on_ros_entity(self, sample: Any) -> None:
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
                self._idle_all()

    def _joint_state(self, states: Mapping[str, Any]) -> bytes:
        store = rosmsg.typestore()
        import numpy as np

        t = store.types
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

    def _read_states(self) -> dict[str, Any]:
        """Every joint's state (wire units; None when its motor did not answer), bus after bus."""
        out: dict[str, Any] = {}
        for face in self.faces.values():
            try:
                got = face.bus.request([FastRead(i) for i in face.ids], missing_ok=True)
            except Exception as exc:
                if self._closed.is_set():
                    raise
                _log.warning("state stream of %s: %s", face.prefix, exc)
                continue
            for j, st in zip(face.joints, got, strict=True):
                out[j.name] = st
            diag = getattr(self, "diagnostics", None)
            if diag is not None:
                diag.saw_states(face.name, got)
        return out

    def _state_loop(self) -> None:
        period = 1.0 / self.options.rate
        next_at = time.monotonic()
        while not self._closed.is_set():
            try:
                payload = self._joint_state(self._read_states())
                self._js_seq += 1
                att = rmw.Attachment(self._js_seq, time.time_ns(), self._gid).encode()
                self._js_pub.put(payload, attachment=att)
                for out in list(self.state_outputs):
                    out(payload)
            except Exception as exc:
                if self._closed.is_set():
                    return
                _log.warning("state stream: %s", exc)
            next_at += period
            delay = next_at - time.monotonic()
            if delay < 0:
                next_at = time.monotonic()
                delay = 0.0
            if self._closed.wait(delay):
                return

    def _commands(self, topic: str, data: Sequence[float]) -> list[tuple[BusFace, list[int], list[float]]]:
        """Each bus's motors and values (motor units) for ``data`` (one value per joint, SI at the joint),
        every value checked by the topic's row of :mod:`drempower.actions` first (its words, naming the joint)."""
        groups: dict[str, tuple[list[int], list[float]]] = {}
        for (j, g, _), x in zip(self._joints, data, strict=True):
            v = check_joint_value(topic, j, g, x)
            ids, values = groups.setdefault(j.bus, ([], []))
            ids.append(j.id)
            values.append(v)
        return [(self.faces[bus], ids, values) for bus, (ids, values) in groups.items()]

    def _presets(self, topic: str, ids: list[int], values: list[float]) -> list[Message]:
        """The presets of one bus's command (what its safety gate checks)."""
        if topic == "position_commands":
            return make_angles(ids, values, 0.0, self.options.bandwidth, 0)[0]
        if topic == "velocity_commands":
            return make_speeds(ids, values)[0]
        return make_torques(ids, values)[0]

    def _pass_gates(self, topic: str, batches: Sequence[tuple[BusFace, list[int], list[float]]]) -> None:
        """Every bus's safety gate for its part of a command, before any bus is sent anything: soft limits,
        and motors in closed loop (refused with :class:`MotorIdleError`'s words, the fix a ROS 2 caller's)."""
        for face, ids, values in batches:
            pass_face_gate(face, self._presets(topic, ids, values))

    def _on_command(self, topic: str, sample: Any) -> None:
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
                        face.bus.set_angles(ids, values, 0.0, self.options.bandwidth, 0)
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

    def _refuse(self, topic: str, why: str) -> None:
        """A command of ``topic`` refused (nothing sent): counted, kept (:attr:`last_refusal`), logged, and
        told the ROS 2 side on ``/rosout`` (one message per topic and second, the next one saying how many
        were held back)."""
        self.refused += 1
        self.last_refusal = text = f"{topic} refused: {why}"
        _log.warning("%s refused: %s", topic, why)
        kind = logging.LogRecord(_log.name, logging.WARNING, __file__, 0, f"{topic} refused", None, None)
        if self._rosout_limit.filter(kind):
            self.rosout(ROSOUT_WARN, text + str(kind.msg)[len(f"{topic} refused") :])

    def rosout(self, level: int, text: str) -> None:
        """Say ``text`` on ``/rosout`` (``rcl_interfaces/msg/Log``, ``level`` as its constants), as the
        bridge's node: what ``ros2 topic echo /rosout`` and rqt_console show."""
        t = rosmsg.typestore().types
        now = time.time_ns()
        o = self.options
        name = ".".join(p for p in (*self.namespace.strip("/").split("/"), o.node_name) if p)
        msg = t[rosmsg.LOG](
            stamp=t["builtin_interfaces/msg/Time"](sec=now // 1_000_000_000, nanosec=now % 1_000_000_000),
            level=level,
            name=name,
            msg=text,
            file="",
            function="",
            line=0,
        )
        try:
            with self._rosout_lock:
                self._rosout_seq += 1
                att = rmw.Attachment(self._rosout_seq, now, self._rosout_gid).encode()
                self._rosout_pub.put(rosmsg.encode(msg, rosmsg.LOG), attachment=att)
        except Exception as exc:  # a closing session: the log line is there
            _log.debug("/rosout: %s", exc)

    def _watchdog_loop(self) -> None:
        timeout = self.options.command_timeout
        while not self._closed.wait(timeout / 4):
            for face in self.faces.values():
                face.check_clients()
            now = time.monotonic()
            for topic, stream in self._streams.items():
                if stream.driven and now - stream.last > timeout:
                    with stream.lock:
                        if stream.driven and time.monotonic() - stream.last > timeout:
                            stream.driven = False
                            _log.info("%s silent for %.3f s: idling %s", topic, timeout, ", ".join(self._names))
                            self._idle_all()

    def _serve(self, query: Any, name: str) -> None:
        """Answer a call of service ``name``: an estop at once; the others one at a time in arrival order,
        each in a thread of its own (an enable waits for closed loop: Zenoh's callback, which an estop
        from the same link would wait behind, returns at once)."""
        if name == "estop":
            self._reply(query, *self._srv_estop())
            return
        ticket = self._order.arrive()  # here: the order of arrival
        threading.Thread(
            target=self._serve_in_turn, args=(query, name, ticket), name=f"drempower bridge {name}", daemon=True
        ).start()

    def _serve_in_turn(self, query: Any, name: str, ticket: int) -> None:
        try:
            with self._order.turn(ticket):
                handler = self._srv_enable if name == "enable" else self._srv_clear_errors
                success, message = handler(ticket)
        except Exception as exc:  # a reply in every case: the caller waits for one
            success, message = False, f"{name} failed: {exc}"
        self._reply(query, success, message)

    def _reply(self, query: Any, success: bool, message: str) -> None:
        """The ``std_srvs/srv/Trigger`` response to ``query``, with rmw_zenoh's attachment."""
        att = query.attachment.to_bytes() if query.attachment is not None else b""
        try:
            req = rmw.Attachment.decode(att)
        except ValueError:
            req = rmw.Attachment(0, 0, bytes(rmw.GID_SIZE))
        t = rosmsg.typestore().types
        payload = rosmsg.encode(
            t[rosmsg.TRIGGER + "_Response"](success=success, message=message), rosmsg.TRIGGER + "_Response"
        )
        reply = rmw.Attachment(req.sequence_number, time.time_ns(), req.gid).encode()
        try:
            query.reply(query.key_expr, payload, attachment=reply)
            query.drop()  # the reply is final
        except Exception as exc:  # the session closed meanwhile
            _log.warning("service reply not sent: %s", exc)

    def estop(self) -> list[str]:
        """Emergency stop of every motor served on every bus at once; returns the failures (``"bus: error"``).

        The first bus is stopped from the calling thread, every other one from
        a thread of its own, so a bus whose device stopped taking data does not
        delay the others' stop. Every ``enable`` or ``clear_errors`` call that
        arrived before it sends nothing more (see :mod:`.order`).
        """
        self._order.arrive(estop=True)
        failures: list[str] = []

        def stop(face: BusFace) -> None:
            try:
                face.estop()
            except Exception as exc:
                failures.append(f"{face.name or face.prefix}: {exc}")

        faces = list(self.faces.values())
        others = [threading.Thread(target=stop, args=(f,), name="drempower bridge estop") for f in faces[1:]]
        for th in others:
            th.start()
        stop(faces[0])
        for th in others:
            th.join(5.0)
        for stream in self._streams.values():
            stream.driven = False
        return failures

    def _srv_estop(self) -> tuple[bool, str]:
        failures = self.estop()
        if failures:
            return False, "estop failed: " + "; ".join(failures)
        return True, "estop sent to " + self._served()

    def _served(self) -> str:
        if len(self.faces) == 1 and "" in self.faces:
            return "motors " + ", ".join(map(str, self._face.ids))
        return "joints " + ", ".join(self._names)

    def _run_each(self, ticket: int, service: str) -> tuple[bool, str]:
        """The service's row of :mod:`drempower.actions` for every motor served, one at a time, until an
        estop that arrived later fences it."""
        row = SERVICE_ROWS[service]
        failures = []
        for face in self.faces.values():
            try:
                for i in face.ids:
                    if not face.run_unless(row, i, lambda: self._order.stale(ticket)):
                        return False, _FENCED.format(service=service)
            except Exception as exc:  # a reply in every case: the caller waits for one
                failures.append(f"{face.name or face.prefix}: {exc}")
        if failures:
            return False, f"{service} failed: " + "; ".join(failures)
        return True, ""

    def _srv_clear_errors(self, ticket: int) -> tuple[bool, str]:
        """Clear the errors of every joint served, unless an estop that arrived later came first; success
        only once none reports an error (an encoder error stays until zeroed)."""
        return self._settled(ticket, "clear_errors", actions.why_not_cleared, "errors cleared on ")

    def _srv_enable(self, ticket: int) -> tuple[bool, str]:
        """Closed loop for every joint served, on every bus (a bus that fails does not keep the others from
        it); success only once each reads closed loop (a motor with error flags ignores an enable)."""
        return self._settled(ticket, "enable", actions.why_not_enabled, "closed loop on ")

    def _settled(
        self, ticket: int, service: str, why_not: Callable[..., dict[int, str]], done: str
    ) -> tuple[bool, str]:
        """Run ``service``'s row for every joint served (:meth:`_run_each`), then check that each got where
        the row takes it (``why_not``: :func:`~drempower.actions.why_not_enabled` or ``why_not_cleared``),
        within :data:`~drempower.actions.ENABLE_SETTLE` s in all, unless an estop that arrived later comes
        first; ``done`` + what is served on success."""
        ok, message = self._run_each(ticket, service)
        if not ok:
            return ok, message
        failures = []
        deadline = time.monotonic() + actions.ENABLE_SETTLE

        def stale() -> bool:
            return self._order.stale(ticket)

        for face in self.faces.values():
            try:
                why = why_not(face.bus, face.ids, max(0.0, deadline - time.monotonic()), stale)
            except Exception as exc:  # a reply in every case: the caller waits for one
                failures.append(f"{face.name or face.prefix}: state not read: {exc}")
                continue
            for j in face.joints:
                if j.id in why:
                    who = f"motor {j.id}" if j.name == motor_name(j.id) else f"joint {j.name} (motor {j.id})"
                    failures.append(f"{who} {why[j.id]}")
        if stale():
            return False, _FENCED.format(service=service)
        if failures:
            return False, f"{service} failed: " + "; ".join(failures)
        return True, done + self._served()

    # ------------------------------------------------------------------ lifetime

    @property
    def failure(self) -> BaseException | None:
        """Why a bus stopped, if one did (the bridge keeps nothing useful running then)."""
        for face in self.faces.values():
            if face.hub.failure is not None:
                return face.hub.failure
        return None

    def stop(self) -> None:
        """Stop serving; idle every motor set moving by the bridge or a client; the buses stay open. Idempotent.

        Between :meth:`stop` and :meth:`close` the buses (:attr:`faces`' ``bus``)
        still answer: the CLI restores the motors' CAN timeout there.
        """
        if self._closed.is_set():
            return
        self._closed.set()
        diag = getattr(self, "diagnostics", None)
        if diag is not None:
            diag.close()
        for th in getattr(self, "_threads", []):
            th.join(2.0)
        for d in self._decls + self._tokens:
            try:
                d.undeclare()
            except Exception as exc:
                _log.debug("undeclare: %s", exc)
        for face in self.faces.values():
            face.stop()
        if any(stream.driven for stream in getattr(self, "_streams", {}).values()):
            for face in self.faces.values():  # each joint as its robot file says: hold, or idle
                try:
                    face.release()
                except Exception as exc:
                    _log.error("releasing the motors of %s failed: %s", face.prefix, exc)

    def close(self) -> None:
        """:meth:`stop`, then close every bus the bridge opened a client on. Idempotent."""
        self.stop()
        for face in self.faces.values():
            face.close()


def _health_policies(spec: RobotSpec | None) -> dict[str, HealthPolicy]:
    """The supervisor's policy of each bus of a robot file with ``[health]`` (none: the bridge only reports)."""
    from ..robot.health_run import bus_policy

    if spec is None:
        return {}
    return {b: p for b in spec.buses if (p := bus_policy(spec, b)) is not None}
