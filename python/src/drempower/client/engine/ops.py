"""Single-motor operations that take more than one frame (see :mod:`.effects`)."""

from __future__ import annotations

import functools
import math
import struct
from collections.abc import Sequence

from ...errors import (
    DrEmpowerError,
    FieldRangeError,
    IdTakenError,
    MotorFaultError,
    MoveError,
    MoveFaultError,
    MoveTimeoutError,
    NoMotorError,
    TimeoutError,
    ValidationError,
    VerifyError,
    motors,
)
from ...protocol.addresses import (
    AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MAX,
    AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MIN,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE,
)
from ...protocol.ids import SysCmd
from ...protocol.limits import check_motor
from ...protocol.messages import FastRead, PresetD, ReadParam, StartImpedance, SystemCommand, WriteParam
from ...protocol.parameters import DataType, Parameter, parameter
from .commands import AxisMode, TrajMode
from .effects import Batch, Op, Request, Send, Single, read_params, read_states, request, sleep
from .results import ERROR_WORD_NAMES, ErrorReport, GpioMode
from .session import MOVE_TOLERANCE, BusSession, MoveRecord
from .state import MotorState

__all__ = [
    "get_state",
    "read_property",
    "write_property",
    "write_verified",
    "get_id",
    "set_id",
    "get_volcur",
    "dump_error",
    "set_can_baud_rate",
    "set_uart_baud_rate",
    "set_mode",
    "get_traj_mode",
    "set_traj_mode",
    "traj_modes",
    "set_angle_range",
    "get_gpio_mode",
    "set_gpio_mode",
    "wait_done",
    "CAN_BAUD_RATES",
    "UART_BAUD_RATES",
]

CAN_BAUD_RATES = (125_000, 250_000, 500_000, 1_000_000)
UART_BAUD_RATES = (9600, 19200, 57600, 115200)
_F32 = struct.Struct("<f")
LOST_MOVE_GRACE = 0.02
"""How long (s) after a start a state showing no motion counts as a sign that the start (or its preset) was lost."""
_SAVE_SETTLE = 0.1
"""Pause (s) between save_config and reboot, as the vendor library does."""
BOOT_WAIT = 5.0
"""Longest wait (s) for a rebooted motor to answer again (it is silent while it boots)."""
_BOOT_POLL = (0.1, 0.05)
"""Fast-read timeout and pause (s) while a rebooted motor boots."""


def _same(p: Parameter, written: float, read: float) -> bool:
    if p.dtype is DataType.F32:
        return _F32.pack(written) == _F32.pack(read)
    return int(written) == int(read)


def _system(node: int, op: SysCmd) -> Send:
    return Send([SystemCommand(node, op)])


@functools.lru_cache(maxsize=256)
def fast_read(node: int, timeout: float | None = None) -> Single[MotorState]:
    """Fresh state by fast read, as one :class:`~drempower.client.engine.effects.Single` request (no generator);
    immutable, so the same arguments give the same object (a polling loop builds it once)."""
    return Single(Request([FastRead(node)], timeout))


def get_state(node: int, timeout: float | None = None) -> Op[MotorState]:
    """Fresh state by fast read."""
    (st,) = yield from read_states([node], timeout)
    assert st is not None
    return st


def read_property(core: BusSession, node: int, prop: str | int, timeout: float | None = None) -> Op[int | float]:
    """Value of parameter ``prop`` (name or address)."""
    p = parameter(prop)
    (value,) = yield from read_params(node, [p], timeout)
    core.learn(node, p.address, value)
    v: int | float = value
    return v


def write_property(
    node: int,
    prop: str | int,
    value: float,
    verify: bool = False,
    timeout: float | None = None,
    force: bool = False,
    retries: int = 0,
) -> Op[None]:
    """Write ``value`` to ``prop``; with ``verify`` read it back and raise :class:`VerifyError` if it differs
    after ``retries`` more writes and read-backs (a write lost on the bus gets no reply).

    A value outside the parameter's domain raises :class:`~drempower.protocol.parameters.DomainError`
    before anything is sent; ``force`` lets one outside a soft domain through.
    """
    msg = WriteParam.of(node, prop, value, force=force)
    yield Send([msg])
    if verify:
        yield from _verify(node, [msg], timeout, retries)


