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

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .adapter_pty import AdapterPty, attach_adapter_pty
    from .attach_pythoncan import PythonCanAttachment, attach_python_can
    from .bus import Listener, SimBus
    from .defaults import MotorModel
    from .faults import Faults
    from .motor import SimMotor
    from .noise import SensorNoise
    from .runner import SimRunner
    from .socketcand import SocketcandServer, attach_socketcand
    from .timing import BusStats, frame_bits
    from .uart_pty import UartPty, attach_uart_pty

__all__ = [
    "AdapterPty",
    "BusStats",
    "Faults",
    "Listener",
    "MotorModel",
    "PythonCanAttachment",
    "SimBus",
    "SimMotor",
    "SimRunner",
    "SensorNoise",
    "SocketcandServer",
    "UartPty",
    "attach_adapter_pty",
    "attach_python_can",
    "attach_socketcand",
    "attach_uart_pty",
    "frame_bits",
]

_HOMES = {
    "adapter_pty": (
        "AdapterPty",
        "attach_adapter_pty",
    ),
    "attach_pythoncan": (
        "PythonCanAttachment",
        "attach_python_can",
    ),
    "bus": (
        "Listener",
        "SimBus",
    ),
    "defaults": ("MotorModel",),
    "faults": ("Faults",),
    "motor": ("SimMotor",),
    "noise": ("SensorNoise",),
    "runner": ("SimRunner",),
    "socketcand": (
        "SocketcandServer",
        "attach_socketcand",
    ),
    "timing": (
        "BusStats",
        "frame_bits",
    ),
    "uart_pty": (
        "UartPty",
        "attach_uart_pty",
    ),
}
__getattr__ = lazy_names(__name__, _HOMES)
