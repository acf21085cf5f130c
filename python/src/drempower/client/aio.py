"""The asyncio client: ``async with open_bus_async(...) as bus``.

The same core as the threaded client (one receive thread per bus); replies
are handed to the event loop with ``loop.call_soon_threadsafe``, so no thread
is used per call. Methods are coroutines with the names, arguments and results
of :class:`~drempower.client.bus.Bus` and :class:`~drempower.client.motor.Motor`.
"""

from __future__ import annotations

import asyncio
import os
import time
from collections.abc import Callable, Iterable, Sequence
from types import TracebackType
from typing import Any, TypeVar

from ..protocol.addresses import AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE
from ..protocol.ids import SysCmd, check_node
from ..protocol.messages import Message
from ..transports.base import Transport
from . import backup as _backup
from . import batch, ops
from .bus import connect
from .busbase import BusBase
from .commands import (
    PositionMode,
    TorqueMode,
    TrajMode,
    VelocityMode,
    as_list,
    make_angle,
    make_impedance,
    make_speed,
    make_torque,
)
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
from .motor import MotorBase
from .results import ErrorReport, GpioMode, MotorInfo
from .state import MotorState
from .timeouts import checks_times

__all__ = ["AsyncBus", "AsyncMotor", "open_bus_async"]

T = TypeVar("T")


def _wake(fut: asyncio.Future[Any], value: Any = None) -> None:
    if not fut.done():
        fut.set_result(value)


def _notifier(loop: asyncio.AbstractEventLoop, fut: asyncio.Future[Any]) -> Callable[[], None]:
    def notify() -> None:
        try:
            loop.call_soon_threadsafe(_wake, fut)
        except RuntimeError:  # the loop is closed; nobody waits any more
            pass

    return notify


