"""Multi-motor operations: synchronised moves, the control cycle and the bus scan."""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable, Sequence

from ...errors import FieldRangeError, ValidationError
from ...protocol.addresses import AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE
from ...protocol.ids import Frame
from ...protocol.limits import MOTION_CMDS, MOTOR_IDS
from ...protocol.messages import S16_MAX, FastRead, Message, ReadParam
from ...protocol.parameters import DataType
from .commands import (
    PositionMode,
    check_ids,
    make_angles,
    make_impedances,
    make_speeds,
    make_torques,
    position_mode,
    q_move_time,
)
from .effects import Batch, Cycle, Op, Runnable, read_states, request
from .ops import traj_modes
from .results import MotorInfo
from .session import BusSession
from .state import MotorState

__all__ = ["move_angles", "set_speeds", "set_torques", "cycle", "scan", "ALL_IDS"]

ALL_IDS = MOTOR_IDS
_REPLY_STATE = AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE


def move_angles(
    core: BusSession,
    ids: Sequence[int],
    angles: Sequence[float],
    speed: float,
    param: float,
    mode: int,
    relative: bool,
    timeout: float | None = None,
) -> Op[float | None]:
    """Synchronised absolute (``set_angles``) or relative (``step_angles``) move.

    Every argument is validated before any frame is sent. In Q mode the move
    time follows PROTOCOL.md 3.4.3 for the biggest mover, from freshly read
    positions (absolute moves) and each motor's real ``traj_mode``, rounded up
    to the 0.01 s the preset carries; it is returned (None in T and P modes).
    Relative moves read the positions first too, so every target is known:
    the bus records each target (and the move time) for the waits.
    """
    m = position_mode(mode)
    nodes = check_ids(ids, angles, "angle_list")
    make_angles(nodes, angles, speed, param, m, move_time=1.0, relative=relative)  # validate all but the time
    move_time: float | None = None
    here: list[float] | None = None
    if relative or m is PositionMode.Q:
        states = yield from read_states(nodes, timeout)
        here = [st.angle for st in states if st is not None]
    if m is PositionMode.Q:
        modes = yield from traj_modes(core, nodes, timeout)
        if relative:
            dists = [abs(a) for a in angles]
        else:
            assert here is not None
            dists = [abs(a - p) for a, p in zip(angles, here, strict=True)]
        t = max(q_move_time(d, speed, param, modes[n]) for n, d in zip(nodes, dists, strict=True))
        move_time = max(0.01, math.ceil(round(t * 100, 6)) / 100)
        if move_time > S16_MAX:
            raise FieldRangeError(
                "move time", move_time, 0.01, S16_MAX, "s; the Q preset carries at most 327.67 s: raise speed or accel"
            )
    presets, start = make_angles(nodes, angles, speed, param, m, move_time=move_time, relative=relative)
    targets = [float(a) + p for a, p in zip(angles, here, strict=True)] if relative and here else list(angles)
    yield Batch(presets, start, targets, move_time)
    return move_time


def set_speeds(ids: Sequence[int], speeds: Sequence[float], param: float, mode: int) -> Op[None]:
    """Synchronised speed change (vendor ``set_speeds``)."""
    presets, start = make_speeds(ids, speeds, param, mode)
    yield Batch(presets, start)


def set_torques(ids: Sequence[int], torques: Sequence[float], param: float, mode: int) -> Op[None]:
    """Synchronised torque change (vendor ``set_torques``)."""
    presets, start = make_torques(ids, torques, param, mode)
    yield Batch(presets, start)


def impedance_controls(
    ids: Sequence[int], positions: Sequence[float], vel: float, tff: float, kp: float, kd: float
) -> Op[None]:
    """Impedance control of several motors, started together."""
    presets, start = make_impedances(ids, positions, vel, tff, kp, kd)
    yield Batch(presets, start)


def cycle(
    core: BusSession, commands: Iterable[Message], timeout: float | None = None, reply_state: bool | None = None
) -> Runnable[dict[int, MotorState]]:
    """Send one command to each motor and collect one state per motor.

    A motor with ``enable_reply_state`` on answers a control or preset frame
    with its state, so it costs one frame each way; the others get a fast read
    after the commands. ``reply_state`` None uses what the bus knows about each
    motor (reading 31214 once for motors it does not know yet); True or False
    asserts it for all. The commands are validated (encoded) here, before
    anything is sent; when nothing is to be read first, the result is a
    :class:`~drempower.client.engine.effects.Cycle` the session runs without a generator.
    """
    cmds = list(commands)
    nodes = check_ids([c.node for c in cmds])
    frames = []
    for c in cmds:
        if c.cmd == 0x1E:
            raise ValidationError("a control cycle sends commands; reads are answered by the cycle itself")
        frames.append(c.encode())
    if reply_state is None:
        known = core.known.reply_state
        unknown = [n for n in nodes if n not in known]
        if unknown:
            return _learn_then_cycle(core, cmds, frames, nodes, unknown, timeout)
        return _cycle(cmds, frames, nodes, {n for n in nodes if known[n]}, timeout)
    return _cycle(cmds, frames, nodes, nodes if reply_state else (), timeout)


def _cycle(
    cmds: list[Message], frames: list[Frame], nodes: list[int], replying: Collection[int], timeout: float | None
) -> Cycle[dict[int, MotorState]]:
    """The cycle of ``cmds``: a fast read after the commands for each motor that will not answer its command."""
    reads = [FastRead(c.node) for c in cmds if not (c.cmd in MOTION_CMDS and c.node in replying)]
    if reads:
        cmds = [*cmds, *reads]
        frames = frames + [r.encode() for r in reads]
    return Cycle(cmds, frames, nodes, timeout)


def _learn_then_cycle(
    core: BusSession,
    cmds: list[Message],
    frames: list[Frame],
    nodes: list[int],
    unknown: list[int],
    timeout: float | None,
) -> Op[dict[int, MotorState]]:
    """Read ``enable_reply_state`` of the motors the bus knows nothing of, then run the cycle."""
    replies = yield from request([ReadParam(n, _REPLY_STATE, DataType.U32) for n in unknown], timeout)
    for n, r in zip(unknown, replies, strict=True):
        core.learn(n, _REPLY_STATE, r.value)
    known = core.known.reply_state
    states: dict[int, MotorState] = yield _cycle(cmds, frames, nodes, {n for n in nodes if known.get(n)}, timeout)
    return states


def scan(ids: Iterable[int] = ALL_IDS, timeout: float | None = None, versions: bool = False) -> Op[list[MotorInfo]]:
    """Fast-read every id at once and collect the answers in one timeout window."""
    nodes = check_ids(list(ids))
    states = yield from read_states(nodes, timeout, missing_ok=True)
    found = [st for st in states if st is not None]
    if not versions or not found:
        return [MotorInfo(st.node, st) for st in found]
    reads = [ReadParam(st.node, a, DataType.U32) for st in found for a in (5, 6)]
    values = yield from request(reads, timeout, missing_ok=True)
    out = []
    for k, st in enumerate(found):
        hw, fw = values[2 * k], values[2 * k + 1]
        out.append(MotorInfo(st.node, st, hw and hw.value, fw and fw.value))
    return out
