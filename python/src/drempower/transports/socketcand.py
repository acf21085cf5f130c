"""A bus served by socketcand over TCP, read and written by drempower (raw mode).

The socket is read with ``select`` and ``recv`` as the serial transports read their ports, and
the messages are parsed by :class:`~drempower.protocol.socketcand.FrameDecoder`. python-can's own
socketcand client stays reachable as interface ``"python-can:socketcand"``.
"""

from __future__ import annotations

import math
import os
import select
import socket
import threading
import time
import weakref
from collections import deque

from ..errors import ValidationError
from ..protocol.ids import Frame, parse_int
from ..protocol.socketcand import FrameDecoder, encode_send
from .base import Transport
from .errors import TransportError, TransportOptionError
from .fds import close_fds, drain_close, nonblocking_pipe

__all__ = ["SocketcandTransport", "CONNECT_TIMEOUT", "SEND_TIMEOUT", "TX_LATENCY"]

CONNECT_TIMEOUT = 2.0
"""How long (s) the server gets to accept the connection and to answer each step of the handshake."""
SEND_TIMEOUT = 1.0
"""Default bound (s) of one send: a server that does not take the command in this time fails it."""
TX_LATENCY = 0.02
"""Margin (s) a socketcand link adds before a batch's start: a TCP hop and the server's own queue."""
_WRITE_SLICE = 0.05
"""Longest single wait of a send for room in the socket (s), so that ``close`` is noticed promptly."""
_HANDSHAKE_LIMIT = 512
"""Most bytes read while waiting for one answer of the handshake."""
MAX_TIMEOUT = 3600.0
"""Longest ``connect_timeout`` and ``send_timeout`` taken (s): a wait must end."""


