"""A simulator of DrEmpower motors that behaves like their firmware.

>>> from drempower.protocol import FastRead, PositionQ
>>> from drempower.sim import SimBus
>>> bus = SimBus(ids=[1])
>>> bus.send(PositionQ(1, 90.0, speed=30.0, accel=100.0).encode())
>>> bus.advance(2.0)
>>> round(bus.motors[1].position, 1)
90.0

:class:`SimBus` holds the motors and a simulated clock; :class:`SimRunner`
advances it in real time on a thread. Attachments connect clients to it: a
python-can bus, pseudo-terminals that behave like the vendor USB-CAN adapter or
a motor's UART, and a socketcand server.
"""

from .bus import Listener, SimBus
from .defaults import MotorModel
from .faults import Faults
from .motor import SimMotor
from .runner import SimRunner
from .timing import BusStats, frame_bits

__all__ = ["BusStats", "Faults", "Listener", "MotorModel", "SimBus", "SimMotor", "SimRunner", "frame_bits"]
