"""Typed DrEmpower messages with byte-exact encode and decode.

Host commands (sent by a controller) and motor replies are frozen dataclasses.
``msg.encode()`` returns a :class:`~drempower.protocol.ids.Frame`;
:func:`decode_command` and :func:`decode_reply` turn an arbitration id and 8 data
bytes back into a message. The codec is pure: no I/O, threads or clocks.

Units are those of the wire, at the output shaft: positions in degrees, speeds
in r/min, torques in Nm, accelerations and ramp rates in (r/min)/s or Nm/s,
filter bandwidth in 1/s, impedance gains Kp in Nm/rad and Kd in Nm/(rad/s).
Fields sent as s16 scaled by 0.01 hold -327.68..327.67; values are rounded to the
nearest 0.01 and anything outside raises :class:`~drempower.errors.FieldRangeError`.
"""

from __future__ import annotations

import struct
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, TypeAlias

from ..errors import FieldRangeError, ProtocolError, ValidationError
from ._packing import (
    _FAST_READS,
    _FSU,
    _PAD4,
    _RW,
    _SYS,
    _SYS_KPKD,
    _ZERO8,
    _address,
    _dtype,
    _frame,
    _fss,
    _FSS_unpack,
    _fsu,
    _new_frame,
    _node,
    _READ_pack,
    _rw,
    _RW_unpack_from,
    _s16,
    _SYS_pack,
    check_f32,
    check_s16,
)
from .enums import TorqueMode, VelocityMode
from .ids import BROADCAST, HOST_CMDS, MAX_NODE, STATE_CMDS, Cmd, Frame, StartKind, SysCmd
from .limits import S16_MAX, S16_MIN
from .parameters import DataType, Parameter, parameter

__all__ = [
    "Message",
    "PositionT",
    "PositionQ",
    "PositionP",
    "Velocity",
    "Torque",
    "Preset",
    "PresetT",
    "PresetQ",
    "PresetP",
    "PresetV",
    "PresetC",
    "PresetD",
    "SystemCommand",
    "Start",
    "StartImpedance",
    "ReadParam",
    "FastRead",
    "WriteParam",
    "ParamValue",
    "State",
    "Command",
    "Reply",
    "decode_command",
    "decode_reply",
    "S16_MIN",
    "S16_MAX",
    "check_s16",
    "check_f32",
    "STATE_CMDS",
    "HOST_CMDS",
]


class Message(ABC):
    """Base class of every DrEmpower message; ``node`` is the motor id (0 = broadcast)."""

    __slots__ = ()
    cmd: ClassVar[int]
    node: int

    @abstractmethod
    def encode(self) -> Frame:
        """The frame for this message; raises a validation error naming the bad field."""

    @property
    def arbitration_id(self) -> int:
        return self.encode().arbitration_id


# --------------------------------------------------------------------------- motion


@dataclass(slots=True)
class PositionT(Message):
    """T mode (0x19): track a stream of target positions through an input filter.

    ``position`` deg; ``bandwidth`` input-filter bandwidth 1/s (half the command
    rate is a good choice); ``speed`` r/min is carried but ignored by the motor.
    """

    node: int
    position: float
    bandwidth: float
    speed: float = 0.0
    cmd: ClassVar[int] = Cmd.POSITION_T

    def encode(self) -> Frame:
        return _fss(self.node, 0x19, self.position, "position", self.speed, "speed", self.bandwidth, "bandwidth")


@dataclass(slots=True)
class PositionQ(Message):
    """Q mode (0x1A): trapezoid or S-curve move to ``position`` deg.

    ``speed`` is the cruise speed (r/min), ``accel`` the acceleration ((r/min)/s).
    """

    node: int
    position: float
    speed: float
    accel: float
    cmd: ClassVar[int] = Cmd.POSITION_Q

    def encode(self) -> Frame:
        return _fss(self.node, 0x1A, self.position, "position", self.speed, "speed", self.accel, "accel")


