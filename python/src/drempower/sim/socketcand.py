"""A socketcand server for a :class:`~drempower.sim.bus.SimBus`, on the loopback interface only.

It speaks the raw mode of the socketcand protocol, which is what python-can's
``can.Bus(interface="socketcand", host="127.0.0.1", port=P, channel="can0")``
uses: the server greets with ``< hi >``; the client sends ``< open can0 >`` and
``< rawmode >``, each answered ``< ok >``; then the client sends
``< send ID LEN B0 B1 ... >`` and receives ``< frame ID SECS.USECS DATA >``
(simulated time, data as one hex string). ``< echo >`` is echoed.

What one local client can cost is bounded: its input is parsed in one pass
and a command longer than :data:`MAX_COMMAND` is refused (and skipped) without
being kept; its output waits in a queue of at most ``max_queue`` messages, and
a client that does not read them is disconnected (counted in
``SocketcandServer.disconnected_slow``); at most ``max_clients`` connections
are served at once (two threads each).

Idle connections never lock other clients out: a connection that has not
reached raw mode within :data:`HANDSHAKE_TIMEOUT` is closed, and while
``max_clients`` are served a new connection takes the place of the one silent
longest, if it has sent nothing for :data:`EVICT_IDLE` (a listening client, such
as a logger, sends nothing after its handshake; it is evicted only when the
server is full). A new connection is refused (counted in
``SocketcandServer.refused``) only when every served client spoke within
:data:`EVICT_IDLE`; evictions are counted in ``SocketcandServer.evicted``.
Malformed commands, such as a ``send`` of an id above 0x7FF, are answered
with the socketcand error form ``< error ... >`` and change nothing.
"""

from __future__ import annotations

import ipaddress
import queue
import socket
import threading
import time
from collections.abc import Callable, Sequence
from types import TracebackType

from ..errors import DrEmpowerError, ProtocolError, ValidationError
from ..protocol.ids import Frame
from ..protocol.socketcand import MAX_COMMAND, CommandParser, format_frame, parse_send
from .bus import SimBus

__all__ = ["MAX_COMMAND", "CommandParser", "SocketcandServer", "attach_socketcand", "parse_send", "format_frame"]

_SETTLE = 0.02
"""Pause after the ``< ok >`` that ends the handshake, so that the client reads it on its own (s)."""
_POLL = 0.2
"""Longest wait of the server threads (s), so that close() is noticed promptly."""
MAX_QUEUE = 4096
"""Default bound of each client's output queue (messages)."""
MAX_CLIENTS = 16
"""Default number of connections served at once."""
HANDSHAKE_TIMEOUT = 5.0
"""Time (s) a connection has to reach raw mode (``< open can0 >``, ``< rawmode >``) before it is closed."""
EVICT_IDLE = 1.0
"""Silence (s) after which a client gives way to a new connection while the server is full."""


class _Client:
    """One connection: handshake, then frames both ways."""

    def __init__(self, server: SocketcandServer, conn: socket.socket) -> None:
        self.server = server
        self.conn = conn
        self.out: queue.Queue[bytes] = queue.Queue(server.max_queue)
        self.raw = False
        self.closed = False
        self.parser = CommandParser()
        self.opened = self.heard = time.monotonic()
        """When the connection was accepted, when its last bytes arrived (monotonic s)."""
        self.reader = threading.Thread(target=self._read, name="drempower-sim-socketcand-client", daemon=True)
        self.writer = threading.Thread(target=self._write, name="drempower-sim-socketcand-writer", daemon=True)
        self.put(b"< hi >")
        self.reader.start()
        self.writer.start()

    def put(self, message: bytes) -> None:
        """Queue ``message``; a client whose queue is full does not read: it is disconnected."""
        if self.closed:
            return
        try:
            self.out.put_nowait(message)
        except queue.Full:
            self.server.count_slow()
            self.close()

    def frame(self, frame: Frame) -> None:
        self.put(format_frame(frame, self.server.sim.now))

    def _write(self) -> None:
        while not self.closed:
            try:
                data = self.out.get(timeout=_POLL)
            except queue.Empty:
                continue
            try:
                self.conn.sendall(data)
            except OSError:
                self.close()
                return
            if data == b"< ok >" and self.raw:
                time.sleep(_SETTLE)

    def _read(self) -> None:
        conn = self.conn
        conn.settimeout(_POLL)
        try:
            while not self.server.closed and not self.closed:
                try:
                    chunk = conn.recv(65536)
                except TimeoutError:
                    if not self.raw and time.monotonic() - self.opened > self.server.handshake_timeout:
                        self.put(b"< error no rawmode within the handshake time >")
                        time.sleep(_SETTLE)  # let the writer send it
                        break
                    continue
                if not chunk:
                    break
                self.heard = time.monotonic()
                for body in self.parser.feed(chunk):
                    if body is None:
                        self.put(f"< error command longer than {MAX_COMMAND} bytes >".encode())
                    else:
                        self._command(body)
        except OSError:
            pass
        finally:
            self.close()

    def _command(self, body: str) -> None:
        word = body.split(" ", 1)[0]
        sim = self.server.sim
        if word == "open":
            ok = body.split()[1:] == [self.server.channel]
            self.put(b"< ok >" if ok else b"< error could not open bus >")
        elif word == "rawmode":
            if not self.raw:  # a repeated rawmode must not deliver every frame twice
                self.raw = True
                sim.add_listener(self.frame, host_frames=True)
            self.put(b"< ok >")
        elif word == "echo":
            self.put(b"< echo >")
        elif word == "push":  # the hand from outside (drempower.sim.hand_link): a twin in this process
            hand = self.server.hand
            if hand is None:
                self.put(b"< error no twin here to push: this simulator runs motors without a model >")
                return
            try:
                hand(body.split()[1:])
            except (DrEmpowerError, ValueError) as exc:
                why = " ".join(str(exc).replace("<", "(").replace(">", ")").split())[:MAX_COMMAND]
                self.put(f"< error {why} >".encode())
                return
            self.put(b"< ok >")
        elif word == "send" and self.raw:
            try:
                frame = parse_send(body)
            except ProtocolError:
                self.put(b"< error bad send command >")
                return
            sim.send(frame, self.frame)
        else:
            self.put(f"< error unknown command {word[:32]} >".encode())

    def close(self) -> None:
        """Drop the connection (idempotent; the threads end within one poll)."""
        if self.closed:
            return
        self.closed = True
        self.server.sim.remove_listener(self.frame)
        try:
            self.conn.shutdown(socket.SHUT_RDWR)  # wakes a writer blocked in sendall
        except OSError:
            pass
        try:
            self.conn.close()
        except OSError:
            pass
        self.server.forget(self)


