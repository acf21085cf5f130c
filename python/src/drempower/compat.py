"""The vendor library's functions, by name and signature, over a drempower bus.

A script written for the vendor's ``DrEmpower_can.py`` switches by changing
its import and adding one line of set-up::

    from drempower import compat as dr          # was: import DrEmpower_can as dr
    dr.open("adapter", "/dev/ttyACM0")          # or dr.use_bus(bus), dr.open("sim", motors=[1, 2])
    dr.set_angle(1, 90, 10, 20, 1)
    dr.position_done(1)

Differences from the vendor library (see docs/client.md):

* Nothing happens at import; the bus is opened by :func:`open` or given to :func:`use_bus`.
* Errors raise (:class:`~drempower.errors.ValidationError`, ``TimeoutError``,
  :class:`~drempower.transports.TransportError`) instead of printing and
  returning None/False; an invalid argument sends nothing, including in
  multi-motor calls (no half-sent batches).
* Values are rounded to the 0.01 step of the wire, not truncated.
* Replies are matched to their request (motor, parameter); ``enable_replay_state``
  needs no host setting, a state reply never disturbs a read.
* ``set_angles`` reads the motors' positions and ``traj_mode`` every time
  (no stale cache); ``step_angle`` and ``impedance_control`` start only their motor.
* ``position_done``/``positions_done`` wait until the move has happened (stale
  state frames do not end them), give up after a timeout (60 s by default) and
  raise ``MoveError`` when a motor reports an error or ends away from its
  target.
* ``dump_error`` returns, like the vendor's, the sum of the seven error words
  (``== 0`` when healthy) as an int that also carries the decoded report
  (``.report``, ``.flags``, ``.words``); it prints nothing.
* A motion command to a motor that is not in closed loop raises
  :class:`~drempower.errors.MotorIdleError` and sends nothing (the vendor's is
  silently ignored by the motor): call ``set_mode(id, 2)`` first, as vendor scripts
  do. ``estop``, ``set_mode``, ``clear_error``, ``save_config``, ``reboot``,
  ``set_zero_position`` run through :mod:`drempower.actions` (its command service:
  ``set_mode(id, 2)`` returns once the motor reads closed loop and ``clear_error``
  once its error flags are gone, else each raises saying why). ``write_property``
  writes any parameter the vendor's does, checked against its domain; one that
  commands motion (``input_pos``, ``input_vel``, modes...) passes the safety gate as
  that motion (:data:`drempower.client.engine.gate.MOTION_PARAMETERS`).
* ``preset_angle``/``preset_speed``/``preset_torque`` pass the safety gate with
  what their start will command (a position preset as an absolute target):
  soft limits, and a motor not in closed loop raises ``MotorIdleError``.
* ``send_command`` is the raw path: its frame is sent as given, past the gate.
* ``set_mode`` refuses modes other than 1 and 2 instead of ignoring them;
  ``set_id`` checks that the motor answers at its new id before saving.
* Motors keep holding when the script ends, as with the vendor library: the bus
  :func:`open` opens does not idle them at close or exit (``stop_on_close=False``;
  pass ``stop_on_close=True`` to :func:`open` for the :class:`~drempower.Bus` default).
* ``preset_angle``/``preset_speed``/``preset_torque`` round to 0.01 and check
  the s16 range (the vendor truncates, and its ``preset_angle`` raises
  ``struct.error`` on overflow); ``send_command`` checks id, command and data.
* ``receive_data`` returns the next frame no request claimed (a reply the client
  matched to one of its own requests is not given twice); it waits ``timeout``
  seconds (the bus's by default) and returns None when nothing came.
* ``reply_state`` reads the motor's state with a fast read (the vendor waits for
  the status frame of the last control frame, which a late call could miss);
  ``motor_state`` rows are lists, indexable as ``motor_state[i][j]`` or
  ``motor_state[i, j]`` (the vendor uses a numpy array); ``format_data`` is
  little-endian on every host (the vendor's uses native byte order).
* ``enable_replay_state`` only selects whether the preset functions call
  ``reply_state``; replies are matched whatever the motor's setting.
* ``TRAJ_MODE`` mirrors the last ``set_traj_mode``; ``set_angles`` reads the motor's
  ``traj_mode`` itself.
"""

