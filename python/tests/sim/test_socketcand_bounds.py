"""What one local socketcand client can cost the simulator: bounded input, output and connections."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import pytest

from drempower.protocol import FastRead
from drempower.sim import SimBus, SimRunner
from drempower.sim.socketcand import MAX_COMMAND, CommandParser, SocketcandServer


@pytest.fixture
def bus() -> Iterator[SimBus]:
    b = SimBus([1])
    with SimRunner(b):
        yield b


def _connect(port: int, rcvbuf: int | None = None) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if rcvbuf is not None:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    s.connect(("127.0.0.1", port))
    s.settimeout(5)
    return s


def _read_until(s: socket.socket, token: bytes, limit: float = 5.0) -> bytes:
    data = b""
    deadline = time.monotonic() + limit
    while token not in data and time.monotonic() < deadline:
        chunk = s.recv(4096)
        if not chunk:
            break
        data += chunk
    return data


def test_parser_is_one_pass_and_bounds_a_command() -> None:
    p = CommandParser()
    assert p.feed(b"junk < send 123 1 AB > <ech") == ["send 123 1 AB"]
    assert p.feed(b"o >") == ["echo"]
    assert p.feed(b"<" + b"x" * (MAX_COMMAND + 1)) == []
    assert p.feed(b"y" * 10_000_000) == []
    assert p.feed(b"> < echo >") == [None, "echo"]
    assert len(p._body or b"") == 0  # nothing of the long command was kept


def test_an_unfinished_command_of_30_mb_costs_little(bus: SimBus) -> None:
    with SocketcandServer(bus) as server, _connect(server.port) as s:
        assert _read_until(s, b"< hi >").endswith(b"< hi >")
        t0, cpu0 = time.monotonic(), time.process_time()
        s.sendall(b"<")
        block = b"a" * (1 << 20)
        for _ in range(30):
            s.sendall(block)
        s.sendall(b"> < echo >")
        got = _read_until(s, b"< echo >", limit=30)
        wall, cpu = time.monotonic() - t0, time.process_time() - cpu0
    assert got == f"< error command longer than {MAX_COMMAND} bytes >< echo >".encode()
    assert wall < 10 and cpu < 5, (wall, cpu)


def test_a_client_that_never_reads_is_disconnected_and_counted(bus: SimBus) -> None:
    with SocketcandServer(bus, max_queue=50) as server, _connect(server.port, rcvbuf=4096) as lazy:
        lazy.sendall(b"< open can0 >< rawmode >")
        deadline = time.monotonic() + 5
        while not bus._listeners and time.monotonic() < deadline:
            time.sleep(0.01)
        frame = FastRead(9).encode()  # every host frame is copied to the client
        for _ in range(20_000):
            bus.send(frame)
            if server.disconnected_slow:
                break
        deadline = time.monotonic() + 5
        while server._clients and time.monotonic() < deadline:
            time.sleep(0.01)
        assert server.disconnected_slow == 1 and not server._clients
        with _connect(server.port) as other:  # the server still serves
            assert _read_until(other, b"< hi >").endswith(b"< hi >")


def test_connections_are_capped(bus: SimBus) -> None:
    before = threading.active_count()
    with SocketcandServer(bus, max_clients=4, evict_idle=60.0) as server:  # nobody silent long enough to give way
        conns = [_connect(server.port) for _ in range(10)]
        try:
            replies = [_read_until(c, b">") for c in conns]
            served = [r for r in replies if r == b"< hi >"]
            refused = [r for r in replies if r == b"< error too many connections (4) >"]
            assert len(served) == 4 and len(refused) == 6 and server.refused == 6
            assert threading.active_count() - before <= 1 + 2 * 4
        finally:
            for c in conns:
                c.close()


def test_a_repeated_rawmode_delivers_each_frame_once(bus: SimBus) -> None:
    with SocketcandServer(bus, port=0) as server:
        s = _connect(server.port)
        assert b"< hi >" in _read_until(s, b"< hi >")
        s.sendall(f"< open {server.channel} >".encode())
        _read_until(s, b"< ok >")
        for _ in range(2):
            s.sendall(b"< rawmode >")
            assert b"< ok >" in _read_until(s, b"< ok >")
        read = FastRead(1).encode()  # a fast read of motor 1: one state frame answers it
        s.sendall(f"< send {read[0]:03x} {len(read[1])} {' '.join(f'{b:x}' for b in read[1])} >".encode())
        time.sleep(0.3)
        s.settimeout(0.2)
        data = b""
        try:
            while chunk := s.recv(4096):
                data += chunk
        except OSError:
            pass
        s.close()
    frames = [f.split()[1] for f in data.decode().split("<") if f.strip().startswith("frame")]
    states = [f for f in frames if int(f, 16) >> 5 == 1 and int(f, 16) & 1]
    assert len(states) == 1, data
