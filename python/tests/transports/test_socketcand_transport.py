"""drempower's socketcand client: its handshake against scripted servers, its options, a full socket,
the server's errors, a close that wakes a waiting receive; on 127.0.0.1 only."""

from __future__ import annotations

import asyncio
import json
import select
import socket
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest

from drempower import BusClosedError, open_bus, open_bus_async
from drempower.protocol import FastRead
from drempower.protocol.ids import Frame
from drempower.sim import SimBus, attach_socketcand
from drempower.transports import TransportError, open_transport
from drempower.transports.errors import TransportOptionError
from drempower.transports.socketcand import SocketcandTransport


@contextmanager
def scripted(answers: Callable[[bytes], bytes | None], greeting: bytes = b"< hi >") -> Iterator[int]:
    """A one-connection server on 127.0.0.1 that greets, then answers each command it reads with
    ``answers(command)`` (None: nothing); yields its port. Its receive buffer is small (4 KiB), so a
    client's sends fill it soon when it stops reading."""
    listener = socket.socket()
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    listener.bind(("127.0.0.1", 0))
    listener.listen(1)
    conns: list[socket.socket] = []

    def serve() -> None:
        try:
            conn, _ = listener.accept()
        except OSError:
            return
        conns.append(conn)
        conn.sendall(greeting)
        buf = b""
        while True:
            try:
                chunk = conn.recv(4096)
            except OSError:
                return
            if not chunk:
                return
            buf += chunk
            while b">" in buf:
                command, _, buf = buf.partition(b">")
                reply = answers(command + b">")
                if reply:
                    conn.sendall(reply)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield listener.getsockname()[1]
    finally:
        listener.close()
        for c in conns:
            c.close()
        thread.join(2)


def handshake(command: bytes) -> bytes | None:
    return b"< ok >" if command in (b"< open can0 >", b"< rawmode >") else None


def test_a_server_that_refuses_the_channel_is_told_in_its_words() -> None:
    server = attach_socketcand(SimBus(ids=[1]))
    try:
        with pytest.raises(TransportError) as info:
            open_transport("socketcand", "can1", host=server.host, port=server.port)
        text = str(info.value)
        assert f"socketcand can1 at 127.0.0.1:{server.port}" in text
        assert "refused to open bus 'can1': could not open bus" in text
    finally:
        server.close()


def test_a_server_that_is_no_socketcand_server_is_named_within_the_connect_timeout() -> None:
    with scripted(lambda c: None, greeting=b"SSH-2.0-OpenSSH_9.2\r\n") as port:
        t0 = time.monotonic()
        with pytest.raises(TransportError) as info:
            SocketcandTransport("127.0.0.1", port, connect_timeout=0.3)
        assert time.monotonic() - t0 < 2
    assert "did not greet with '< hi >' in 0.3 s (got b'SSH-2.0-OpenSSH_9.2\\r\\n')" in str(info.value)


def test_a_server_that_answers_rawmode_oddly_is_named() -> None:
    def answers(c: bytes) -> bytes | None:
        return b"< ok >" if c == b"< open can0 >" else b"< what >"

    with scripted(answers) as port, pytest.raises(TransportError) as info:
        SocketcandTransport("127.0.0.1", port, connect_timeout=1.0)
    assert "did not enter raw mode (it said b'< what >'); is it a socketcand server?" in str(info.value)


def test_frames_in_the_same_packet_as_the_last_ok_are_kept_and_errors_are_counted() -> None:
    def answers(c: bytes) -> bytes | None:
        if c == b"< rawmode >":
            return b"< ok >< frame 023 1.000000 0102 >< error no such thing >"
        return handshake(c)

    with scripted(answers) as port:
        t = SocketcandTransport("127.0.0.1", port, connect_timeout=1.0)
        try:
            fd = t.fileno()
            assert fd is not None and select.select([fd], [], [], 1.0)[0]  # left in the socket: it says so
            assert t.read_nowait() == [Frame(0x023, b"\x01\x02", False)]
            deadline = time.monotonic() + 2
            while t.decoder.errors == 0 and time.monotonic() < deadline:
                t.recv(0.05)
            assert (t.decoder.errors, t.decoder.last_error) == (1, "no such thing")
        finally:
            t.close()