def _verify(node: int, writes: Sequence[WriteParam], timeout: float | None, retries: int = 0) -> Op[None]:
    """Read ``writes`` back; write the differing ones again and read again, up to ``retries`` times."""
    params = {w.address: parameter(w.address) for w in writes}
    left = list(writes)
    for attempt in range(retries + 1):
        if attempt:
            yield Send(left)
        values = yield from read_params(node, [params[w.address] for w in left], timeout)
        wrong = [(w, v) for w, v in zip(left, values, strict=True) if not _same(params[w.address], w.value, v)]
        if not wrong:
            return
        left = [w for w, _ in wrong]
    w, v = wrong[0]
    raise VerifyError(f"motor {node}: {params[w.address].name} reads {v!r} after writing {w.value!r}")


def write_verified(
    node: int, items: Sequence[tuple[str | int, float]], timeout: float | None = None, retries: int = 0
) -> Op[None]:
    """Write several parameters, then read them all back in one exchange and check them; the ones that
    differ are written and read again, up to ``retries`` times."""
    writes = [WriteParam.of(node, prop, value) for prop, value in items]
    yield Send(writes)
    yield from _verify(node, writes, timeout, retries)


def get_id(node: int, timeout: float | None = None) -> Op[int]:
    """The motor's id as it reports it (``axis0.config.can_node_id``)."""
    (value,) = yield from read_params(node, ["axis0.config.can_node_id"], timeout)
    return int(value)


def set_id(core: BusSession, node: int, new_id: int, timeout: float | None = None) -> Op[None]:
    """Give the motor ``new_id`` (1..63), check that it answers there, then save.

    Before writing: the motor must answer at ``node`` (any motor, for broadcast 0)
    and no motor may answer at ``new_id``, so two motors never end up sharing an id.
    """
    check_motor(new_id, "new_id")
    write = WriteParam.of(node, "axis0.config.can_node_id", new_id)
    if new_id == node:
        (present,) = yield from read_states([node], timeout, missing_ok=True)
        if present is None:
            raise NoMotorError(f"no motor answers at id {node}; nothing was changed")
    else:
        here, taken = yield from read_states([node, new_id], timeout, missing_ok=True)
        if taken is not None:
            raise IdTakenError(f"id {new_id} is already taken by another motor; nothing was changed")
        if here is None:
            raise NoMotorError(f"no motor answers at id {node}; nothing was changed")
    yield Send([write])
    try:
        answered = yield from get_id(new_id, timeout)
    except TimeoutError as exc:
        raise NoMotorError(f"motor {node} does not answer at its new id {new_id}; nothing was saved") from exc
    if answered != new_id:
        raise VerifyError(f"motor at id {new_id} reports id {answered}; nothing was saved")
    yield _system(new_id, SysCmd.SAVE_CONFIG)
    if node != new_id:
        for n in (node, new_id):
            core.forget(n)
            core.known.states.pop(n, None)


def get_volcur(node: int, timeout: float | None = None) -> Op[tuple[float, float]]:
    """Supply voltage (V) and q-axis current (A) (vendor ``get_volcur``)."""
    v, i = yield from read_params(node, ["vbus_voltage", "axis0.motor.current_control.Iq_measured"], timeout)
    return float(v), float(i)


def dump_error(node: int, timeout: float | None = None) -> Op[ErrorReport]:
    """Read the seven error words in one exchange."""
    values = yield from read_params(node, ERROR_WORD_NAMES, timeout)
    return ErrorReport(node, {name: int(v) for name, v in zip(ERROR_WORD_NAMES, values, strict=True)})


def set_can_baud_rate(node: int, baud_rate: int, timeout: float | None = None, retries: int = 0) -> Op[None]:
    """Set the CAN bitrate (125k/250k/500k/1M), verify, save; it applies after a reboot."""
    if baud_rate not in CAN_BAUD_RATES:
        raise ValidationError(f"baud_rate={baud_rate!r}: CAN bitrates are {', '.join(map(str, CAN_BAUD_RATES))}")
    yield from write_verified(node, [("can.config.baud_rate", baud_rate)], timeout, retries)
    yield _system(node, SysCmd.SAVE_CONFIG)


