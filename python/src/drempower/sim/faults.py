"""Faults a :class:`~drempower.sim.bus.SimBus` can inject on request.

Random faults draw from the bus's seeded generator, so a run is repeatable.
Change them at any time (``bus.faults.drop_rate = 0.1``). Other faults are
methods: :meth:`SimMotor.inject_error <drempower.sim.motor.SimMotor.inject_error>`
raises a motor error (with :meth:`SimBus.schedule <drempower.sim.bus.SimBus.schedule>`
in the middle of a move), and setting ``node_id`` of one motor to another's makes
two motors share an id.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Faults"]


@dataclass
class Faults:
    """What goes wrong on the simulated bus.

    * ``drop_rate``: probability that a frame (either direction) is lost.
    * ``corrupt_rate``: probability that one random data bit of a frame is flipped
      and the frame delivered anyway (a faulty gateway; a healthy CAN bus's CRC
      would catch it).
    * ``reply_delay``: seconds added before every motor frame enters the bus, plus
      up to ``reply_jitter`` seconds more, drawn uniformly.
    * ``silent``: motors (by the id they were created with) that stop answering:
      they still obey commands but send nothing.
    * ``serial_garbage``: probability that random bytes (1 to 8) precede a frame
      sent out of a binary serial attachment (the 0xAA adapter pty, the UART pty).
    """

    drop_rate: float = 0.0
    corrupt_rate: float = 0.0
    reply_delay: float = 0.0
    reply_jitter: float = 0.0
    silent: set[int] = field(default_factory=set)
    serial_garbage: float = 0.0
