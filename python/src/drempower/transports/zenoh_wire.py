"""A remote bus on Zenoh: its keys and frame encoding (served by ``drempower bridge``, read by the ``zenoh`` transport).

Under a key prefix (``drempower`` by default) a bridge serves:

* ``<prefix>/tx``: frames a remote client puts on the bus (attachment: ``<client id>:<sequence number>``,
  one counter for tx and estop);
* ``<prefix>/estop``: emergency stops, on their own key at Zenoh's real-time priority; the
  bridge drops the client's samples numbered before an estop that arrive after it;
* ``<prefix>/rx``: every frame on the bus: the motors' and those of every host
  (attachment: the id of the host that sent it, empty for motor frames);
* ``<prefix>/alive``: a client's keep-alive (empty payload, attachment: its client id), sent
  every ``command_timeout / 4`` while it has driven motors: a client not heard from (any sample)
  for ``command_timeout`` s has its motors idled, before its liveliness lease runs out;
* ``<prefix>/info``: a queryable answering JSON ``{"description", "default_timeout", "motors",
  "command_timeout"}``;
* liveliness tokens ``<prefix>/clients/<client id>`` of the connected clients.

A sample holds one or more frames, each ``<u32 LE id | flags> <u8 length> <data>``
(bit 31 of the id word: extended id, bit 30: remote frame).
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence

from ..errors import ProtocolError
from ..protocol.ids import Cmd, Frame, SysCmd
from ..protocol.limits import MOTION_CMDS, START_SYS_CMDS

__all__ = [
    "DEFAULT_PREFIX",
    "BRIDGE_ORIGIN",
    "keys",
    "encode_frames",
    "decode_frames",
    "is_estop",
    "driven_nodes",
    "join_origin",
    "split_origin",
]

DEFAULT_PREFIX = "drempower"
BRIDGE_ORIGIN = b"bridge"
"""Origin of the frames the bridge itself sends (its state stream, ROS 2 commands)."""
_HEAD = struct.Struct("<IB")
_EXTENDED = 1 << 31
_REMOTE = 1 << 30


def keys(prefix: str) -> dict[str, str]:
    """The key expressions under ``prefix``: tx, estop, alive, rx, info, clients (liveliness, with ``/*``)."""
    prefix = prefix.strip("/")
    if not prefix or any(c in prefix for c in "*$?#"):
        raise ValueError(f"key prefix {prefix!r}: a non-empty Zenoh key without wildcards, e.g. 'drempower/arm'")
    return {
        "tx": f"{prefix}/tx",
        "estop": f"{prefix}/estop",
        "alive": f"{prefix}/alive",
        "rx": f"{prefix}/rx",
        "info": f"{prefix}/info",
        "clients": f"{prefix}/clients",
    }


def encode_frames(frames: Iterable[Frame]) -> bytes:
    """Frames as one sample payload."""
    out = bytearray()
    for f in frames:
        word = f.arbitration_id | (_EXTENDED if f.is_extended else 0) | (_REMOTE if f.is_remote else 0)
        out += _HEAD.pack(word, len(f.data))
        out += f.data
    return bytes(out)


def decode_frames(data: bytes) -> list[Frame]:
    """The frames of a sample payload; ProtocolError when it is cut short or a frame is too long."""
    frames = []
    i, n = 0, len(data)
    while i < n:
        if n - i < _HEAD.size:
            raise ProtocolError(f"tunnelled frames: {n - i} trailing bytes, a frame header has {_HEAD.size}")
        word, size = _HEAD.unpack_from(data, i)
        i += _HEAD.size
        if size > 8 or i + size > n:
            raise ProtocolError(f"tunnelled frame of {size} data bytes with {n - i} left (CAN frames hold 0..8)")
        frames.append(Frame(word & 0x1FFFFFFF, bytes(data[i : i + size]), bool(word & _EXTENDED), bool(word & _REMOTE)))
        i += size
    return frames


def join_origin(client: bytes, seq: int) -> bytes:
    """Attachment of a client's sample: ``<client id>:<sequence number>``."""
    return client + b":" + str(seq).encode()


def split_origin(attachment: bytes) -> tuple[bytes, int]:
    """``(client id, sequence number)`` of a client's attachment; ValueError when it is not one."""
    client, sep, seq = attachment.rpartition(b":")
    if not sep or not client or not seq.isdigit():
        raise ValueError(f"attachment {attachment[:48]!r} is no '<client id>:<sequence number>'")
    return client, int(seq)


def is_estop(frame: Frame) -> bool:
    """True for an emergency-stop frame (system command 0x08, op 0x06)."""
    return (
        not frame.is_extended
        and frame.arbitration_id & 0x1F == Cmd.SYSTEM
        and len(frame.data) >= 1
        and frame.data[0] == SysCmd.ESTOP
    )


def driven_nodes(frames: Sequence[Frame]) -> set[int]:
    """Motors (0 = every motor) that these frames set moving: motion commands, presets and starts."""
    nodes = set()
    for f in frames:
        if f.is_extended or f.arbitration_id > 0x7FF:
            continue
        node, cmd = f.arbitration_id >> 5, f.arbitration_id & 0x1F
        if cmd in MOTION_CMDS or (cmd == Cmd.SYSTEM and f.data[:1] and f.data[0] in START_SYS_CMDS):
            nodes.add(node)
    return nodes
