"""The dashboard's motions without a browser: idle motors refused, timed steps ended by the server,
the step's bandwidth, and what the first scan shows."""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import Any

import pytest

aiohttp = pytest.importorskip("aiohttp")

from drempower import open_bus  # noqa: E402
from drempower.protocol.enums import AxisState  # noqa: E402
from drempower.protocol.ids import Cmd  # noqa: E402

from .conftest import serve_in_thread  # noqa: E402

_MOTION = {Cmd.POSITION_T, Cmd.POSITION_Q, Cmd.POSITION_P, Cmd.VELOCITY, Cmd.TORQUE, Cmd.PRESET}


@dataclass
class Page:
    """A raw WebSocket client of a dashboard on simulated motors, with the simulator beside it."""

    ws: Any
    hub: Any
    sim: Any
    req: int = 0

    async def ask(self, op: str, **args: Any) -> dict[str, Any]:
        self.req += 1
        await self.ws.send_json({"op": op, "req": self.req, **args})
        while True:
            m: dict[str, Any] = await self.ws.receive_json(timeout=15)
            if m["t"] == "reply" and m["req"] == self.req:
                return m


@pytest.fixture
async def page() -> AsyncIterator[Page]:
    bus = open_bus("sim", motors=[1, 2], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            await ws.receive_json(timeout=5)

            async def beat() -> None:  # a page's heartbeat, every 100 ms
                while not ws.closed:
                    await ws.send_json({"op": "hb"})
                    await asyncio.sleep(0.1)

            heart = asyncio.ensure_future(beat())
            try:
                yield Page(ws, hub, bus.transport.bus)  # type: ignore[attr-defined]
            finally:
                heart.cancel()
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


async def test_motion_to_an_idle_motor_is_refused_saying_so_and_nothing_moves(page: Page) -> None:
    assert (await page.ask("control", action="idle", id=1))["ok"]
    motor = page.sim.motors[1]
    assert motor.state == AxisState.IDLE
    frames: list[Any] = []
    page.sim.add_listener(frames.append, host_frames=True)
    moves = [
        {"action": "Q", "angle": 90, "speed": 20, "param": 20},
        {"action": "T", "angle": 90, "param": 20},
        {"action": "jog", "delta": 10},
        {"action": "step", "delta": 30},
        {"action": "V", "speed": 30},
        {"action": "C", "torque": 0.5},
        {"action": "impedance", "angle": 10, "kp": 5, "kd": 0.5},
        {"action": "sync_move", "ids": [1, 2], "angles": [10, 10]},
    ]
    for args in moves:
        r = await page.ask("control", id=1, **args)
        assert not r["ok"], args
        assert r["error"].startswith("motor 1 is idle (not in closed loop): enable it first")
        assert "drempower enable 1" in r["error"]
    r = await page.ask("step", id=1, mode="position", amplitude=30, duration=0.5)
    assert not r["ok"] and "motor 1 is idle" in r["error"]  # no "overshoot 0.0 %" of a flat trace
    page.sim.remove_listener(frames.append)
    sent = {f.arbitration_id & 0x1F for f in frames if f.arbitration_id >> 5 in (0, 1)}
    assert not sent & _MOTION, sent
    assert page.hub.commanded == set() and page.hub.targets == {}
    assert motor.state == AxisState.IDLE and abs(motor.speed) < 0.01
    # enabled, the same move goes
    assert (await page.ask("control", action="enable", id=1))["ok"]
    assert (await page.ask("control", id=1, action="V", speed=30))["ok"]
    assert page.hub.commanded == {1}


async def test_a_velocity_step_ends_at_its_duration(page: Page) -> None:
    motor = page.sim.motors[1]
    t0 = time.monotonic()
    r = await page.ask("step", id=1, mode="velocity", amplitude=30, duration=1.0)
    assert r["ok"], r
    assert 1.0 <= time.monotonic() - t0 < 3
    assert max(r["result"]["y"]) > 25  # it did turn at about 30 r/min
    # ended by the server: not turning, now or seconds later (the page sent nothing more)
    deadline = time.monotonic() + 2
    while abs(motor.speed) > 0.5 and time.monotonic() < deadline:
        await asyncio.sleep(0.02)
    assert abs(motor.speed) <= 0.5, motor.speed
    await asyncio.sleep(2.0)  # the page's heartbeat goes on: nothing idles the motor meanwhile
    assert abs(motor.speed) <= 0.5 and motor.state == AxisState.CLOSED_LOOP_CONTROL
    assert page.hub.targets[1] == [None, 0.0, None]


async def test_a_position_step_uses_the_motors_filter_bandwidth(page: Page) -> None:
    bw = "axis0.controller.config.input_filter_bandwidth"
    assert (await page.ask("write", id=1, name=bw, value=20))["ok"]
    r = await page.ask("step", id=1, mode="position", amplitude=10, duration=0.5)
    assert r["ok"], r
    # a T frame writes its bandwidth into the parameter: 20 still, as the gains box shows it
    assert page.sim.motors[1].param(bw) == pytest.approx(20)
    r = await page.ask("step", id=1, mode="position", amplitude=10, duration=0.5, bandwidth=40)
    assert r["ok"] and page.sim.motors[1].param(bw) == pytest.approx(40)
    r = await page.ask("step", id=1, mode="position", amplitude=10, duration=0.5, bandwidth=400)
    assert not r["ok"] and r["error"].startswith("bandwidth=400 is out of range: allowed 0.01..300 (1/s)")


async def test_the_first_scan_runs_by_itself_and_the_cards_carry_the_versions(page: Page) -> None:
    deadline = time.monotonic() + 10
    cards: list[dict[str, Any]] = []
    while not cards and time.monotonic() < deadline:  # no scan asked for
        m = await page.ws.receive_json(timeout=5)
        if m["t"] == "cards":
            cards = m["cards"]
    assert [c["id"] for c in cards] == [1, 2]
    fw = page.sim.motors[1].param("fw_version")
    hw = page.sim.motors[1].param("hw_version")
    assert all(c["fw"] == fw and c["hw"] == hw for c in cards), cards


async def test_an_enable_that_does_not_take_is_an_error_not_a_success(page: Page) -> None:
    from drempower.protocol.flags import MotorError

    motor = page.sim.motors[1]
    motor.inject_error(MotorError.DRV_FAULT)  # the axis drops to idle and refuses closed loop
    assert motor.state == AxisState.IDLE
    r = await page.ask("control", action="enable", id=1)
    assert not r["ok"]
    assert r["error"].startswith("motor_1 did not enter closed loop (state idle): its error flags are set")
    assert (await page.ask("control", action="clear_errors", id=1))["ok"]
    assert (await page.ask("control", action="enable", id=1))["ok"]
    assert motor.state == AxisState.CLOSED_LOOP_CONTROL


async def test_a_clear_that_leaves_an_error_is_an_error_not_a_success(page: Page) -> None:
    from drempower.protocol.flags import EncoderError

    motor = page.sim.motors[1]
    motor.inject_error(EncoderError.EDR_BATTERY_LOW)  # stays after a clear until the motor is zeroed
    r = await page.ask("control", action="clear_errors", id=1)
    assert not r["ok"]
    assert r["error"] == "motor_1 errors remain after clearing: see its errors (an encoder error needs zeroing first)"
    with page.sim.lock:  # as drempower zero does
        motor._set_zero()
    assert (await page.ask("control", action="clear_errors", id=1))["ok"]
    assert motor.axis_error == 0