def set_uart_baud_rate(node: int, baud_rate: int, timeout: float | None = None, retries: int = 0) -> Op[None]:
    """Set the UART rate of an M-series motor (9600/19200/57600/115200), verify, save."""
    if baud_rate not in UART_BAUD_RATES:
        raise ValidationError(f"baud_rate={baud_rate!r}: UART rates are {', '.join(map(str, UART_BAUD_RATES))}")
    yield from write_verified(node, [("config.uart_baudrate", baud_rate)], timeout, retries)
    yield _system(node, SysCmd.SAVE_CONFIG)


def set_mode(node: int, mode: int) -> WriteParam:
    """The write of ``axis0.requested_state`` for set_mode: 1 = IDLE, 2 = closed loop."""
    try:
        m = AxisMode(mode)
    except ValueError:
        raise ValidationError(f"mode={mode!r}: 1 (idle) or 2 (closed loop); calibration is not offered") from None
    return WriteParam.of(node, "axis0.requested_state", 1 if m is AxisMode.IDLE else 8)


def get_traj_mode(core: BusSession, node: int, timeout: float | None = None) -> Op[TrajMode]:
    """The motor's Q-mode profile (35104), read and remembered."""
    value = yield from read_property(core, node, AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE, timeout)
    return _reported_traj_mode(node, value)


def _reported_traj_mode(node: int, value: float) -> TrajMode:
    if value in (1, 2):
        return TrajMode(int(value))
    raise DrEmpowerError(
        f"motor {node} reports axis0.trap_traj.config.traj_mode={value!r}, which is neither "
        "1 (trapezoid) nor 2 (S-curve); set it with set_traj_mode"
    )


def set_traj_mode(node: int, mode: int, timeout: float | None = None, retries: int = 0) -> Op[None]:
    """Set the Q-mode profile (1 trapezoid, 2 S-curve), verified and remembered (not saved)."""
    try:
        m = TrajMode(mode)
    except ValueError:
        raise ValidationError(f"mode={mode!r}: 1 (trapezoid) or 2 (S-curve)") from None
    yield from write_property(node, AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE, int(m), True, timeout, retries=retries)


def traj_modes(core: BusSession, nodes: Sequence[int], timeout: float | None = None) -> Op[dict[int, int]]:
    """The Q-mode profile of each motor: remembered ones, the rest read in one exchange."""
    unknown = [n for n in nodes if n not in core.known.traj_mode]
    if unknown:
        p = parameter(AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE)
        replies = yield from request([ReadParam(n, p.address, p.dtype) for n in unknown], timeout)
        for n, r in zip(unknown, replies, strict=True):
            core.learn(n, p.address, int(_reported_traj_mode(n, r.value)))
    return {n: core.known.traj_mode[n] for n in nodes}


def set_angle_range(
    node: int, angle_min: float, angle_max: float, timeout: float | None = None, retries: int = 0
) -> Op[None]:
    """Enable software limits [angle_min, angle_max] deg; the motor must be inside them now."""
    for v, f in ((angle_min, "angle_min"), (angle_max, "angle_max")):
        if not (isinstance(v, (int, float)) and math.isfinite(v)):
            raise ValidationError(f"{f}={v!r}: expected a finite number of degrees")
    if not angle_min < angle_max:
        raise ValidationError(f"angle_min={angle_min} must be below angle_max={angle_max}")
    for address, v in (
        (AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MIN, angle_min),
        (AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MAX, angle_max),
    ):
        parameter(address).check(v)  # before the read: nothing is sent for a limit that cannot be written
    st = yield from get_state(node, timeout)
    if not angle_min <= st.angle <= angle_max:
        raise ValidationError(
            f"motor {node} is at {st.angle:.2f} deg, outside [{angle_min}, {angle_max}]; move it inside first"
        )
    yield from write_verified(
        node,
        [
            ("axis0.output_shaft.circular_setpoint_min", angle_min),
            ("axis0.output_shaft.circular_setpoint_max", angle_max),
            ("axis0.config.extra_setting.enable_circular_setpoint_limit", 1),
        ],
        timeout,
        retries,
    )
    yield _system(node, SysCmd.SAVE_CONFIG)


