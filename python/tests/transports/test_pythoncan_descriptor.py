"""The python-can transport's descriptor: callers read python-can buses in ``select`` where python-can
allows it (virtual through a signalled queue, socketcand's socket, socketcan's), with no thread handoff."""

from __future__ import annotations

import queue
import select
import socket
import threading
import time
from typing import Any

import can
import pytest

import drempower
from drempower.protocol import FastRead
from drempower.protocol.ids import Frame
from drempower.sim import SimBus, attach_python_can, attach_socketcand
from drempower.transports import TransportError, open_transport, pythoncan

FRAMES = [Frame(0x021, bytes(range(8))), Frame(0x7FF, b""), Frame(0x1234567, b"\x01", True)]


def readable(fd: int, timeout: float = 0.0) -> bool:
    return bool(select.select([fd], [], [], timeout)[0])


def take(t: Any, count: int, limit: float = 2.0) -> list[Frame]:
    got: list[Frame] = []
    deadline = time.monotonic() + limit
    while len(got) < count and time.monotonic() < deadline:
        fd = t.fileno()
        if readable(fd, 0.1):
            got += t.read_nowait()
    return got


def test_virtual_bus_signals_its_descriptor() -> None:
    t = open_transport("virtual", "drempower-test-descriptor")
    peer = can.Bus(interface="virtual", channel="drempower-test-descriptor")
    try:
        fd = t.fileno()
        assert fd is not None and not readable(fd)
        assert t.read_nowait() == []
        for f in FRAMES:
            peer.send(can.Message(arbitration_id=f[0], data=f[1], is_extended_id=f[2]))
        assert readable(fd, 1.0)
        assert t.read_nowait() == FRAMES
        assert not readable(fd)  # emptied with the queue
        t.send(FRAMES[0])  # and sending still reaches the peer
        msg = peer.recv(1.0)
        assert msg is not None and msg.arbitration_id == FRAMES[0][0]
    finally:
        peer.shutdown()
        t.close()


def test_virtual_bus_received_by_recv_too() -> None:
    t = open_transport("virtual", "drempower-test-descriptor-recv")
    peer = can.Bus(interface="virtual", channel="drempower-test-descriptor-recv")
    try:
        peer.send(can.Message(arbitration_id=0x21, data=b"\x01", is_extended_id=False))
        assert t.recv(1.0) == Frame(0x21, b"\x01")
        assert t.read_nowait() == []
        fd = t.fileno()
        assert fd is not None and not readable(fd)  # read_nowait emptied the signal of the frame recv took
    finally:
        peer.shutdown()
        t.close()


def test_filters_in_software_keep_the_receive_thread() -> None:
    """python-can filters a virtual bus in its recv, which then gives None at a dropped message with more
    held: such a bus has no descriptor, and only what passes the filter arrives."""
    t = open_transport("virtual", "drempower-test-filtered", can_filters=[{"can_id": 0x21, "can_mask": 0x7FF}])
    peer = can.Bus(interface="virtual", channel="drempower-test-filtered")
    try:
        assert t.fileno() is None
        for arb in (0x22, 0x21):
            peer.send(can.Message(arbitration_id=arb, data=b"", is_extended_id=False))
        assert t.recv(1.0) == Frame(0x21, b"")
        assert t.recv(0.05) is None
    finally:
        peer.shutdown()
        t.close()


def test_client_over_virtual_reads_in_the_calling_thread() -> None:
    sim = SimBus(ids=[1])
    channel = "drempower-test-descriptor-client"
    with (
        attach_python_can(sim, channel=channel),
        drempower.open_bus("virtual", channel, timeout=1.0, stop_on_close=False) as bus,
    ):
        assert bus.transport.fileno() is not None
        for _ in range(20):
            assert bus.motor(1).get_state().node == 1


