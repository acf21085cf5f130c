"""The bridge: one bus or a whole robot on Zenoh, for drempower clients (frames tunnelled) and ROS 2 (rmw_zenoh).

The drempower face is one per bus (:class:`BusFace`): a bus served alone under
the key prefix, each bus of a robot under ``<prefix>/<bus>``. The ROS 2 face is
one for all: ``joint_states`` holds every joint in SI units at the joint (after
the robot file's gear and offset), and each value of a command goes to its
joint's bus and motor through the same gear.

The bridge holds its parts, each with only what it needs: the faces
(:mod:`.bus_face`), the ``joint_states`` stream (:mod:`.joint_states`), the
command topics (:mod:`.command_topics`), the services (:mod:`.services`),
``/rosout`` (:mod:`.rosout`) and ``/diagnostics`` (:mod:`.diagnostics`).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Mapping
from typing import Any

from ..client.api.bus_sync import Bus
from ..client.engine.supervisor import HealthPolicy
from ..logline import RateLimit
from ..robot.config import JOINT_NAME, JointSpec, RobotSpec
from ..robot.joint import Gearing
from ..transports.base import Transport
from . import rmw, rosmsg
from .bus_face import (
    COMMAND_TOPICS,
    DEFAULT_BANDWIDTH,
    DEFAULT_COMMAND_TIMEOUT,
    DEFAULT_RATE,
    NODE_NAME,
    BridgeOptions,
    BusFace,
    motor_joints,
)
from .command_topics import CommandTopics
from .diagnostics import DIAGNOSTIC_ARRAY, Diagnostics
from .hub import BusHub
from .joint_states import StateStream
from .rosout import RosOut
from .services import SERVICES, Services

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


class Bridge:
    """Serve ``transport`` (one bus) or ``{bus name: transport}`` (a robot) on Zenoh ``session`` until :meth:`close`.

    One bus is served under ``options.prefix``; each bus of a robot under
    ``<prefix>/<bus>`` (``options.joints`` then maps names to the robot file's
    joints). The bridge owns neither the session nor the transports: the caller
    closes them after :meth:`close`, which idles every motor the bridge or its
    clients set moving.
    """

    def __init__(self, transport: Transport | Mapping[str, Transport], session: Any, options: BridgeOptions) -> None:
        self.options = o = options
        self.session = session
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
        self.faces: dict[str, BusFace] = {}
        """The drempower face of each bus by name (``""`` for a bus served alone)."""
        self.joints: list[tuple[JointSpec, Gearing, BusFace]] = []
        """Each joint served, in the order of ``joint_states``: its spec, its gearing, its bus's face."""
        self._decls: list[Any] = []
        self._tokens: list[Any] = []
        self.state_outputs: list[Callable[[bytes], None]] = []
        """Called with each JointState payload after ``joint_states`` (other topics of the same states)."""
        self._watchdog = threading.Thread(target=self._watchdog_loop, name="drempower bridge watchdog", daemon=True)
        try:
            for name, t in transports.items():
                prefix = o.prefix if not name else f"{o.prefix.strip('/')}/{name}"
                self.faces[name] = BusFace(
                    name, t, session, prefix, [j for j in specs if j.bus == name], o.command_timeout, o.timeout, o.robot
                )
            self.joints = [(j, Gearing(j), self.faces[j.bus]) for j in specs]
            self._declare_ros()
        except BaseException:
            self.close()
            raise
        self.states.start()
        self._watchdog.start()

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

        def publisher(key: str) -> Any:
            pub = s.declare_publisher(key)
            self._decls.append(pub)
            return pub

        self.joint_states_key, js_gid = declare("MP", "joint_states", rosmsg.JOINT_STATE)
        js_pub = s.declare_publisher(self.joint_states_key)
        node = ".".join(p for p in (*ns.strip("/").split("/"), o.node_name) if p)
        self.command_keys: dict[str, str] = {}
        self.service_keys: dict[str, str] = {}
        command_keys = {topic: declare("MS", topic, rosmsg.FLOAT64_MULTI_ARRAY)[0] for topic in COMMAND_TOPICS}
        service_keys = {name: declare("SS", name, rosmsg.TRIGGER)[0] for name in SERVICES}
        rosout_key, rosout_gid = declare("MP", "/rosout", rosmsg.LOG)
        self.log = RosOut(publisher(rosout_key), rosout_gid, node)
        """``/rosout``, and the command topics' refusals told there (:mod:`.rosout`)."""
        self.commands = CommandTopics(self.joints, self.faces, ns, o.bandwidth, self.log.refuse)
        """The command topics (:mod:`.command_topics`)."""
        for topic, key in command_keys.items():
            self.command_keys[topic] = key
            self._decls.append(s.declare_subscriber(key, lambda sample, t=topic: self.commands.on_command(t, sample)))
        self.services = Services(self.faces, [j.name for j, _, _ in self.joints], self.commands.forget_driven)
        """``estop``, ``clear_errors`` and ``enable`` (:mod:`.services`)."""
        for name, key in service_keys.items():
            self.service_keys[name] = key
            self._decls.append(s.declare_queryable(key, lambda q, n=name: self.services.serve(q, n), complete=True))
        diag_key, diag_gid = declare("MP", "/diagnostics", DIAGNOSTIC_ARRAY)
        self.diagnostics_key = diag_key
        diag_pub = publisher(diag_key)
        self.diagnostics = Diagnostics(
            self.faces, lambda p, a: diag_pub.put(p, attachment=a), diag_gid, _health_policies(o.robot)
        )
        """``/diagnostics``: each joint's health at 1 Hz and on change (:mod:`drempower.bridge.diagnostics`)."""
        self.states = StateStream(
            self.joints,
            list(self.faces.values()),
            js_pub,
            js_gid,
            o.rate,
            self.diagnostics.saw_states,
            self.state_outputs,
        )
        """The ``joint_states`` stream (:mod:`.joint_states`)."""
        self._decls.append(
            s.liveliness().declare_subscriber(
                f"{rmw.ADMIN_SPACE}/{o.domain_id}/**", self.commands.on_ros_entity, history=True
            )
        )

    # ------------------------------------------------------------------ what other parts use

    @property
    def closed(self) -> bool:
        """Whether the bridge stopped serving."""
        return self._closed.is_set()

    @property
    def busy(self) -> Callable[[], str | None]:
        """Says why the command topics are refused now (a trajectory goal executing: its action sets it),
        else None: a stray command then neither moves the joints nor starts the topic's watch."""
        return self.commands.busy

    @busy.setter
    def busy(self, why: Callable[[], str | None]) -> None:
        self.commands.busy = why

    @property
    def refused(self) -> int:
        """Commands of the ROS 2 topics refused (a value out of range, the safety gate); nothing was sent."""
        return self.log.refused

    @property
    def last_refusal(self) -> str | None:
        """The words of the last refusal (those of :mod:`drempower.actions` and the safety gate)."""
        return self.log.last_refusal

    def refuse(self, topic: str, why: str) -> None:
        """A command of ``topic`` refused (nothing sent): counted, logged and told on ``/rosout``."""
        self.log.refuse(topic, why)

    def rosout(self, level: int, text: str) -> None:
        """Say ``text`` on ``/rosout`` (``rcl_interfaces/msg/Log``, ``level`` as its constants), as the
        bridge's node: what ``ros2 topic echo /rosout`` and rqt_console show."""
        self.log.say(level, text)

    def estop(self) -> list[str]:
        """Emergency stop of every motor served on every bus at once; returns the failures (``"bus: error"``);
        every ``enable`` or ``clear_errors`` call that arrived before it sends nothing more (:mod:`.services`)."""
        return self.services.estop()

    def _watchdog_loop(self) -> None:
        timeout = self.options.command_timeout
        while not self._closed.wait(timeout / 4):
            for face in self.faces.values():
                face.check_clients()
            self.commands.check_silent(timeout)

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
        commands: CommandTopics | None = getattr(self, "commands", None)
        if commands is not None:
            commands.close()
        diag = getattr(self, "diagnostics", None)
        if diag is not None:
            diag.close()
        states = getattr(self, "states", None)
        if states is not None:
            states.close()
        if self._watchdog.is_alive():
            self._watchdog.join(2.0)
        for d in self._decls + self._tokens:
            try:
                d.undeclare()
            except Exception as exc:
                _log.debug("undeclare: %s", exc)
        for face in self.faces.values():
            face.stop()
        if commands is not None and commands.driven:
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
