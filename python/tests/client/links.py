"""Open a client bus to a simulated bus through each transport the client supports."""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from typing import Any

from drempower.client import Bus, open_bus
from drempower.protocol.ids import Frame
from drempower.sim import (
    SimBus,
    SimRunner,
    attach_adapter_pty,
    attach_python_can,
    attach_socketcand,
    attach_uart_pty,
)
from drempower.sim.bus import Listener

TRANSPORTS = ("inprocess", "virtual", "slcan", "adapter", "uart", "socketcand", "python-can:socketcand")
"""Every way the client reaches the simulator."""

_channels = itertools.count()


class Recorder:
    """Records every host frame that reaches a SimBus (whatever the transport)."""

    def __init__(self, sim: SimBus) -> None:
        self.frames: list[Frame] = []
        send: Callable[[Frame, Listener | None], None] = sim.send

        def recording_send(frame: Frame, origin: Listener | None = None) -> None:
            self.frames.append(frame)
            send(frame, origin)

        sim.send = recording_send  # type: ignore[method-assign]


def lose(sim: SimBus, lost: Callable[[Frame], bool], count: int = 1) -> list[Frame]:
    """Lose the first ``count`` host frames for which ``lost`` is true; returns the lost frames."""
    gone: list[Frame] = []
    send = sim.send

    def lossy_send(frame: Frame, origin: Listener | None = None) -> None:
        if len(gone) < count and lost(frame):
            gone.append(frame)
            return
        send(frame, origin)

    sim.send = lossy_send  # type: ignore[method-assign]
    return gone


@contextmanager
def link(kind: str, sim: SimBus, time_scale: float = 20.0, clock: str = "virtual", **options: Any) -> Iterator[Bus]:
    """A client Bus on ``sim`` through transport ``kind``.

    In process the bus runs on the simulator's virtual clock (no real waits), unless ``clock="wall"``
    or ``time_scale=0`` (the test advances ``sim`` itself); every other transport needs a runner: the
    simulation then runs ``time_scale`` x real time.
    """
    options.setdefault("stop_on_close", False)
    with ExitStack() as stack:
        if kind == "inprocess":
            if clock == "virtual" and time_scale != 0:
                bus = open_bus("sim", bus=sim, clock="virtual", **options)
            else:
                bus = open_bus("sim", bus=sim, time_scale=time_scale, **options)
        else:
            stack.callback(SimRunner(sim, time_scale).start().stop)
            if kind == "virtual":
                channel = f"drempower-client-test-{next(_channels)}"
                stack.callback(attach_python_can(sim, channel=channel).close)
                bus = open_bus("virtual", channel, **options)
            elif kind in ("slcan", "adapter"):
                pty = attach_adapter_pty(sim)
                stack.callback(pty.close)
                if kind == "slcan":
                    bus = open_bus("slcan", pty.path, 1_000_000, sleep_after_open=0, **options)
                else:
                    bus = open_bus("adapter", pty.path, **options)
            elif kind == "uart":
                pty = attach_uart_pty(sim, min(sim.motors))
                stack.callback(pty.close)
                bus = open_bus("uart", pty.path, **options)
            elif kind in ("socketcand", "python-can:socketcand"):
                server = attach_socketcand(sim)
                stack.callback(server.close)
                bus = open_bus(kind, "can0", host=server.host, port=server.port, **options)
            else:
                raise ValueError(kind)
        stack.callback(bus.close)  # closes first: before the attachment and the runner stop
        yield bus