@pytest.mark.parametrize("interface", ["socketcand", "python-can:socketcand"])
def test_socketcand_reads_its_socket_and_notices_a_closed_server(interface: str) -> None:
    """drempower's socketcand client and python-can's (through its socket) alike."""
    sim = SimBus(ids=[1])
    server = attach_socketcand(sim)
    t = open_transport(interface, "can0", host=server.host, port=server.port)
    try:
        fd = t.fileno()
        assert fd is not None
        t0 = time.monotonic()
        assert t.read_nowait() == []  # nothing there: at once (the socket's send timeout is no wait here)
        assert time.monotonic() - t0 < 0.5
        t.send(FastRead(1).encode())
        got = take(t, 1)
        assert len(got) == 1 and got[0].arbitration_id == (1 << 5) | 0x03
        server.close()
        assert readable(fd, 2.0)
        with pytest.raises(TransportError, match="closed the connection"):
            for _ in range(10):
                t.read_nowait()
    finally:
        server.close()
        t.close()


class PairBus(can.BusABC):
    """A python-can bus on a socket pair (one datagram a message) with a descriptor, as socketcan has."""

    def __init__(self, channel: Any = None, **kwargs: Any) -> None:
        self.sock, self.peer = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self.channel_info = f"pair {channel}"
        super().__init__(channel=channel)

    def put(self, frame: Frame, error: bool = False) -> None:
        self.peer.send(bytes((error,)) + frame[0].to_bytes(4, "big") + frame[1])

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.sock.send(b"\0" + msg.arbitration_id.to_bytes(4, "big") + bytes(msg.data))

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if not select.select([self.sock], [], [], timeout)[0]:
            return None, False
        d = self.sock.recv(64)
        arb = int.from_bytes(d[1:5], "big")
        return can.Message(arbitration_id=arb, data=d[5:], is_extended_id=False, is_error_frame=bool(d[0])), False

    def fileno(self) -> int:
        return self.sock.fileno()

    def shutdown(self) -> None:
        super().shutdown()
        self.sock.close()
        self.peer.close()


@pytest.mark.parametrize(("interface", "has_fd"), [("socketcan", True), ("pcan", False)])
def test_a_bus_descriptor_is_used_where_python_can_promises_it(
    monkeypatch: pytest.MonkeyPatch, interface: str, has_fd: bool
) -> None:
    made: list[PairBus] = []

    def bus(**cfg: Any) -> PairBus:
        made.append(PairBus(cfg.get("channel")))
        return made[0]

    monkeypatch.setattr(pythoncan.can, "Bus", bus)
    t = open_transport(interface, "can7")
    try:
        assert (t.fileno() == made[0].fileno()) if has_fd else (t.fileno() is None)
        if not has_fd:
            return
        made[0].put(Frame(0x10, b"\x01"))
        made[0].put(Frame(0x11, b""), error=True)  # skipped
        made[0].put(Frame(0x12, b"\x02\x03"))
        assert readable(made[0].fileno(), 1.0)
        assert t.read_nowait() == [Frame(0x10, b"\x01"), Frame(0x12, b"\x02\x03")]
        assert t.read_nowait() == []
    finally:
        t.close()


class _ClosesOnPut(queue.Queue):  # type: ignore[type-arg]
    """A virtual bus's queue that, when a message reaches it, has its bus shut down by another thread."""

    def __init__(self, closer: threading.Thread) -> None:
        super().__init__()
        self.closer = closer

    def put(self, item: Any, block: bool = True, timeout: float | None = None) -> None:
        super().put(item, block, timeout)
        self.closer.start()
        self.closer.join(0.2)  # the shutdown runs now, unless the send holds it off


def test_a_virtual_bus_closing_during_a_send_loses_no_frame_of_another() -> None:
    """python-can's virtual send walks the channel's queues while a closing bus removes its own: the walk
    skips the next queue (without the transport's lock over its send, ``other`` gets nothing here)."""
    from can.interfaces import virtual

    channel = "drempower-test-close-race"
    t = open_transport("virtual", channel)
    closing = can.Bus(interface="virtual", channel=channel)
    other = can.Bus(interface="virtual", channel=channel)
    closer = threading.Thread(target=closing.shutdown)
    with virtual.channels_lock:
        q = _ClosesOnPut(closer)
        closing.channel[closing.channel.index(closing.queue)] = q
        closing.queue = q
    try:
        t.send(Frame(0x21, b"\x01"))
        closer.join(2.0)
        msg = other.recv(0.5)
        assert msg is not None and msg.arbitration_id == 0x21
    finally:
        other.shutdown()
        t.close()


