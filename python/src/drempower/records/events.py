"""What one frame means for a recording: the messages it becomes, topic by topic (pure, no I/O).

A frame becomes its raw copy on ``/can/tx`` or ``/can/rx`` (a robot's bus:
``/can/<bus>/tx``, ``/can/<bus>/rx``); a received state
frame also a ``/joint_states`` message, a parameter reply a
``/drempower/parameters`` message, and a change of the E bit or an error word with
flags set a ``/drempower/errors`` message: errors of motors only. Received frames are
decoded as ``drempower decode`` does (:class:`~drempower.protocol.describe.CaptureDecoder`):
another host's commands, fast reads and reads are recorded as raw frames and nothing else,
and so are frames that are no DrEmpower frame at all.
The messages are dicts in the layout of :mod:`drempower.records.ros2_types`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..errors import ProtocolError
from ..naming import motor_name
from ..protocol.describe import CaptureDecoder
from ..protocol.flags import ERROR_WORDS, decode_error_word
from ..protocol.ids import Frame
from ..protocol.messages import ParamValue, State
from ..protocol.parameters import find_parameter

__all__ = ["FrameEvents"]

_DEG = math.pi / 180.0
_RPM = 2.0 * math.pi / 60.0
_ERROR_WORDS = {w.address: w for w in ERROR_WORDS}

Event = tuple[str, dict[str, Any]]


class FrameEvents:
    """Turns frames into ``(topic, message)`` pairs; remembers each motor's E bit to report changes.

    ``names`` maps motor ids to joint names (default ``motor_<id>``); ``channel`` is the headers' ``frame_id``;
    ``topic_prefix`` the raw frames' topics' (``<prefix>/tx``, ``<prefix>/rx``). ``gears`` maps motor ids
    to a robot joint's ``(gear, offset)``: its states are then at the joint (rad / gear + offset,
    rad/s / gear, Nm x gear, as :class:`drempower.robot.Gearing`); other motors' at the motor.
    """

    def __init__(
        self,
        names: Mapping[int, str] | None = None,
        channel: str = "can",
        *,
        topic_prefix: str = "/can",
        gears: Mapping[int, tuple[float, float]] | None = None,
    ) -> None:
        self.names = dict(names or {})
        self.channel = channel
        self.gears = dict(gears or {})
        self._tx, self._rx = f"{topic_prefix}/tx", f"{topic_prefix}/rx"
        self._error_bit: dict[int, bool] = {}
        self._capture = CaptureDecoder()
        """Pairs parameter reads (ours and other hosts') with their replies: a reply of value 0 repeats its read."""

    def __call__(self, ns: int, frame: Frame, tx: bool) -> list[Event]:
        """The messages of ``frame`` seen at ``ns`` (Unix ns); ``tx`` when this host sent it."""
        arb, data, ext, rtr = frame
        header = {"stamp": {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}, "frame_id": self.channel}
        raw = {
            "header": header,
            "id": arb,
            "is_rtr": rtr,
            "is_extended": ext,
            "is_error": False,
            "dlc": len(data),
            "data": list(bytes(data).ljust(8, b"\0")[:8]),
        }
        out: list[Event] = [(self._tx if tx else self._rx, raw)]
        if ext or rtr or len(data) != 8:
            return out  # no DrEmpower frame: another device's
        try:
            who, reply = self._capture.decode(arb, bytes(data), ns / 1e9)
        except ProtocolError:
            return out  # neither a host's nor a motor's frame: kept raw
        if tx or who == "host":
            return out  # ours (a read is remembered for its reply) or another host's
        node = arb >> 5
        if isinstance(reply, State):
            gear, offset = self.gears.get(node, (1.0, 0.0))
            out.append(
                (
                    "/joint_states",
                    {
                        "header": header,
                        "name": [motor_name(node, named=self.names.get(node))],
                        "position": [reply.position * _DEG / gear + offset],
                        "velocity": [reply.speed * _RPM / gear],
                        "effort": [reply.torque * gear],
                    },
                )
            )
            if reply.error != self._error_bit.get(node, False):
                self._error_bit[node] = reply.error
                text = "axis error set (E bit)" if reply.error else "axis error cleared (E bit)"
                out.append(self._error(header, node, "state", int(reply.error), text))
        elif isinstance(reply, ParamValue):
            p = find_parameter(reply.address)
            out.append(
                (
                    "/drempower/parameters",
                    {
                        "header": header,
                        "node": node,
                        "address": reply.address,
                        "name": p.name if p else "",
                        "unit": (p.unit or "") if p else "",
                        "value": float(reply.value),
                    },
                )
            )
            word = _ERROR_WORDS.get(reply.address)
            if word is not None and isinstance(reply.value, int) and reply.value:
                code = reply.value & 0xFFFFFFFF
                out.append(self._error(header, node, word.name, code, ", ".join(decode_error_word(word.name, code))))
        return out

    @staticmethod
    def _error(header: dict[str, Any], node: int, source: str, code: int, text: str) -> Event:
        return ("/drempower/errors", {"header": header, "node": node, "source": source, "code": code, "text": text})
