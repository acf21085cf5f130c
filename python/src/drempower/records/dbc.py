"""A DBC of the DrEmpower protocol: every command and reply of every node, from the protocol tables.

The layouts are those of :mod:`drempower.protocol.messages` (spec/PROTOCOL.md),
the parameter names those of spec/parameters.csv. Parameter read/write frames are
multiplexed on their data type so that the value is decoded as f32, u16, s16,
u32 or s32; float fields carry ``SIG_VALTYPE_``. State replies carry their T and
E bits in the id, so each combination is its own message (``STATE``,
``STATE_T``, ``STATE_E``, ``STATE_TE``, and ``_S1``/``_S2`` for the unspecified
spare bits; spare bits 3 share their ids with host commands, which a DBC cannot
tell apart, so only the host commands are described there).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from ..protocol.enums import TorqueMode, VelocityMode
from ..protocol.ids import MAX_NODE, Cmd, SysCmd
from ..protocol.limits import S16_MAX, S16_MIN
from ..protocol.parameters import DataType, parameters

__all__ = ["dbc_text", "write_dbc", "parse_nodes"]

_F32 = (0.0, 0.0)
"""A float signal's range: none (``[0|0]``, as cantools writes a signal without one), so a strict encoder takes
every float32 value, +-3.4028234663852886e38, infinities and NaN included."""
_S16 = (S16_MIN, S16_MAX)


@dataclass(frozen=True)
class _Sig:
    name: str
    start: int
    size: int
    kind: str  # "f32", "s", "u"
    scale: float = 1.0
    unit: str = ""
    mux: str = ""  # "", "M" or "m<n>"
    comment: str = ""

    def line(self, receiver: str) -> str:
        signed = "-" if self.kind in ("f32", "s") else "+"
        if self.kind == "f32":
            lo, hi = _F32
        elif self.kind == "s":
            lo = -(1 << (self.size - 1)) * self.scale
            hi = ((1 << (self.size - 1)) - 1) * self.scale
        else:
            lo, hi = 0.0, ((1 << self.size) - 1) * self.scale
        mux = f" {self.mux}" if self.mux else ""
        return (
            f" SG_ {self.name}{mux} : {self.start}|{self.size}@1{signed} ({self.scale:g},0) "
            f'[{lo:.10g}|{hi:.10g}] "{self.unit}" {receiver}'
        )


def _fss(a: tuple[str, str], b: tuple[str, str], c: tuple[str, str]) -> list[_Sig]:
    """f32 at byte 0, two s16 scaled 0.01 at bytes 4 and 6: ``(name, unit)`` each."""
    return [
        _Sig(a[0], 0, 32, "f32", 1.0, a[1]),
        _Sig(b[0], 32, 16, "s", 0.01, b[1]),
        _Sig(c[0], 48, 16, "s", 0.01, c[1]),
    ]


@dataclass(frozen=True)
class _Msg:
    name: str
    cmd: int
    signals: list[_Sig]
    comment: str
    host: bool = True
    """Sent by the host (else by the motor)."""
    values: tuple[tuple[str, dict[int, str]], ...] = ()


_RW_VALUES = [
    _Sig(
        "value_" + d.name.lower(),
        32,
        32 if d.size == 4 else 16,
        "f32" if d is DataType.F32 else ("s" if d.name[0] == "S" else "u"),
        mux=f"m{int(d)}",
    )
    for d in DataType
]


def _rw(name: str, cmd: int, comment: str, host: bool) -> _Msg:
    return _Msg(
        name,
        cmd,
        [_Sig("address", 0, 16, "u"), _Sig("dtype", 16, 16, "u", mux="M"), *_RW_VALUES],
        comment,
        host,
        (("address", {p.address: p.name for p in parameters()}), ("dtype", {int(d): d.name.lower() for d in DataType})),
    )


def _messages() -> list[_Msg]:
    start_kinds = range(0x10, 0x15)
    out = [
        _Msg(
            "SYSTEM",
            Cmd.SYSTEM,
            [
                _Sig("sys_num", 0, 32, "u", mux="M"),
                *[_Sig(f"relative_{k:02X}", 32, 16, "u", mux=f"m{k}") for k in start_kinds],
                _Sig("kp", 32, 16, "s", 0.01, "Nm/rad", mux="m21"),
                _Sig("kd", 48, 16, "s", 0.01, "Nm/(rad/s)", mux="m21"),
            ],
            "System command 0x08: sys_num 0x00-0x07 operations, 0x10-0x14 start T/Q/P/V/C "
            "(relative: 1 = relative move), 0x15 start impedance with kp and kd.",
            values=(("sys_num", {int(s): s.name.lower() for s in SysCmd}),),
        ),
        _Msg(
            "PRESET",
            Cmd.PRESET,
            _fss(("p1", ""), ("p2", ""), ("p3", "")),
            "Preset 0x0C, generic form: what p1..p3 mean depends on the start command that follows "
            "(T: position deg, speed r/min, bandwidth 1/s; Q: position, time s, accel; P: position, speed_ff, "
            "torque_ff; V: speed, param, mode x100; C: torque, param, mode x100; D: position, speed, torque_ff).",
        ),
        _Msg(
            "POSITION_T",
            Cmd.POSITION_T,
            _fss(("position", "deg"), ("speed", "r/min"), ("bandwidth", "1/s")),
            "Position, trajectory tracking (0x19).",
        ),
        _Msg(
            "POSITION_Q",
            Cmd.POSITION_Q,
            _fss(("position", "deg"), ("speed", "r/min"), ("accel", "(r/min)/s")),
            "Position, trapezoid/S-curve profile (0x1A).",
        ),
        _Msg(
            "POSITION_P",
            Cmd.POSITION_P,
            _fss(("position", "deg"), ("speed_ff", "r/min"), ("torque_ff", "Nm")),
            "Position with feed-forwards (0x1B).",
        ),
        _Msg(
            "VELOCITY",
            Cmd.VELOCITY,
            [_Sig("speed", 0, 32, "f32", 1.0, "r/min"), _Sig("param", 32, 16, "s", 0.01), _Sig("mode", 48, 16, "u")],
            "Velocity (0x1C): param is a torque feed-forward (Nm, passthrough) or a ramp rate ((r/min)/s, ramp).",
            values=(("mode", {int(v): v.name.lower() for v in VelocityMode}),),
        ),
        _Msg(
            "TORQUE",
            Cmd.TORQUE,
            [_Sig("torque", 0, 32, "f32", 1.0, "Nm"), _Sig("param", 32, 16, "s", 0.01), _Sig("mode", 48, 16, "u")],
            "Torque (0x1D): param is the ramp rate (Nm/s) in ramp mode, unused in direct mode.",
            values=(("mode", {int(v): v.name.lower() for v in TorqueMode}),),
        ),
        _rw(
            "READ",
            Cmd.READ,
            "Parameter read (0x1E): the host's request (value 0; address 0 is the fast read, answered by a "
            "state) and the motor's reply with the value, multiplexed on dtype.",
            True,
        ),
        _rw("WRITE", Cmd.WRITE, "Parameter write (0x1F), the value multiplexed on dtype.", True),
    ]
    for spare in (0, 1, 2):
        for done in (False, True):
            for error in (False, True):
                flags = ("T" if done else "") + ("E" if error else "")
                name = "STATE" + (f"_{flags}" if flags else "") + (f"_S{spare}" if spare else "")
                cmd = spare << 3 | error << 2 | done << 1 | 1
                what = f"trajectory_done={int(done)}, error={int(error)}" + (f", spare bits {spare}" if spare else "")
                out.append(
                    _Msg(
                        name,
                        cmd,
                        _fss(("position", "deg"), ("speed", "r/min"), ("torque", "Nm")),
                        f"Motor state (reply, fast read answer or heartbeat), command field 0x{cmd:02X}: {what}.",
                        host=False,
                    )
                )
    return out


def parse_nodes(text: str) -> list[int]:
    """``"1-63"``, ``"0,5,7-9"`` -> node ids (0 = broadcast); raises ValueError naming the bad part."""
    nodes: set[int] = set()
    for part in filter(None, (p.strip() for p in text.split(","))):
        lo, sep, hi = part.partition("-")
        try:
            a, b = (int(lo), int(hi)) if sep else (int(part), int(part))
        except ValueError:
            raise ValueError(f"nodes {part!r}: expected a node id or a range such as 1-63") from None
        if not 0 <= a <= b <= MAX_NODE:
            raise ValueError(f"nodes {part!r} is out of range: allowed 0..{MAX_NODE} (0 = broadcast), low to high")
        nodes.update(range(a, b + 1))
    if not nodes:
        raise ValueError("nodes: none given")
    return sorted(nodes)


def _q(text: str) -> str:
    return text.replace('"', "'")


def dbc_text(nodes: Iterable[int] = range(MAX_NODE + 1)) -> str:
    """The DBC for ``nodes`` (0: the broadcast commands, and the states a motor would send with id 0)."""
    nodes = sorted(set(nodes))
    ecus = ["HOST", *[f"MOTOR_{n}" for n in nodes if n]]
    body: list[str] = []
    comments: list[str] = []
    valtypes: list[str] = []
    values: list[str] = []
    for n in nodes:
        suffix = "ALL" if n == 0 else str(n)
        motor = "MOTOR_ALL" if n == 0 else f"MOTOR_{n}"
        for m in _messages():
            ident = n << 5 | m.cmd
            sender, receiver = ("HOST", motor) if m.host else (motor, "HOST")
            if receiver == "MOTOR_ALL" or sender == "MOTOR_ALL":
                sender, receiver = ("HOST", "Vector__XXX") if m.host else ("Vector__XXX", "HOST")
            body.append(f"BO_ {ident} {m.name}_{suffix}: 8 {sender}")
            body.extend(s.line(receiver) for s in m.signals)
            body.append("")
            comments.append(f'CM_ BO_ {ident} "{_q(m.comment)}";')
            valtypes.extend(f"SIG_VALTYPE_ {ident} {s.name} : 1;" for s in m.signals if s.kind == "f32")
            for sig, table in m.values:
                pairs = " ".join(f'{k} "{_q(v)}"' for k, v in sorted(table.items(), reverse=True))
                values.append(f"VAL_ {ident} {sig} {pairs} ;")
    head = [
        'VERSION "drempower"',
        "",
        "NS_ :",
        "    CM_",
        "    SIG_VALTYPE_",
        "    VAL_",
        "",
        "BS_:",
        "",
        "BU_: " + " ".join(ecus),
        "",
        "",
    ]
    tail = ['CM_ "DrEmpower servo joint motors: CAN protocol. Generated by drempower dbc.";', *comments]
    return "\n".join([*head, *body, *tail, *valtypes, *values]) + "\n"


def write_dbc(path: str | os.PathLike[str], nodes: Sequence[int] = range(MAX_NODE + 1)) -> None:
    """Write :func:`dbc_text` for ``nodes`` to ``path``."""
    with open(path, "w", encoding="ascii", newline="\n") as fh:
        fh.write(dbc_text(nodes))
