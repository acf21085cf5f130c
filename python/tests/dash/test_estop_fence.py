"""A dashboard ESTOP fences every request issued before it, from every page: actions queued behind busy
workers never run after it; a clear and an enable issued after it do."""

from __future__ import annotations

import asyncio
import time
from typing import Any

import aiohttp
import pytest

from drempower import open_bus
from drempower.errors import ValidationError
from drempower.protocol.enums import AxisState

from .conftest import serve_in_thread

FENCED = "an ESTOP was pressed after this request was issued: it was not carried out"


async def test_an_estop_cancels_what_other_pages_queued_before_it() -> None:
    bus = open_bus("sim", motors=[1, 2, 3], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    sim = bus.transport.bus  # type: ignore[attr-defined]
    ws_url = url.replace("http:", "ws:") + "ws"
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(ws_url) as a, s.ws_connect(ws_url) as b:
            await a.receive_json(timeout=5)
            await b.receive_json(timeout=5)
            for k in range(8):  # more step runs than workers: what follows waits in the queue
                step = {"op": "step", "req": k, "id": 1 + k % 3, "mode": "velocity", "amplitude": 10, "duration": 2}
                await a.send_json(step)
            queued = [
                {"op": "control", "req": 20, "action": "clear_errors", "id": 1},
                {"op": "control", "req": 21, "action": "enable", "id": 1},
                {"op": "action", "req": 22, "action": "move", "args": {"id": 1, "angle": 90, "enable": True}},
            ]
            for q in queued:
                await a.send_json(q)
            await asyncio.sleep(0.05)
            await b.send_json({"op": "estop", "req": 99})
            replies: dict[int, dict[str, Any]] = {}
            deadline = time.monotonic() + 8
            while time.monotonic() < deadline and not {20, 21, 22} <= set(replies):
                await a.send_json({"op": "hb"})
                await b.send_json({"op": "hb"})
                try:
                    m = await a.receive_json(timeout=0.1)
                except asyncio.TimeoutError:
                    continue
                if m.get("t") == "reply":
                    replies[m["req"]] = m
            for r in (20, 21, 22):
                assert replies[r]["ok"] is False and replies[r]["error"] == FENCED, replies[r]
            await asyncio.sleep(0.3)
            assert all(m.state == AxisState.IDLE for m in sim.motors.values())
            assert abs(sim.motors[1].position) < 45
            # a clear and an enable issued after the ESTOP are carried out
            await b.send_json({"op": "control", "req": 30, "action": "clear_errors", "id": 1})
            await b.send_json({"op": "control", "req": 31, "action": "enable", "id": 1})
            got: dict[int, dict[str, Any]] = {}
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline and not {30, 31} <= set(got):
                await b.send_json({"op": "hb"})
                try:
                    m = await b.receive_json(timeout=0.1)
                except asyncio.TimeoutError:
                    continue
                if m.get("t") == "reply":
                    got[m["req"]] = m
            assert got[30]["ok"] and got[31]["ok"], got
            assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


def test_the_fence_in_the_hub() -> None:
    from drempower.dash import Hub

    with open_bus("sim", motors=[1], stop_on_close=False) as bus:
        hub = Hub(bus, poll_hz=5)
        try:
            before = hub.ticket()
            hub.estop("page B")
            with pytest.raises(ValidationError, match=FENCED):
                hub.issued(before, hub.do_control, "page A", {"action": "enable", "id": 1})
            hub.issued(before, hub.do_control, "page A", {"action": "idle", "id": 1})  # stopping is never fenced
            hub.issued(hub.ticket(), hub.do_control, "page A", {"action": "clear_errors", "id": 1})
        finally:
            hub.close()


async def test_a_page_that_goes_idles_what_it_moved_while_another_stays() -> None:
    """Each page is a controller: page A's connection goes, the motor it set moving is idled although
    page B is still open; page B's own motor keeps going."""
    bus = open_bus("sim", motors=[1, 2], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    sim = bus.transport.bus  # type: ignore[attr-defined]
    ws_url = url.replace("http:", "ws:") + "ws"
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(ws_url) as b:
            await b.receive_json(timeout=5)
            await b.send_json({"op": "control", "req": 1, "action": "V", "id": 1, "speed": 10})
            a = await s.ws_connect(ws_url)
            await a.receive_json(timeout=5)
            await a.send_json({"op": "control", "req": 2, "action": "V", "id": 2, "speed": 20})
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline and not (sim.motors[1].speed > 5 and sim.motors[2].speed > 10):
                await a.send_json({"op": "hb"})
                await b.send_json({"op": "hb"})
                await asyncio.sleep(0.02)
            assert sim.motors[2].speed > 10
            await a.close()  # page A goes
            t0 = time.monotonic()
            while time.monotonic() - t0 < 1.5 and sim.motors[2].state != AxisState.IDLE:
                await b.send_json({"op": "hb"})
                await asyncio.sleep(0.02)
            assert sim.motors[2].state == AxisState.IDLE, f"motor 2 still running {time.monotonic() - t0:.2f} s later"
            assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL and sim.motors[1].speed > 5
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()