def test_commands_reach_the_server_as_golden_lines() -> None:
    heard: list[bytes] = []

    def answers(c: bytes) -> bytes | None:
        heard.append(c)
        return handshake(c)

    with scripted(answers) as port:
        t = SocketcandTransport("127.0.0.1", port)
        try:
            t.send(FastRead(3).encode())
            t.send(Frame(0x1ABCDEF0, b"\x00\xff", True))
            deadline = time.monotonic() + 2
            while len(heard) < 4 and time.monotonic() < deadline:
                time.sleep(0.01)
        finally:
            t.close()
    assert heard == [
        b"< open can0 >",
        b"< rawmode >",
        b"< send 07E 8 00 00 00 00 00 00 00 00 >",
        b"< send 1ABCDEF0 2 00 FF >",
    ]


def test_a_server_that_stops_reading_fails_a_send_within_its_timeout_and_never_hangs() -> None:
    release = threading.Event()

    def answers(c: bytes) -> bytes | None:
        if c.startswith(b"< send"):
            release.wait(10)  # the server stops reading at the first frame
        return handshake(c)

    with scripted(answers) as port:
        t = SocketcandTransport("127.0.0.1", port, send_timeout=0.2)
        t._sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)
        try:
            t0 = time.monotonic()
            with pytest.raises(TransportError) as info:
                for _ in range(2_000_000):
                    t.send(FastRead(1).encode())
            assert time.monotonic() - t0 < 30
            assert "not sent" in str(info.value) or "cut off" in str(info.value)
            with pytest.raises(TransportError, match=r"not sent|close and reopen"):
                t.send(FastRead(1).encode())
        finally:
            release.set()
            t0 = time.monotonic()
            t.close()
            assert time.monotonic() - t0 < 2


def test_close_wakes_a_waiting_receive_at_once() -> None:
    server = attach_socketcand(SimBus(ids=[1]))
    t = open_transport("socketcand", "can0", host=server.host, port=server.port)
    got: list[object] = []
    waiter = threading.Thread(target=lambda: got.append(t.recv(30.0)))
    try:
        waiter.start()
        time.sleep(0.1)
        t0 = time.monotonic()
        t.close()
        waiter.join(2)
        assert not waiter.is_alive() and got == [None] and time.monotonic() - t0 < 1
        with pytest.raises(TransportError, match="closed, frame not sent"):
            t.send(FastRead(1).encode())
    finally:
        server.close()


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"can_filters": []}, "unknown option(s) can_filters; it takes host, port, connect_timeout, send_timeout"),
        ({"port": None}, "give host= and port= of the server"),
        ({"port": "29x"}, "port: '29x' is not a whole number"),
        ({"port": 70000}, "port=70000 must be 1..65535"),
        ({"send_timeout": 0}, "send_timeout=0 must be seconds in (0, 3600]"),
        ({"connect_timeout": float("inf")}, "connect_timeout=inf must be seconds in (0, 3600]"),
    ],
)
def test_bad_options_are_refused_before_connecting(options: dict[str, object], words: str) -> None:
    kwargs = {"host": "127.0.0.1", "port": 1, **options}
    if kwargs["port"] is None:
        del kwargs["port"]
    with pytest.raises(TransportOptionError) as info:
        open_transport("socketcand", "can0", **kwargs)
    assert words in str(info.value)


