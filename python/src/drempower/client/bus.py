"""The threaded client: :func:`open_bus` and :class:`Bus`."""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from types import TracebackType
from typing import Any, TypeVar

from ..errors import ValidationError
from ..protocol.ids import check_node
from ..protocol.messages import Message
from ..transports.base import Transport
from ..transports.factory import open_transport
from . import batch, ops
from .busbase import BusBase
from .commands import PositionMode, TorqueMode, VelocityMode, as_list
from .core import (
    DEFAULT_MOVE_TIMEOUT,
    DEFAULT_POLL_INTERVAL,
    MOVE_TOLERANCE,
    Exchange,
    StartPolicy,
    StopOnClose,
)
from .effects import Batch, Effect, Op, Request, Send, Sleep, request
from .errors import TimeoutError
from .motor import Motor
from .results import MotorInfo
from .state import MotorState
from .timeouts import checks_times

__all__ = ["Bus", "open_bus", "DEFAULT_MOVE_TIMEOUT", "DEFAULT_POLL_INTERVAL"]

T = TypeVar("T")


@checks_times
class Bus(BusBase[Motor]):
    """A DrEmpower bus: owns a transport and the receive thread; hands out :class:`Motor` handles.

    Use it as a context manager, or call :meth:`close`. Every method may be
    called from several threads at once. Requests wait at most ``timeout``
    seconds (default 0.1; each method also takes ``timeout=``) and raise
    :class:`~drempower.client.errors.TimeoutError`. See :class:`BusCore` for
    ``retries``, ``start`` and ``stop_on_close``; buses left open are closed
    when Python exits.
    """

    def run(self, op: Op[T]) -> T:
        """Run an operation (a generator of effects, see :mod:`drempower.client.effects`) to completion."""
        execute = self._execute
        value: Any = None
        error: Exception | None = None
        while True:
            try:
                effect = op.send(value) if error is None else op.throw(error)
            except StopIteration as stop:
                result: T = stop.value
                return result
            try:
                value, error = execute(effect), None
            except Exception as exc:
                value, error = None, exc

    def _execute(self, effect: Effect) -> Any:
        core = self._core
        if isinstance(effect, Request):
            self._check_broadcast_reads(effect.messages)
            ex = Exchange(core, effect.messages, effect.timeout, effect.missing_ok, effect.expect, effect.what)
            while True:
                w = ex.start()
                assert w.event is not None
                try:
                    w.event.wait(ex.timeout)
                except BaseException:  # Ctrl-C: the waiter must not take the next request's reply
                    core.matcher.cancel(w)
                    raise
                if ex.collect(w):
                    return self._heard_from(ex.result())
        if isinstance(effect, Send):
            core.send_many(effect.messages)
            return None
        if isinstance(effect, Batch):
            return core.send_batch(effect.presets, effect.start, effect.targets, effect.move_time)
        assert isinstance(effect, Sleep)
        if core.closed_event.wait(effect.seconds):
            core.check_open()
        return None

    def send(self, msg: Message) -> None:
        """Send one message (validated first); never waits for a reply."""
        self._check_writes([msg])
        self._core.send(msg)

    def send_many(self, msgs: Sequence[Message]) -> None:
        """Send several messages; if any is invalid, none is sent."""
        self._check_writes(msgs)
        self._core.send_many(msgs)

    def request(self, msgs: Sequence[Message], timeout: float | None = None, *, missing_ok: bool = False) -> list[Any]:
        """Send reads/fast reads and return their answers (ParamValue / MotorState) in order.

        Missing answers raise :class:`TimeoutError`, or are None with ``missing_ok``.
        """
        return self.run(request(list(msgs), timeout, missing_ok))

    # ------------------------------------------------------------------ motors

    def _new_motor(self, id: int) -> Motor:
        return Motor(self, id)

    def estop(self, id_list: Iterable[int] | None = None) -> None:
        """Emergency-stop the listed motors, or every motor (one broadcast frame) when None."""
        self._core.estop(self._estop_nodes(id_list))

    def scan(
        self, ids: Iterable[int] = batch.ALL_IDS, *, timeout: float | None = None, versions: bool = False
    ) -> list[MotorInfo]:
        """Find the motors that answer (ids 1..63 by default), with hardware/firmware versions on request."""
        return self.run(batch.scan(as_list(ids, "ids"), timeout, versions))

    def cycle(
        self, commands: Iterable[Message], *, timeout: float | None = None, reply_state: bool | None = None
    ) -> dict[int, MotorState]:
        """Send one command per motor and return each motor's state (see :func:`batch.cycle`)."""
        return self.run(batch.cycle(self._core, self._commands(commands), timeout, reply_state))

    # ------------------------------------------------------------------ multi-motor (vendor names)

    def set_angles(
        self,
        id_list: Sequence[int],
        angle_list: Sequence[float],
        speed: float = 10.0,
        param: float = 10.0,
        mode: int = PositionMode.Q,
        *,
        timeout: float | None = None,
    ) -> float | None:
        """Synchronised absolute move: ``angle_list`` deg for ``id_list``.

        mode 0 (T): ``param`` = filter bandwidth 1/s; mode 1 (Q): the motor
        moving furthest cruises at ``speed`` r/min with accel ``param``
        (r/min)/s and all finish together (returns that time, s); mode 2 (P):
        ``speed`` = speed FF r/min, ``param`` = torque FF Nm. Nothing is sent if
        any value is invalid.
        """
        return self.run(batch.move_angles(self._core, id_list, angle_list, speed, param, mode, False, timeout))

    def step_angles(
        self,
        id_list: Sequence[int],
        angle_list: Sequence[float],
        speed: float = 10.0,
        param: float = 10.0,
        mode: int = PositionMode.Q,
        *,
        timeout: float | None = None,
    ) -> float | None:
        """Synchronised relative move by ``angle_list`` deg (see :meth:`set_angles`)."""
        return self.run(batch.move_angles(self._core, id_list, angle_list, speed, param, mode, True, timeout))

    def set_speeds(
        self,
        id_list: Sequence[int],
        speed_list: Sequence[float],
        param: float = 0.0,
        mode: int = VelocityMode.PASSTHROUGH,
    ) -> None:
        """Synchronised speeds (r/min); mode 1: ``param`` = torque FF Nm, mode 2: ramp (r/min)/s."""
        self.run(batch.set_speeds(id_list, speed_list, param, mode))

    def set_torques(
        self,
        id_list: Sequence[int],
        torque_list: Sequence[float],
        param: float = 0.0,
        mode: int = TorqueMode.DIRECT,
    ) -> None:
        """Synchronised torques (Nm); mode 1: direct, mode 6: ramp ``param`` Nm/s."""
        self.run(batch.set_torques(id_list, torque_list, param, mode))

    def impedance_controls(
        self,
        id_list: Sequence[int],
        pos_list: Sequence[float],
        vel: float = 0.0,
        tff: float = 0.0,
        kp: float = 0.0,
        kd: float = 0.0,
    ) -> None:
        """Impedance control of several motors started together: each holds its ``pos_list`` deg;
        ``vel`` r/min, ``tff`` Nm, ``kp`` Nm/rad and ``kd`` Nm/(rad/s) are shared (one start)."""
        self.run(batch.impedance_controls(id_list, pos_list, vel, tff, kp, kd))

    def positions_done(
        self,
        id_list: Sequence[int],
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
        tolerance: float = MOVE_TOLERANCE,
    ) -> dict[int, MotorState]:
        """Wait until every listed motor has finished its move; returns their final states.

        Only states received after the move was sent count, once the motor showed
        it took the move; each final position must be within ``tolerance`` deg of
        its target. Raises MoveError (motor, target, position, error flags) on a
        miss, MoveFaultError (a MotorFaultError) when one reports an error and
        MoveTimeoutError (a TimeoutError) after ``timeout`` s: see :func:`ops.wait_done`.
        """
        return self.run(
            ops.wait_done(self._core, as_list(id_list, "id_list"), timeout, poll_interval, tolerance=tolerance)
        )

    wait_positions_done = positions_done

    # ------------------------------------------------------------------ state

    def wait_state(self, id: int, timeout: float, newer_than: float | None = None) -> MotorState:
        """Wait for a state of motor ``id`` newer than ``newer_than`` (monotonic s; default: now)."""
        check_node(id, "id")
        since = time.monotonic() if newer_than is None else newer_than
        st = self._core.states.wait(id, since, timeout)
        if st is None:
            self._core.check_open()
            raise TimeoutError([id], "a state update", timeout)
        return st

    # ------------------------------------------------------------------ lifetime

    def close(self) -> None:
        """Apply ``stop_on_close`` to the motors this bus commanded, then release the transport."""
        self._core.close()

    def __enter__(self) -> Bus:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def connect(
    interface: str | None, channel: str | int | None, bitrate: int | None, transport: Transport | None, **kwargs: Any
) -> Transport:
    """The transport named by the open_bus arguments, or ``transport`` itself."""
    if transport is None:
        return open_transport(interface, channel, bitrate, **kwargs)
    if interface is not None or channel is not None or bitrate is not None or kwargs:
        raise ValidationError("pass either transport= or interface/channel/bitrate options, not both")
    return transport


def open_bus(
    interface: str | None = None,
    channel: str | int | None = None,
    bitrate: int | None = None,
    *,
    timeout: float | None = None,
    retries: int = 0,
    stop_on_close: StopOnClose = True,
    start: StartPolicy = "auto",
    transport: Transport | None = None,
    **kwargs: Any,
) -> Bus:
    """Open a bus: ``open_bus("sim", motors=[1, 2, 3])``, ``open_bus("socketcan", "can0")``,
    ``open_bus("adapter", "/dev/ttyACM0")``, ``open_bus("uart", "/dev/ttyUSB0")``...

    ``interface``/``channel``/``bitrate`` and extra keyword arguments select the
    transport (see :func:`drempower.transports.open_transport`); or pass an open
    ``transport``. Fails at once with :class:`~drempower.transports.TransportError`
    when the bus does not exist. The remaining options are those of :class:`Bus`.
    """
    transport = connect(interface, channel, bitrate, transport, **kwargs)
    try:
        return Bus(transport, timeout=timeout, retries=retries, stop_on_close=stop_on_close, start=start)
    except BaseException:
        transport.close()
        raise