from __future__ import annotations

import queue
import struct
from collections.abc import Sequence
from typing import Any

from . import actions
from .client.api.bus_sync import Bus, Motor, open_bus
from .client.engine.gate import Intent
from .client.engine.results import ErrorReport
from .client.engine.session import DEFAULT_MOVE_TIMEOUT
from .client.engine.state import MotorState
from .client.errors import TimeoutError
from .errors import DrEmpowerError, FieldRangeError, ProtocolError, ValidationError
from .protocol import Frame
from .protocol.ids import check_node
from .protocol.messages import Preset, State, check_f32, check_s16, decode_command

__all__ = [
    "use_bus",
    "open",
    "close",
    "current_bus",
    "set_angle",
    "set_angles",
    "step_angle",
    "step_angles",
    "set_speed",
    "set_speeds",
    "set_torque",
    "set_torques",
    "impedance_control",
    "estop",
    "set_id",
    "set_uart_baud_rate",
    "set_can_baud_rate",
    "set_mode",
    "set_zero_position",
    "set_GPIO_mode",
    "set_angle_range",
    "set_traj_mode",
    "write_property",
    "get_id",
    "get_state",
    "get_volcur",
    "get_GPIO_mode",
    "read_property",
    "clear_error",
    "dump_error",
    "save_config",
    "reboot",
    "position_done",
    "positions_done",
    "preset_angle",
    "preset_speed",
    "preset_torque",
    "send_command",
    "receive_data",
    "format_data",
    "reply_state",
    "motor_state",
    "READ_FLAG",
    "TRAJ_MODE",
    "MOTOR_NUM",
    "enable_replay_state",
    "reply_state_error",
    "ErrorSum",
]


class _StateTable(list[list[float]]):
    """``motor_state``: row ``id - 1`` = ``[angle deg, speed r/min, torque Nm, traj_done, axis_error]``.

    Indexable as the vendor's numpy array is used: ``motor_state[0][1]`` or ``motor_state[0, 1]``.
    """

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, tuple):
            row, col = key
            return super().__getitem__(row)[col]
        return super().__getitem__(key)


MOTOR_NUM = 16
"""Rows of :data:`motor_state` (motors 1..MOTOR_NUM), as the vendor's."""
motor_state = _StateTable([0.0] * 5 for _ in range(MOTOR_NUM))
"""The last state read of each motor (see :class:`_StateTable`); updated by get_state, reply_state, the presets."""
READ_FLAG = 0
"""Result of the last read: 1 answered, -1 no answer (the call also raised), 0 nothing read yet."""
TRAJ_MODE = 1
"""The velocity profile last set with :func:`set_traj_mode` (1 trapezoid, 2 S-curve)."""
enable_replay_state = 0
"""1: the preset functions call :func:`reply_state` after sending, as the vendor's (spelling as the vendor's)."""
reply_state_error = 0
"""How often :func:`reply_state` got no answer."""

_MODES = {1: "idle", 2: "enable"}
"""set_mode's modes and the actions that carry them out."""

_bus: Bus | None = None
_frames: queue.Queue[Frame] = queue.Queue(maxsize=256)
"""Frames no request claimed, for :func:`receive_data` (the newest 256; :func:`send_command` empties it)."""


class ErrorSum(int):
    """What :func:`dump_error` returns: the vendor's sum of the seven error words, with the decoded report.

    ``dump_error(1) == 0`` means healthy, as with the vendor library; ``.report``
    is the :class:`~drempower.client.ErrorReport` (``.flags``, ``.words``).
    """

    report: ErrorReport

    def __new__(cls, report: ErrorReport) -> ErrorSum:
        obj = super().__new__(cls, sum(report.words.values()))
        obj.report = report
        return obj

    @property
    def flags(self) -> dict[str, list[str]]:
        """Flag names per non-zero error word."""
        return self.report.flags

    @property
    def words(self) -> dict[str, int]:
        """Each error word's raw value by name."""
        return self.report.words

    def __repr__(self) -> str:
        return f"ErrorSum({int(self)}: {self.report})"