def get_gpio_mode(node: int, timeout: float | None = None) -> Op[GpioMode]:
    """What the spare pins do (M series)."""
    uart, step = yield from read_params(node, ["config.enable_uart", "axis0.config.enable_step_dir"], timeout)
    if uart:
        (baud,) = yield from read_params(node, ["config.uart_baudrate"], timeout)
        return GpioMode("tx_rx", True, bool(step), float(baud))
    if step:
        (steps,) = yield from read_params(node, ["axis0.output_shaft.steps_per_turn"], timeout)
        return GpioMode("step_dir", False, True, float(steps))
    return GpioMode("off", False, False, None)


def set_gpio_mode(node: int, mode: str, param: float, timeout: float | None = None, retries: int = 0) -> Op[None]:
    """Switch the spare pins to UART (``"tx_rx"``, param = baud) or step/dir (param = pulses 1..1024).

    The writes are verified, then saved, and the motor reboots (as the vendor's does); this returns once
    it answers again (it is silent while it boots).
    """
    if mode == "tx_rx":
        if param not in UART_BAUD_RATES:
            raise ValidationError(f"param={param!r}: UART rates are {', '.join(map(str, UART_BAUD_RATES))}")
        items: list[tuple[str | int, float]] = [
            ("axis0.config.enable_step_dir", 0),
            ("config.enable_uart", 1),
            ("config.uart_baudrate", int(param)),
        ]
    elif mode == "step_dir":
        if not (
            isinstance(param, (int, float)) and math.isfinite(param) and param == int(param) and 1 <= param <= 1024
        ):
            raise FieldRangeError("param", param, 1, 1024, "whole pulses per turn")
        items = [
            ("config.enable_uart", 0),
            ("axis0.config.enable_step_dir", 1),
            ("axis0.output_shaft.steps_per_turn", float(param)),
        ]
    else:
        raise ValidationError(f"mode={mode!r}: 'tx_rx' or 'step_dir'")
    yield from write_verified(node, items, timeout, retries)
    yield _system(node, SysCmd.SAVE_CONFIG)
    yield from sleep(_SAVE_SETTLE)
    yield _system(node, SysCmd.REBOOT)
    if node:
        yield from wait_booted(node)


def wait_booted(node: int, limit: float = BOOT_WAIT) -> Op[None]:
    """Fast-read ``node`` until it answers again after a reboot; :class:`TimeoutError` after about ``limit`` s."""
    wait, pause = _BOOT_POLL
    for _ in range(max(1, math.ceil(limit / (wait + pause)))):
        (st,) = yield from read_states([node], wait, missing_ok=True)
        if st is not None:
            return
        yield from sleep(pause)
    raise TimeoutError([node], "a fast read after the reboot", limit)


def _fault(node: int, doing: str, timeout: float | None) -> Op[MotorFaultError]:
    flags = yield from _flags(node, timeout)
    return MotorFaultError(node, doing, flags)


def _flags(node: int, timeout: float | None) -> Op[dict[str, list[str]]]:
    """The motor's decoded error flags, or {} when they cannot be read."""
    try:
        report = yield from dump_error(node, timeout)
    except TimeoutError:
        return {}
    return report.flags


def _finished(st: MotorState, mv: MoveRecord | None, tolerance: float) -> bool:
    """Whether ``st`` shows that the move ``mv`` is over (see :func:`wait_done`)."""
    if not st.trajectory_done:
        return False
    if mv is None:
        return True
    if st.timestamp <= mv.sent:
        return False
    if mv.took is not None and st.timestamp > mv.took:
        return True
    if mv.move_time is not None and st.timestamp >= mv.sent + mv.move_time:
        return True
    return mv.target is not None and abs(st.angle - mv.target) <= tolerance


def _lost(st: MotorState, mv: MoveRecord, tolerance: float) -> bool:
    """Whether ``st`` shows that the motor never got the move ``mv`` (a frame that started it was lost):
    a state newer than the start by :data:`LOST_MOVE_GRACE`, with T = 1, no T = 0 seen since the start,
    away from a known target."""
    return (
        bool(mv.resend)
        and mv.took is None
        and mv.target is not None
        and st.trajectory_done
        and st.timestamp > mv.sent + LOST_MOVE_GRACE
        and abs(st.angle - mv.target) > tolerance
    )