def test_a_virtual_send_gives_each_peer_what_python_cans_own_send_gives() -> None:
    """The transport puts a frame in the virtual channel's queues itself (no deep copy per peer): each peer
    gets a message of its own with python-can's fields (the channel, ``is_rx``, a timestamp of now)."""
    channel = "drempower-test-direct-send"
    t = open_transport("virtual", channel)
    peers = [can.Bus(interface="virtual", channel=channel) for _ in range(2)]
    reference = can.Bus(interface="virtual", channel=channel)
    try:
        assert isinstance(t, pythoncan.PythonCanTransport) and t._direct
        before = time.time()
        for f in FRAMES:
            t.send(f)
        got = [[p.recv(1.0) for _ in FRAMES] for p in peers]
        for msgs in got:
            assert [(m.arbitration_id, bytes(m.data), m.is_extended_id, m.is_remote_frame) for m in msgs] == FRAMES
            for m in msgs:
                assert m.channel == channel and m.is_rx and before <= m.timestamp <= time.time()
                assert m.dlc == len(m.data)
        assert got[0][0] is not got[1][0]  # one message each
        assert [reference.recv(1.0) is not None for _ in FRAMES] == [True] * len(FRAMES)
        assert t.read_nowait() == []  # not its own frames (receive_own_messages is off)
        assert peers[0].recv(0.0) is None
        # python-can's own send of the same frame on the same channel gives the same fields
        ref = can.Message(arbitration_id=FRAMES[0][0], data=FRAMES[0][1], is_extended_id=False)
        reference.send(ref)
        theirs = peers[0].recv(1.0)
        ours = got[0][0]
        for attr in ("arbitration_id", "data", "is_extended_id", "is_remote_frame", "dlc", "channel", "is_rx"):
            assert getattr(ours, attr) == getattr(theirs, attr), attr
    finally:
        for p in (*peers, reference):
            p.shutdown()
        t.close()


def test_a_virtual_send_with_receive_own_messages_reaches_itself() -> None:
    channel = "drempower-test-direct-own"
    t = open_transport("virtual", channel, receive_own_messages=True)
    peer = can.Bus(interface="virtual", channel=channel)
    try:
        assert isinstance(t, pythoncan.PythonCanTransport) and t._direct
        data = bytearray(b"\x01\x02")
        t.send(Frame(0x10, data))  # type: ignore[arg-type]
        data[0] = 0xFF  # the caller's buffer changes after the send: what was sent does not
        assert take(t, 1) == [Frame(0x10, b"\x01\x02")]
        msg = peer.recv(1.0)
        assert msg is not None and bytes(msg.data) == b"\x01\x02"
        t.send(FRAMES[0])
        assert take(t, 1) == [FRAMES[0]]
    finally:
        peer.shutdown()
        t.close()


def test_a_virtual_send_a_full_peer_refuses_is_an_error_and_others_still_get_it() -> None:
    channel = "drempower-test-direct-full"
    t = open_transport("virtual", channel, send_timeout=0.05)
    full = can.Bus(interface="virtual", channel=channel, rx_queue_size=1)
    other = can.Bus(interface="virtual", channel=channel)
    try:
        t.send(FRAMES[0])  # fills ``full``
        with pytest.raises(TransportError, match=r"send did not complete in 0.05 s \(1 receiving bus"):
            t.send(FRAMES[1])
        assert [other.recv(1.0).arbitration_id for _ in range(2)] == [FRAMES[0][0], FRAMES[1][0]]  # type: ignore[union-attr]
    finally:
        full.shutdown()
        other.shutdown()
        t.close()


def test_a_virtual_send_after_python_can_shut_the_bus_down_is_an_error() -> None:
    t = open_transport("virtual", "drempower-test-direct-shut")
    assert isinstance(t, pythoncan.PythonCanTransport)
    t.bus.shutdown()
    try:
        with pytest.raises(TransportError, match="shut down"):
            t.send(FRAMES[0])
    finally:
        t.close()
