"""Which frames with bit 0 set are a motor's state: the rule of spec/PROTOCOL.md section 1.6.

The vendor's document draws a state frame's command bits as ``* * E T 1``: bits 3-4
may hold anything. A firmware that sends them as 0 answers with 0x01-0x07; one that
keeps the bits of the command it answers sends 0x19-0x1F for a fast read (0x1E) or a
control frame (0x19-0x1D) and 0x09-0x0F for a preset (0x0C). 0x19/0x1B/0x1D/0x1F are
also the host commands T, P, C and write, so on a bus with another host one of those
frames can be either. The rule, for a frame of node N with command ``cmd``:

1. ``cmd`` odd below 0x18: N's state (no host sends these). 0x01-0x07 answering this
   host's fast read, control cycle or wait shows that N's firmware sends bits 3-4 as 0
   (an unsolicited one, a heartbeat, shows nothing: it answers no command); 0x09-0x17
   shows that it keeps them.
2. ``cmd`` 0x1F whose bytes 0-3 are a parameter write's ``[address != 0][data type 0-4]``:
   another host's write, never a state (as a position those bytes are a subnormal float).
3. ``cmd`` 0x19/0x1B/0x1D and any other 0x1F:

   * N is known to send bits 3-4 as 0 (rule 1 saw it, or the profile says ``zero``):
     another host's command;
   * else, while this host waits for a state of N (a fast read, a control cycle, a wait
     for a state): N's state, and N is taken to keep the bits until a frame of rule 1
     shows otherwise;
   * else, when N is known to keep the bits and no other host has been heard: N's state
     (a heartbeat, a reply to a control frame this host did not wait for);
   * else another host's command.

What stays undecidable: on a firmware that keeps the bits, another host's T, P or C
command to N (or a write that is no valid write) while this host waits for N's state
is taken as N's state. A profile (``open_bus(..., profile=...)``, written by
``drempower doctor --write-profile``) that says ``zero`` closes the gap for firmware
that sends 0 from the first frame on.
"""

from __future__ import annotations

import struct
from typing import Literal

from ...errors import ValidationError

__all__ = ["STATUS_BITS", "StatusBits", "StatusBitsSetting", "is_valid_write"]

StatusBitsSetting = Literal["auto", "zero", "kept"]
STATUS_BITS: tuple[StatusBitsSetting, ...] = ("auto", "zero", "kept")
"""What a client may be told of its motors' firmware: learn it (``auto``), bits 3-4 sent as 0, or kept."""

_RW = struct.Struct("<HH").unpack_from


def is_valid_write(data: bytes) -> bool:
    """True when ``data`` (8 bytes of a 0x1F frame) starts with a write's ``[u16 address != 0][u16 data type 0-4]``."""
    address, dtype = _RW(data)
    return bool(address != 0 and dtype <= 4)


class StatusBits:
    """What this bus knows of each motor's bits 3-4 in state frames, and the decision of section 1.6."""

    __slots__ = ("default", "known")

    def __init__(self, default: StatusBitsSetting = "auto") -> None:
        if default not in STATUS_BITS:
            raise ValidationError(f"status_bits={default!r}: one of {', '.join(map(repr, STATUS_BITS))}")
        self.default: StatusBitsSetting = default
        """What is assumed of a motor not heard from yet."""
        self.known: dict[int, StatusBitsSetting] = {}
        """Per motor, what its own state frames showed (``zero`` or ``kept``)."""

    def of(self, node: int) -> StatusBitsSetting:
        """What is known or assumed of ``node``'s firmware."""
        return self.known.get(node, self.default)

    def saw(self, node: int, cmd: int) -> None:
        """Learn from a state frame of ``node`` with command value ``cmd`` below 0x18 that answered this host
        (or any with bits 3-4 set: rule 1)."""
        bits: StatusBitsSetting = "zero" if cmd < 0x08 else "kept"
        if self.known.get(node) != bits:
            self.known[node] = bits

    def is_state(self, node: int, cmd: int, data: bytes, waited: bool, other_hosts: bool) -> bool:
        """Rules 2 and 3 for a frame of ``node`` with ``cmd`` 0x19/0x1B/0x1D/0x1F: True when it is ``node``'s
        state. ``waited``: this host waits for a state of ``node``; ``other_hosts``: another host was heard."""
        if cmd == 0x1F and is_valid_write(data):
            return False
        bits = self.known.get(node, self.default)
        if bits == "zero":
            return False
        if waited:
            self.known.setdefault(node, "kept")
            return True
        return bits == "kept" and not other_hosts