def test_python_cans_configuration_gives_the_channel_and_a_bad_one_is_refused_in_its_words(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    server = attach_socketcand(SimBus(ids=[1]), channel="vcan3")
    try:
        monkeypatch.setenv("CAN_CHANNEL", "vcan3")
        t = open_transport("socketcand", host=server.host, port=server.port)
        assert t.description == f"socketcand vcan3 at 127.0.0.1:{server.port}"
        t.close()
    finally:
        server.close()
    monkeypatch.setenv("CAN_CONFIG", json.dumps({"host": "127.0.0.1", "port": 99999}))
    with pytest.raises(TransportOptionError) as info:
        open_transport("socketcand", "can0")
    assert "python-can's configuration is invalid: Port config must be inside 0-65535 range!" in str(info.value)
    monkeypatch.delenv("CAN_CHANNEL")
    server = attach_socketcand(SimBus(ids=[1]))
    try:  # what the caller gives takes precedence over the configuration, as in python-can
        t = open_transport("socketcand", host=server.host, port=server.port)
        assert t.description == f"socketcand can0 at 127.0.0.1:{server.port}"
        t.close()
    finally:
        server.close()


def test_the_server_may_come_from_python_cans_configuration_and_bitrate_times_the_bus(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    server = attach_socketcand(SimBus(ids=[1]))
    monkeypatch.setenv("CAN_CONFIG", json.dumps({"host": server.host, "port": server.port}))
    try:
        with open_bus("socketcand", "can0", 1_000_000, timeout=1.0, stop_on_close=False) as bus:
            assert bus.transport.wire_bitrate == 1_000_000
            assert bus.transport.description == f"socketcand can0 at 127.0.0.1:{server.port}"
            assert bus.motor(1).get_state().node == 1
    finally:
        server.close()


@pytest.mark.parametrize(
    ("interface", "options"),
    [
        ("socketcand", {}),
        ("python-can:socketcand", {}),
        ("python-can:socketcand", {"can_filters": [{"can_id": 0, "can_mask": 0}]}),  # read in a thread
    ],
)
def test_a_server_that_goes_away_fails_the_bus_once_and_costs_no_cpu(
    interface: str, options: dict[str, object], caplog: pytest.LogCaptureFixture
) -> None:
    """The socket of a closed connection stays readable: the receive thread stops at the first failure
    (it used to read it again at once, logging each time, until the bus was closed; with python-can's
    filters, python-can's own receive never noticed and the bus timed out instead)."""
    server = attach_socketcand(SimBus(ids=[1]))
    with open_bus(
        interface, "can0", host=server.host, port=server.port, timeout=0.5, stop_on_close=False, **options
    ) as bus:
        assert bus.motor(1).get_state().node == 1
        time.sleep(0.3)  # the receive thread takes the reading over from the caller
        server.close()
        cpu = time.process_time()
        time.sleep(1.0)
        assert time.process_time() - cpu < 0.3
        stopped = [r for r in caplog.records if "receive loop" in r.getMessage()]
        assert len(stopped) == 1, [r.getMessage() for r in stopped]
        with pytest.raises(BusClosedError, match="the receive loop stopped"):
            bus.motor(1).get_state()


@pytest.mark.parametrize("interface", ["socketcand", "python-can:socketcand"])
def test_an_event_loop_reading_a_server_that_goes_away_stops_reading_it(
    interface: str, caplog: pytest.LogCaptureFixture
) -> None:
    async def main() -> float:
        server = attach_socketcand(SimBus(ids=[1]))
        bus = open_bus_async(interface, "can0", host=server.host, port=server.port, stop_on_close=False)
        try:
            assert (await bus.motor(1).get_state()).node == 1
            waiting = asyncio.ensure_future(bus.motor(1).wait_state(5.0))
            await asyncio.sleep(0.05)
            server.close()
            with pytest.raises(BusClosedError):
                await asyncio.wait_for(waiting, 2.0)
            cpu = time.process_time()
            await asyncio.sleep(1.0)
            return time.process_time() - cpu
        finally:
            await bus.close()
            server.close()

    assert asyncio.run(main()) < 0.3
    assert len([r for r in caplog.records if "receive loop" in r.getMessage()]) == 1


@pytest.mark.parametrize("interface", ["socketcand", "python-can:socketcand"])
def test_the_last_frames_sent_before_close_reach_the_server(interface: str) -> None:
    """Closing waits (briefly) for the server to close its side: a socket closed with unread data is reset,
    and the reset would drop what it still had to send, the stops of stop_on_close among them."""
    sim = SimBus(ids=[1])
    heard: list[Frame] = []
    sim.add_listener(heard.append, host_frames=True)
    server = attach_socketcand(sim)
    try:
        t = open_transport(interface, "can0", host=server.host, port=server.port)
        for i in range(20):
            sim.send(Frame(0x100, bytes([i]), False))  # arrives at the client, unread
        time.sleep(0.1)
        for i in range(200):
            t.send(Frame(0x200, i.to_bytes(2, "big"), False))
        t.close()
        deadline = time.monotonic() + 3
        while sum(f.arbitration_id == 0x200 for f in heard) < 200 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert sum(f.arbitration_id == 0x200 for f in heard) == 200
    finally:
        server.close()
