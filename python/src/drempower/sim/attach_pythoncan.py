"""Attach a :class:`~drempower.sim.bus.SimBus` to a python-can bus.

With python-can's ``virtual`` interface (the default), any ``can.Bus(interface=
"virtual", channel="drempower-sim")`` in the same process talks to the simulated
motors. Other interfaces work too, e.g. ``interface="socketcan", channel="vcan0"``
puts the simulated motors on a Linux virtual CAN interface.
"""

from __future__ import annotations

import contextlib
import threading
from types import TracebackType
from typing import Any

import can
from can.interfaces import virtual

from ..protocol.ids import Frame
from .bus import SimBus

__all__ = ["PythonCanAttachment", "attach_python_can"]

_POLL = 0.05
"""Longest wait of the receive thread (s), so that close() is noticed promptly."""


class PythonCanAttachment:
    """Moves host frames from a python-can bus into a SimBus, and motor frames out. ``close()`` ends it."""

    def __init__(self, bus: SimBus, channel: str = "drempower-sim", interface: str = "virtual", **kwargs: Any) -> None:
        self.sim = bus
        self.channel = channel
        self.interface = interface
        self.can_bus = can.Bus(channel=channel, interface=interface, **kwargs)
        """The python-can bus on the simulator's side."""
        self._send_guard: contextlib.AbstractContextManager[Any] = (
            virtual.channels_lock if interface == "virtual" else contextlib.nullcontext()
        )
        """Held around a send on python-can's virtual bus: its send walks the channel's queues without a lock
        while a bus shutting down removes its own (under this lock), and the walk would skip the next one."""
        self._stop = threading.Event()
        bus.add_listener(self._out, host_frames=True)
        self._thread = threading.Thread(target=self._pump, name="drempower-sim-python-can", daemon=True)
        self._thread.start()

    def _out(self, frame: Frame) -> None:
        msg = can.Message(
            arbitration_id=frame.arbitration_id,
            data=frame.data,
            is_extended_id=frame.is_extended,
            is_remote_frame=frame.is_remote,
        )
        try:
            with self._send_guard:  # a bus closing meanwhile must not make the send skip another
                self.can_bus.send(msg)
        except can.CanError:
            pass  # a full or failed interface loses the frame, as a bus would

    def _pump(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self.can_bus.recv(_POLL)
            except (can.CanError, OSError, ValueError):
                if self._stop.is_set():
                    return
                raise
            if msg is not None and not msg.is_error_frame:
                frame = Frame(msg.arbitration_id, bytes(msg.data), msg.is_extended_id, msg.is_remote_frame)
                self.sim.send(frame, self._out)

    def close(self) -> None:
        """Detach from the SimBus and shut the python-can bus down (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self.sim.remove_listener(self._out)
        self._thread.join()
        self.can_bus.shutdown()

    def __enter__(self) -> PythonCanAttachment:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def attach_python_can(
    bus: SimBus, channel: str = "drempower-sim", interface: str = "virtual", **kwargs: Any
) -> PythonCanAttachment:
    """Connect ``bus`` to the python-can bus ``interface``/``channel`` (extra arguments go to can.Bus)."""
    return PythonCanAttachment(bus, channel, interface, **kwargs)
