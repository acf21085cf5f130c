"""The bridge's drempower face of one bus (:class:`BusFace`): frames tunnelled to and from remote clients, held
to the robot file's limits and the remote policy, the bus's info, its services; and the bridge's options."""

from __future__ import annotations

import json
import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from .. import actions
from ..client.api.bus_sync import Bus
from ..client.engine.stops import hold_frames
from ..errors import DrEmpowerError, MotorIdleError, ValidationError
from ..naming import motor_name
from ..protocol.addresses import AXIS0_CURRENT_STATE
from ..protocol.ids import Frame
from ..protocol.limits import check_motor
from ..protocol.messages import Message, ReadParam
from ..protocol.parameters import DataType
from ..robot.config import JointSpec, RobotSpec
from ..robot.joint import Gearing
from ..transports.base import Transport
from ..transports.zenoh_wire import BRIDGE_ORIGIN, DEFAULT_PREFIX, decode_frames, encode_frames, keys, split_origin
from .hub import BusHub, axis_changed, driven_nodes
from .motors import ServedMotors
from .remote_policy import RemotePolicy

_log = logging.getLogger("drempower.bridge")

DEFAULT_RATE = 100.0
"""JointState messages per second."""
DEFAULT_COMMAND_TIMEOUT = 0.2
"""s without a streamed command before the motors it drove go idle."""
DEFAULT_BANDWIDTH = 20.0
"""T-mode filter bandwidth (1/s) of position commands."""
NODE_NAME = "drempower_bridge"
FORGET_AFTER = 10.0
"""s of silence after which a client that drives nothing is forgotten (its last estop's number too)."""
COMMAND_TOPICS = ("position_commands", "velocity_commands", "effort_commands")
COMMAND_ROWS = {
    "position_commands": ("move", "angle", "position", "rad", "motor_angle"),
    "velocity_commands": ("speed", "speed", "velocity", "rad/s", "motor_speed"),
    "effort_commands": ("torque", "torque", "effort", "Nm", "motor_torque"),
}
"""Each command topic's row of :mod:`drempower.actions`, the row's field that a value becomes (motor units),
what a value is at the joint with its unit, and the gearing's conversion to the motor."""


def check_joint_value(face: BusFace, topic: str, j: JointSpec, g: Gearing, x: float) -> float:
    """``x`` (SI at joint ``j`` of bus ``face``) in motor units, checked by ``topic``'s row through the
    face's command service (the table's words, naming the joint); nothing is sent: the one check of the
    bridge's command topics and its ros2_control topics."""
    row, field, what, unit, convert = COMMAND_ROWS[topic]
    try:
        value: float = face.service.check(row, {"id": j.id, field: getattr(g, convert)(x)}).args[field]
    except ValidationError as exc:
        raise ValidationError(f"joint {j.name!r} ({what} {x:g} {unit}): {exc}") from None
    return value


_WHO = "the bridge"
"""Who runs the bridge's own rows, as the command service logs it."""
ENABLE_FIX = "(call the enable service, or drempower enable {ids})"
"""How a refusal for a motor not in closed loop names the fix, in the terms of a ROS 2 caller."""


def in_ros_terms(exc: MotorIdleError) -> MotorIdleError:
    """``exc`` (the safety gate's refusal) with the fix a ROS 2 caller has: the ``enable`` service."""
    return MotorIdleError(exc.nodes, exc.states, fix=ENABLE_FIX.format(ids=",".join(map(str, exc.nodes))))


def motor_joints(ids: Sequence[int]) -> dict[str, int]:
    """The joints of motors ``ids`` served alone, named as everywhere: ``motor_<id>`` (:mod:`drempower.naming`)."""
    return {motor_name(i): i for i in ids}


