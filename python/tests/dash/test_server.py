"""The dashboard server without a browser: token and Origin checks, stop rules, read-only, figures."""

from __future__ import annotations

import asyncio
import json
import math
import os
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Iterator

import pytest

aiohttp = pytest.importorskip("aiohttp")

from drempower import open_bus  # noqa: E402
from drempower.dash.server import format_url  # noqa: E402
from drempower.dash.tuning import step_figures  # noqa: E402
from drempower.protocol.enums import AxisState  # noqa: E402

from .conftest import serve_in_thread  # noqa: E402


def _status(url: str) -> int:
    try:
        with urllib.request.urlopen(url, timeout=5) as r:
            return int(r.status)
    except urllib.error.HTTPError as exc:
        return exc.code


@pytest.fixture
def proc(request: pytest.FixtureRequest) -> Iterator[subprocess.Popen[str]]:
    args = [sys.executable, "-m", "drempower", "dash", "--port", "0", *request.param]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        yield p
    finally:
        if p.poll() is None:
            p.kill()
        p.communicate(timeout=10)


@pytest.mark.parametrize("proc", [["--host", "127.0.0.2", "--json", "--sim", "1"]], indirect=True)
async def test_a_bind_beyond_the_default_needs_the_token(proc: subprocess.Popen[str]) -> None:
    assert proc.stdout is not None
    first = json.loads(proc.stdout.readline())
    url = first["url"]
    assert url.startswith("http://127.0.0.2:") and "?token=" in url
    base, token = url.split("?token=")
    assert _status(base) == 403
    assert _status(base + "static/app.js") == 403
    assert _status(base + "?token=wrong") == 403
    assert _status(url) == 200
    ws_url = base.replace("http:", "ws:") + "ws"
    async with aiohttp.ClientSession() as s:
        with pytest.raises(aiohttp.WSServerHandshakeError) as e:
            await s.ws_connect(ws_url)
        assert e.value.status == 403
        with pytest.raises(aiohttp.WSServerHandshakeError) as e:
            await s.ws_connect(ws_url + "?token=" + token, origin="http://evil.example")
        assert e.value.status == 403
        origin = base.rstrip("/")
        async with s.ws_connect(ws_url + "?token=" + token, origin=origin) as ws:
            hello = await ws.receive_json(timeout=5)
            assert hello["t"] == "hello" and hello["read_only"] is False
            await ws.send_json({"op": "scan", "req": 1})
            await ws.send_json({"op": "control", "req": 2, "action": "V", "id": 1, "speed": 20})
            replies = {}
            deadline = time.monotonic() + 10
            while len(replies) < 2 and time.monotonic() < deadline:
                m = await ws.receive_json(timeout=5)
                if m["t"] == "reply":
                    replies[m["req"]] = m
            assert replies[1]["ok"] and [f["id"] for f in replies[1]["result"]] == [1]
            assert replies[2]["ok"], replies[2]
            # SIGTERM idles the motor the dashboard moved (said on stderr) and ends the command
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(10) == 128 + signal.SIGTERM
    assert proc.stderr is not None
    err = proc.stderr.read()
    assert "motor_1 speed(speed=20.0, mode=1, torque_ff=0.0, enable=False)" in err  # row speed of the table
    assert "SIGTERM: stopping" in err and "idled motor_1" in err


@pytest.mark.parametrize("proc", [[]], indirect=True)
def test_default_serves_three_simulated_motors_on_loopback(proc: subprocess.Popen[str]) -> None:
    assert proc.stdout is not None
    url = proc.stdout.readline().strip()
    assert url.startswith("http://127.0.0.1:") and url.endswith("/") and "token" not in url
    assert _status(url) == 200
    proc.send_signal(signal.SIGINT)
    assert proc.wait(10) == 128 + signal.SIGINT


def test_help_names_one_default_connection_and_the_watchdog() -> None:
    r = subprocess.run(
        [sys.executable, "-m", "drempower", "dash", "--help"], capture_output=True, text=True, timeout=30
    )
    assert r.returncode == 0
    assert "connection (one of; default: simulated motors 1,2,3)" in r.stdout
    assert "python-can's configuration" not in r.stdout
    assert "--watchdog MS" in r.stdout and "128 + the signal number" in r.stdout


