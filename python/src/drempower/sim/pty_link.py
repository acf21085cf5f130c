"""A pseudo-terminal served by a thread: the base of the serial attachments.

The master end is in raw mode and non-blocking; the simulator keeps the slave
end open too, so clients may open and close ``path`` as often as they like.
Incoming bytes go to :meth:`PtyLink.received` in whatever pieces they arrive;
:meth:`PtyLink.write` queues bytes for the client. When nobody reads and the
queue overflows, what is waiting is discarded, as a USB serial adapter does when
no program has its port open.
"""

from __future__ import annotations

import os
import select
import termios
import threading
import tty
from abc import ABC, abstractmethod
from types import TracebackType
from typing import TypeVar

__all__ = ["PtyLink"]

_Link = TypeVar("_Link", bound="PtyLink")

_OUT_LIMIT = 1 << 16
"""Most bytes queued for the client before the queue is discarded."""


class PtyLink(ABC):
    """Owns a pty pair and a thread moving bytes through its master end. ``path`` is the slave's name."""

    def __init__(self, name: str) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._master)
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        """The device a client opens, e.g. ``/dev/pts/5``."""
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        self._pending = bytearray()
        self._out_lock = threading.Lock()
        self._closed = False
        self._thread = threading.Thread(target=self._serve, name=name, daemon=True)

    def _start(self) -> None:
        self._thread.start()

    @abstractmethod
    def received(self, data: bytes) -> None:
        """Bytes from the client, in the pieces they arrived in."""

    def write(self, data: bytes) -> None:
        """Queue ``data`` for the client. When the queue overflows, nobody is reading: what is
        waiting, here and in the terminal, is discarded first."""
        with self._out_lock:
            if len(self._pending) + len(data) > _OUT_LIMIT:
                termios.tcflush(self._slave, termios.TCIFLUSH)
                self._pending.clear()
            self._pending += data
        self._wake()

    def _wake(self) -> None:
        try:
            os.write(self._wake_w, b"\0")
        except BlockingIOError:
            pass  # the thread has wake-ups pending already

    def _serve(self) -> None:
        master = self._master
        while not self._closed:
            with self._out_lock:
                pending = bool(self._pending)
            readable, writable, _ = select.select([master, self._wake_r], [master] if pending else [], [])
            if self._wake_r in readable:
                os.read(self._wake_r, 4096)
            if master in readable:
                try:
                    data = os.read(master, 4096)
                except BlockingIOError:
                    data = b""
                if data:
                    self.received(data)
            if master in writable:
                self._flush()

    def _flush(self) -> None:
        with self._out_lock:
            try:
                n = os.write(self._master, self._pending)
            except BlockingIOError:
                return
            del self._pending[:n]

    def close(self) -> None:
        """Stop the thread and close the terminal (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._wake()
        if self._thread.is_alive():
            self._thread.join()
        for fd in (self._master, self._slave, self._wake_r, self._wake_w):
            os.close(fd)

    def __enter__(self: _Link) -> _Link:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