def _keep(frame: Frame) -> None:
    """Keep ``frame`` for receive_data, dropping the oldest when full (called in the receive thread)."""
    while True:
        try:
            _frames.put_nowait(frame)
            return
        except queue.Full:
            _drain(1)


def _drain(n: int | None = None) -> None:
    """Forget the ``n`` oldest kept frames (all when None)."""
    k = 0
    while n is None or k < n:
        try:
            _frames.get_nowait()
        except queue.Empty:
            return
        k += 1


def _keep_state(st: MotorState) -> None:
    _keep(State(st.node, st.angle, st.speed, st.torque, st.trajectory_done, st.error).encode())


def use_bus(bus: Bus) -> Bus:
    """Make ``bus`` the one the functions of this module use; returns it."""
    global _bus
    _bus = bus
    _drain()
    bus.on_unsolicited = _keep
    bus.subscribe(_keep_state)
    return bus


def open(
    interface: str | None = None, channel: str | int | None = None, bitrate: int | None = None, **kwargs: Any
) -> Bus:
    """Open a bus with :func:`drempower.open_bus` arguments and use it (closing the previous one).

    Motors keep holding when the bus closes or the script ends, as with the vendor
    library (``stop_on_close=False`` unless given).
    """
    close()
    kwargs.setdefault("stop_on_close", False)
    return use_bus(open_bus(interface, channel, bitrate, **kwargs))


def close() -> None:
    """Close the bus in use, if any."""
    global _bus
    if _bus is not None:
        _bus.close()
        _bus = None
    _drain()


def current_bus() -> Bus:
    """The bus in use; raises if none was set up."""
    if _bus is None:
        raise DrEmpowerError("no bus: call drempower.compat.open(...) or drempower.compat.use_bus(bus) first")
    return _bus


def _m(id_num: int) -> Motor:
    return current_bus().motor(id_num)


# ---------------------------------------------------------------------- motion


def set_angle(id_num: int = 0, angle: float = 0, speed: float = 0, param: float = 0, mode: int = 0) -> bool:
    _m(id_num).set_angle(angle, speed, param, mode)
    return True


def set_angles(
    id_list: Sequence[int] = (1, 2, 3),
    angle_list: Sequence[float] = (150, 150, 150),
    speed: float = 10,
    param: float = 10,
    mode: int = 1,
) -> float | None:
    return current_bus().set_angles(id_list, angle_list, speed, param, mode)


def step_angle(id_num: int = 1, angle: float = 0, speed: float = 0, param: float = 0, mode: int = 0) -> float | None:
    return _m(id_num).step_angle(angle, speed, param, mode)


def step_angles(
    id_list: Sequence[int] = (1, 2, 3),
    angle_list: Sequence[float] = (150, 150, 150),
    speed: float = 10,
    param: float = 10,
    mode: int = 1,
) -> float | None:
    return current_bus().step_angles(id_list, angle_list, speed, param, mode)


def set_speed(id_num: int = 0, speed: float = 10, param: float = 0, mode: int = 1) -> bool:
    _m(id_num).set_speed(speed, param, mode)
    return True


def set_speeds(
    id_list: Sequence[int] = (1, 2, 3), speed_list: Sequence[float] = (10, 20, 30), param: float = 0, mode: int = 1
) -> bool:
    current_bus().set_speeds(id_list, speed_list, param, mode)
    return True


def set_torque(id_num: int = 0, torque: float = 0.1, param: float = 0, mode: int = 1) -> bool:
    _m(id_num).set_torque(torque, param, mode)
    return True


def set_torques(
    id_list: Sequence[int] = (1, 2, 3), torque_list: Sequence[float] = (3, 4, 5), param: float = 0, mode: int = 1
) -> bool:
    current_bus().set_torques(id_list, torque_list, param, mode)
    return True