@dataclass(slots=True)
class PositionP(Message):
    """P mode (0x1B): position ``position`` deg with speed (r/min) and torque (Nm) feed-forward."""

    node: int
    position: float
    speed_ff: float = 0.0
    torque_ff: float = 0.0
    cmd: ClassVar[int] = Cmd.POSITION_P

    def encode(self) -> Frame:
        return _fss(self.node, 0x1B, self.position, "position", self.speed_ff, "speed_ff", self.torque_ff, "torque_ff")


@dataclass(slots=True)
class Velocity(Message):
    """V mode (0x1C): run at ``speed`` r/min.

    ``mode`` PASSTHROUGH: ``param`` is a torque feed-forward (Nm);
    RAMP: ``param`` is the ramp rate ((r/min)/s). The mode travels as a raw u16.
    """

    node: int
    speed: float
    param: float = 0.0
    mode: VelocityMode = VelocityMode.PASSTHROUGH
    cmd: ClassVar[int] = Cmd.VELOCITY

    def encode(self) -> Frame:
        mode = self.mode
        if mode != 1 and mode != 2:
            raise FieldRangeError("mode", mode, 1, 2, "1 = passthrough, 2 = ramp")
        return _fsu(self.node, 0x1C, self.speed, "speed", self.param, "param", int(mode))


@dataclass(slots=True)
class Torque(Message):
    """C mode (0x1D): apply ``torque`` Nm.

    ``mode`` DIRECT: ``param`` unused; RAMP: ``param`` is the ramp rate (Nm/s).
    """

    node: int
    torque: float
    param: float = 0.0
    mode: TorqueMode = TorqueMode.DIRECT
    cmd: ClassVar[int] = Cmd.TORQUE

    def encode(self) -> Frame:
        mode = self.mode
        if mode != 1 and mode != 6:
            raise FieldRangeError("mode", mode, 1, 6, "1 = direct, 6 = ramp")
        return _fsu(self.node, 0x1D, self.torque, "torque", self.param, "param", int(mode))


# --------------------------------------------------------------------------- presets


