"""Helpers of the simulator tests: send commands, collect and decode what the motors answer."""

from __future__ import annotations

from collections.abc import Callable

from drempower.protocol import (
    DataType,
    FastRead,
    Message,
    ParamValue,
    ReadParam,
    Reply,
    State,
    WriteParam,
    decode_reply,
    parameter,
)
from drempower.protocol.ids import Frame
from drempower.sim import SimBus


class Tap:
    """Collects every frame the motors put on ``bus``."""

    def __init__(self, bus: SimBus) -> None:
        self.frames: list[Frame] = []
        bus.add_listener(self.frames.append)

    def take(self) -> list[Frame]:
        out = list(self.frames)
        self.frames.clear()
        return out

    def replies(self) -> list[Reply]:
        return [decode_reply(f.arbitration_id, f.data) for f in self.take()]


def exchange(bus: SimBus, *messages: Message) -> list[Reply]:
    """Send ``messages`` (instant delivery) and return the decoded answers."""
    tap = Tap(bus)
    try:
        for m in messages:
            bus.send(m.encode())
        return tap.replies()
    finally:
        bus.remove_listener(tap.frames.append)


def read(bus: SimBus, node: int, name: str | int) -> int | float:
    """Read a parameter over the simulated bus with its table type."""
    (answer,) = exchange(bus, ReadParam.of(node, name))
    assert isinstance(answer, ParamValue)
    return answer.value


def write(bus: SimBus, node: int, name: str | int, value: float) -> None:
    """Write a parameter over the simulated bus with its table type (no answer expected).

    The frame is built raw, without the client's domain check: a motor must cope with
    whatever arrives on the wire (only the type's range applies).
    """
    p = parameter(name)
    assert (
        exchange(bus, WriteParam(node, p.address, p.dtype, float(value) if p.dtype is DataType.F32 else int(value)))
        == []
    )


def fast_read(bus: SimBus, node: int) -> State:
    (answer,) = exchange(bus, FastRead(node))
    assert isinstance(answer, State)
    return answer


def run_until(bus: SimBus, done: Callable[[], bool], limit: float) -> float:
    """Advance 1 ms at a time until ``done()`` (at most ``limit`` s); return the simulated time it took."""
    start = bus.now
    while not done():
        if bus.now - start > limit:
            raise AssertionError(f"not done within {limit} s")
        bus.advance(0.001)
    return bus.now - start
