"""The dashboard under attack: a browser that stops reading, a stderr nobody reads, a polling flood,
SIGKILL, deeply nested messages, long paths."""

from __future__ import annotations

import asyncio
import base64
import fcntl
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from typing import Any

import pytest

aiohttp = pytest.importorskip("aiohttp")

from drempower import open_bus  # noqa: E402
from drempower.protocol.enums import AxisState  # noqa: E402
from drempower.sim import SimBus, SimRunner, attach_socketcand  # noqa: E402

from .conftest import serve_in_thread  # noqa: E402

_F_SETPIPE_SZ = 1031


class RawClient:
    """A WebSocket client on a bare socket that sends and never reads (its receive buffer kept small)."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket()
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        self.sock.connect(("127.0.0.1", port))
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(
            f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: Upgrade\r\nUpgrade: websocket\r\n"
            f"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: {key}\r\n\r\n".encode()
        )
        head = b""
        while b"\r\n\r\n" not in head:
            head += self.sock.recv(1)
        assert head.split()[1] == b"101", head

    def send(self, msg: dict[str, Any]) -> None:
        data = json.dumps(msg).encode()
        mask = os.urandom(4)
        n = len(data)
        if n < 126:
            head = bytes([0x81, 0x80 | n])
        elif n < 1 << 16:
            head = bytes([0x81, 0x80 | 126]) + n.to_bytes(2, "big")
        else:
            head = bytes([0x81, 0x80 | 127]) + n.to_bytes(8, "big")
        self.sock.sendall(head + mask + bytes(b ^ mask[k % 4] for k, b in enumerate(data)))

    def close(self) -> None:
        self.sock.close()


@dataclass
class Running:
    url: str
    hub: Any
    dash: Any
    sim: SimBus


@contextmanager
def dashboard(ids: list[int], **kwargs: Any) -> Iterator[Running]:
    """A dashboard over simulated motors ``ids``, served from a thread."""
    bus = open_bus("sim", motors=ids, stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus, **kwargs)
    try:
        yield Running(url, hub, dash, bus.transport.bus)  # type: ignore[attr-defined]
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


def _port(url: str) -> int:
    return int(url.rsplit(":", 1)[1].strip("/"))


async def test_a_client_that_stops_reading_holds_up_neither_the_heartbeat_watch_nor_other_browsers() -> None:
    with dashboard([1, 2, 3]) as d:
        url, sim = d.url, d.sim
        stuck = RawClient(_port(url))
        try:
            stuck.send({"op": "control", "req": 1, "action": "V", "id": 1, "speed": 20})
            for k in range(12):  # replies of about 0.4 MB each, nobody reading them
                stuck.send({"op": "x" * 200_000, "req": 10 + k})
            deadline = time.monotonic() + 5
            while sim.motors[1].speed < 10 and time.monotonic() < deadline:
                stuck.send({"op": "hb"})
                await asyncio.sleep(0.05)
            assert sim.motors[1].speed > 10
            async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
                await ws.receive_json(timeout=5)
                # the stuck client's heartbeats stop: its motor idles within 0.5 s (+ a tick)
                t0 = time.monotonic()
                while sim.motors[1].state != AxisState.IDLE and time.monotonic() - t0 < 3:
                    await asyncio.sleep(0.02)
                took = time.monotonic() - t0
                assert sim.motors[1].state == AxisState.IDLE and took < 1.0, f"idled after {took:.2f} s"
                # the other browser goes on receiving samples every second
                per_second = []
                for _ in range(3):
                    got, end = 0, time.monotonic() + 1
                    while time.monotonic() < end:
                        await ws.send_json({"op": "hb"})
                        try:
                            m = await ws.receive_json(timeout=max(0.01, end - time.monotonic()))
                        except asyncio.TimeoutError:
                            break
                        if m["t"] == "samples":
                            got += len(m["s"])
                    per_second.append(got)
                assert min(per_second) > 50, per_second  # 3 motors polled at 50/s: about 150/s
        finally:
            stuck.close()


async def test_a_client_that_never_reads_is_dropped_and_its_motor_idled() -> None:
    with dashboard([1]) as d:
        url, dash, sim = d.url, d.dash, d.sim
        stuck = RawClient(_port(url))
        try:
            stuck.send({"op": "control", "req": 1, "action": "V", "id": 1, "speed": 20})
            deadline = time.monotonic() + 5
            while sim.motors[1].speed < 10 and time.monotonic() < deadline:
                stuck.send({"op": "hb"})
                await asyncio.sleep(0.05)
            for k in range(40):  # about 16 MB of replies
                try:
                    stuck.send({"op": "x" * 200_000, "req": 10 + k})
                    stuck.send({"op": "hb"})
                except OSError:  # dropped meanwhile
                    break
            deadline = time.monotonic() + 5
            while dash.clients and time.monotonic() < deadline:
                await asyncio.sleep(0.02)
            assert not dash.clients  # dropped: it was not reading
            deadline = time.monotonic() + 5  # its motor is idled on the dashboard's stop thread, after the drop
            while sim.motors[1].state != AxisState.IDLE and time.monotonic() < deadline:
                await asyncio.sleep(0.02)
            assert sim.motors[1].state == AxisState.IDLE
        finally:
            stuck.close()


async def test_the_dashboard_stops_at_once_with_a_client_that_never_reads() -> None:
    bus = open_bus("sim", motors=[1], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    stuck = RawClient(_port(url))
    try:
        for k in range(12):  # about 5 MB of replies waiting: under the limit that drops the client
            stuck.send({"op": "x" * 200_000, "req": k})
        await asyncio.sleep(0.5)
        t0 = time.monotonic()
        loop.call_soon_threadsafe(dash.stopping.set)
        await asyncio.to_thread(thread.join, 10)
        assert not thread.is_alive() and time.monotonic() - t0 < 3
    finally:
        stuck.close()
        if thread.is_alive():
            loop.call_soon_threadsafe(dash.stopping.set)
            thread.join(10)
        hub.close()
        bus.close()


async def test_the_watchdog_is_kept_alive_while_the_motors_send_heartbeats() -> None:
    with dashboard([1], keep_running=True) as d:  # no browser needed to keep the motor going
        hub, sim = d.hub, d.sim
        deadline = time.monotonic() + 10
        while not hub.motors and time.monotonic() < deadline:  # the first scan
            await asyncio.sleep(0.05)
        hub.watchdog_ms = 150
        await asyncio.to_thread(hub.arm_watchdog, [1])
        assert sim.motors[1].param("can.config.timeout_ms") == 150
        await asyncio.to_thread(hub.do_rate, "test", 100)  # heartbeats: the dashboard polls no more
        await asyncio.to_thread(hub.do_control, "test", {"action": "V", "id": 1, "speed": 20})
        await asyncio.sleep(1.0)
        assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL and sim.motors[1].speed > 10
        await asyncio.to_thread(hub.do_rate, "test", 0)
        await asyncio.to_thread(hub.idle_commanded, "test")
        await asyncio.to_thread(hub.restore_watchdog)
        assert sim.motors[1].param("can.config.timeout_ms") == 0


@pytest.fixture
def external_sim() -> Iterator[tuple[SimBus, list[str]]]:
    sim = SimBus([1])
    with ExitStack() as stack:
        stack.enter_context(SimRunner(sim))
        port = stack.enter_context(attach_socketcand(sim)).port
        yield sim, ["-i", "socketcand", "-c", "can0", "-o", "host=127.0.0.1", "-o", f"port={port}"]


async def _drive(url: str, sim: SimBus, speed: float = 20) -> None:
    """Wait for the dashboard's first scan, command ``speed`` on motor 1 and wait until it turns."""
    async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
        await ws.receive_json(timeout=5)
        await ws.send_json({"op": "scan", "req": 1})
        while True:
            m = await ws.receive_json(timeout=5)
            if m["t"] == "reply" and m["req"] == 1:
                break
        for k, action in enumerate(("clear_errors", "enable")):  # as a user does after a stop
            await ws.send_json({"op": "control", "req": 10 + k, "action": action, "id": 1})
            while (m := await ws.receive_json(timeout=5))["t"] != "reply":
                pass
            assert m["ok"], m["error"]
        await ws.send_json({"op": "control", "req": 2, "action": "V", "id": 1, "speed": speed})
        while (m := await ws.receive_json(timeout=5))["t"] != "reply":
            pass
        assert m["ok"], m["error"]
        deadline = time.monotonic() + 5
        while sim.motors[1].speed < speed / 2 and time.monotonic() < deadline:
            await ws.send_json({"op": "hb"})
            await asyncio.sleep(0.02)
        assert sim.motors[1].speed >= speed / 2


