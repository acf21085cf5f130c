"""Readable names and JSON-friendly fields of messages, and direction-guessing decode.

Used by the sniffer, ``drempower decode`` and the golden vectors: each message
has a stable snake-case name (``position_q``, ``state``...) and a flat dict of
fields in engineering units, enums given by their lower-case names.
"""

from __future__ import annotations

from dataclasses import fields as dc_fields
from enum import Enum
from typing import Any, Literal

from ..errors import ProtocolError
from . import messages as m
from .parameters import find_parameter

__all__ = [
    "MESSAGE_NAMES",
    "message_name",
    "message_fields",
    "decode_frame",
    "CaptureDecoder",
    "Direction",
    "describe",
]

Direction = Literal["host", "motor", "auto"]

MESSAGE_NAMES: dict[type[m.Message], str] = {
    m.PositionT: "position_t",
    m.PositionQ: "position_q",
    m.PositionP: "position_p",
    m.Velocity: "velocity",
    m.Torque: "torque",
    m.Preset: "preset",
    m.PresetT: "preset_t",
    m.PresetQ: "preset_q",
    m.PresetP: "preset_p",
    m.PresetV: "preset_v",
    m.PresetC: "preset_c",
    m.PresetD: "preset_d",
    m.SystemCommand: "system",
    m.Start: "start",
    m.StartImpedance: "start_impedance",
    m.ReadParam: "read_param",
    m.FastRead: "fast_read",
    m.WriteParam: "write_param",
    m.ParamValue: "param_value",
    m.State: "state",
}
"""Stable name of every message class (also used in ``spec/vectors``)."""

CLASSES_BY_NAME: dict[str, type[m.Message]] = {v: k for k, v in MESSAGE_NAMES.items()}


def message_name(msg: m.Message) -> str:
    return MESSAGE_NAMES[type(msg)]


def _jsonable(v: object) -> Any:
    if isinstance(v, Enum):
        return str(v.name).lower()
    return v


def message_fields(msg: m.Message) -> dict[str, Any]:
    """Fields of ``msg`` except ``node``, enums as lower-case names."""
    return {f.name: _jsonable(getattr(msg, f.name)) for f in dc_fields(msg) if f.name != "node"}  # type: ignore[arg-type]


def decode_frame(arb_id: int, data: bytes, direction: Direction = "auto") -> tuple[str, m.Command | m.Reply]:
    """Decode a frame whose direction may be unknown (a bus capture).

    Returns ``("host" | "motor", message)``. With ``direction="auto"``: command
    ids 0x19/0x1B/0x1D/0x1F are taken as host commands (a motor's state reply can
    use the same ids; the host reading wins when it decodes), other odd ids are
    state replies, and a 0x1E frame with non-zero value bytes is a parameter
    reply. A reply whose value is 0 has the bytes of the read request it answers
    and is shown as the request here; :class:`CaptureDecoder` tells them apart
    from the order of the frames.
    """
    if direction == "host":
        return "host", m.decode_command(arb_id, data)
    if direction == "motor":
        return "motor", m.decode_reply(arb_id, data)
    cmd = arb_id & 0x1F
    if cmd == 0x1E:
        if len(data) == 8 and any(data[4:8]):
            return "motor", m.decode_reply(arb_id, data)
        return "host", m.decode_command(arb_id, data)
    if cmd in m.STATE_CMDS:
        return "motor", m.decode_reply(arb_id, data)
    try:
        return "host", m.decode_command(arb_id, data)
    except ProtocolError:
        if cmd & 1:
            return "motor", m.decode_reply(arb_id, data)
        raise


class CaptureDecoder:
    """Decode a bus capture frame by frame, pairing parameter reads with their replies.

    A parameter reply of value 0 repeats its read request byte for byte, so alone it
    cannot be told from a request (:func:`decode_frame` shows it as one). This decoder
    remembers the reads it has seen: the same frame again while that read is
    outstanding is the motor's reply. A read stays outstanding until answered, or for
    ``reply_window`` seconds when frames carry times. Pure: it holds no clock, the
    caller passes each frame's time.
    """

    __slots__ = ("_pending", "reply_window")

    def __init__(self, reply_window: float = 0.5) -> None:
        self.reply_window = reply_window
        """How long a read waits for its reply, in seconds of the frames' own times."""
        self._pending: dict[tuple[int, bytes], float | None] = {}

    def decode(
        self, arb_id: int, data: bytes, time: float | None = None, direction: Direction = "auto"
    ) -> tuple[str, m.Command | m.Reply]:
        """Like :func:`decode_frame`; ``time`` (s) is the frame's capture time, if known."""
        if direction != "auto" or arb_id & 0x1F != 0x1E or not any(data[:2]):
            return decode_frame(arb_id, data, direction)  # address 0 is the fast read: no value reply
        key = (arb_id, bytes(data[:4]))
        who, msg = decode_frame(arb_id, data)
        if who == "motor":
            self._pending.pop(key, None)
            return who, msg
        if key in self._pending:
            sent = self._pending.pop(key)
            if sent is None or time is None or time - sent <= self.reply_window:
                return "motor", m.decode_reply(arb_id, data)
        self._pending[key] = time
        return who, msg


def _fmt(v: object) -> str:
    if isinstance(v, float):
        return f"{v + 0.0:.6g}"  # + 0.0: -0.0 reads 0
    return str(v)


def describe(msg: m.Message) -> str:
    """One-line human description, e.g. ``node 1 position_q position=-150 speed=10 accel=5``."""
    fields = message_fields(msg)
    extra = ""
    if isinstance(msg, (m.ReadParam, m.WriteParam, m.ParamValue)):
        p = find_parameter(msg.address)
        if p is not None:
            extra = f" [{p.name}{' ' + p.unit if p.unit else ''}]"
    body = " ".join(f"{k}={_fmt(v)}" for k, v in fields.items())
    node = "broadcast" if msg.node == 0 else f"node {msg.node}"
    return f"{node} {message_name(msg)} {body}{extra}".rstrip()