class SocketcandServer:
    """Serves ``bus`` to socketcand clients on ``host`` (a loopback address) and ``port``
    (0 picks a free one; see ``.port``), as bus ``channel``.

    ``max_clients`` connections at most; each client's output queue holds
    ``max_queue`` messages at most. ``refused`` counts the connections turned
    away, ``disconnected_slow`` the clients dropped for not reading.
    """

    def __init__(
        self,
        bus: SimBus,
        port: int = 0,
        host: str = "127.0.0.1",
        channel: str = "can0",
        *,
        max_clients: int = MAX_CLIENTS,
        max_queue: int = MAX_QUEUE,
        handshake_timeout: float = HANDSHAKE_TIMEOUT,
        evict_idle: float = EVICT_IDLE,
        hand: Callable[[Sequence[str]], None] | None = None,
    ) -> None:
        if not ipaddress.ip_address(host).is_loopback:
            raise ValidationError(f"host={host!r}: the simulator serves loopback addresses only")
        if max_clients < 1 or max_queue < 1:
            raise ValidationError(f"max_clients={max_clients}, max_queue={max_queue}: both must be >= 1")
        self.sim = bus
        self.channel = channel
        self.hand = hand
        """Takes ``< push ... >`` (see :mod:`drempower.sim.hand_link`): a twin's hand, or None (no twin)."""
        self.closed = False
        self.max_clients = max_clients
        self.max_queue = max_queue
        self.handshake_timeout = handshake_timeout
        self.evict_idle = evict_idle
        self.refused = 0
        """Connections turned away because ``max_clients`` were being served, all of them active."""
        self.evicted = 0
        """Clients closed to make room for a new connection (silent for ``evict_idle`` s at least)."""
        self.disconnected_slow = 0
        """Clients disconnected because they did not read what was queued for them."""
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
            victim: _Client | None = None
            with self._lock:
                full = len(self._clients) >= self.max_clients
                if full:
                    quiet = min(self._clients, key=lambda c: c.heard)
                    if time.monotonic() - quiet.heard >= self.evict_idle:
                        victim, full = quiet, False
                        self._clients.discard(quiet)
                        self.evicted += 1
                    else:
                        self.refused += 1
                if not full:
                    self._clients.add(_Client(self, conn))
            if victim is not None:
                _refuse(victim.conn, b"< error closed: idle while the server is full >")
                victim.close()
            if full:
                _refuse(conn, f"< error too many connections ({self.max_clients}) >".encode())

    def forget(self, client: _Client) -> None:
        with self._lock:
            self._clients.discard(client)

    def count_slow(self) -> None:
        with self._lock:
            self.disconnected_slow += 1

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


def _refuse(conn: socket.socket, message: bytes) -> None:
    """Tell a connection it is not served, without waiting on it, and close it."""
    try:
        conn.setblocking(False)
        conn.send(message)
    except OSError:
        pass
    finally:
        conn.close()


def attach_socketcand(
    bus: SimBus,
    port: int = 0,
    host: str = "127.0.0.1",
    channel: str = "can0",
    hand: Callable[[Sequence[str]], None] | None = None,
) -> SocketcandServer:
    """Serve ``bus`` over the socketcand protocol on ``host``:``port`` (127.0.0.1 and a free port by default);
    ``hand`` takes the pushes of a twin's hand from outside (:mod:`drempower.sim.hand_link`)."""
    return SocketcandServer(bus, port, host, channel, hand=hand)