@pytest.mark.parametrize("stderr", ["full", "closed"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
async def test_signals_stop_the_dashboard_when_its_stderr_is_full_or_closed(
    external_sim: tuple[SimBus, list[str]], stderr: str, sig: int
) -> None:
    sim, conn = external_sim
    r, w = os.pipe()
    fcntl.fcntl(w, _F_SETPIPE_SZ, 4096)  # the smallest pipe: a few log lines fill it
    args = [sys.executable, "-m", "drempower", "dash", "--port", "0", "--keep-running", *conn]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=w, text=True)
    os.close(w)
    if stderr == "closed":
        os.close(r)
    try:
        assert p.stdout is not None
        url = p.stdout.readline().strip()
        await _drive(url, sim)
        if stderr == "full":  # each refused request is a log line: fill the pipe
            for _ in range(20):
                await asyncio.to_thread(_raw_status, _port(url), "x" * 400)
        assert sim.motors[1].speed > 10  # --keep-running: still turning with no browser
        t0 = time.monotonic()
        p.send_signal(sig)
        while sim.motors[1].state != AxisState.IDLE and time.monotonic() - t0 < 5:
            await asyncio.sleep(0.01)
        assert sim.motors[1].state == AxisState.IDLE, "the motor kept turning"
        assert await asyncio.to_thread(p.wait, 10) == 128 + sig
    finally:
        if p.poll() is None:
            p.kill()
            p.wait(5)
        if stderr == "full":
            os.close(r)


def _raw_status(port: int, host: str, path: str = "/") -> int:
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(f"GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n".encode())
        return int(s.recv(64).split()[1])


async def test_sigkill_with_watchdog_stops_the_motor_and_a_clean_exit_restores_it(
    external_sim: tuple[SimBus, list[str]],
) -> None:
    sim, conn = external_sim
    timeout = "can.config.timeout_ms"
    assert sim.motors[1].param(timeout) == 0
    args = [sys.executable, "-m", "drempower", "dash", "--port", "0", "--keep-running", "--watchdog", "200"]
    for how in ("sigterm", "sigkill"):
        p = subprocess.Popen([*args, *conn], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        try:
            assert p.stdout is not None
            url = p.stdout.readline().strip()
            await _drive(url, sim)
            assert sim.motors[1].param(timeout) == 200  # armed when the scan found it
            await asyncio.sleep(1.0)  # no browser, --keep-running: kept alive by the dashboard's polling
            assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL and sim.motors[1].speed > 10
            if how == "sigterm":
                p.send_signal(signal.SIGTERM)
                assert await asyncio.to_thread(p.wait, 10) == 128 + signal.SIGTERM
                assert sim.motors[1].param(timeout) == 0  # put back
                assert sim.motors[1].state == AxisState.IDLE
            else:
                t0 = time.monotonic()
                p.kill()
                while sim.motors[1].state != AxisState.IDLE and time.monotonic() - t0 < 3:
                    await asyncio.sleep(0.01)
                took = time.monotonic() - t0
                assert sim.motors[1].state == AxisState.IDLE and took < 0.5, f"idled after {took:.2f} s"
        finally:
            if p.poll() is None:
                p.kill()
            p.wait(5)


async def test_parameter_plots_stay_within_the_bus_load_budget() -> None:
    from drempower.protocol.parameters import parameters

    with dashboard([1]) as d:
        url, hub, sim = d.url, d.hub, d.sim
        hub.read_only = True  # watching is what a read-only browser may do
        frames: list[float] = []
        sim.add_listener(lambda f: frames.append(time.monotonic()), host_frames=True)
        names = [p.name for p in parameters()]
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            await ws.receive_json(timeout=5)
            for k, name in enumerate(names):
                await ws.send_json({"op": "watch", "req": k, "id": 1, "name": name, "hz": 50})
            replies: dict[int, Any] = {}
            while len(replies) < len(names):
                m = await ws.receive_json(timeout=5)
                if m["t"] == "reply":
                    replies[m["req"]] = m
            refused = [m for m in replies.values() if not m["ok"]]
            await asyncio.sleep(0.5)
            t0 = time.monotonic()
            await asyncio.sleep(2.0)
            n = sum(1 for t in frames if t0 <= t < t0 + 2.0)
        budget_frames = 0.30 * 1_000_000 / 130  # 30 % of 1 Mbit/s in frames of 130 bits: requests and replies
        print(
            f"polling with {len(names)} parameter plots asked at 50/s: {n / 2:.0f} frames/s, budget {budget_frames:.0f}"
        )
        assert n / 2 <= budget_frames * 1.1, f"{n / 2:.0f} frames/s over a budget of {budget_frames:.0f}"
        # the plots beyond the budget were refused, saying why
        assert refused and "budget of 30 % of the bus" in refused[0]["error"], refused[:1]


async def test_deep_json_is_refused_and_the_connection_goes_on() -> None:
    with dashboard([1]) as d:
        url = d.url
        async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
            await ws.receive_json(timeout=5)
            for depth in (100_000, 40):
                await ws.send_str('{"op": "control", "req": 1, "x": ' + "[" * depth + "]" * depth + "}")
                while (m := await ws.receive_json(timeout=5))["t"] != "reply":
                    pass
                assert not m["ok"] and "nested deeper than 32 levels" in m["error"], m
            await ws.send_json({"op": "watch", "req": 2, "id": 1, "name": "vbus_voltage", "hz": 0})
            while (m := await ws.receive_json(timeout=5))["t"] != "reply":
                pass
            assert m["req"] == 2 and m["ok"]


async def test_a_long_static_path_is_not_found() -> None:
    with dashboard([1]) as d:
        url = d.url
        async with aiohttp.ClientSession() as s:
            for n in (300, 5000):
                async with s.get(url + "static/" + "a" * n + ".js") as r:
                    assert r.status == 404
            async with s.get(url + "static/app.js") as r:
                assert r.status == 200
