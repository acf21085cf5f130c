"""Shared machinery of the serial-port transports (vendor adapter, motor UART)."""

from __future__ import annotations

import errno
import os
import select
import threading
import time
import weakref
from collections import deque
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Protocol

import serial

from ..protocol.ids import Frame
from .base import Transport
from .capabilities import Capabilities
from .errors import TransportError, TransportOptionError
from .fds import close_fds

try:
    from serial.serialposix import Serial as _PosixSerial
except ImportError:  # not a POSIX system: pyserial's own write (with its write timeout) is used
    _PosixSerial = None  # type: ignore[assignment,misc]

__all__ = ["SerialFrameTransport", "StreamDecoder", "READ_TIMEOUT", "WRITE_TIMEOUT"]

READ_TIMEOUT = 0.02
"""Timeout of one blocking read of the port (s); a partial frame followed by this much silence is dropped."""
WRITE_TIMEOUT = 1.0
"""A frame the device does not take in this time (s) fails instead of hanging (``write_timeout=`` changes it)."""
_WRITE_SLICE = 0.05
"""Longest single wait of a write (s), so that ``close`` is noticed promptly."""
_MAX_REST_WAIT = 0.1
"""Longest wait (s) for the rest of a partial frame before reading again."""
_BUSY = (errno.EAGAIN, errno.EWOULDBLOCK, errno.EBUSY)


class StreamDecoder(Protocol):
    """What the framings' incremental decoders provide."""

    @property
    def pending(self) -> int: ...

    @property
    def needed(self) -> int: ...

    def feed(self, chunk: bytes) -> list[Frame]: ...

    def flush(self) -> int: ...


