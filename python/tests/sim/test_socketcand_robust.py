"""The simulator's socketcand server against bad input and idle connections: it answers errors in the
socketcand form and keeps serving."""

from __future__ import annotations

import socket
import time
from collections.abc import Iterator

import pytest

from drempower.sim import SimBus, SimRunner
from drempower.sim.socketcand import SocketcandServer

FAST_READ_1 = "< send 03e 8 0 0 0 0 0 0 0 0 >"


@pytest.fixture
def bus() -> Iterator[SimBus]:
    b = SimBus([1, 2])
    with SimRunner(b):
        yield b


def _connect(port: int) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    return s


def _read_until(s: socket.socket, token: bytes, limit: float = 5.0) -> bytes:
    data = b""
    deadline = time.monotonic() + limit
    while token not in data and time.monotonic() < deadline:
        try:
            chunk = s.recv(4096)
        except TimeoutError:
            continue
        if not chunk:
            break
        data += chunk
    return data


def _raw(port: int) -> socket.socket:
    s = _connect(port)
    assert b"< hi >" in _read_until(s, b"< hi >")
    s.sendall(b"< open can0 >")
    assert b"< ok >" in _read_until(s, b"< ok >")
    s.sendall(b"< rawmode >")
    assert b"< ok >" in _read_until(s, b"< ok >")
    return s


def _answers(s: socket.socket) -> bool:
    s.sendall(FAST_READ_1.encode())
    return b"< frame 023 " in _read_until(s, b"< frame 023 ") or False


def test_an_id_above_0x7ff_gets_an_error_and_the_server_carries_on(bus: SimBus) -> None:
    with SocketcandServer(bus) as server, _raw(server.port) as s:
        s.sendall(b"< send 800 1 01 >")
        assert b"< error bad send command" in _read_until(s, b"< error")
        s.sendall(b"< send 1FFFFFFFF 1 01 >< send 039 8 00 00 c0 7f e8 03 00 01 02 >< send 03x 1 01 >")
        assert _read_until(s, b">", limit=1.0).count(b"< error") >= 1
        assert _answers(s)
        assert bus.stats.frames >= 2


def test_a_nan_frame_leaves_every_motor_answering(bus: SimBus) -> None:
    with SocketcandServer(bus) as server, _raw(server.port) as s:
        s.sendall(b"< send 039 8 00 00 c0 7f e8 03 00 00 >")  # T to NaN
        time.sleep(0.05)
        assert _answers(s)
        s.sendall(b"< send 05e 8 0 0 0 0 0 0 0 0 >")
        assert b"< frame 043 " in _read_until(s, b"< frame 043 ")
    assert bus.ignored == 1


@pytest.mark.parametrize("handshake", [False, True])
def test_16_idle_connections_do_not_lock_a_new_client_out(bus: SimBus, handshake: bool) -> None:
    """Chosen: at most 16 connections; while full, a new one takes the place of the one silent longest
    (silent 1 s at least); a connection that never reaches raw mode is closed after 5 s."""
    with SocketcandServer(bus) as server:
        idle = [_raw(server.port) if handshake else _connect(server.port) for _ in range(16)]
        try:
            time.sleep(1.1)
            t0 = time.monotonic()
            with _raw(server.port) as s:
                assert _answers(s)
            assert time.monotonic() - t0 < 3
            assert server.evicted == 1 and server.refused == 0
            dropped = _read_until(idle[0], b"idle while the server is full")
            assert b"< error closed: idle while the server is full >" in dropped
        finally:
            for c in idle:
                c.close()


def test_a_connection_without_rawmode_is_closed_after_the_handshake_time(bus: SimBus) -> None:
    with SocketcandServer(bus, handshake_timeout=0.5) as server, _connect(server.port) as s:
        t0 = time.monotonic()
        got = _read_until(s, b"handshake time >")
        assert b"< error no rawmode within the handshake time >" in got
        assert s.recv(100) == b""  # closed
        assert 0.4 < time.monotonic() - t0 < 3


def test_active_clients_are_not_evicted(bus: SimBus) -> None:
    with SocketcandServer(bus, max_clients=2) as server, _raw(server.port) as a, _raw(server.port) as b:
        a.sendall(b"< echo >")
        b.sendall(b"< echo >")
        new = _connect(server.port)
        try:
            assert b"< error too many connections (2) >" in _read_until(new, b">")
            assert server.refused == 1 and server.evicted == 0
        finally:
            new.close()