@checks_times
class AsyncBus(BusBase["AsyncMotor"]):
    """The asyncio counterpart of :class:`~drempower.client.bus.Bus` (same options)."""

    async def run(self, op: Op[T]) -> T:
        """Run an operation (a generator of effects) to completion."""
        value: Any = None
        error: Exception | None = None
        while True:
            try:
                effect = op.send(value) if error is None else op.throw(error)
            except StopIteration as stop:
                result: T = stop.value
                return result
            try:
                value, error = await self._execute(effect), None
            except Exception as exc:
                value, error = None, exc

    async def _execute(self, effect: Effect) -> Any:
        core = self._core
        if isinstance(effect, Request):
            self._check_broadcast_reads(effect.messages)
            ex = Exchange(core, effect.messages, effect.timeout, effect.missing_ok, effect.expect, effect.what)
            loop = asyncio.get_running_loop()
            while True:
                fut: asyncio.Future[None] = loop.create_future()
                w = ex.start(_notifier(loop, fut))
                try:
                    await asyncio.wait((fut,), timeout=ex.timeout)
                except BaseException:
                    core.matcher.cancel(w)
                    raise
                if ex.collect(w):
                    return self._heard_from(ex.result())
        if isinstance(effect, Send):
            if core.sequenced(effect.messages):  # a start may wait until its presets are on the wire
                await asyncio.to_thread(core.send_many, effect.messages)
            else:
                core.send_many(effect.messages)
            return None
        if isinstance(effect, Batch):  # in a thread: the start waits until the presets are on the wire
            return await asyncio.to_thread(
                core.send_batch, effect.presets, effect.start, effect.targets, effect.move_time
            )
        assert isinstance(effect, Sleep)
        await asyncio.sleep(effect.seconds)
        core.check_open()
        return None

    async def send(self, msg: Message) -> None:
        """Send one message (validated first); never waits for a reply."""
        self._check_writes([msg])
        if self._core.sequenced([msg]):  # a start may wait until its presets are on the wire
            await asyncio.to_thread(self._core.send, msg)
        else:
            self._core.send(msg)

    async def send_many(self, msgs: Sequence[Message]) -> None:
        """Send several messages; if any is invalid, none is sent."""
        self._check_writes(msgs)
        if self._core.sequenced(msgs):  # a start may wait until its presets are on the wire
            await asyncio.to_thread(self._core.send_many, msgs)
        else:
            self._core.send_many(msgs)

    async def request(
        self, msgs: Sequence[Message], timeout: float | None = None, *, missing_ok: bool = False
    ) -> list[Any]:
        """Send reads/fast reads and return their answers in order."""
        return await self.run(request(list(msgs), timeout, missing_ok))

    def _new_motor(self, id: int) -> AsyncMotor:
        return AsyncMotor(self, id)

    async def estop(self, id_list: Iterable[int] | None = None) -> None:
        """Emergency-stop the listed motors, or every motor when None."""
        self._core.estop(self._estop_nodes(id_list))

    async def scan(
        self, ids: Iterable[int] = batch.ALL_IDS, *, timeout: float | None = None, versions: bool = False
    ) -> list[MotorInfo]:
        """Find the motors that answer."""
        return await self.run(batch.scan(as_list(ids, "ids"), timeout, versions))

    async def cycle(
        self, commands: Iterable[Message], *, timeout: float | None = None, reply_state: bool | None = None
    ) -> dict[int, MotorState]:
        """Send one command per motor and return each motor's state."""
        return await self.run(batch.cycle(self._core, self._commands(commands), timeout, reply_state))

    async def set_angles(
        self,
        id_list: Sequence[int],
        angle_list: Sequence[float],
        speed: float = 10.0,
        param: float = 10.0,
        mode: int = PositionMode.Q,
        *,
        timeout: float | None = None,
    ) -> float | None:
        """Synchronised absolute move (see :meth:`Bus.set_angles`)."""
        return await self.run(batch.move_angles(self._core, id_list, angle_list, speed, param, mode, False, timeout))

    async def step_angles(
        self,
        id_list: Sequence[int],
        angle_list: Sequence[float],
        speed: float = 10.0,
        param: float = 10.0,
        mode: int = PositionMode.Q,
        *,
        timeout: float | None = None,
    ) -> float | None:
        """Synchronised relative move (see :meth:`Bus.step_angles`)."""
        return await self.run(batch.move_angles(self._core, id_list, angle_list, speed, param, mode, True, timeout))

    async def set_speeds(
        self, id_list: Sequence[int], speed_list: Sequence[float], param: float = 0.0, mode: int = 1
    ) -> None:
        """Synchronised speeds (see :meth:`Bus.set_speeds`)."""
        await self.run(batch.set_speeds(id_list, speed_list, param, mode))

    async def set_torques(
        self, id_list: Sequence[int], torque_list: Sequence[float], param: float = 0.0, mode: int = 1
    ) -> None:
        """Synchronised torques (see :meth:`Bus.set_torques`)."""
        await self.run(batch.set_torques(id_list, torque_list, param, mode))

    async def impedance_controls(
        self,
        id_list: Sequence[int],
        pos_list: Sequence[float],
        vel: float = 0.0,
        tff: float = 0.0,
        kp: float = 0.0,
        kd: float = 0.0,
    ) -> None:
        """Impedance control of several motors started together (see :meth:`Bus.impedance_controls`)."""
        await self.run(batch.impedance_controls(id_list, pos_list, vel, tff, kp, kd))

    async def positions_done(
        self,
        id_list: Sequence[int],
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
        tolerance: float = MOVE_TOLERANCE,
    ) -> dict[int, MotorState]:
        """Wait until every listed motor reports its move done."""
        return await self.run(
            ops.wait_done(self._core, as_list(id_list, "id_list"), timeout, poll_interval, tolerance=tolerance)
        )

    wait_positions_done = positions_done

    async def wait_state(self, id: int, timeout: float, newer_than: float | None = None) -> MotorState:
        """Wait for a state of motor ``id`` newer than ``newer_than`` (monotonic s; default: now)."""
        check_node(id, "id")
        since = time.monotonic() if newer_than is None else newer_than
        cache = self._core.states
        loop = asyncio.get_running_loop()
        fut: asyncio.Future[MotorState] = loop.create_future()

        def on_state(st: MotorState) -> None:
            if st.timestamp > since:
                loop.call_soon_threadsafe(_wake, fut, st)

        with cache.subscribe(on_state, id):
            st = cache.get(id)
            if st is not None and st.timestamp > since:
                return st
            await asyncio.wait((fut,), timeout=timeout)
        if not fut.done():
            self._core.check_open()
            raise TimeoutError([id], "a state update", timeout)
        return fut.result()

    async def close(self) -> None:
        """Apply ``stop_on_close`` and release the transport (in a worker thread; it may block briefly)."""
        await asyncio.get_running_loop().run_in_executor(None, self._core.close)

    async def __aenter__(self) -> AsyncBus:
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.close()


