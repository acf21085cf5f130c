"""The client's front end, written once: :class:`AsyncMotor` and :class:`AsyncBus`.

This module is the one source of both front ends: ``tools/gen_sync.py`` writes the
threaded ``api_sync.py`` (``Motor``, ``Bus``) from it (``async def`` -> ``def``,
``await`` dropped, ``Async`` names -> their threaded names), and the tests run it with
``--check``. Edit this file, then run ``make generate``. What differs by nature (running
an operation's effects, waiting for a state, closing) is in :mod:`drempower.client.api.flavours`.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from types import TracebackType
from typing import TYPE_CHECKING, Any

from ...protocol.addresses import (
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE,
    AXIS0_CURRENT_STATE,
    AXIS0_REQUESTED_STATE,
)
from ...protocol.ids import SysCmd
from ...protocol.messages import Message, Velocity
from ...protocol.parameters import parameter
from ...transports.base import Transport
from ..engine import batch, ops
from ..engine.commands import (
    PositionMode,
    TorqueMode,
    TrajMode,
    VelocityMode,
    as_list,
    check_ids,
    make_angle,
    make_impedance,
    make_speed,
    make_torque,
)
from ..engine.effects import request
from ..engine.health import Health, read_health, read_healths
from ..engine.results import ErrorReport, GpioMode, MotorInfo
from ..engine.session import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL, MOVE_TOLERANCE, StartPolicy, StopOnClose
from ..engine.state import MotorState
from ..engine.supervisor import HealthEvent, Watch, prepare, supervise
from ..engine.timeouts import checks_times
from .busbase import connect
from .motorbase import MotorBase
from .moves_async import AsyncBusMoves
from .profile import FirmwareProfile, apply_profile, load_profile
from .timed import check_duration

if TYPE_CHECKING:
    from ..engine import backup as _backup

__all__ = ["AsyncBus", "AsyncMotor", "open_bus_async"]


@checks_times
class AsyncMotor(MotorBase):
    """One motor on a bus (:class:`AsyncBus`); get it with ``bus.motor(id)``.

    Method names and parameter meanings are the vendor library's, without the
    leading ``id_num``. Units: degrees, r/min, Nm, (r/min)/s, Nm/s, seconds.
    Commands return as soon as their frame is sent; queries wait for the reply
    (``timeout=`` s, default the bus's) and raise
    :class:`~drempower.client.errors.TimeoutError`. Invalid arguments raise
    :class:`~drempower.errors.ValidationError` before anything is sent; a closed
    bus raises :class:`~drempower.client.errors.BusClosedError`.
    """

    __slots__ = ("_bus",)

    def __init__(self, bus: AsyncBus, id: int) -> None:
        super().__init__(bus._core, id, bus._gate)
        self._bus = bus

    @property
    def bus(self) -> AsyncBus:
        """The bus this handle sends on."""
        return self._bus

    # ------------------------------------------------------------------ motion

    async def set_angle(
        self, angle: float, speed: float = 0.0, param: float = 0.0, mode: int = PositionMode.T, *, enable: bool = False
    ) -> None:
        """Move to ``angle`` deg. mode 0 (T): ``param`` = filter bandwidth 0.01..300 1/s;
        mode 1 (Q): cruise ``speed`` r/min, accel ``param`` (r/min)/s; mode 2 (P):
        ``speed`` = speed FF r/min, ``param`` = torque FF Nm.

        Every motion command passes the safety gate (:mod:`drempower.client.engine.gate`): a motor not in
        closed loop raises MotorIdleError unless ``enable=True`` (then it is enabled first), a value
        beyond a soft limit (:meth:`AsyncBus.set_limits`) raises SoftLimitError; nothing is sent then.
        """
        await self._bus._gated((make_angle(self._id, angle, speed, param, mode),), enable)

    async def step_angle(
        self,
        angle: float,
        speed: float = 0.0,
        param: float = 0.0,
        mode: int = PositionMode.T,
        *,
        timeout: float | None = None,
        enable: bool = False,
    ) -> float | None:
        """Move by ``angle`` deg from where the motor is (preset + relative start).

        The start goes to this motor only (bus option ``start``); returns the Q move time (s).
        """
        return await self._bus.step_angles([self._id], [angle], speed, param, mode, timeout=timeout, enable=enable)

    async def set_speed(
        self,
        speed: float,
        param: float = 0.0,
        mode: int = VelocityMode.PASSTHROUGH,
        *,
        duration: float | None = None,
        enable: bool = False,
    ) -> None:
        """Run at ``speed`` r/min. mode 1: ``param`` = torque FF Nm; mode 2: ramp ``param`` (r/min)/s.

        With ``duration`` (s) the bus sends speed 0 that long after, by itself (see :mod:`drempower.client.api.timed`).
        """
        msg = make_speed(self._id, speed, param, mode)
        await self._bus._gated((msg,), enable, duration=check_duration(duration))

    async def set_torque(
        self,
        torque: float,
        param: float = 0.0,
        mode: int = TorqueMode.DIRECT,
        *,
        duration: float | None = None,
        enable: bool = False,
    ) -> None:
        """Apply ``torque`` Nm. mode 1: at once; mode 6: ramp at ``param`` Nm/s.

        With ``duration`` (s) the bus sends torque 0 that long after, by itself.
        """
        msg = make_torque(self._id, torque, param, mode)
        await self._bus._gated((msg,), enable, duration=check_duration(duration))

    async def impedance_control(
        self, pos: float, vel: float = 0.0, tff: float = 0.0, kp: float = 0.0, kd: float = 0.0, *, enable: bool = False
    ) -> None:
        """Impedance control: ``tff + kp*(pos - P) + kd*(vel - V)``; pos deg, vel r/min, tff Nm,
        kp Nm/rad, kd Nm/(rad/s). The start goes to this motor only (bus option ``start``)."""
        preset, start = make_impedance(self._id, pos, vel, tff, kp, kd)
        await self._bus.pass_gate((preset,), enable)
        await self._bus.run(ops.impedance(preset, start))
        self._bus._sent((preset,))

    async def stop(self) -> None:
        """Speed 0 now: the motor holds where it is. Never refused by the safety gate (stopping is always
        possible); a pending timed stop is dropped (this one came first)."""
        msg = Velocity(self._id, 0.0)
        self._core.send(msg)
        self._bus._sent((msg,))

    async def enable(self) -> None:
        """Enter closed loop (``set_mode(2)``): motion commands are obeyed from now on."""
        await self.set_mode(2)

    async def idle(self) -> None:
        """Release the motor (``set_mode(1)``): it stops driving and can be turned by hand."""
        await self.set_mode(1)

    async def estop(self) -> None:
        """Emergency stop: the motor goes idle and ignores motion until clear_error + set_mode(2)."""
        self._core.estop([self._id])
        self._gate.estopped((self._id,))

    async def position_done(
        self,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
        tolerance: float = MOVE_TOLERANCE,
    ) -> MotorState:
        """Wait until the move is done (vendor name of :meth:`wait_position_done`)."""
        return await self.wait_position_done(timeout, poll_interval=poll_interval, tolerance=tolerance)

    async def wait_position_done(
        self,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
        tolerance: float = MOVE_TOLERANCE,
    ) -> MotorState:
        """Wait until the motor has finished its move; returns the final state.

        The final position must be within ``tolerance`` deg of the target: raises
        MoveError on a miss (angle limits, stall, estop), MoveFaultError (a
        MotorFaultError, with the decoded error flags) as soon as the motor
        reports an error and MoveTimeoutError (a TimeoutError) after ``timeout`` s;
        the state is polled every ``poll_interval`` s.
        """
        done = await self._bus.run(
            ops.wait_done(self._session, [self._id], timeout, poll_interval, tolerance=tolerance)
        )
        return done[self._id]

    async def wait_state(self, timeout: float) -> MotorState:
        """Wait for the next state frame of this motor (heartbeat, reply...) without sending anything;
        raises TimeoutError after ``timeout`` s without one."""
        return await self._bus.wait_state(self._id, timeout)

    # ------------------------------------------------------------------ settings

    async def set_id(self, new_id: int, *, timeout: float | None = None) -> AsyncMotor:
        """Change the id to ``new_id`` (1..63), check the motor answers there, save; returns its new handle.

        Raises IdTakenError when another motor already answers at ``new_id`` and
        VerifyError when the motor is not heard at its new id.
        """
        await self._bus.run(ops.set_id(self._session, self._id, new_id, timeout))
        return self._bus.motor(new_id)

    async def set_can_baud_rate(self, baud_rate: int, *, timeout: float | None = None) -> None:
        """Set the CAN bitrate (125000/250000/500000/1000000) and save; applies after a reboot."""
        await self._bus.run(ops.set_can_baud_rate(self._id, baud_rate, timeout, self._session.retries))

    async def set_uart_baud_rate(self, baud_rate: int, *, timeout: float | None = None) -> None:
        """Set the UART rate (M series: 9600/19200/57600/115200) and save."""
        await self._bus.run(ops.set_uart_baud_rate(self._id, baud_rate, timeout, self._session.retries))

    async def set_mode(self, mode: int = 2) -> None:
        """1 (AxisMode.IDLE): release the motor; 2 (AxisMode.CLOSED_LOOP): enable control."""
        msg = ops.set_mode(self._id, mode)
        self._core.send(msg)
        self._gate.note_sent((msg,))

    async def set_zero_position(self) -> None:
        """Make the current output position 0 deg."""
        self._system(SysCmd.SET_ZERO_POSITION)

    async def set_GPIO_mode(self, mode: str = "tx_rx", param: float = 115200, *, timeout: float | None = None) -> None:
        """Spare pins as UART (``"tx_rx"``, param = baud) or step/dir (param = pulses); saves and reboots."""
        try:
            await self._bus.run(ops.set_gpio_mode(self._id, mode, param, timeout, self._session.retries))
        finally:
            self._gate.forget((self._id,))  # it reboots

    async def get_GPIO_mode(self, *, timeout: float | None = None) -> GpioMode:
        """What the spare pins do (M series)."""
        return await self._bus.run(ops.get_gpio_mode(self._id, timeout))

    async def set_angle_range(
        self, angle_min: float = -360.0, angle_max: float = 360.0, *, timeout: float | None = None
    ) -> None:
        """Enable software limits [angle_min, angle_max] deg and save; the motor must be inside them."""
        await self._bus.run(ops.set_angle_range(self._id, angle_min, angle_max, timeout, self._session.retries))

    async def set_traj_mode(self, mode: int = TrajMode.TRAPEZOID, *, timeout: float | None = None) -> None:
        """Q-mode profile: 1 trapezoid, 2 S-curve (verified, remembered for set_angles; not saved)."""
        await self._bus.run(ops.set_traj_mode(self._id, mode, timeout, self._session.retries))

    async def get_traj_mode(self, *, timeout: float | None = None) -> TrajMode:
        """The motor's Q-mode profile, read from it."""
        return await self._bus.run(ops.get_traj_mode(self._session, self._id, timeout))

    async def write_property(
        self,
        property: str | int,
        value: float,
        *,
        verify: bool = False,
        timeout: float | None = None,
        force: bool = False,
    ) -> None:
        """Write parameter ``property`` (name or address) in RAM; ``verify`` reads it back.

        A value outside the parameter's domain (``spec/parameters.csv``) raises
        :class:`~drempower.protocol.parameters.DomainError` naming parameter, value and
        domain, and nothing is sent; ``force=True`` writes one outside a soft domain
        (never outside a hard one, such as can_node_id 1..63, or the type's range).
        A read-back that differs is written and read again up to the bus's ``retries``
        times, then raises VerifyError.

        A parameter that commands motion (the output shaft's ``input_pos``/``input_vel``/
        ``input_torque``, modes...: :data:`~drempower.client.engine.gate.MOTION_PARAMETERS`) passes the
        safety gate as the motion command it is (MotorIdleError, SoftLimitError) or is refused
        (MotionParameterError) before anything is sent.
        """
        op = self._bus._param_gate(self._id, property, value, force)
        if op is not None:
            await self._bus.run(op)
        await self._bus.run(
            ops.write_property(self._id, property, value, verify, timeout, force, self._session.retries)
        )
        self._bus._param_sent(self._id, property, value)
        if parameter(property).address == AXIS0_REQUESTED_STATE:
            self._gate.learn(self._id, int(value))

    async def read_property(self, property: str | int, *, timeout: float | None = None) -> int | float:
        """Read parameter ``property`` (name or address)."""
        value = await self._bus.run(ops.read_property(self._session, self._id, property, timeout))
        if parameter(property).address == AXIS0_CURRENT_STATE:
            self._gate.learn(self._id, int(value))
        return value

    async def enable_reply_state(self, on: bool = True, *, timeout: float | None = None) -> None:
        """Make the motor answer every control frame with its state (31214), verified."""
        await self._bus.run(
            ops.write_property(
                self._id,
                AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE,
                int(on),
                True,
                timeout,
                retries=self._session.retries,
            )
        )

    # ------------------------------------------------------------------ queries

    async def get_id(self, *, timeout: float | None = None) -> int:
        """The id the motor reports (useful with handle 0 and a single motor)."""
        return await self._bus.run(ops.get_id(self._id, timeout))

    async def get_state(self, *, timeout: float | None = None) -> MotorState:
        """Fresh state (angle deg, speed r/min, torque Nm, done, error) by fast read."""
        return await self._bus.run(ops.fast_read(self._id, timeout))

    async def get_volcur(self, *, timeout: float | None = None) -> tuple[float, float]:
        """Supply voltage (V) and q-axis current (A)."""
        return await self._bus.run(ops.get_volcur(self._id, timeout))

    async def dump_error(self, *, timeout: float | None = None) -> ErrorReport:
        """The seven error words, decoded into flag names."""
        return await self._bus.run(ops.dump_error(self._id, timeout))

    async def health(self, *, timeout: float | None = None) -> Health:
        """Temperatures (degC), effective current limit (A), derating (0..1) and errors, in one exchange
        of five reads (a second one reads the error words when the motor is faulted)."""
        return await self._bus.run(read_health(self._id, timeout))

    # ------------------------------------------------------------------ system

    async def clear_error(self) -> None:
        """Clear the error flags; the motor stays idle until set_mode(2)."""
        self._system(SysCmd.CLEAR_ERRORS)

    async def save_config(self) -> None:
        """Store the RAM configuration in flash."""
        self._system(SysCmd.SAVE_CONFIG)

    async def reboot(self) -> None:
        """Software reset (unsaved writes are lost)."""
        self._system(SysCmd.REBOOT)

    async def init_config(self) -> None:
        """Restore the default configuration (a calibration is needed afterwards)."""
        self._system(SysCmd.INIT_CONFIG)

    async def erase_config(self) -> None:
        """Erase the stored configuration (calibration is lost)."""
        self._system(SysCmd.ERASE_CONFIG)

    # ------------------------------------------------------------------ configuration backup

    async def backup(
        self, path: str | os.PathLike[str] | None = None, *, timeout: float | None = None
    ) -> _backup.ConfigBackup:
        """Read every parameter; also write them as JSON to ``path`` when given (OSError if it cannot)."""
        from ..engine import backup as _backup  # loaded on first use, not with drempower

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
        """Write a backup (object or JSON file) back; see :func:`drempower.client.engine.backup.restore`."""
        from ..engine import backup as _backup  # loaded on first use, not with drempower

        op = _backup.restore(
            self._session, self._id, source, timeout, include_link=include_link, save=save, dry_run=dry_run, force=force
        )
        return await self._bus.run(op)


@checks_times
class AsyncBus(AsyncBusMoves[AsyncMotor]):
    """A DrEmpower bus: owns a transport and hands out :class:`AsyncMotor` handles (``bus.motor(id)``).

    Use it as a context manager, or call :meth:`close`. The threaded bus may be
    called from several threads at once; the asyncio one from one event loop.
    Requests wait at most ``timeout`` seconds (default the transport's, else 0.1;
    each method also takes ``timeout=``) and raise
    :class:`~drempower.client.errors.TimeoutError`. See
    :class:`~drempower.client.engine.session.BusSession` for ``retries``, ``start`` and
    ``stop_on_close``; buses left open are closed when Python exits.
    """

    def _new_motor(self, id: int) -> AsyncMotor:
        return AsyncMotor(self, id)

    async def send(self, msg: Message) -> None:
        """Send one message (validated first); never waits for a reply.

        The raw path: no safety gate (see :mod:`drempower.client.engine.gate`); the motion methods and
        :meth:`cycle` pass it."""
        self._check_writes([msg])
        await self._send_all([msg])
        self._sent((msg,))

    async def send_many(self, msgs: Sequence[Message]) -> None:
        """Send several messages; if any is invalid, none is sent (raw, as :meth:`send`)."""
        self._check_writes(msgs)
        await self._send_all(msgs)
        self._sent(msgs)

    async def enable(self, id_list: Iterable[int]) -> None:
        """Put the listed motors in closed loop (``set_mode(2)`` each, in one go)."""
        msgs = [ops.set_mode(n, 2) for n in check_ids(as_list(id_list, "id_list"))]
        self._core.send_many(msgs)
        self._gate.note_sent(msgs)

    async def idle(self, id_list: Iterable[int]) -> None:
        """Release the listed motors (``set_mode(1)`` each, in one go)."""
        msgs = [ops.set_mode(n, 1) for n in check_ids(as_list(id_list, "id_list"))]
        self._core.send_many(msgs)
        self._gate.note_sent(msgs)

    async def request(
        self, msgs: Sequence[Message], timeout: float | None = None, *, missing_ok: bool = False
    ) -> list[Any]:
        """Send reads/fast reads and return their answers (ParamValue / MotorState) in order.

        Missing answers raise :class:`~drempower.client.errors.TimeoutError`, or are None with ``missing_ok``.
        """
        answers = await self.run(request(list(msgs), timeout, missing_ok))
        self._gate.learn_replies(answers)
        return answers

    # ------------------------------------------------------------------ motors

    async def estop(self, id_list: Iterable[int] | None = None) -> None:
        """Emergency-stop the listed motors, or every motor (one broadcast frame) when None."""
        self.estop_now(id_list)

    async def health(self, id_list: Iterable[int], *, timeout: float | None = None) -> dict[int, Health]:
        """The health of every motor of ``id_list``, read in one exchange (see :meth:`AsyncMotor.health`)."""
        nodes = check_ids(list(id_list))
        return {h.id: h for h in await self.run(read_healths(nodes, timeout))}

    async def supervise(self, watches: Sequence[Watch], *, timeout: float | None = None) -> list[HealthEvent]:
        """One supervisor step over ``watches`` (see :mod:`drempower.client.engine.supervisor`): the state and health of
        every watched motor in one exchange (12 frames per motor), the events that began, their actions sent.
        Call it every ``policy.period`` s; the first call also reads each motor's limits (7 reads per motor)."""
        fresh = [w for w in watches if w.limits.kt != w.limits.kt]
        if fresh:
            await self.run(prepare(fresh, timeout))
        events = await self.run(supervise(watches, self.now(), timeout))
        self.health_acted(events)
        return events

    async def traj_modes(self, ids: Iterable[int], *, timeout: float | None = None) -> dict[int, int]:
        """The Q-mode profile of each motor (:class:`~drempower.client.engine.commands.TrajMode` values): those the
        bus knows, the rest read in one exchange."""
        return await self.run(ops.traj_modes(self._session, check_ids(as_list(ids, "ids")), timeout))

    async def scan(
        self, ids: Iterable[int] = batch.ALL_IDS, *, timeout: float | None = None, versions: bool = False
    ) -> list[MotorInfo]:
        """Find the motors that answer (ids 1..63 by default), with hardware/firmware versions on request."""
        return await self.run(batch.scan(as_list(ids, "ids"), timeout, versions))

    async def cycle(
        self,
        commands: Iterable[Message],
        *,
        timeout: float | None = None,
        reply_state: bool | None = None,
        enable: bool = False,
    ) -> dict[int, MotorState]:
        """Send one command per motor and return each motor's state (see :func:`drempower.client.engine.batch.cycle`).

        The commands pass the safety gate; once their motors are known to be in closed loop that
        costs no exchange (see :mod:`drempower.client.engine.gate`).
        """
        cmds = self._commands(commands)
        run = batch.cycle(self._session, cmds, timeout, reply_state)  # every command valid before the gate reads
        op = self._gate_op(cmds, enable)
        if op is not None:
            await self.run(op)
        states = await self.run(run)
        self._sent(cmds)
        return states

    # ------------------------------------------------------------------ lifetime

    async def __aenter__(self) -> AsyncBus:
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.close()


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
    profile: str | os.PathLike[str] | Mapping[str, Any] | FirmwareProfile | None = None,
    **kwargs: Any,
) -> AsyncBus:
    """Open a bus: ``open_bus_async("sim", motors=[1, 2, 3])``, ``open_bus_async("socketcan", "can0")``,
    ``open_bus_async("adapter", "/dev/ttyACM0")``, ``open_bus_async("uart", "/dev/ttyUSB0")``...

    ``interface``/``channel``/``bitrate`` and extra keyword arguments select the
    transport (see :func:`drempower.transports.open_transport`); or pass an open
    ``transport``. Fails at once with :class:`~drempower.transports.TransportError`
    when the bus does not exist. ``profile`` (a file of ``drempower doctor --write-profile``,
    or its mapping) says what the motors' firmware sends (:mod:`drempower.client.api.profile`).
    The remaining options are those of :class:`AsyncBus`; use it as a context manager, which
    closes the bus (applying ``stop_on_close``).
    """
    prof = load_profile(profile) if profile is not None else None
    transport = connect(interface, channel, bitrate, transport, **kwargs)
    try:
        bus = AsyncBus(transport, timeout=timeout, retries=retries, stop_on_close=stop_on_close, start=start)
        if prof is not None:
            apply_profile(bus._session.inbox.bits, prof)
        return bus
    except BaseException:
        transport.close()
        raise