def impedance_control(
    id_num: int = 0, pos: float = 0, vel: float = 0, tff: float = 0, kp: float = 0, kd: float = 0
) -> None:
    _m(id_num).impedance_control(pos, vel, tff, kp, kd)


def _act(action: str, id: int, **args: Any) -> Any:
    """Carry out ``action`` of :mod:`drempower.actions` for motor ``id`` on the bus in use through the command
    service (its checks, its words; an enable or a clear confirmed)."""
    return actions.Service(actions.OneBus(_m(id).bus)).run("compat", action, {"id": id, **args}).result


def estop(id_num: int = 0) -> None:
    _act("estop", id=id_num)


# ---------------------------------------------------------------------- settings


def set_id(id_num: int = 0, new_id: int = 0) -> None:
    _m(id_num).set_id(new_id)


def set_uart_baud_rate(id_num: int = 0, baud_rate: int = 115200) -> None:
    _m(id_num).set_uart_baud_rate(baud_rate)


def set_can_baud_rate(id_num: int = 0, baud_rate: int = 500000) -> None:
    _m(id_num).set_can_baud_rate(baud_rate)


def set_mode(id_num: int = 0, mode: int = 2) -> None:
    if mode.__class__ is int and mode in _MODES:
        _act(_MODES[mode], id=id_num)
    else:
        _m(id_num).set_mode(mode)  # refuses it, naming the modes


def set_zero_position(id_num: int = 0) -> None:
    if id_num == 0:
        _m(id_num).set_zero_position()  # every motor at once: the vendor allows it, the table does not
    else:
        _act("zero", id=id_num)


def set_GPIO_mode(id_num: int = 0, mode: str = "tx_rx", param: float = 115200) -> None:
    _m(id_num).set_GPIO_mode(mode, param)


def set_angle_range(id_num: int = 0, angle_min: float = -360, angle_max: float = 360) -> bool:
    _m(id_num).set_angle_range(angle_min, angle_max)
    return True


def set_traj_mode(id_num: int = 0, mode: int = 1) -> None:
    global TRAJ_MODE
    _m(id_num).set_traj_mode(mode)
    TRAJ_MODE = mode


def write_property(id_num: int = 0, property: str | int = "", value: float = 0) -> None:
    _m(id_num).write_property(property, value)


# ---------------------------------------------------------------------- read-back


def get_id(id_num: int = 0) -> int:
    return _m(id_num).get_id()


def _read(id_num: int) -> MotorState:
    """A fast read that sets READ_FLAG and updates motor_state."""
    global READ_FLAG
    READ_FLAG = -1
    st = _m(id_num).get_state()
    READ_FLAG = 1
    _remember(st)
    return st


def _remember(st: MotorState) -> None:
    if 1 <= st.node <= MOTOR_NUM:
        motor_state[st.node - 1][:] = [st.angle, st.speed, st.torque, float(st.trajectory_done), float(st.error)]


def get_state(id_num: int = 0) -> list[float]:
    """``[angle deg, speed r/min]``, rounded to 0.01 as the vendor's; also updates ``motor_state``."""
    st = _read(id_num)
    return [round(st.angle, 2), round(st.speed, 2)]


def get_volcur(id_num: int = 0) -> list[float]:
    """``[voltage V (0.1), current A (0.01)]``."""
    v, i = _m(id_num).get_volcur()
    return [round(v, 1), round(i, 2)]


def get_GPIO_mode(id_num: int = 0) -> list[int]:
    """``[enable_uart, enable_step_dir]``."""
    g = _m(id_num).get_GPIO_mode()
    return [int(g.enable_uart), int(g.enable_step_dir)]


def read_property(id_num: int = 0, property: str | int = "") -> int | float:
    global READ_FLAG
    READ_FLAG = -1
    value = _m(id_num).read_property(property)
    READ_FLAG = 1
    return value


# ---------------------------------------------------------------------- utilities