@dataclass(slots=True)
class Preset(Message):
    """Preset (0x0C) as it is on the wire: ``p1`` f32, ``p2`` and ``p3`` s16 scaled by 0.01.

    What the values mean depends on the start command that follows; decode gives
    this generic form and :meth:`as_kind` interprets it.
    """

    node: int
    p1: float
    p2: float
    p3: float
    cmd: ClassVar[int] = Cmd.PRESET

    def encode(self) -> Frame:
        return _fss(self.node, 0x0C, self.p1, "p1", self.p2, "p2", self.p3, "p3")

    def as_kind(self, kind: StartKind | int) -> PresetT | PresetQ | PresetP | PresetV | PresetC | PresetD:
        """Interpret this preset for the start command ``kind`` (StartKind or sys_num)."""
        try:
            k = StartKind(kind)
        except ValueError:
            raise ProtocolError(f"sys_num 0x{int(kind):02X} is not a start command") from None
        n, p1, p2, p3 = self.node, self.p1, self.p2, self.p3
        if k is StartKind.T:
            return PresetT(n, p1, p3, p2)
        if k is StartKind.Q:
            return PresetQ(n, p1, p2, p3)
        if k is StartKind.P:
            return PresetP(n, p1, p2, p3)
        if k is StartKind.D:
            return PresetD(n, p1, p2, p3)
        code = round(p3 * 100)
        if k is StartKind.V:
            if code not in (100, 200):
                raise ProtocolError(f"V preset mode code {code} is not 100 (passthrough) or 200 (ramp)")
            return PresetV(n, p1, p2, VelocityMode(code // 100))
        if code not in (100, 600):
            raise ProtocolError(f"C preset mode code {code} is not 100 (direct) or 600 (ramp)")
        return PresetC(n, p1, p2, TorqueMode(code // 100))


class _TypedPreset(Message):
    __slots__ = ()
    cmd: ClassVar[int] = Cmd.PRESET
    kind: ClassVar[StartKind]

    def to_preset(self) -> Preset:
        """The generic wire form of this preset (what decoding gives back)."""
        f = self.encode()
        p = decode_command(f.arbitration_id, f.data)
        assert isinstance(p, Preset)
        return p


@dataclass(slots=True)
class PresetT(_TypedPreset):
    """Preset for a synchronised T move (start 0x10): ``position`` deg, ``bandwidth`` 1/s."""

    node: int
    position: float
    bandwidth: float
    speed: float = 0.0
    kind: ClassVar[StartKind] = StartKind.T

    def encode(self) -> Frame:
        return _fss(self.node, 0x0C, self.position, "position", self.speed, "speed", self.bandwidth, "bandwidth")


@dataclass(slots=True)
class PresetQ(_TypedPreset):
    """Preset for a synchronised Q move (start 0x11): reach ``position`` deg in ``time`` s at ``accel`` (r/min)/s."""

    node: int
    position: float
    time: float
    accel: float
    kind: ClassVar[StartKind] = StartKind.Q

    def encode(self) -> Frame:
        return _fss(self.node, 0x0C, self.position, "position", self.time, "time", self.accel, "accel")


@dataclass(slots=True)
class PresetP(_TypedPreset):
    """Preset for a synchronised P move (start 0x12): ``position`` deg, feed-forwards r/min and Nm."""

    node: int
    position: float
    speed_ff: float = 0.0
    torque_ff: float = 0.0
    kind: ClassVar[StartKind] = StartKind.P

    def encode(self) -> Frame:
        return _fss(self.node, 0x0C, self.position, "position", self.speed_ff, "speed_ff", self.torque_ff, "torque_ff")


@dataclass(slots=True)
class PresetV(_TypedPreset):
    """Preset for synchronised V (start 0x13). The mode code travels x100 (100, 200)."""

    node: int
    speed: float
    param: float = 0.0
    mode: VelocityMode = VelocityMode.PASSTHROUGH
    kind: ClassVar[StartKind] = StartKind.V

    def encode(self) -> Frame:
        mode = self.mode
        if mode != 1 and mode != 2:
            raise FieldRangeError("mode", mode, 1, 2, "1 = passthrough, 2 = ramp")
        return _fss(self.node, 0x0C, self.speed, "speed", self.param, "param", int(mode), "mode")


@dataclass(slots=True)
class PresetC(_TypedPreset):
    """Preset for synchronised C (start 0x14). The mode code travels x100 (100, 600)."""

    node: int
    torque: float
    param: float = 0.0
    mode: TorqueMode = TorqueMode.DIRECT
    kind: ClassVar[StartKind] = StartKind.C

    def encode(self) -> Frame:
        mode = self.mode
        if mode != 1 and mode != 6:
            raise FieldRangeError("mode", mode, 1, 6, "1 = direct, 6 = ramp")
        return _fss(self.node, 0x0C, self.torque, "torque", self.param, "param", int(mode), "mode")


@dataclass(slots=True)
class PresetD(_TypedPreset):
    """Preset for impedance control (start 0x15): ``position`` deg, ``speed`` r/min, ``torque_ff`` Nm."""

    node: int
    position: float
    speed: float = 0.0
    torque_ff: float = 0.0
    kind: ClassVar[StartKind] = StartKind.D

    def encode(self) -> Frame:
        return _fss(self.node, 0x0C, self.position, "position", self.speed, "speed", self.torque_ff, "torque_ff")


# --------------------------------------------------------------------------- system


_SINGLE_SHOT = frozenset(range(0x00, 0x08))


@dataclass(slots=True)
class SystemCommand(Message):
    """A single-shot system command (0x08, sys_num 0x00..0x07), e.g. estop or save_config."""

    node: int
    op: SysCmd
    cmd: ClassVar[int] = Cmd.SYSTEM

    def encode(self) -> Frame:
        op = self.op
        if op not in _SINGLE_SHOT:
            raise ValidationError(f"op={op!r}: system op must be 0x00..0x07; use Start/StartImpedance for 0x10..0x15")
        node = self.node
        if not (node.__class__ is int and 0 <= node <= MAX_NODE):
            _node(node)
        return _new_frame(Frame, ((node << 5) | 0x08, _SYS_pack(op, 0, 0), False, False))


@dataclass(slots=True)
class Start(Message):
    """Start the pending presets (0x08, sys_num 0x10..0x14).

    ``relative`` (T/Q/P only) makes preset targets relative to the current position.
    Usually broadcast (node 0) so every motor holding a preset starts at once.
    """

    node: int
    kind: StartKind
    relative: bool = False
    cmd: ClassVar[int] = Cmd.SYSTEM

    def encode(self) -> Frame:
        kind = self.kind
        if kind not in (0x10, 0x11, 0x12, 0x13, 0x14):
            raise ValidationError(f"kind={kind!r}: Start takes T, Q, P, V or C; use StartImpedance for D")
        if self.relative and kind > 0x12:
            raise ValidationError(f"relative=True: only T, Q and P starts have a relative flag, not {kind!r}")
        node = self.node
        if not (node.__class__ is int and 0 <= node <= MAX_NODE):
            _node(node)
        return _new_frame(Frame, ((node << 5) | 0x08, _SYS_pack(kind, 1 if self.relative else 0, 0), False, False))


@dataclass(slots=True)
class StartImpedance(Message):
    """Start impedance control (0x08, sys_num 0x15) with ``kp`` Nm/rad and ``kd`` Nm/(rad/s).

    Every motor holding a preset that receives it uses the same gains.
    """

    node: int
    kp: float
    kd: float
    cmd: ClassVar[int] = Cmd.SYSTEM
    kind: ClassVar[StartKind] = StartKind.D

    def encode(self) -> Frame:
        return _frame((_node(self.node) << 5) | 0x08, _SYS_KPKD.pack(0x15, _s16(self.kp, "kp"), _s16(self.kd, "kd")))


# --------------------------------------------------------------------------- parameters


@dataclass(slots=True)
class ReadParam(Message):
    """Read a parameter (0x1E) at ``address`` as ``dtype``; the motor answers with :class:`ParamValue`."""

    node: int
    address: int
    dtype: DataType
    cmd: ClassVar[int] = Cmd.READ

    @classmethod
    def of(cls, node: int, name: str | int | Parameter) -> ReadParam:
        """Read the parameter ``name`` (or address) with its table type."""
        p = parameter(name)
        return cls(node, p.address, p.dtype)

    def encode(self) -> Frame:
        node, address, dtype = self.node, self.address, self.dtype
        if (
            node.__class__ is int
            and 0 <= node <= MAX_NODE
            and address.__class__ is int
            and 1 <= address <= 0xFFFF
            and (dtype.__class__ is DataType or (dtype.__class__ is int and 0 <= dtype <= 4))
        ):
            return _new_frame(Frame, ((node << 5) | 0x1E, _READ_pack(address, dtype), False, False))
        return _frame((_node(node) << 5) | 0x1E, _RW.pack(_address(address), _dtype(dtype)) + _PAD4)


@dataclass(slots=True)
class FastRead(Message):
    """Fast read (0x1E, address 0): the motor answers with one :class:`State` frame."""

    node: int
    cmd: ClassVar[int] = Cmd.READ

    def encode(self) -> Frame:
        node = self.node
        if node.__class__ is int and 0 <= node <= MAX_NODE:
            return _FAST_READS[node]
        return _frame((_node(node) << 5) | 0x1E, _ZERO8)


@dataclass(slots=True)
class WriteParam(Message):
    """Write ``value`` to the parameter at ``address`` as ``dtype`` (0x1F). Changes RAM only."""

    node: int
    address: int
    dtype: DataType
    value: int | float
    cmd: ClassVar[int] = Cmd.WRITE

    @classmethod
    def of(
        cls,
        node: int,
        name: str | int | Parameter,
        value: int | float | bool,
        *,
        allow_read_only: bool = False,
        force: bool = False,
    ) -> WriteParam:
        """Write ``value`` to the parameter ``name`` with its table type.

        Checks access, the wire range and the parameter's domain
        (:meth:`Parameter.check`); ``force`` lets a value outside a soft domain through.
        """
        p = parameter(name)
        if not p.writable and not allow_read_only:
            raise ValidationError(f"{p.name} ({p.address}) is read-only")
        return cls(node, p.address, p.dtype, p.check(value, force))

    def encode(self) -> Frame:
        return _rw(self.node, 0x1F, self.address, self.dtype, self.value)


@dataclass(slots=True)
class ParamValue(Message):
    """The motor's answer to :class:`ReadParam` (0x1E): ``value`` of ``dtype`` at ``address``."""

    node: int
    address: int
    dtype: DataType
    value: int | float
    cmd: ClassVar[int] = Cmd.READ

    def encode(self) -> Frame:
        return _rw(self.node, 0x1E, self.address, self.dtype, self.value)


@dataclass(slots=True)
class State(Message):
    """Real-time state frame (reply to a control frame, fast read, or heartbeat).

    ``position`` deg, ``speed`` r/min, ``torque`` Nm; ``trajectory_done`` is the T
    bit, ``error`` the E bit (axis0.error != 0). ``spare_bits`` holds bits 3-4 of
    the command field, which the protocol leaves unspecified (0..3).
    """

    node: int
    position: float
    speed: float
    torque: float
    trajectory_done: bool
    error: bool
    spare_bits: int = 0
    cmd: ClassVar[int] = 0x01

    def encode(self) -> Frame:
        spare = self.spare_bits
        if not (spare.__class__ is int and 0 <= spare <= 3):
            raise FieldRangeError("spare_bits", spare, 0, 3, "bits 3-4 of the command field")
        cmd = (spare << 3) | (4 if self.error else 0) | (2 if self.trajectory_done else 0) | 1
        return _fss(self.node, cmd, self.position, "position", self.speed, "speed", self.torque, "torque")


Command: TypeAlias = (
    PositionT
    | PositionQ
    | PositionP
    | Velocity
    | Torque
    | Preset
    | PresetT
    | PresetQ
    | PresetP
    | PresetV
    | PresetC
    | PresetD
    | SystemCommand
    | Start
    | StartImpedance
    | ReadParam
    | FastRead
    | WriteParam
)
"""Every message a host sends."""

Reply: TypeAlias = ParamValue | State
"""Every message a motor sends."""


# --------------------------------------------------------------------------- decoding


_VMODES = {1: VelocityMode.PASSTHROUGH, 2: VelocityMode.RAMP}
_TMODES = {1: TorqueMode.DIRECT, 6: TorqueMode.RAMP}
_DTYPES = tuple(DataType)
_VALUE_FROM = tuple(struct.Struct(f"<{c}").unpack_from for c in "fHhIi")
"""Unpackers of the value (offset 4) by data type code."""
_OPS = {op.value: op for op in SysCmd}
_KINDS = {k.value: k for k in StartKind}


def _dec_t(node: int, data: bytes) -> Command:
    p, s, b = _FSS_unpack(data)
    return PositionT(node, p, b / 100, s / 100)


def _dec_q(node: int, data: bytes) -> Command:
    p, s, a = _FSS_unpack(data)
    return PositionQ(node, p, s / 100, a / 100)


def _dec_p(node: int, data: bytes) -> Command:
    p, s, t = _FSS_unpack(data)
    return PositionP(node, p, s / 100, t / 100)


def _dec_v(node: int, data: bytes) -> Command:
    v, prm, mode = _FSU.unpack(data)
    m = _VMODES.get(mode)
    if m is None:
        raise ProtocolError(f"velocity command mode {mode} is not 1 (passthrough) or 2 (ramp)")
    return Velocity(node, v, prm / 100, m)


def _dec_c(node: int, data: bytes) -> Command:
    t, prm, mode = _FSU.unpack(data)
    m = _TMODES.get(mode)
    if m is None:
        raise ProtocolError(f"torque command mode {mode} is not 1 (direct) or 6 (ramp)")
    return Torque(node, t, prm / 100, m)


def _dec_preset(node: int, data: bytes) -> Command:
    p1, p2, p3 = _FSS_unpack(data)
    return Preset(node, p1, p2 / 100, p3 / 100)


def _dec_sys(node: int, data: bytes) -> Command:
    op, d1, _d2 = _SYS.unpack(data)
    if op < 0x08:
        return SystemCommand(node, _OPS[op])
    if 0x10 <= op <= 0x12:
        if d1 > 1:
            raise ProtocolError(f"start 0x{op:02X}: sys_data1={d1} is not 0 (absolute) or 1 (relative)")
        return Start(node, _KINDS[op], d1 == 1)
    if op == 0x13 or op == 0x14:
        return Start(node, _KINDS[op], False)
    if op == 0x15:
        _, kp, kd = _SYS_KPKD.unpack(data)
        return StartImpedance(node, kp / 100, kd / 100)
    raise ProtocolError(f"unknown system command sys_num=0x{op:X}")


def _dec_read(node: int, data: bytes) -> Command:
    addr, dtype = _RW_unpack_from(data)
    if addr == 0:
        if dtype != 0:
            raise ProtocolError(f"fast read (address 0) with data type {dtype}; it must be 0")
        return FastRead(node)
    if dtype > 4:
        raise ProtocolError(f"read of {addr}: unknown data type code {dtype}")
    return ReadParam(node, addr, _DTYPES[dtype])


def _dec_write(node: int, data: bytes) -> Command:
    addr, dtype = _RW_unpack_from(data)
    if dtype > 4:
        raise ProtocolError(f"write of {addr}: unknown data type code {dtype}")
    if addr == 0:
        raise ProtocolError("write to address 0 (reserved for the fast read)")
    return WriteParam(node, addr, _DTYPES[dtype], _VALUE_FROM[dtype](data, 4)[0])


_COMMAND_DECODERS: dict[int, Callable[[int, bytes], Command]] = {
    0x08: _dec_sys,
    0x0C: _dec_preset,
    0x19: _dec_t,
    0x1A: _dec_q,
    0x1B: _dec_p,
    0x1C: _dec_v,
    0x1D: _dec_c,
    0x1E: _dec_read,
    0x1F: _dec_write,
}


def _check(arb_id: int, data: bytes) -> None:
    if not 0 <= arb_id <= 0x7FF:
        raise ProtocolError(f"arbitration id 0x{arb_id:X} is not an 11-bit standard id")
    raise ProtocolError(f"frame 0x{arb_id:03X} has {len(data)} data bytes; DrEmpower frames have 8")


def decode_command(arb_id: int, data: bytes) -> Command:
    """Decode a host frame (what a motor receives). Raises :class:`ProtocolError` when malformed."""
    if len(data) != 8 or not 0 <= arb_id <= 0x7FF:
        _check(arb_id, data)
    try:
        dec = _COMMAND_DECODERS[arb_id & 0x1F]
    except KeyError:
        raise ProtocolError(f"frame 0x{arb_id:03X}: unknown command 0x{arb_id & 0x1F:02X}") from None
    return dec(arb_id >> 5, data)


def decode_reply(arb_id: int, data: bytes) -> Reply:
    """Decode a frame as a motor's. Raises :class:`ProtocolError` when malformed.

    A command field with bit 0 set is a state frame (bit 1 = T, bit 2 = E; bits
    3-4 are kept in ``spare_bits``); 0x1E is a parameter value. The caller says
    the frame is a motor's: on a bus with other hosts, 0x19/0x1B/0x1D/0x1F are
    their commands (see :data:`STATE_CMDS`, and :func:`~drempower.protocol.describe.decode_frame`
    for frames of either direction).
    """
    if len(data) != 8 or not 0 <= arb_id <= 0x7FF:
        _check(arb_id, data)
    cmd = arb_id & 0x1F
    if cmd & 1:
        p, v, t = _FSS_unpack(data)
        return State(arb_id >> 5, p, v / 100, t / 100, (cmd & 2) != 0, (cmd & 4) != 0, cmd >> 3)
    if cmd == 0x1E:
        addr, dtype = _RW_unpack_from(data)
        if dtype > 4:
            raise ProtocolError(f"reply for {addr}: unknown data type code {dtype}")
        if addr == 0:
            raise ProtocolError("parameter reply for address 0 (the fast read answers with a state frame)")
        return ParamValue(arb_id >> 5, addr, _DTYPES[dtype], _VALUE_FROM[dtype](data, 4)[0])
    raise ProtocolError(f"frame 0x{arb_id:03X}: command 0x{cmd:02X} is not a motor reply")


def is_broadcast(msg: Message) -> bool:
    """True when ``msg`` is addressed to every motor (node 0)."""
    return msg.node == BROADCAST
