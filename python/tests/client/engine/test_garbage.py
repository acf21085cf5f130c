"""A request leaves nothing for Python's cycle collector: what it made is freed as soon as it is answered.

A cycle left behind by every request (an exchange holding a bound method of its own as its waiter's
callback) made the collector run every few hundred requests, and now and then over the whole heap:
pauses of tens of milliseconds in a control loop.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import gc
from collections.abc import Callable, Iterator

import drempower
from drempower.protocol import FastRead
from drempower.sim import SimBus


@contextlib.contextmanager
def collected_garbage() -> Iterator[list[object]]:
    """The objects the cycle collector finds unreachable after the block (kept, not freed); the
    collector's state (enabled, debug flags, ``gc.garbage``) is as it was after."""
    gc.collect()
    was_enabled, flags, before = gc.isenabled(), gc.get_debug(), len(gc.garbage)
    gc.disable()
    gc.set_debug(gc.DEBUG_SAVEALL)
    found: list[object] = []
    try:
        yield found
        gc.collect()
        found.extend(gc.garbage[before:])
    finally:
        gc.set_debug(flags)
        del gc.garbage[before:]
        if was_enabled:
            gc.enable()


def ours(garbage: list[object]) -> collections.Counter[str]:
    """The kinds of the client's objects among ``garbage`` (others may come from anything else in the
    process: another test's simulator still running, python-can...)."""
    return collections.Counter(
        type(o).__qualname__ for o in garbage if type(o).__module__.startswith("drempower.client.")
    )


def test_requests_of_every_kind_leave_no_cycles() -> None:
    with drempower.open_bus("sim", bus=SimBus(ids=[1, 2]), time_scale=0, stop_on_close=False) as bus:
        m1, m2 = bus.motor(1), bus.motor(2)
        m1.set_angle(0.0, enable=True, param=10.0)
        m2.set_angle(0.0, enable=True, param=10.0)
        cmds = [m1.make_angle(5.0, 0.0, 10.0), m2.make_angle(5.0, 0.0, 10.0)]
        calls: dict[str, Callable[[], object]] = {
            "get_state (one request)": m1.get_state,
            "get_volcur (an exchange)": m1.get_volcur,
            "read_property": lambda: m1.read_property(31214),
            "cycle (two motors)": lambda: bus.cycle(cmds),
            "a poll with missing_ok, motor 9 silent": lambda: bus.request(
                [FastRead(1), FastRead(9)], missing_ok=True, timeout=0.01
            ),
        }
        for name, call in calls.items():
            call()
            with collected_garbage() as garbage:
                for _ in range(50):
                    call()
            assert not ours(garbage), f"{name} left cycles: {dict(ours(garbage))}"


def test_asyncio_requests_leave_no_cycles() -> None:
    async def main() -> collections.Counter[str]:
        async with drempower.open_bus_async("sim", bus=SimBus(ids=[1]), time_scale=0, stop_on_close=False) as bus:
            m = bus.motor(1)
            await m.get_state()
            await m.get_volcur()
            with collected_garbage() as garbage:
                for _ in range(50):
                    await m.get_state()
                    await m.get_volcur()
            return ours(garbage)

    left = asyncio.run(main())
    assert not left, f"asyncio requests left cycles: {dict(left)}"