def clear_error(id_num: int = 0) -> None:
    _act("clear", id=id_num)


def dump_error(id_num: int = 0) -> ErrorSum:
    """The sum of the seven error words, as the vendor's (0 when healthy), carrying the decoded ``.report``."""
    return ErrorSum(_m(id_num).dump_error())


def save_config(id_num: int = 0) -> None:
    _act("save", id=id_num)


def reboot(id_num: int = 0) -> None:
    _act("reboot", id=id_num)


def position_done(id_num: int = 0, timeout: float = DEFAULT_MOVE_TIMEOUT) -> bool:
    _m(id_num).wait_position_done(timeout)
    return True


def positions_done(id_list: Sequence[int] = (1, 2, 3), timeout: float = DEFAULT_MOVE_TIMEOUT) -> bool:
    current_bus().positions_done(id_list, timeout)
    return True


# ---------------------------------------------------------------------- the vendor's helpers


def reply_state(id_num: int = 1) -> bool | None:
    """Read motor ``id_num``'s state into ``motor_state``: True, or False when it did not answer.

    As the vendor's, it does nothing (None) unless ``enable_replay_state`` is set
    and ``id_num`` <= ``MOTOR_NUM``; id 0 reads nothing here (no broadcast read).
    """
    global reply_state_error
    if not enable_replay_state or not 1 <= id_num <= MOTOR_NUM:
        return None
    try:
        _read(id_num)
    except TimeoutError:
        reply_state_error += 1
        return False
    return True


def _s16(value: float, field: str) -> float:
    return check_s16(round(value, 2), field)


def preset_angle(id_num: int = 0, angle: float = 0, t: float = 0, param: float = 0, mode: int = 0) -> None:
    """Send a position preset (0x0C), as the vendor's; a start command (0x08) then moves the motor.

    mode 0 (T): ``t`` speed r/min, ``param`` filter bandwidth 1/s (<= 300);
    mode 1 (Q): ``t`` move time s, ``param`` accel (r/min)/s; mode 2 (P): ``t``
    speed feed-forward r/min, ``param`` torque feed-forward Nm.
    """
    if mode == 0:
        p2, p3 = abs(t), abs(min(param, 300))
    elif mode == 1:
        p2, p3 = abs(t), abs(param)
    elif mode == 2:
        p2, p3 = t, param
    else:
        raise FieldRangeError("mode", mode, 0, 2, "0 = T, 1 = Q, 2 = P")
    node = check_node(id_num, "id_num")
    q, p = mode == 1, mode == 2  # what the start will command: Q's accel, P's feed-forwards
    intent = Intent(
        node, check_f32(angle, "angle"), speed=p2 if p else None, torque=p3 if p else None, accel=p3 if q else None
    )
    _preset(id_num, angle, p2, p3, intent)


def preset_speed(id_num: int = 0, speed: float = 0, param: float = 0, mode: int = 1) -> bool:
    """Send a speed preset (0x0C), as the vendor's: mode 1 ``param`` = torque feed-forward Nm, else ramp (r/min)/s."""
    node = check_node(id_num, "id_num")
    if mode == 1:
        _preset(id_num, speed, 0 if speed == 0 else param, 1, Intent(node, speed=speed, torque=param))
    else:
        _preset(id_num, speed, param, 2, Intent(node, speed=speed, accel=param))
    return True


def preset_torque(id_num: int = 0, torque: float = 0, param: float = 0, mode: int = 1) -> bool:
    """Send a torque preset (0x0C), as the vendor's: mode 1 direct, else ramp ``param`` Nm/s."""
    node = check_node(id_num, "id_num")
    if mode == 1:
        _preset(id_num, torque, 0, 1, Intent(node, torque=torque))
    else:
        _preset(id_num, torque, param, 6, Intent(node, torque=torque))
    return True