@checks_times
class AsyncMotor(MotorBase):
    """One motor on an :class:`AsyncBus`: the methods of :class:`~drempower.client.motor.Motor` as coroutines."""

    __slots__ = ("_bus",)

    def __init__(self, bus: AsyncBus, id: int) -> None:
        super().__init__(bus.core, id)
        self._bus = bus

    @property
    def bus(self) -> AsyncBus:
        return self._bus

    async def set_angle(self, angle: float, speed: float = 0.0, param: float = 0.0, mode: int = PositionMode.T) -> None:
        self._core.send(make_angle(self._id, angle, speed, param, mode))

    async def step_angle(
        self,
        angle: float,
        speed: float = 0.0,
        param: float = 0.0,
        mode: int = PositionMode.T,
        *,
        timeout: float | None = None,
    ) -> float | None:
        op = batch.move_angles(self._core, [self._id], [angle], speed, param, mode, True, timeout)
        return await self._bus.run(op)

    async def set_speed(self, speed: float, param: float = 0.0, mode: int = VelocityMode.PASSTHROUGH) -> None:
        self._core.send(make_speed(self._id, speed, param, mode))

    async def set_torque(self, torque: float, param: float = 0.0, mode: int = TorqueMode.DIRECT) -> None:
        self._core.send(make_torque(self._id, torque, param, mode))

    async def impedance_control(
        self, pos: float, vel: float = 0.0, tff: float = 0.0, kp: float = 0.0, kd: float = 0.0
    ) -> None:
        preset, start = make_impedance(self._id, pos, vel, tff, kp, kd)
        await asyncio.to_thread(self._core.send_batch, [preset], start)

    async def estop(self) -> None:
        self._core.estop([self._id])

    async def position_done(
        self,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
        tolerance: float = MOVE_TOLERANCE,
    ) -> MotorState:
        return await self.wait_position_done(timeout, poll_interval=poll_interval, tolerance=tolerance)

    async def wait_position_done(
        self,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
        tolerance: float = MOVE_TOLERANCE,
    ) -> MotorState:
        return (
            await self._bus.run(ops.wait_done(self._core, [self._id], timeout, poll_interval, tolerance=tolerance))
        )[self._id]

    async def wait_state(self, timeout: float) -> MotorState:
        return await self._bus.wait_state(self._id, timeout)

    async def set_id(self, new_id: int, *, timeout: float | None = None) -> AsyncMotor:
        await self._bus.run(ops.set_id(self._core, self._id, new_id, timeout))
        return self._bus.motor(new_id)

    async def set_can_baud_rate(self, baud_rate: int, *, timeout: float | None = None) -> None:
        await self._bus.run(ops.set_can_baud_rate(self._id, baud_rate, timeout))

    async def set_uart_baud_rate(self, baud_rate: int, *, timeout: float | None = None) -> None:
        await self._bus.run(ops.set_uart_baud_rate(self._id, baud_rate, timeout))

    async def set_mode(self, mode: int = 2) -> None:
        self._core.send(ops.set_mode(self._id, mode))

    async def set_zero_position(self) -> None:
        self._system(SysCmd.SET_ZERO_POSITION)

    async def set_GPIO_mode(self, mode: str = "tx_rx", param: float = 115200, *, timeout: float | None = None) -> None:
        await self._bus.run(ops.set_gpio_mode(self._id, mode, param, timeout))

    async def get_GPIO_mode(self, *, timeout: float | None = None) -> GpioMode:
        return await self._bus.run(ops.get_gpio_mode(self._id, timeout))

    async def set_angle_range(
        self, angle_min: float = -360.0, angle_max: float = 360.0, *, timeout: float | None = None
    ) -> None:
        await self._bus.run(ops.set_angle_range(self._id, angle_min, angle_max, timeout))

    async def set_traj_mode(self, mode: int = TrajMode.TRAPEZOID, *, timeout: float | None = None) -> None:
        await self._bus.run(ops.set_traj_mode(self._id, mode, timeout))

    async def get_traj_mode(self, *, timeout: float | None = None) -> TrajMode:
        return await self._bus.run(ops.get_traj_mode(self._core, self._id, timeout))

    async def write_property(
        self,
        property: str | int,
        value: float,
        *,
        verify: bool = False,
        timeout: float | None = None,
        force: bool = False,
    ) -> None:
        await self._bus.run(ops.write_property(self._id, property, value, verify, timeout, force))

    async def read_property(self, property: str | int, *, timeout: float | None = None) -> int | float:
        return await self._bus.run(ops.read_property(self._core, self._id, property, timeout))

    async def enable_reply_state(self, on: bool = True, *, timeout: float | None = None) -> None:
        await self._bus.run(
            ops.write_property(self._id, AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE, int(on), True, timeout)
        )

    async def get_id(self, *, timeout: float | None = None) -> int:
        return await self._bus.run(ops.get_id(self._id, timeout))

    async def get_state(self, *, timeout: float | None = None) -> MotorState:
        return await self._bus.run(ops.get_state(self._id, timeout))

    async def get_volcur(self, *, timeout: float | None = None) -> tuple[float, float]:
        return await self._bus.run(ops.get_volcur(self._id, timeout))

    async def dump_error(self, *, timeout: float | None = None) -> ErrorReport:
        return await self._bus.run(ops.dump_error(self._id, timeout))

    async def clear_error(self) -> None:
        self._system(SysCmd.CLEAR_ERRORS)

    async def save_config(self) -> None:
        self._system(SysCmd.SAVE_CONFIG)

    async def reboot(self) -> None:
        self._system(SysCmd.REBOOT)

    async def init_config(self) -> None:
        self._system(SysCmd.INIT_CONFIG)

    async def erase_config(self) -> None:
        self._system(SysCmd.ERASE_CONFIG)

    async def backup(
        self, path: str | os.PathLike[str] | None = None, *, timeout: float | None = None
    ) -> _backup.ConfigBackup:
        result = await self._bus.run(_backup.backup(self._id, timeout))
        if path is not None:
            result.save(path)
        return result

    async def restore(
        self,
        source: _backup.ConfigBackup | str | os.PathLike[str],
        *,
        include_link: bool = False,
        save: bool = False,
        dry_run: bool = False,
        force: bool = False,
        timeout: float | None = None,
    ) -> _backup.RestoreReport:
        op = _backup.restore(
            self._core, self._id, source, timeout, include_link=include_link, save=save, dry_run=dry_run, force=force
        )
        return await self._bus.run(op)


def open_bus_async(
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
) -> AsyncBus:
    """Open a bus for asyncio (same arguments as :func:`~drempower.client.bus.open_bus`).

    Use as ``async with open_bus_async("sim", motors=[1]) as bus:``.
    """
    transport = connect(interface, channel, bitrate, transport, **kwargs)
    try:
        return AsyncBus(transport, timeout=timeout, retries=retries, stop_on_close=stop_on_close, start=start)
    except BaseException:
        transport.close()
        raise