def test_bad_host_is_a_usage_error() -> None:
    r = subprocess.run(
        [sys.executable, "-m", "drempower", "dash", "--host", "not an address", "--port", "0"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert r.returncode == 2
    assert "--host 'not an address'" in r.stderr and "Traceback" not in r.stderr


async def test_a_silent_browser_gets_its_motors_idled_after_half_a_second() -> None:
    bus = open_bus("sim", motors=[1], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    sim = bus.transport.bus.motors[1]  # type: ignore[attr-defined]
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            await ws.receive_json(timeout=5)
            await ws.send_json({"op": "control", "req": 1, "action": "V", "id": 1, "speed": 30})
            t0 = time.monotonic()
            while sim.state != AxisState.IDLE and time.monotonic() - t0 < 3:
                if time.monotonic() - t0 < 1:
                    await ws.send_json({"op": "hb"})
                await asyncio.sleep(0.05)
            # heartbeats for 1 s kept it moving; then 0.5 s of silence idled it, the socket still open
            assert sim.state == AxisState.IDLE
            assert 1.4 < time.monotonic() - t0 < 2.5
            assert not ws.closed
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


async def test_read_only_refuses_control_but_not_estop() -> None:
    bus = open_bus("sim", motors=[1], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    hub.read_only = True
    sim = bus.transport.bus.motors[1]  # type: ignore[attr-defined]
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            await ws.receive_json(timeout=5)
            await ws.send_json({"op": "control", "req": 1, "action": "V", "id": 1, "speed": 30})
            await ws.send_json({"op": "estop", "req": 2})
            replies = {}
            while len(replies) < 2:
                m = await ws.receive_json(timeout=5)
                if m["t"] == "reply":
                    replies[m["req"]] = m
            assert not replies[1]["ok"] and "read-only" in replies[1]["error"]
            assert replies[2]["ok"]
            assert sim.state != AxisState.CLOSED_LOOP_CONTROL
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


def test_step_figures_of_a_first_order_response() -> None:
    tau = 0.1
    t = [k * 0.001 for k in range(2000)]
    y = [10 + 20 * (1 - math.exp(-tt / tau)) for tt in t]
    f = step_figures(t, y, 10, 30)
    assert f["rise_s"] == pytest.approx(tau * math.log(9), abs=0.002)
    assert f["overshoot_pct"] == 0
    assert f["settling_s"] == pytest.approx(tau * math.log(50), abs=0.002)
    assert f["steady_error"] == pytest.approx(0, abs=1e-3)


def test_step_figures_of_an_overshoot_and_an_offset() -> None:
    t = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]
    y = [0.0, 50.0, 120.0, 95.0, 99.0, 99.0, 99.0, 99.0, 99.0, 99.0]
    f = step_figures(t, y, 0, 100)
    assert f["overshoot_pct"] == pytest.approx(20)
    assert f["rise_s"] == pytest.approx(0.1)  # 10 % first reached at 0.1 s, 90 % at 0.2 s
    assert f["settling_s"] == pytest.approx(0.3)
    assert f["steady_error"] == pytest.approx(1.0)
    assert step_figures([], [], 0, 1)["rise_s"] is None


def test_urls() -> None:
    assert format_url("::1", 80, None) == "http://[::1]:80/"
    assert format_url("127.0.0.2", 5, "abc") == "http://127.0.0.2:5/?token=abc"
    import socket

    # a bind to every address is reached by the machine's name, not by 0.0.0.0
    name = socket.gethostname()
    assert format_url("0.0.0.0", 5, "abc") == f"http://{name}:5/?token=abc"
    assert format_url("::", 5, "abc") == f"http://{name}:5/?token=abc"


@pytest.mark.skipif(not os.path.exists("/proc/net/if_inet6"), reason="no IPv6")
@pytest.mark.parametrize("proc", [["--host", "::1", "--sim", "1"]], indirect=True)
def test_ipv6_loopback_also_needs_the_token(proc: subprocess.Popen[str]) -> None:
    assert proc.stdout is not None
    url = proc.stdout.readline().strip()
    assert url.startswith("http://[::1]:") and "?token=" in url
    assert _status(url.split("?")[0]) == 403
    assert _status(url) == 200


@pytest.mark.parametrize("attachment", ["adapter", "socketcand"])
async def test_through_the_simulators_adapter_pty_and_socketcand(attachment: str) -> None:
    from contextlib import ExitStack

    from drempower.sim import SimBus, SimRunner, attach_adapter_pty, attach_socketcand

    sim = SimBus([1, 2])
    with ExitStack() as stack:
        stack.enter_context(SimRunner(sim))
        if attachment == "adapter":
            conn = ["--serial", stack.enter_context(attach_adapter_pty(sim)).path]
        else:
            port = stack.enter_context(attach_socketcand(sim)).port
            conn = ["-i", "socketcand", "-c", "can0", "-o", "host=127.0.0.1", "-o", f"port={port}"]
        p = subprocess.Popen(
            [sys.executable, "-m", "drempower", "dash", "--port", "0", *conn],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            assert p.stdout is not None
            url = p.stdout.readline().strip()
            async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
                hello = await ws.receive_json(timeout=5)
                if attachment == "adapter":  # the serial link's baud rate is not taken for the CAN bit rate
                    assert " Bd" in hello["bus"] and hello["bitrate"] is None
                await ws.send_json({"op": "scan", "req": 1})
                samples = 0
                deadline = time.monotonic() + 15
                while abs(sim.motors[1].position - 30) > 0.05 and time.monotonic() < deadline:
                    await ws.send_json({"op": "hb"})
                    m = await ws.receive_json(timeout=5)
                    if m["t"] == "samples":
                        samples += len(m["s"])
                    if m["t"] == "reply" and m["req"] == 1:
                        assert [f["id"] for f in m["result"]] == [1, 2]
                        move = {"op": "control", "req": 2, "action": "Q", "id": 1, "angle": 30, "speed": 60}
                        await ws.send_json({**move, "param": 100})
                assert abs(sim.motors[1].position - 30) <= 0.05
                assert samples > 20
            # the browser went away: the motor it moved is idled
            deadline = time.monotonic() + 5
            while sim.motors[1].state != AxisState.IDLE and time.monotonic() < deadline:
                await asyncio.sleep(0.05)
            assert sim.motors[1].state == AxisState.IDLE
        finally:
            p.send_signal(signal.SIGTERM)
            p.communicate(timeout=10)


def test_a_port_in_use_is_one_line_and_exit_1() -> None:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        r = subprocess.run(
            [sys.executable, "-m", "drempower", "dash", "--port", str(port)],
            capture_output=True,
            text=True,
            timeout=30,
        )
    assert r.returncode == 1
    assert r.stdout == ""
    assert f"cannot serve on 127.0.0.1 port {port}" in r.stderr and "Traceback" not in r.stderr


async def test_two_browsers_see_the_same_state_and_either_controls() -> None:
    bus = open_bus("sim", motors=[1, 2], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    sim = bus.transport.bus.motors  # type: ignore[attr-defined]
    ws_url = url.replace("http:", "ws:") + "ws"

    async def until(ws: aiohttp.ClientWebSocketResponse, kind: str, req: int | None = None) -> dict[str, object]:
        while True:
            await ws.send_json({"op": "hb"})
            m: dict[str, object] = await ws.receive_json(timeout=5)
            if m["t"] == kind and (req is None or m.get("req") == req):
                return m

    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(ws_url) as a, s.ws_connect(ws_url) as b:
            await a.receive_json(timeout=5)
            await b.receive_json(timeout=5)
            await a.send_json({"op": "scan", "req": 1})
            cards_a, cards_b = await until(a, "cards"), await until(b, "cards")  # both see a's scan
            assert [c["id"] for c in cards_a["cards"]] == [c["id"] for c in cards_b["cards"]] == [1, 2]  # type: ignore[index, union-attr]
            await b.send_json(
                {"op": "control", "req": 5, "action": "Q", "id": 2, "angle": 20, "speed": 60, "param": 100}
            )
            assert (await until(b, "reply", 5))["ok"]
            deadline = time.monotonic() + 5
            while abs(sim[2].position - 20) > 0.05 and time.monotonic() < deadline:
                await a.send_json({"op": "hb"})
                await b.send_json({"op": "hb"})
                await asyncio.sleep(0.05)
            assert abs(sim[2].position - 20) <= 0.05
            # both receive the samples of the move
            sa, sb = await until(a, "samples"), await until(b, "samples")
            assert sa["s"] and sb["s"]
            await a.send_json({"op": "control", "req": 6, "action": "V", "id": 1, "speed": 10})
            assert (await until(a, "reply", 6))["ok"]
            await b.close()  # each page is a controller: what b set moving stops with it, a's goes on
            for _ in range(8):
                await a.send_json({"op": "hb"})
                await asyncio.sleep(0.1)
            assert hub.commanded == {1}
            assert sim[2].state == AxisState.IDLE
            assert sim[1].state == AxisState.CLOSED_LOOP_CONTROL and sim[1].speed > 5
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


async def test_bad_requests_are_refused_naming_the_field_and_nothing_is_sent() -> None:
    bus = open_bus("sim", motors=[1], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    sim = bus.transport.bus.motors[1]  # type: ignore[attr-defined]
    bad = [
        ({"action": "V", "id": 1.5, "speed": 10}, "id=1.5"),
        ({"action": "V", "id": 1, "speed": 10, "mode": 3}, "mode=3"),
        ({"action": "V", "id": 1, "speed": "fast"}, "speed='fast'"),
        ({"action": "Q", "id": 1, "angle": 10, "speed": 500, "param": 10}, "500"),
        ({"action": "spin", "id": 1}, "action='spin'"),
    ]
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            await ws.receive_json(timeout=5)
            for k, (args, _) in enumerate(bad):
                await ws.send_json({"op": "control", "req": k, **args})
            await ws.send_json({"op": "write", "req": 10, "id": 1, "name": "can.config.heartbeat_ms", "value": 2.5})
            replies = {}
            while len(replies) < len(bad) + 1:
                m = await ws.receive_json(timeout=5)
                if m["t"] == "reply":
                    replies[m["req"]] = m
            for k, (_, named) in enumerate(bad):
                assert not replies[k]["ok"] and named in replies[k]["error"], replies[k]
            assert not replies[10]["ok"] and "heartbeat_ms=2.5" in replies[10]["error"]
        assert sim.param("can.config.heartbeat_ms") == 0
        assert abs(sim.speed) < 0.01 and abs(sim.position) < 0.01
        assert hub.commanded == set()
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


async def test_writes_and_inputs_outside_their_domains_are_refused_before_sending() -> None:
    from drempower.errors import DomainError
    from drempower.protocol.parameters import parameter

    bus = open_bus("sim", motors=[1], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    sim = bus.transport.bus.motors[1]  # type: ignore[attr-defined]
    gain, baud = "axis0.controller.config.pos_gain", "can.config.baud_rate"
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            hello = await ws.receive_json(timeout=5)
            row = next(p for p in hello["params"] if p["name"] == gain)
            assert (row["min"], row["max"], row["hard"]) == (0, 1000, False) and row["domain"].startswith("0..1000")
            assert hello["bandwidth"] == [0, 300]

            async def ask(req: int, **msg: object) -> dict[str, object]:
                await ws.send_json({"req": req, **msg})
                while True:
                    m: dict[str, object] = await ws.receive_json(timeout=5)
                    if m["t"] == "reply" and m["req"] == req:
                        return m

            assert (await ask(1, op="scan"))["ok"]
            assert hub.limits[1]["speed"] == 300 and hub.limits[1]["torque"] == 12
            # a soft bound: refused with the DomainError's message, nothing written; passed with force
            r = await ask(2, op="write", id=1, name=gain, value=1500)
            assert not r["ok"] and r["error"] == str(DomainError(parameter(gain), 1500.0))
            assert sim.param(gain) == 40
            r = await ask(3, op="write", id=1, name=gain, value=1500, force=True)
            assert r["ok"] and r["result"]["value"] == 1500 and sim.param(gain) == 1500  # type: ignore[index]
            # a hard one: force does not pass it
            r = await ask(4, op="write", id=1, name=baud, value=123, force=True)
            assert not r["ok"] and r["error"] == str(DomainError(parameter(baud), 123)) and "(hard)" in str(r["error"])
            assert sim.param(baud) == 1000000
            # Control inputs: the speed and torque limits the motor holds, the T-mode bandwidth's domain
            bad = [
                ({"action": "V", "speed": 301}, "speed=301: outside -300..300 r/min, the speed limit motor_1 holds"),
                ({"action": "C", "torque": -12.5}, "torque=-12.5: outside -12..12 Nm, the torque limit motor_1"),
                ({"action": "T", "angle": 10, "param": 301}, "bandwidth=301 is out of range: allowed 0.01..300 (1/s)"),
                ({"action": "Q", "angle": 10, "speed": 310, "param": 10}, "speed=310: outside -300..300"),
            ]
            for k, (args, text) in enumerate(bad):
                r = await ask(10 + k, op="control", id=1, **args)
                assert not r["ok"] and text in str(r["error"]), r
            # a lower limit written from the page bounds the inputs from then on
            r = await ask(20, op="write", id=1, name="axis0.output_shaft.vel_limit", value=50)
            assert r["ok"] and r["result"]["limits"]["speed"] == 50  # type: ignore[index]
            r = await ask(21, op="control", id=1, action="V", speed=60)
            assert not r["ok"] and "speed=60: outside -50..50 r/min" in str(r["error"])
        assert abs(sim.speed) < 0.01 and abs(sim.position) < 0.01 and hub.commanded == set()
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


def _raw_status(port: int, host: str, path: str = "/", headers: str = "Connection: close\r\n") -> int:
    """The status of one raw HTTP/1.1 request to 127.0.0.1:``port`` carrying ``Host: host``."""
    import socket

    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(f"GET {path} HTTP/1.1\r\nHost: {host}\r\n{headers}\r\n".encode())
        return int(s.recv(64).split()[1])


def _upgrade(origin: str) -> str:
    return (
        "Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\n"
        f"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nOrigin: {origin}\r\n"
    )


async def test_without_a_token_only_a_loopback_host_is_served() -> None:
    bus = open_bus("sim", motors=[1], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    port = int(url.rsplit(":", 1)[1].strip("/"))
    evil = f"evil.example:{port}"
    try:
        # DNS rebinding: a page of evil.example whose name now resolves to 127.0.0.1
        assert await asyncio.to_thread(_raw_status, port, evil) == 403
        assert await asyncio.to_thread(_raw_status, port, evil, "/static/app.js") == 403
        assert await asyncio.to_thread(_raw_status, port, evil, "/ws", _upgrade(f"http://{evil}")) == 403
        assert await asyncio.to_thread(_raw_status, port, f"127.0.0.1:{port + 1}") == 403
        assert await asyncio.to_thread(_raw_status, port, "127.0.0.1") == 403
        for name in ("127.0.0.1", "localhost", "LocalHost", "[::1]"):
            assert await asyncio.to_thread(_raw_status, port, f"{name}:{port}") == 200, name
        # the Origin check stays: a loopback Host with a foreign Origin is refused
        own = f"localhost:{port}"
        assert await asyncio.to_thread(_raw_status, port, own, "/ws", _upgrade(f"http://{evil}")) == 403
        assert await asyncio.to_thread(_raw_status, port, own, "/ws", _upgrade(f"http://{own}")) == 101
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


async def test_estop_goes_out_at_once_while_step_runs_fill_the_workers() -> None:
    from drempower.protocol.ids import SysCmd
    from drempower.protocol.messages import SystemCommand

    bus = open_bus("sim", motors=[1, 2, 3], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    sim = bus.transport.bus  # type: ignore[attr-defined]
    golden = SystemCommand(0, SysCmd.ESTOP).encode()
    seen: list[float] = []

    def listen(f: object) -> None:
        if f == golden:
            seen.append(time.monotonic())

    sim.add_listener(listen, host_frames=True)
    try:
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            await ws.receive_json(timeout=5)
            for k in range(8):
                step = {"op": "step", "req": k, "id": 1 + k % 3, "mode": "velocity", "amplitude": 10, "duration": 4}
                await ws.send_json(step)
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline and not all(
                m.state == AxisState.CLOSED_LOOP_CONTROL for m in sim.motors.values()
            ):
                await ws.send_json({"op": "hb"})
                await asyncio.sleep(0.02)
            assert all(m.state == AxisState.CLOSED_LOOP_CONTROL for m in sim.motors.values())
            await asyncio.sleep(0.2)  # the step runs sleep in their worker threads
            t0 = time.monotonic()
            await ws.send_json({"op": "estop", "req": 99})
            while not seen and time.monotonic() - t0 < 5:
                await asyncio.sleep(0.002)
            assert seen, "no ESTOP frame reached the bus"
            assert seen[0] - t0 < 0.05, f"the ESTOP frame took {seen[0] - t0:.3f} s"
            while time.monotonic() - t0 < 1 and any(m.state != AxisState.IDLE for m in sim.motors.values()):
                await asyncio.sleep(0.01)
            assert all(m.state == AxisState.IDLE for m in sim.motors.values())
    finally:
        sim.remove_listener(listen)
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


async def test_sigterm_idles_a_running_step_at_once() -> None:
    from contextlib import ExitStack

    from drempower.sim import SimBus, SimRunner, attach_socketcand

    sim = SimBus([1])
    with ExitStack() as stack:
        stack.enter_context(SimRunner(sim))
        port = stack.enter_context(attach_socketcand(sim)).port
        conn = ["-i", "socketcand", "-c", "can0", "-o", "host=127.0.0.1", "-o", f"port={port}"]
        p = subprocess.Popen(
            [sys.executable, "-m", "drempower", "dash", "--port", "0", *conn],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            assert p.stdout is not None
            url = p.stdout.readline().strip()
            motor = sim.motors[1]
            async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
                await ws.receive_json(timeout=5)
                step = {"op": "step", "req": 1, "id": 1, "mode": "velocity", "amplitude": 20, "duration": 5}
                await ws.send_json(step)
                deadline = time.monotonic() + 5
                while motor.speed < 5 and time.monotonic() < deadline:  # the step is under way
                    await ws.send_json({"op": "hb"})
                    await asyncio.sleep(0.02)
                assert motor.state == AxisState.CLOSED_LOOP_CONTROL
                t0 = time.monotonic()
                p.send_signal(signal.SIGTERM)
                while motor.state != AxisState.IDLE and time.monotonic() - t0 < 5:
                    await asyncio.sleep(0.005)
                took = time.monotonic() - t0
                assert motor.state == AxisState.IDLE and took < 0.3, f"idled after {took:.3f} s"
            assert p.wait(5) == 128 + signal.SIGTERM  # the step run ended early too
            assert time.monotonic() - t0 < 3
        finally:
            if p.poll() is None:
                p.kill()
            _, err = p.communicate(timeout=10)
    assert "SIGTERM: stopping" in err and "idled motor_1" in err


async def test_a_closed_browser_idles_its_motors_at_once_while_step_runs_fill_the_workers() -> None:
    bus = open_bus("sim", motors=[1, 2, 3], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    sim = bus.transport.bus  # type: ignore[attr-defined]
    try:
        async with aiohttp.ClientSession() as s:
            ws = await s.ws_connect(url.replace("http:", "ws:") + "ws")
            await ws.receive_json(timeout=5)
            for k in range(8):
                step = {"op": "step", "req": k, "id": 1 + k % 3, "mode": "velocity", "amplitude": 10, "duration": 4}
                await ws.send_json(step)
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline and not all(
                m.state == AxisState.CLOSED_LOOP_CONTROL for m in sim.motors.values()
            ):
                await ws.send_json({"op": "hb"})
                await asyncio.sleep(0.02)
            assert all(m.state == AxisState.CLOSED_LOOP_CONTROL for m in sim.motors.values())
            t0 = time.monotonic()
            await ws.close()
            while time.monotonic() - t0 < 5 and any(m.state != AxisState.IDLE for m in sim.motors.values()):
                await asyncio.sleep(0.005)
            took = time.monotonic() - t0
            assert all(m.state == AxisState.IDLE for m in sim.motors.values()) and took < 0.3, f"{took:.3f} s"
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()
