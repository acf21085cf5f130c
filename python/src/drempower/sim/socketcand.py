"""A socketcand server for a :class:`~drempower.sim.bus.SimBus`, on the loopback interface only.

It speaks the raw mode of the socketcand protocol, which is what python-can's
``can.Bus(interface="socketcand", host="127.0.0.1", port=P, channel="can0")``
uses: the server greets with ``< hi >``; the client sends ``< open can0 >`` and
``< rawmode >``, each answered ``< ok >``; then the client sends
``< send ID LEN B0 B1 ... >`` and receives ``< frame ID SECS.USECS DATA >``
(simulated time, data as one hex string). ``< echo >`` is echoed.
"""

from __future__ import annotations

import ipaddress
import queue
import socket
import threading
import time
from types import TracebackType

from ..errors import ProtocolError, ValidationError
from ..protocol.ids import Frame
from .bus import SimBus

__all__ = ["SocketcandServer", "attach_socketcand", "parse_send", "format_frame"]

_SETTLE = 0.02
"""Pause after the ``< ok >`` that ends the handshake, so that the client reads it on its own (s)."""
_POLL = 0.2
"""Longest wait of the server threads (s), so that close() is noticed promptly."""


def parse_send(body: str) -> Frame:
    """``send ID LEN B0 ...`` (the text between ``<`` and ``>``) as a frame; raises :class:`ProtocolError`."""
    parts = body.split()
    if len(parts) < 3 or parts[0] != "send":
        raise ProtocolError(f"not a send command: {body!r}")
    try:
        ident, length, data = parts[1], int(parts[2]), bytes(int(b, 16) for b in parts[3:])
        arb = int(ident, 16)
    except ValueError:
        raise ProtocolError(f"bad send command: {body!r}") from None
    if length != len(data) or length > 8 or len(ident) not in (3, 8):
        raise ProtocolError(f"bad send command: {body!r}")
    return Frame(arb, data, len(ident) == 8)


def format_frame(frame: Frame, seconds: float) -> bytes:
    """A frame as the server sends it, time stamped ``seconds``."""
    ident = f"{frame.arbitration_id:08X}" if frame.is_extended else f"{frame.arbitration_id:03X}"
    whole = int(seconds)
    return f"< frame {ident} {whole}.{int((seconds - whole) * 1e6):06d} {frame.data.hex().upper()} >".encode()


class _Client:
    """One connection: handshake, then frames both ways."""

    def __init__(self, server: SocketcandServer, conn: socket.socket) -> None:
        self.server = server
        self.conn = conn
        self.out: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self.raw = False
        self.buf = ""
        self.reader = threading.Thread(target=self._read, name="drempower-sim-socketcand-client", daemon=True)
        self.writer = threading.Thread(target=self._write, name="drempower-sim-socketcand-writer", daemon=True)
        self.out.put(b"< hi >")
        self.reader.start()
        self.writer.start()

    def frame(self, frame: Frame) -> None:
        self.out.put(format_frame(frame, self.server.sim.now))

    def _write(self) -> None:
        while True:
            data = self.out.get()
            if data is None:
                return
            try:
                self.conn.sendall(data)
            except OSError:
                return
            if data == b"< ok >" and self.raw:
                time.sleep(_SETTLE)

    def _read(self) -> None:
        conn = self.conn
        conn.settimeout(_POLL)
        try:
            while not self.server.closed:
                try:
                    chunk = conn.recv(4096)
                except TimeoutError:
                    continue
                if not chunk:
                    break
                self.buf += chunk.decode("ascii", "replace")
                self._commands()
        except OSError:
            pass
        finally:
            self.close()

    def _commands(self) -> None:
        while True:
            start = self.buf.find("<")
            end = self.buf.find(">", start + 1)
            if start < 0 or end < 0:
                if start < 0:
                    self.buf = ""
                return
            body = self.buf[start + 1 : end].strip()
            self.buf = self.buf[end + 1 :]
            self._command(body)

    def _command(self, body: str) -> None:
        word = body.split(" ", 1)[0]
        sim = self.server.sim
        if word == "open":
            ok = body.split()[1:] == [self.server.channel]
            self.out.put(b"< ok >" if ok else b"< error could not open bus >")
        elif word == "rawmode":
            self.raw = True
            sim.add_listener(self.frame, host_frames=True)
            self.out.put(b"< ok >")
        elif word == "echo":
            self.out.put(b"< echo >")
        elif word == "send" and self.raw:
            try:
                frame = parse_send(body)
            except ProtocolError:
                self.out.put(b"< error bad send command >")
                return
            sim.send(frame, self.frame)
        else:
            self.out.put(f"< error unknown command {word} >".encode())

    def close(self) -> None:
        self.server.sim.remove_listener(self.frame)
        self.out.put(None)
        try:
            self.conn.close()
        except OSError:
            pass
        self.server.forget(self)


class SocketcandServer:
    """Serves ``bus`` to socketcand clients on ``host`` (a loopback address) and ``port``
    (0 picks a free one; see ``.port``), as bus ``channel``."""

    def __init__(self, bus: SimBus, port: int = 0, host: str = "127.0.0.1", channel: str = "can0") -> None:
        if not ipaddress.ip_address(host).is_loopback:
            raise ValidationError(f"host={host!r}: the simulator serves loopback addresses only")
        self.sim = bus
        self.channel = channel
        self.closed = False
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._sock = socket.socket(family, socket.SOCK_STREAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._sock.bind((host, port))
        self._sock.listen(8)
        self._sock.settimeout(_POLL)
        self.host = host
        self.port: int = self._sock.getsockname()[1]
        self._clients: set[_Client] = set()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._accept, name="drempower-sim-socketcand", daemon=True)
        self._thread.start()

    def _accept(self) -> None:
        while not self.closed:
            try:
                conn, _ = self._sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._lock:
                self._clients.add(_Client(self, conn))

    def forget(self, client: _Client) -> None:
        with self._lock:
            self._clients.discard(client)

    def close(self) -> None:
        """Stop serving and drop every connection (idempotent)."""
        if self.closed:
            return
        self.closed = True
        self._thread.join()
        self._sock.close()
        with self._lock:
            clients = list(self._clients)
        for c in clients:
            c.close()
            c.reader.join()

    def __enter__(self) -> SocketcandServer:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def attach_socketcand(bus: SimBus, port: int = 0, host: str = "127.0.0.1", channel: str = "can0") -> SocketcandServer:
    """Serve ``bus`` over the socketcand protocol on ``host``:``port`` (127.0.0.1 and a free port by default)."""
    return SocketcandServer(bus, port, host, channel)