class SerialFrameTransport(Transport):
    """Frames over a serial port (pyserial; URLs such as ``loop://`` work).

    The port is opened exclusively (pyserial's ``exclusive=True``; pass
    ``exclusive=False`` to share it), so a second program cannot open it and
    take half the frames.

    A quiet line is waited on in ``select`` with no wake-ups (``close`` wakes the
    wait through a pipe); a read takes everything that has arrived. When part of a frame has arrived,
    the reader waits the time the rest takes on the line (bytes x 10 / baud
    rate) and takes it in one read, so a byte-paced UART costs about two reads a
    frame and no CPU is spent waiting. A read that times out with part of a frame buffered drops that
    partial frame (the line went quiet mid-frame: it was garbage or truncated).

    Writes go out whole or not at all, within ``write_timeout`` seconds: a
    frame the device took none of raises ``TransportError`` ("not sent") and
    the transport stays usable; a frame the device took only part of is
    finished if the device reads again before the deadline, otherwise the
    transport is marked broken (the device's framing is out of step) and every
    later send fails saying so.
    """

    recv_slice: float | None = 0.25
    """Ports without a file descriptor (URLs, Windows): ``close`` is noticed within this time.
    Ports with one wait in ``select`` until a byte arrives or ``close`` wakes them (None)."""

    def __init__(
        self,
        port: str,
        baudrate: int,
        decoder: StreamDecoder,
        encode: Callable[[Frame], bytes],
        what: str,
        **serial_kwargs: Any,
    ) -> None:
        write_timeout = serial_kwargs.pop("write_timeout", WRITE_TIMEOUT)
        if isinstance(write_timeout, bool) or not isinstance(write_timeout, int | float) or not write_timeout > 0:
            raise TransportOptionError(
                f"cannot open {what} on serial port {port!r}: write_timeout={write_timeout!r} "
                "must be a number of seconds > 0 (a write must not hang)"
            )
        serial_kwargs.setdefault("exclusive", True)
        try:
            self._ser = serial.serial_for_url(
                port, baudrate=baudrate, timeout=READ_TIMEOUT, write_timeout=write_timeout, **serial_kwargs
            )
        except (serial.SerialException, OSError, ValueError, TypeError) as exc:
            hint = ""
            if getattr(exc, "errno", None) in _BUSY or "lock" in str(exc).lower():
                hint = " (another program, or another bus in this one, has the port open)"
            raise TransportError(f"cannot open {what} on serial port {port!r}: {exc}{hint}") from exc
        self._write_timeout = float(write_timeout)
        self._decoder = decoder
        self._encode = encode
        self._frames: deque[Frame] = deque()
        self._byte_time = 10.0 / (self._ser.baudrate or 115200)
        self._wlock = threading.Lock()
        self._closing = threading.Event()
        self._broken: str | None = None
        self._fd: int | None = None
        self._last_chunk = 0.0
        self._wake_w: int | None = None
        self._wait_fds: list[int] = []
        posix = _PosixSerial is not None and isinstance(self._ser, _PosixSerial)
        if posix and type(self._ser).write is _PosixSerial.write:
            self._fd = self._ser.fileno()
            os.set_blocking(self._fd, False)  # pyserial opens it so already; the write loop relies on it
            # close() writes a byte to this pipe, which wakes a wait in select at once; the pipe
            # stays open (and readable) until the transport is collected, so a late wait returns too
            wake_r, self._wake_w = os.pipe()
            weakref.finalize(self, close_fds, wake_r, self._wake_w)
            self._wait_fds = [self._fd, wake_r]
            self.recv_slice = None
        self.description = f"{what} on {port} at {self._ser.baudrate} Bd"

    @property
    def decoder(self) -> StreamDecoder:
        """The stream decoder (its ``dropped`` count tells how much garbage was skipped)."""
        return self._decoder

    # ------------------------------------------------------------------ sending

    def send(self, frame: Frame) -> None:
        data = self._encode(frame)
        with self._wlock:
            if self._closing.is_set():
                raise TransportError(f"{self.description}: closed, frame not sent")
            fd = self._fd
            if fd is None or self._broken is not None:
                self._write(data)
                return
            try:  # the commonest: the device takes the whole frame at once
                sent = os.write(fd, data)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError as exc:
                raise self._failed(0, len(data), f"write failed: {exc}") from exc
            if sent < len(data):
                self._write_fd(fd, data, sent=sent)

    def _write(self, data: bytes, timeout: float | None = None) -> None:
        """Write ``data`` whole (the write lock is held) within ``timeout`` s (None: the write timeout)."""
        if self._broken is not None:
            raise TransportError(f"{self.description}: frame not sent: {self._broken}; close and reopen the bus")
        if self._fd is not None:
            self._write_fd(self._fd, data, timeout)
        else:
            self._write_pyserial(data)

    def _write_fd(self, fd: int, data: bytes, timeout: float | None = None, sent: int = 0) -> None:
        """Write ``data`` whole (its first ``sent`` bytes are out already), counting what the device took;
        never longer than ``timeout`` s (None: the write timeout)."""
        total = len(data)
        limit = self._write_timeout if timeout is None else timeout
        deadline = time.monotonic() + limit
        while True:
            try:
                sent += os.write(fd, data[sent:] if sent else data)
            except (BlockingIOError, InterruptedError):
                pass
            except OSError as exc:
                raise self._failed(sent, total, f"write failed: {exc}") from exc
            if sent >= total:
                return
            left = deadline - time.monotonic()
            if left <= 0:
                break
            if self._closing.is_set():
                raise self._failed(sent, total, "closed while writing")
            try:
                select.select([], [fd], [], min(left, _WRITE_SLICE))
            except (OSError, ValueError) as exc:
                raise self._failed(sent, total, f"write failed: {exc}") from exc
        raise self._failed(sent, total, f"the device took no data for {limit:g} s (not reading?)")

    def _failed(self, sent: int, total: int, why: str) -> TransportError:
        if sent == 0:
            return TransportError(f"{self.description}: frame not sent: {why}")
        self._broken = f"a frame was cut off after {sent} of {total} bytes ({why}); the device's framing is out of step"
        return TransportError(f"{self.description}: {self._broken}; close and reopen the bus")

    def _write_pyserial(self, data: bytes) -> None:
        """Ports without a file descriptor (URLs, Windows): pyserial's write and write timeout."""
        try:
            self._ser.write(data)
        except serial.SerialTimeoutException as exc:  # pyserial does not tell how much went out
            self._broken = (
                f"a write timed out after {self._write_timeout:g} s with part of a frame possibly sent, "
                "so the device's framing may be out of step"
            )
            raise TransportError(f"{self.description}: {self._broken}; close and reopen the bus") from exc
        except (serial.SerialException, OSError, ValueError) as exc:
            raise TransportError(f"{self.description}: frame not sent: write failed: {exc}") from exc

    # ------------------------------------------------------------------ receiving

    def is_closed(self) -> bool:
        return self._closing.is_set()

    def wait_frame(self, timeout: float) -> Frame | None:
        """One read of the port: everything that has arrived, or what comes within ``timeout`` s.

        While the line is quiet and no partial frame is buffered, the wait sleeps in
        ``select`` on the port (no wake-ups); otherwise one read blocks at most
        :data:`READ_TIMEOUT`.
        """
        frames = self._frames
        if frames:
            return frames.popleft()
        ser = self._ser
        decoder = self._decoder
        closing = self._closing
        try:
            waiting = ser.in_waiting
            if decoder.pending:
                # part of a frame is here: give the rest its time on the line, then take it in one read
                need = decoder.needed - waiting
                if need > 0:
                    closing.wait(min(need * self._byte_time, _MAX_REST_WAIT))
                    waiting = ser.in_waiting
            elif not waiting and self._fd is not None and timeout > READ_TIMEOUT:
                if not select.select(self._wait_fds, [], [], timeout)[0] or closing.is_set():
                    return None
                waiting = ser.in_waiting
            chunk = ser.read(waiting or 1)
        except (serial.SerialException, OSError, ValueError, TypeError, AttributeError) as exc:
            if closing.is_set():
                return None
            raise TransportError(f"{self.description}: read failed: {exc}") from exc
        if chunk:
            got = decoder.feed(chunk)
            if got:
                frames.extend(got)
                return frames.popleft()
        elif decoder.pending:
            decoder.flush()
        return None

    def fileno(self) -> int | None:
        """The port's descriptor (None for URLs and ports without one): readable when bytes arrived."""
        return self._fd

    @property
    def capabilities(self) -> Capabilities:
        """A serial line's: frames arrive in pieces (:meth:`rest_time`)."""
        return replace(super().capabilities, partial_frames=True)

    def rest_time(self) -> float:
        """How long (s) the rest of a partly received frame takes on the line (0 when none is):
        a reader waits that long before reading again instead of waking for every byte."""
        decoder = self._decoder
        if not decoder.pending:
            return 0.0
        return min(decoder.needed * self._byte_time, _MAX_REST_WAIT)

    def read_nowait(self) -> list[Frame]:
        """Every frame received so far: those buffered plus one non-blocking read of the port.

        Only for ports with a :meth:`fileno`. A partial frame stays buffered for
        the next read unless :data:`READ_TIMEOUT` passed since its bytes came (then
        it is dropped, as :meth:`wait_frame` does).
        """
        frames = self._frames
        out = list(frames) if frames else []
        frames.clear()
        fd = self._fd
        assert fd is not None, "read_nowait needs a port with a file descriptor"
        try:
            chunk = os.read(fd, 4096)
        except (BlockingIOError, InterruptedError):
            return out
        except OSError as exc:
            if self._closing.is_set():
                return out
            raise TransportError(f"{self.description}: read failed: {exc}") from exc
        if chunk:
            decoder = self._decoder
            now = time.monotonic()
            if decoder.pending and now - self._last_chunk > READ_TIMEOUT:
                decoder.flush()
            self._last_chunk = now
            got = decoder.feed(chunk)
            if got:
                out.extend(got)
        return out

    # ------------------------------------------------------------------ closing

    def close(self) -> None:
        if self._closing.is_set():
            return
        self._closing.set()
        if self._wake_w is not None:
            try:
                os.write(self._wake_w, b"\0")
            except OSError:
                pass
        cancel = getattr(self._ser, "cancel_read", None)
        if cancel is not None:
            try:
                cancel()
            except (serial.SerialException, OSError):
                pass
        # a send in progress notices the close within one write slice; do not close its descriptor under it
        locked = self._wlock.acquire(timeout=max(1.0, 4 * _WRITE_SLICE))
        try:
            self._ser.close()
        finally:
            if locked:
                self._wlock.release()