@dataclass
class BridgeOptions:
    """What a bridge serves and how."""

    joints: Mapping[str, int] | Mapping[str, JointSpec]
    """Joint name -> motor id (one bus; :func:`motor_joints` names them ``motor_<id>``), or -> the robot
    file's joint (bus, id, gear, offset), in the order of ``joint_states``."""
    prefix: str = DEFAULT_PREFIX
    namespace: str = ""
    domain_id: int = 0
    rate: float = DEFAULT_RATE
    command_timeout: float = DEFAULT_COMMAND_TIMEOUT
    bandwidth: float = DEFAULT_BANDWIDTH
    node_name: str = NODE_NAME
    timeout: float | None = None
    """Reply timeout (s) of the bridge's own requests (state stream, arming a CAN timeout); None: the transport's."""
    robot: RobotSpec | None = None
    """The robot file the joints come from: the buses get its joints' limits (and its model's joint range)
    from the one place every front end uses, so a refusal has the words of Python and the CLI."""

    def __post_init__(self) -> None:
        if not self.joints:
            raise ValueError("joints: the bridge needs at least one motor")
        if not 0 < self.rate <= 1000:
            raise ValueError(f"rate={self.rate!r}: 0 < rate <= 1000 Hz")
        if not 0 < self.command_timeout <= 60:
            raise ValueError(f"command_timeout={self.command_timeout!r}: 0 < timeout <= 60 s")
        if not 0 <= self.domain_id <= 232:
            raise ValueError(f"domain_id={self.domain_id!r}: ROS 2 domain ids are 0..232")
        if not 0 < self.bandwidth <= 300:
            raise ValueError(f"bandwidth={self.bandwidth!r}: the T-mode filter bandwidth is 0 < b <= 300 1/s")
        taken: dict[tuple[str, int], str] = {}
        for j in self.specs():
            check_motor(j.id, f"joint {j.name!r}: id")
            other = taken.setdefault((j.bus, j.id), j.name)
            if other != j.name:
                raise ValueError(f"joint {j.name!r}: motor {j.id} is joint {other!r} already")

    def specs(self) -> list[JointSpec]:
        """The joints as robot-file joints (a bare motor id is on bus ``""``, gear 1, offset 0)."""
        return [j if isinstance(j, JointSpec) else JointSpec(n, "", int(j)) for n, j in self.joints.items()]


