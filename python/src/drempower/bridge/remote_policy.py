"""What a remote peer may put on the bus through the bridge's drempower face (the ``tx`` and ``estop``
keys), and how it is checked. The policy, in the order applied to each sample (all of it passes or none):

1. every frame must be a host command the protocol defines (:func:`~drempower.protocol.messages.decode_command`);
   one that is not is refused;
2. on the ``estop`` key, only emergency stops (system command ESTOP) are taken;
3. motion commands (position, speed, torque, impedance) and the values of presets are checked against
   the robot file's limits by the bridge bus's safety gate (:mod:`drempower.client.engine.gate`): position range,
   speed, torque, acceleration, and ``max_step`` and relative steps measured from the motor's measured
   position (one read when the bridge has no fresh state); a preset's target is checked when its start
   comes, as an absolute or a relative target as the start says; a command to every motor (id 0) is
   checked for every motor of the face;
4. parameter writes are checked against the parameter's domain (never forced), and one that commands
   motion (:data:`~drempower.client.engine.gate.MOTION_PARAMETERS`) as that motion, or refused on a joint with limits;
5. everything else passes as sent: reads, fast reads, enable, idle, stop, clear, save, reboot, starts.

Whether a motor is in closed loop is left to the motor (it ignores motion until enabled) and to the remote
client's own gate. A refused sample is logged (one line per kind per second) and counted; nothing of it is sent.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from ..client.api.bus_sync import Bus
from ..client.engine.effects import Op
from ..client.engine.gate import Intent, intents_of
from ..errors import ValidationError
from ..protocol.ids import Frame, SysCmd
from ..protocol.messages import (
    Message,
    PresetP,
    PresetQ,
    PresetT,
    Start,
    SystemCommand,
    WriteParam,
    decode_command,
)
from ..protocol.parameters import find_parameter

__all__ = ["RemotePolicy"]

_POSITION_PRESETS = (PresetT, PresetQ, PresetP)


class RemotePolicy:
    """The checks of one face's remote samples against the bridge's bus (its limits and its gate)."""

    def __init__(self, bus: Bus) -> None:
        self.bus = bus
        self._presets: dict[int, Intent] = {}
        """Per motor, the position preset a remote peer sent and no start has taken yet."""

    def messages(self, frames: Sequence[Frame], estop_key: bool = False) -> list[Message]:
        """``frames`` as protocol messages (ValidationError for one the protocol does not define)."""
        out: list[Message] = []
        for f in frames:
            try:
                m = decode_command(f.arbitration_id, bytes(f.data))
            except ValueError as exc:
                raise ValidationError(
                    f"frame {f.arbitration_id:#05x} is no command the protocol defines: {exc}"
                ) from None
            if estop_key and not (isinstance(m, SystemCommand) and m.op == SysCmd.ESTOP):
                raise ValidationError(f"{type(m).__name__} on the estop key: only emergency stops are taken there")
            out.append(m)
        return out

    def intents(self, msgs: Sequence[Message]) -> list[Intent]:
        """What ``msgs`` command, for the gate (domains checked; raises what the gate raises)."""
        out: list[Intent] = []
        presets = dict(self._presets)
        gate = self.bus._gate
        for m in msgs:
            if isinstance(m, _POSITION_PRESETS):
                (it,) = intents_of([m])
                presets[m.node] = it
                out.append(dataclasses.replace(it, position=None))  # its target when its start comes
            elif isinstance(m, Start):
                nodes = list(presets) if m.node == 0 else [m.node]
                for n in nodes:
                    pending = presets.pop(n, None)
                    if pending is not None:
                        out.append(dataclasses.replace(pending, relative=m.relative))
            elif isinstance(m, WriteParam):
                p = find_parameter(m.address)
                if p is not None:
                    p.check(m.value)
                    nodes = sorted(self.bus.known_motors()) if m.node == 0 else [m.node]
                    out.extend(gate.param_intents(nodes, p.address, m.value))
            else:
                out.extend(intents_of([m]))
        return out

    def check(self, msgs: Sequence[Message]) -> Op[None] | None:
        """None when ``msgs`` may go at once, else the operation (reads) that checks them; raises a
        ValidationError (SoftLimitError, MotionParameterError, DomainError) for what may not."""
        return self.bus._passage(self.intents(msgs), False, closed_loop=False)

    def sent(self, msgs: Sequence[Message]) -> None:
        """Note samples that went: presets waiting for their start, what the gate learns."""
        for m in msgs:
            if isinstance(m, _POSITION_PRESETS):
                (self._presets[m.node],) = intents_of([m])
            elif isinstance(m, Start):
                if m.node == 0:
                    self._presets.clear()
                else:
                    self._presets.pop(m.node, None)
        self.bus._gate.note_sent(msgs)