def _why(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


class SocketcandTransport(Transport):
    """The CAN bus ``channel`` (e.g. ``can0``) served by socketcand at ``host``:``port``.

    Opening connects (TCP_NODELAY on), waits for the server's ``< hi >``, opens
    ``channel`` and enters raw mode, each step within ``connect_timeout`` s; a
    refusal raises :class:`TransportError` with the server's words (default
    timeout: :data:`CONNECT_TIMEOUT`). A send
    writes the whole ``< send ... >`` command within ``send_timeout`` s or fails
    (a command cut off part way marks the connection broken: every later send
    fails saying so). A server that closes the connection fails the next read.
    ``bitrate`` (bit/s), when given, is the served bus's rate: the client then
    times what it queues; socketcand itself sets no bit rate.

    Each received frame keeps the server's time stamp as its ``time`` (a
    :class:`~drempower.protocol.ids.TimedFrame`), put on the scale of :func:`time.monotonic`: the
    server's clock plus the smallest difference seen so far between when a frame reached this host and
    its stamp (the server's clock and this host's then differ by the quickest hop's latency), so the
    frames keep the spacing the server gave them however late this host reads them.
    """

    recv_slice = None
    """``close`` wakes a waiting receive itself (through a pipe)."""
    tx_latency = TX_LATENCY
    unbounded_latency = True

    def __init__(
        self,
        host: str,
        port: int | str,
        channel: str = "can0",
        *,
        bitrate: int | None = None,
        connect_timeout: float | None = None,
        send_timeout: float = SEND_TIMEOUT,
    ) -> None:
        where = f"{host}:{port}"
        if connect_timeout is None:
            connect_timeout = CONNECT_TIMEOUT
        if not isinstance(host, str) or not host:
            raise TransportOptionError(f"cannot open socketcand bus: host={host!r} must name the server")
        try:
            number = port if isinstance(port, int) and not isinstance(port, bool) else parse_int(str(port), "port")
        except ValidationError as exc:
            raise TransportOptionError(f"cannot open socketcand bus at {where}: {exc}") from None
        if not 1 <= number <= 65535:
            raise TransportOptionError(f"cannot open socketcand bus at {where}: port={port!r} must be 1..65535")
        if not isinstance(channel, str) or not channel or not channel.isprintable() or any(c in channel for c in " <>"):
            raise TransportOptionError(
                f"cannot open socketcand bus at {where}: channel={channel!r} must be the served bus's name, e.g. 'can0'"
            )
        for name, value in (("connect_timeout", connect_timeout), ("send_timeout", send_timeout)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= MAX_TIMEOUT:
                raise TransportOptionError(
                    f"cannot open socketcand bus at {where}: {name}={value!r} must be seconds in (0, {MAX_TIMEOUT:g}]"
                )
        if bitrate is not None and (isinstance(bitrate, bool) or not isinstance(bitrate, int) or bitrate <= 0):
            raise TransportOptionError(f"cannot open socketcand bus at {where}: bitrate={bitrate!r} must be bit/s > 0")
        self.description = f"socketcand {channel} at {where}"
        self.wire_bitrate = bitrate
        self._send_timeout = float(send_timeout)
        self._decoder = FrameDecoder()
        self._offset = math.inf
        """This host's monotonic clock minus the server's (s): the smallest difference seen so far."""
        self._frames: deque[Frame] = deque()
        self._wlock = threading.Lock()
        self._closed = False
        """Set once by :meth:`close` (a plain flag: read on every send and receive)."""
        self._broken: str | None = None
        wake_r, self._wake_w = nonblocking_pipe()
        weakref.finalize(self, close_fds, wake_r, self._wake_w)
        try:
            sock = socket.create_connection((host, number), timeout=connect_timeout)
        except TimeoutError as exc:
            raise TransportError(f"cannot reach socketcand at {where}: no connection in {connect_timeout:g} s") from exc
        except OSError as exc:
            raise TransportError(f"cannot reach socketcand at {where}: {_why(exc)}") from exc
        try:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._handshake(sock, channel, float(connect_timeout))
            sock.setblocking(False)
        except BaseException:
            sock.close()
            raise
        self._sock = sock
        self._fd = sock.fileno()
        self._wait_fds = [self._fd, wake_r]

    def _handshake(self, sock: socket.socket, channel: str, timeout: float) -> None:
        """Greeting, open, raw mode. Only the answers are taken from the socket: what the server sends
        after the last ``< ok >`` stays there, so the descriptor tells that it is there."""
        for say, want, step in (
            (None, b"< hi >", "greet with '< hi >'"),
            (b"< open %s >" % channel.encode(), b"< ok >", f"open bus {channel!r}"),
            (b"< rawmode >", b"< ok >", "enter raw mode"),
        ):
            if say is not None:
                try:
                    sock.settimeout(timeout)
                    sock.sendall(say)
                except OSError as exc:
                    raise TransportError(f"{self.description}: the server did not {step}: {_why(exc)}") from exc
            answer = self._answer(sock, timeout, step)
            if answer != want:
                if answer.startswith(b"< error"):
                    words = answer[7:-1].strip().decode("ascii", "replace")
                    raise TransportError(f"{self.description}: the server refused to {step}: {words}")
                raise TransportError(
                    f"{self.description}: the server did not {step} (it said {answer!r}); is it a socketcand server?"
                )

    def _answer(self, sock: socket.socket, timeout: float, step: str) -> bytes:
        """The next ``< ... >`` message of the handshake, taken from the socket up to its ``>`` (what follows
        stays unread: it is looked at with ``MSG_PEEK`` first)."""
        deadline = time.monotonic() + timeout
        buf = b""
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or len(buf) > _HANDSHAKE_LIMIT:
                got = f"got {buf!r}" if buf else "got nothing"
                raise TransportError(f"{self.description}: the server did not {step} in {timeout:g} s ({got})")
            try:
                sock.settimeout(left)
                peek = sock.recv(256, socket.MSG_PEEK)
                end = peek.find(b">")
                chunk = sock.recv(len(peek) if end < 0 else end + 1) if peek else b""
            except TimeoutError:
                continue
            except OSError as exc:
                raise TransportError(f"{self.description}: the server did not {step}: {_why(exc)}") from exc
            if not chunk:
                raise TransportError(f"{self.description}: the server closed the connection instead of answering")
            buf += chunk
            if end >= 0:
                start = buf.rfind(b"<")
                return buf[max(start, 0) :]

    @property
    def decoder(self) -> FrameDecoder:
        """The decoder: its counts tell the server's answers, errors (``last_error``) and dropped bytes."""
        return self._decoder

    # ------------------------------------------------------------------ sending

    def send(self, frame: Frame) -> None:
        data = encode_send(frame)
        with self._wlock:
            if self._closed:
                raise TransportError(f"{self.description}: closed, frame not sent")
            if self._broken is not None:
                raise TransportError(f"{self.description}: frame not sent: {self._broken}; close and reopen the bus")
            try:  # the commonest: the socket takes the whole command at once
                sent = self._sock.send(data)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError as exc:
                raise TransportError(f"{self.description}: frame not sent: {_why(exc)}") from exc
            if sent < len(data):
                self._send_rest(data, sent)

    def _send_rest(self, data: bytes, sent: int) -> None:
        """Write the rest of ``data`` (its first ``sent`` bytes are out) within the send timeout."""
        total = len(data)
        deadline = time.monotonic() + self._send_timeout
        while sent < total:
            left = deadline - time.monotonic()
            if left <= 0 or self._closed:
                break
            try:
                select.select([], [self._fd], [], min(left, _WRITE_SLICE))
                sent += self._sock.send(data[sent:])
            except (BlockingIOError, InterruptedError):
                pass
            except (OSError, ValueError) as exc:
                raise self._failed(sent, total, _why(exc)) from exc
        if sent < total:
            why = f"the server took no data for {self._send_timeout:g} s"
            if self._closed:
                why = "closed while writing"
            raise self._failed(sent, total, why)

    def _failed(self, sent: int, total: int, why: str) -> TransportError:
        if sent == 0:
            return TransportError(f"{self.description}: frame not sent: {why}")
        self._broken = f"a command was cut off after {sent} of {total} bytes ({why}); the stream is out of step"
        return TransportError(f"{self.description}: {self._broken}; close and reopen the bus")

    # ------------------------------------------------------------------ receiving

    def is_closed(self) -> bool:
        return self._closed

    def fileno(self) -> int | None:
        """The socket's descriptor: readable when the server sent something."""
        return self._fd

    def read_nowait(self) -> list[Frame]:
        """Every frame received so far: those buffered plus one non-blocking read of the socket.

        Raises :class:`TransportError` when the server closed the connection.
        """
        frames = self._frames
        out: list[Frame] = []
        if frames:
            out.extend(frames)
            frames.clear()
        try:
            chunk = self._sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return out
        except OSError as exc:
            if self._closed:
                return out
            raise TransportError(f"{self.description}: receive failed: {_why(exc)}") from exc
        if not chunk:
            if self._closed:
                return out
            raise TransportError(f"{self.description}: the socketcand server closed the connection")
        got = self._decoder.feed(chunk)
        if got:
            self._on_host_scale(got)
        if not out:
            return got
        out.extend(got)
        return out

    def _on_host_scale(self, frames: list[Frame]) -> None:
        """Put the server's time stamps of ``frames`` (just read) on this host's monotonic scale."""
        last = max(f.time for f in frames)  # type: ignore[attr-defined]
        offset = min(self._offset, time.monotonic() - last)
        self._offset = offset
        for f in frames:
            f.time += offset  # type: ignore[attr-defined]

    def wait_frame(self, timeout: float) -> Frame | None:
        """The next frame, or None after at most ``timeout`` s (or once closed)."""
        frames = self._frames
        if frames:
            return frames.popleft()
        try:
            ready = select.select(self._wait_fds, [], [], timeout)[0]
        except (OSError, ValueError) as exc:
            if self._closed:
                return None
            raise TransportError(f"{self.description}: receive failed: {_why(exc)}") from exc
        if not ready or self._closed:
            return None
        frames.extend(self.read_nowait())
        return frames.popleft() if frames else None

    # ------------------------------------------------------------------ closing

    def close(self) -> None:
        """Close the connection (the server then closes the bus for this client); wakes a waiting receive."""
        if self._closed:
            return
        self._closed = True
        try:
            os.write(self._wake_w, b"\0")
        except OSError:
            pass
        # a send in progress notices the close within one write slice; do not close the socket under it
        locked = self._wlock.acquire(timeout=max(1.0, 4 * _WRITE_SLICE))
        try:
            drain_close(self._sock)  # what was sent last (the stops) is not reset away
        finally:
            if locked:
                self._wlock.release()
