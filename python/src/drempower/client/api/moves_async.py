"""Motion through the safety gate, written once: the gate and the synchronised moves of several motors
(the vendor library's multi-motor names), of :class:`~drempower.client.api.bus_async.AsyncBus`.

This module is a source of both front ends: ``tools/gen_sync.py`` writes the threaded
``moves_sync.py`` from it. Edit this file, then run ``make generate``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TypeVar

from ...protocol.messages import Message
from ..engine import batch, ops
from ..engine.commands import (
    PositionMode,
    TorqueMode,
    VelocityMode,
    as_list,
    make_impedances,
    make_speeds,
    make_torques,
)
from ..engine.effects import Op
from ..engine.gate import Intent, move_intents
from ..engine.session import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL, MOVE_TOLERANCE
from ..engine.state import MotorState
from ..engine.timeouts import checks_times
from .flavours import AsyncBusBase
from .timed import check_duration

__all__ = ["AsyncBusMoves"]

M = TypeVar("M")


@checks_times
class AsyncBusMoves(AsyncBusBase[M]):
    """The safety gate and the synchronised moves of a bus (see :class:`~drempower.client.api.bus_async.AsyncBus`)."""

    async def _gated(self, msgs: Sequence[Message], enable: bool, *, duration: float | None = None) -> None:
        """Send direct motion commands (no start among them) through the safety gate."""
        op = self._gate_op(msgs, enable)
        if op is not None:
            await self.run(op)
        self._timed.arm(duration)  # its stop first: a command whose stop cannot be kept is not sent
        self._core.send_many(msgs)
        self._sent(msgs, duration)

    async def pass_gate(self, motion: Sequence[Message] | Sequence[Intent], enable: bool = False) -> None:
        """The safety gate alone, for motion about to be sent (messages, or the gate's intents): raises
        :class:`~drempower.errors.MotorIdleError` or :class:`~drempower.errors.SoftLimitError` as the motion
        methods do, and sends nothing but, for motors not yet known in closed loop, one state read (their
        enable with ``enable=True``). A loop calls it once before its clock starts, so no cycle pays a read."""
        intents = [i for i in motion if isinstance(i, Intent)]
        if intents:
            op = self._passage(intents, enable)
        else:
            op = self._gate_op([m for m in motion if isinstance(m, Message)], enable)
        if op is not None:
            await self.run(op)

    async def set_angles(
        self,
        id_list: Sequence[int],
        angle_list: Sequence[float],
        speed: float = 10.0,
        param: float = 10.0,
        mode: int = PositionMode.Q,
        *,
        timeout: float | None = None,
        enable: bool = False,
    ) -> float | None:
        """Synchronised absolute move: ``angle_list`` deg for ``id_list``.

        mode 0 (T): ``param`` = filter bandwidth 1/s; mode 1 (Q): the motor
        moving furthest cruises at ``speed`` r/min with accel ``param``
        (r/min)/s and all finish together (returns that time, s); mode 2 (P):
        ``speed`` = speed FF r/min, ``param`` = torque FF Nm. Nothing is sent if
        any value is invalid.
        """
        return await self._move_angles(id_list, angle_list, speed, param, mode, False, timeout, enable)

    async def step_angles(
        self,
        id_list: Sequence[int],
        angle_list: Sequence[float],
        speed: float = 10.0,
        param: float = 10.0,
        mode: int = PositionMode.Q,
        *,
        timeout: float | None = None,
        enable: bool = False,
    ) -> float | None:
        """Synchronised relative move by ``angle_list`` deg (see :meth:`set_angles`)."""
        return await self._move_angles(id_list, angle_list, speed, param, mode, True, timeout, enable)

    async def _move_angles(
        self,
        id_list: Sequence[int],
        angle_list: Sequence[float],
        speed: float,
        param: float,
        mode: int,
        relative: bool,
        timeout: float | None,
        enable: bool,
    ) -> float | None:
        """A synchronised move (``relative``: by ``angle_list``) through the gate; ends the motors' timed stops."""
        await self.pass_gate(move_intents(id_list, angle_list, speed, param, mode, relative=relative), enable)
        result = await self.run(
            batch.move_angles(self._session, id_list, angle_list, speed, param, mode, relative, timeout)
        )
        self._moved(id_list)
        return result

    async def set_speeds(
        self,
        id_list: Sequence[int],
        speed_list: Sequence[float],
        param: float = 0.0,
        mode: int = VelocityMode.PASSTHROUGH,
        *,
        duration: float | None = None,
        enable: bool = False,
    ) -> None:
        """Synchronised speeds (r/min); mode 1: ``param`` = torque FF Nm, mode 2: ramp (r/min)/s.

        With ``duration`` (s) the bus sends speed 0 to them that long after, by itself."""
        presets, _ = make_speeds(id_list, speed_list, param, mode)
        await self._preset_all(presets, batch.set_speeds(id_list, speed_list, param, mode), duration, enable)

    async def set_torques(
        self,
        id_list: Sequence[int],
        torque_list: Sequence[float],
        param: float = 0.0,
        mode: int = TorqueMode.DIRECT,
        *,
        duration: float | None = None,
        enable: bool = False,
    ) -> None:
        """Synchronised torques (Nm); mode 1: direct, mode 6: ramp ``param`` Nm/s.

        With ``duration`` (s) the bus sends torque 0 to them that long after, by itself."""
        presets, _ = make_torques(id_list, torque_list, param, mode)
        await self._preset_all(presets, batch.set_torques(id_list, torque_list, param, mode), duration, enable)

    async def _preset_all(self, presets: Sequence[Message], op: Op[None], duration: float | None, enable: bool) -> None:
        """``presets`` through the gate, then ``op`` (their one batch); with ``duration`` (s) their zero follows
        by itself."""
        duration = check_duration(duration)
        await self.pass_gate(presets, enable)
        self._timed.arm(duration)
        await self.run(op)
        self._sent(presets, duration)

    async def impedance_controls(
        self,
        id_list: Sequence[int],
        pos_list: Sequence[float],
        vel: float = 0.0,
        tff: float = 0.0,
        kp: float = 0.0,
        kd: float = 0.0,
        *,
        enable: bool = False,
    ) -> None:
        """Impedance control of several motors started together: each holds its ``pos_list`` deg;
        ``vel`` r/min, ``tff`` Nm, ``kp`` Nm/rad and ``kd`` Nm/(rad/s) are shared (one start)."""
        presets, _ = make_impedances(id_list, pos_list, vel, tff, kp, kd)
        await self.pass_gate(presets, enable)
        await self.run(batch.impedance_controls(id_list, pos_list, vel, tff, kp, kd))
        self._sent(presets)

    async def positions_done(
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
        MoveTimeoutError (a TimeoutError) after ``timeout`` s: see
        :func:`drempower.client.engine.ops.wait_done`.
        """
        return await self.run(
            ops.wait_done(self._session, as_list(id_list, "id_list"), timeout, poll_interval, tolerance=tolerance)
        )

    wait_positions_done = positions_done