def wait_done(
    core: BusSession,
    nodes: Sequence[int],
    timeout: float,
    poll_interval: float,
    request_timeout: float | None = None,
    tolerance: float = MOVE_TOLERANCE,
) -> Op[dict[int, MotorState]]:
    """Poll the motors (fast reads, one exchange per round) until each has finished its move,
    then check that each is within ``tolerance`` deg of its target.

    A state counts as the end of a move this bus commanded (see
    :attr:`BusSession.moves`) only when it arrived after the move's command or
    start was sent, has the T bit set, and the motor has shown it took the
    move: a state with T = 0 arrived after the start, or the planned Q move
    time has passed, or it is at the new target. For a motor this bus did not
    move, the first state with T = 1 ends the wait.

    Raises :class:`MoveError` when a motor ended away from its target (angle
    limits, a stall, an estop), :class:`MoveFaultError` (also a
    :class:`MotorFaultError`) as soon as one reports an error, and
    :class:`MoveTimeoutError` (also a :class:`TimeoutError`) naming the motors
    still moving after ``timeout`` s; each names the motor, its target, the
    position reached and its decoded error flags.
    """
    if not timeout > 0 or not poll_interval > 0:
        raise ValidationError(f"timeout={timeout!r} and poll_interval={poll_interval!r} must be > 0 s")
    if not (isinstance(tolerance, (int, float)) and tolerance >= 0 and math.isfinite(tolerance)):
        raise ValidationError(f"tolerance={tolerance!r}: expected a finite number of degrees >= 0")
    deadline = core.now + timeout
    waiting = list(dict.fromkeys(nodes))
    moves = core.known.moves
    resent: dict[int, int] = {}
    done: dict[int, MotorState] = {}
    last: dict[int, MotorState] = {}
    while True:
        states = yield from read_states(waiting, request_timeout)
        for st in states:
            assert st is not None
            node = st.node
            last[node] = st
            mv = moves.get(node)
            if st.error:
                flags = yield from _flags(node, request_timeout)
                target = None if mv is None else mv.target
                raise MoveFaultError(node, target, st.angle, flags, "reported an error while moving")
            if mv is not None and resent.get(node, 0) < core.retries and _lost(st, mv, tolerance):
                resent[node] = resent.get(node, 0) + 1
                core.moves_resent += 1
                yield Send(mv.resend)
                again = moves.get(node)
                if again is not None and again is not mv:  # the resend's own record: keep what the wait knows
                    again.target, again.move_time = mv.target, mv.move_time
                continue
            if _finished(st, mv, tolerance):
                done[node] = st
        waiting = [n for n in waiting if n not in done]
        if not waiting:
            break
        left = deadline - core.now
        if left <= 0:
            late: list[MoveError] = []
            for n in waiting:
                mv = moves.get(n)
                st = last.get(n)
                took = mv is None or mv.took is not None or (st is not None and not st.trajectory_done)
                why = "still moving" if took else "no sign that it took the move"
                flags = yield from _flags(n, request_timeout)
                late.append(
                    MoveError(
                        n,
                        None if mv is None else mv.target,
                        None if st is None else st.angle,
                        flags,
                        f"{why} after {timeout:g} s",
                    )
                )
            first = late[0]
            raise MoveTimeoutError(
                first.node,
                first.target,
                first.position,
                first.flags,
                first.reason + ("" if len(waiting) == 1 else f" ({motors(waiting)} not done)"),
                timeout,
                waiting,
                late[1:],
            )
        yield from sleep(min(poll_interval, left))
    for node, st in done.items():
        mv = moves.get(node)
        if mv is not None and mv.target is not None and abs(st.angle - mv.target) > tolerance:
            flags = yield from _flags(node, request_timeout)
            raise MoveError(
                node, mv.target, st.angle, flags, f"the move ended {st.angle - mv.target:+.2f} deg off its target"
            )
    return done


def impedance(preset: PresetD, start: StartImpedance) -> Op[None]:
    """Impedance control of one motor: its preset, then the start addressed to it alone."""
    yield Batch([preset], start)