def _preset(id_num: int, p1: float, p2: float, p3: float, intent: Intent) -> None:
    """Send a preset once its values are valid and ``intent`` (what its start will command) passes the
    safety gate: soft limits, closed loop (a preset to an idle motor raises MotorIdleError)."""
    msg = Preset(check_node(id_num, "id_num"), check_f32(p1, "p1"), _s16(p2, "p2"), _s16(p3, "p3"))
    bus = current_bus()
    bus.pass_gate([intent])
    bus.send(msg)
    reply_state(id_num)


def send_command(id_num: int = 0, cmd: int = 0, data: Sequence[int] | bytes = (), rtr: int = 0) -> None:
    """Send one frame with CAN id ``(id_num << 5) + cmd`` and ``data`` (up to 8 bytes), as the vendor's."""
    node = check_node(id_num, "id_num")
    if not (isinstance(cmd, int) and 0 <= cmd <= 0x1F):
        raise FieldRangeError("cmd", cmd, 0, 0x1F, "the command field is 5 bits")
    payload = bytes(data)
    if len(payload) > 8:
        raise ValidationError(f"data: {len(payload)} bytes, a CAN frame holds at most 8")
    frame = Frame((node << 5) + cmd, payload.ljust(8, b"\0"), is_remote=bool(rtr))  # 8 bytes, as the vendor's
    bus = current_bus()
    try:
        msg = None if rtr else decode_command(frame.arbitration_id, frame.data)
    except ProtocolError:
        msg = None
    _drain()  # as the vendor's, which empties the input buffer first: receive_data gets what follows
    if msg is not None:
        bus.send(msg)  # through the client: checked, and the motor counts as commanded
    else:
        bus.send_frames([frame])  # a frame the protocol does not define goes out as given


def receive_data(return_id: bool = False, timeout: float | None = None) -> bytes | None:
    """The next frame no request claimed: its 8 data bytes, or with ``return_id`` the vendor's 11-byte form
    ``0x08, id high, id low, data``; None when none came within ``timeout`` s (the bus's by default)."""
    global READ_FLAG
    READ_FLAG = -1
    bus = current_bus()
    wait = bus.timeout if timeout is None else timeout
    if bus.virtual and _frames.empty():  # simulated time passes only while the client waits
        bus.pass_time(wait, until=lambda: not _frames.empty())
        wait = 0.0
    try:
        frame = _frames.get(timeout=wait) if wait > 0 else _frames.get_nowait()
    except queue.Empty:
        return None
    READ_FLAG = 1
    data = frame.data.ljust(8, b"\0")
    if return_id:
        return bytes([0x08, frame.arbitration_id >> 8, frame.arbitration_id & 0xFF]) + data
    return data


_FORMATS = {"f": "f", "u16": "H", "s16": "h", "u32": "I", "s32": "i"}
"""The vendor's type names and their struct codes (little-endian here, native in the vendor's)."""


def format_data(data: Sequence[float] | bytes = (), format: str = "f f", type: str = "decode") -> Any:
    """Pack values into 8 bytes (``type="encode"``) or unpack 8 bytes (``"decode"``), as the vendor's.

    ``format`` names each field: ``f`` (float32), ``u16``, ``s16``, ``u32``, ``s32``;
    e.g. ``format_data([90.0, 1000, 500], "f s16 s16", "encode")``.
    """
    try:
        codes = "<" + "".join(_FORMATS[f] for f in format.split())
    except KeyError as exc:
        raise ValidationError(f"format: {exc.args[0]!r} is not one of {', '.join(_FORMATS)}") from None
    if type == "encode":
        values = [v if c == "f" else int(v) for c, v in zip(codes[1:], data, strict=True)]
        try:
            return struct.pack(codes, *values).ljust(8, b"\0")
        except struct.error as exc:
            raise ValidationError(f"format_data: {data!r} does not fit {format!r}: {exc}") from None
    if type == "decode":
        raw = data if isinstance(data, bytes) else bytes(int(b) for b in data)
        if len(raw) != 8:
            raise ValidationError(f"format_data: decode needs 8 bytes, got {len(raw)}")
        return list(struct.unpack_from(codes, raw))
    raise ValidationError(f"type: {type!r}, expected 'encode' or 'decode'")