class BusFace:
    """One bus on Zenoh under ``prefix``: remote clients' frames, estop ahead of them, client watch.

    A client that drove motors is watched two ways: its liveliness token (gone
    when it closes, or after Zenoh's lease when it is cut off) and
    :meth:`check_clients`, which idles its motors once nothing of it (a frame or
    a keep-alive) arrived for ``command_timeout`` s. The face owns the hub and
    the bridge's :class:`~drempower.client.Bus` of this bus (:attr:`bus`), not
    the transport.
    """

    def __init__(
        self,
        name: str,
        transport: Transport,
        session: Any,
        prefix: str,
        joints: Sequence[JointSpec],
        command_timeout: float = DEFAULT_COMMAND_TIMEOUT,
        timeout: float | None = None,
        robot: RobotSpec | None = None,
    ) -> None:
        import zenoh

        self.name = name
        self.session = session
        self._zenoh = zenoh
        self.prefix = prefix
        self.joints = list(joints)
        self.ids = [j.id for j in joints]
        self.command_timeout = command_timeout
        """s a client that drove motors may stay silent before they go idle."""
        self._keys = keys(prefix)
        self._closed = threading.Event()
        self._clients: dict[bytes, set[int]] = {}
        """Per client, the motors it set moving."""
        self._heard: dict[bytes, float] = {}
        """Per client, when (monotonic s) its last sample arrived."""
        self._clients_lock = threading.Lock()
        self._unsure: set[int] = set()
        """Motors whose axis state a client may have changed (idled, enabled, stopped) since :attr:`bus` learned it."""
        self.clients_idled = 0
        self._queue: deque[tuple[bytes, int, int, list[Frame]]] = deque()
        """Client samples waiting for the bus: (client, sequence number, estop generation, frames)."""
        self._queue_cv = threading.Condition()
        self._write_lock = threading.Lock()
        self._generation = 0
        """Bumped by every estop: samples queued before it are dropped."""
        self._stopped_at: dict[bytes, int] = {}
        """Per client, the sequence number of its last estop: its earlier samples arriving late are dropped."""
        self.dropped_by_estop = 0
        """Client frames dropped because an estop overtook them."""
        self._rx_pub = session.declare_publisher(
            self._keys["rx"], priority=zenoh.Priority.DATA_HIGH, congestion_control=zenoh.CongestionControl.DROP
        )
        self.hub = BusHub(transport, self._publish_rx, self._client_sent)
        self.bus = Bus(self.hub.local, stop_on_close=True, timeout=timeout)
        self.held = {j.id for j in self.joints if j.bus and j.on_timeout == "hold"}
        """The motors of a robot file's joints that hold when the bridge ends (a bare motor id idles)."""
        self.bus.hold_on_close(self.held)
        if robot is not None:  # the robot file's limits and its model's range, as every front end gives them
            from ..robot.limits import apply_limits, model_range_of

            apply_limits(self.bus, robot, [j.name for j in self.joints], model_range_of(robot))
        else:
            for j in self.joints:
                if j.limits:  # soft limits in motor units: the safety gate holds every command to them
                    self.bus.set_limits(j.id, **Gearing(j).motor_limits(j.limits), where=f"joint {j.name!r} limits")
        self._limits: dict[str, dict[str, Any]] = {}
        """The soft limits of each motor (motor units), told remote clients in the bus's info."""
        for j in self.joints:
            held = self.bus.limits(j.id)
            if held:
                told: dict[str, Any] = {
                    n: (lim.low, lim.high) if n == "position" else lim.high for n, lim in held.items()
                }
                told["where"] = f"{next(iter(held.values())).where} (the bridge's)"
                self._limits[str(j.id)] = told
        self.service = actions.Service(ServedMotors([(name, self.bus, self.joints)]))
        """The command service of this bus's rows (:mod:`drempower.actions.service`): the table's checks
        and words, an enable or a clear confirmed."""
        self.policy = RemotePolicy(self.bus)
        """What remote peers may send (see :mod:`.remote_policy`)."""
        self.refused = 0
        """Remote frames refused by :attr:`policy`."""
        self._decls: list[Any] = []
        self._writer = threading.Thread(target=self._writer_loop, name=f"drempower bridge writer {name}", daemon=True)
        try:
            self._declare()
        except BaseException:
            self.close()
            raise
        self._writer.start()

    def _publish_rx(self, frames: Sequence[Frame], origin: bytes) -> None:
        self._rx_pub.put(encode_frames(frames), attachment=origin)

    def _declare(self) -> None:
        k, s = self._keys, self.session
        info = json.dumps(
            {
                "description": self.hub.transport.description,
                "default_timeout": self.hub.transport.default_timeout,
                "motors": self.ids,
                "joints": [j.name for j in self.joints],
                "command_timeout": self.command_timeout,
                "limits": self._limits,
                **({"bus": self.name} if self.name else {}),
            }
        ).encode()
        self._decls.append(s.declare_queryable(k["info"], lambda q: q.reply(k["info"], info), complete=True))
        self._decls.append(s.declare_subscriber(k["tx"], self._on_tx))
        self._decls.append(s.declare_subscriber(k["estop"], self._on_estop))
        self._decls.append(s.declare_subscriber(k["alive"], self._on_alive))
        self._decls.append(s.liveliness().declare_subscriber(k["clients"] + "/*", self._on_client, history=True))

    def _sample(self, sample: Any) -> tuple[bytes, int, list[Frame]] | None:
        """Client id, sequence number and frames of a client's sample (None, logged, when malformed)."""
        att = sample.attachment.to_bytes() if sample.attachment is not None else b""
        try:
            origin, seq = split_origin(att)
            return origin, seq, decode_frames(sample.payload.to_bytes())
        except (DrEmpowerError, ValueError) as exc:
            _log.warning("frames on %s refused: %s", sample.key_expr, exc)
            return None

    def _on_tx(self, sample: Any) -> None:
        """Write a client's frames at once when the bus is free, else queue them for the writer thread.

        Zenoh's receive thread so waits at most for one sample being written,
        and an estop behind it on the same link waits no longer.
        """
        got = self._sample(sample)
        if got is None:
            return
        origin, seq, frames = got
        self._heard[origin] = time.monotonic()
        if not self._admit(frames, origin):
            return
        with self._queue_cv:
            if seq < self._stopped_at.get(origin, -1):
                self.dropped_by_estop += len(frames)
                return
            direct = not self._queue and self._write_lock.acquire(blocking=False)
            if not direct:
                self._queue.append((origin, seq, self._generation, frames))
                self._queue_cv.notify()
        if direct:
            try:
                self.hub.send(frames, origin)
            except Exception as exc:
                _log.error("sending frames of client %s failed: %s", origin.decode(errors="replace"), exc)
            finally:
                self._write_lock.release()

    def _admit(self, frames: Sequence[Frame], origin: bytes, estop_key: bool = False) -> bool:
        """True when a remote sample may go on the bus by :attr:`policy` (checked with the bridge bus's gate,
        which may read a motor's position first); else False, logged and counted."""
        try:
            msgs = self.policy.messages(frames, estop_key)
            op = self.policy.check(msgs)
            if op is not None:
                self.bus.run(op)
        except DrEmpowerError as exc:
            self.refused += len(frames)
            where = "estop key" if estop_key else "bus"
            _log.warning(
                f"{where}: frames of client %s on %s refused: %s", origin.decode(errors="replace"), self.prefix, exc
            )
            return False
        self.policy.sent(msgs)
        return True

    def _on_estop(self, sample: Any) -> None:
        got = self._sample(sample)
        if got is None:
            return
        origin, seq, frames = got
        if not self._admit(frames, origin, estop_key=True):
            return
        self._heard[origin] = time.monotonic()
        with self._queue_cv:
            self._stopped_at[origin] = max(seq, self._stopped_at.get(origin, -1))
        self.estop_now(frames, origin)

    def estop_now(self, frames: Sequence[Frame], origin: bytes = BRIDGE_ORIGIN) -> None:
        """Put a client's estop frames on the bus ahead of everything queued, and drop what was queued before them.

        Frames queued before an estop are commands given before the stop: sent
        after it they could enable and move a motor again.
        """
        self._fence()
        with self._write_lock:  # waits at most for the sample being written
            self.hub.send(frames, origin)

    def _fence(self) -> None:
        """Drop the client samples queued so far: an estop is coming, and they were given before it."""
        with self._queue_cv:
            self._generation += 1
            dropped = sum(len(f) for *_, f in self._queue)
            self._queue.clear()
            self.dropped_by_estop += dropped
        if dropped:
            _log.warning("estop: %d queued client frames dropped", dropped)

    def estop(self) -> None:
        """Emergency stop of every motor of this bus that the bridge serves (the ``estop`` row of
        :mod:`drempower.actions` for each, through :attr:`service`), ahead of queued client frames."""
        self._fence()
        with self._write_lock:
            for i in self.ids:
                self.service.run(_WHO, "estop", {"id": i})

    def act_unless(self, stale: Callable[[], bool], act: Callable[[], object]) -> bool:
        """``act()`` (a row sent on the bridge's bus) ahead of queued client samples, unless ``stale()``
        once the bus is free.

        ``stale`` is asked while the bus is held, so an estop that makes it
        true either finds this action's frames written already (and comes after them) or
        keeps them off the bus. False when nothing was sent.
        """
        with self._write_lock:
            if stale():
                return False
            act()
            return True

    def relearn(self) -> None:
        """Read the axis state of the motors a client may have idled or enabled (through the tunnel) since
        :attr:`bus` learned it, so that its safety gate judges the bridge's next command by what they are."""
        with self._clients_lock:
            nodes, self._unsure = sorted(self._unsure), set()
        if nodes:
            self.bus.request([ReadParam(n, AXIS0_CURRENT_STATE, DataType.U32) for n in nodes], missing_ok=True)

    def _writer_loop(self) -> None:
        cv = self._queue_cv
        while True:
            with cv:
                while not self._queue and not self._closed.is_set():
                    cv.wait(0.25)
                if not self._queue:
                    return
                origin, _, generation, frames = self._queue.popleft()
            with self._write_lock:
                if generation != self._generation:
                    self.dropped_by_estop += len(frames)
                    continue
                try:
                    self.hub.send(frames, origin)
                except Exception as exc:
                    _log.error("sending frames of client %s failed: %s", origin.decode(errors="replace"), exc)

    def _on_alive(self, sample: Any) -> None:
        """A client's keep-alive: it is there, even if it has nothing to send."""
        if sample.attachment is not None:
            self._heard[sample.attachment.to_bytes()] = time.monotonic()

    def _client_sent(self, origin: bytes, frames: Sequence[Frame]) -> None:
        changed = axis_changed(frames)
        if changed:
            with self._clients_lock:
                self._unsure.update(self.ids if 0 in changed else changed & set(self.ids))
        nodes = driven_nodes(frames)
        if nodes:
            with self._clients_lock:
                self._clients.setdefault(origin, set()).update(nodes)
                self._heard[origin] = max(self._heard.get(origin, 0.0), time.monotonic())

    def check_clients(self) -> None:
        """Idle the motors of every client that drove some and was not heard from for ``command_timeout`` s.

        Also forgets clients that drive nothing and were silent for :data:`FORGET_AFTER` s (or ten
        command timeouts), so that clients coming and going, or samples naming made-up clients,
        leave nothing behind.
        """
        now = time.monotonic()
        gone: list[tuple[bytes, set[int]]] = []
        forget = now - max(FORGET_AFTER, 10 * self.command_timeout)
        with self._clients_lock:
            for client in list(self._clients):
                if now - self._heard.get(client, 0.0) > self.command_timeout:
                    gone.append((client, self._clients.pop(client)))
            for client, heard in list(self._heard.items()):
                if heard < forget and client not in self._clients:
                    del self._heard[client]
                    self._stopped_at.pop(client, None)
        for client, nodes in gone:
            _log.info(
                "client %s silent for %.3f s on %s; idling motors %s",
                client.decode(errors="replace"),
                self.command_timeout,
                self.prefix,
                sorted(nodes),
            )
            self.clients_idled += 1  # counted first: whoever sees the motors idle sees the count
            try:
                self.idle(nodes)
            except Exception as exc:
                _log.error("idling the motors of %s failed: %s", self.prefix, exc)

    def _on_client(self, sample: Any) -> None:
        client = str(sample.key_expr).rsplit("/", 1)[1].encode()
        if sample.kind == self._zenoh.SampleKind.PUT:
            _log.info("client %s connected to %s", client.decode(), self.prefix)
            return
        with self._clients_lock:
            nodes = self._clients.pop(client, set())
            self._heard.pop(client, None)
            self._stopped_at.pop(client, None)
        _log.info("client %s left %s; idling motors %s", client.decode(), self.prefix, sorted(nodes) or "none")
        if nodes:
            self.clients_idled += 1  # counted first: whoever sees the motors idle sees the count
            try:
                self.idle(nodes)
            except Exception as exc:  # a Zenoh callback must not raise (the bridge may be closing)
                _log.error("idling the motors of %s failed: %s", self.prefix, exc)

    def idle(self, nodes: set[int] | None = None) -> None:
        """Set motors ``nodes`` (default: those served; 0: every motor) to idle: the ``idle`` row of
        :mod:`drempower.actions` for each through :attr:`service`, so the bridge's bus knows them idle
        (its safety gate then refuses motion to them until an ``enable``)."""
        nodes = set(self.ids) if nodes is None else nodes
        for n in [0] if 0 in nodes else sorted(nodes):
            self.service.run(_WHO, "idle", {"id": n})

    def stop(self) -> None:
        """Stop serving; idle every motor a client set moving (hold a robot file's joint that holds). The bus
        stays open (:meth:`close`). Idempotent."""
        if self._closed.is_set():
            return
        self._closed.set()
        if self._writer.is_alive():
            self._writer.join(2.0)
        for d in self._decls:
            try:
                d.undeclare()
            except Exception as exc:
                _log.debug("undeclare: %s", exc)
        with self._clients_lock:
            nodes = set().union(*self._clients.values()) if self._clients else set()
            self._clients.clear()
        if nodes:
            self.release(nodes)

    def release(self, nodes: set[int] | None = None) -> None:
        """Leave motors ``nodes`` (default: those served) in their safe state when the bridge ends: a robot
        file's joint that holds gets speed 0 (it holds where it is, an arm is not dropped), the others idle."""
        nodes = set(self.ids) if nodes is None else nodes
        held = nodes & self.held
        if held:
            self.bus.send_frames(hold_frames(sorted(held)))
        if nodes - held:
            self.idle(nodes - held)

    def close(self) -> None:
        """:meth:`stop`, then close the bridge's bus (idling what it commanded) and the hub. Idempotent."""
        self.stop()
        self.bus.close()
        self.hub.close()
        try:
            self._rx_pub.undeclare()
        except Exception as exc:
            _log.debug("undeclare: %s", exc)


def pass_face_gate(face: BusFace, motion: Sequence[Message]) -> None:
    """Bus ``face``'s safety gate for ``motion`` (a motor a remote client idled is read again first): soft
    limits, and motors in closed loop, refused in :class:`MotorIdleError`'s words with a ROS 2 caller's fix;
    the one gate of the bridge's command topics and its ros2_control topics. Sends no motion."""
    try:
        face.relearn()
        face.bus.pass_gate(motion)
    except MotorIdleError as exc:
        raise _on_bus(face, in_ros_terms(exc), exc.nodes) from None
    except DrEmpowerError as exc:
        raise _on_bus(face, exc, [getattr(exc, "node", 0)]) from None


def _on_bus(face: BusFace, exc: DrEmpowerError, nodes: Sequence[int]) -> DrEmpowerError:
    """``exc`` of a bus of a robot, its words kept, prefixed with the bus and the joints it names; as it
    is for a bus served alone."""
    if not face.name:
        return exc
    names = [j.name for j in face.joints if j.id in nodes] or [j.name for j in face.joints]
    out = DrEmpowerError(f"bus {face.name!r}, joint{'s' if len(names) > 1 else ''} {', '.join(names)}: {exc}")
    return out
