"""Termination signals (SIGTERM, SIGHUP) stop what this process started, like Ctrl-C.

Two policies, one per kind of program:

* The Python API (:func:`install_stop_handlers`, called when a bus with
  ``stop_on_close`` opens): on SIGTERM or SIGHUP every open bus with
  ``stop_on_close`` is closed at once (its commanded motors go idle, or get an
  emergency stop), then the handler that was installed before is called; when
  there was none (the default action) the process exits with 128 + the signal
  number (``SystemExit``). Handlers are installed only from the main thread
  (Python allows no other) and never over a signal that is ignored (``nohup``
  ignores SIGHUP: the program keeps running and so do its motors). A handler
  the program installs later replaces this one: call
  :func:`stop_open_buses` from it to keep the guarantee. A handler that
  interrupted its own thread in the middle of a bus's work (a send, say)
  does not write to that bus: a thread of its own closes it as soon as the
  interrupted code lets it go, and closing it again waits for that.
* Commands (:func:`signals_interrupt`): SIGTERM and SIGHUP raise
  :class:`Terminated`, a :class:`KeyboardInterrupt`, so every path that
  handles Ctrl-C handles them too; :func:`exit_code` turns it into 128 + the
  signal number. Only the first signal raises: one arriving while the command
  stops its motors sets :func:`hurried` and lets the stop finish.
* Servers that wait in a loop (:class:`SignalLatch`): SIGINT, SIGTERM and
  SIGHUP are noted and wake the wait; the server then stops in its own time.
"""

from __future__ import annotations

import signal
import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

__all__ = [
    "TERMINATING_SIGNALS",
    "SignalLatch",
    "Terminated",
    "exit_code",
    "hurried",
    "install_stop_handlers",
    "signals_interrupt",
    "stop_open_buses",
]

TERMINATING_SIGNALS: tuple[signal.Signals, ...] = tuple(
    s for s in (getattr(signal, "SIGTERM", None), getattr(signal, "SIGHUP", None)) if s is not None
)
"""The signals that end a process politely: systemd and docker stop (SIGTERM), a closed terminal (SIGHUP)."""

_Handler = Callable[[int, FrameType | None], Any] | int | None

_previous: dict[int, _Handler] = {}
"""Per signal, the handler that was installed before :func:`_stop_and_chain`."""
_stoppers: list[Callable[[], None]] = []


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP received by a command: handled as Ctrl-C is, then exit 128 + ``signum``."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum

    def __str__(self) -> str:
        return signal.Signals(self.signum).name


def exit_code(exc: KeyboardInterrupt) -> int:
    """128 + the signal number that ended the process (SIGINT, 2, for a plain Ctrl-C)."""
    return 128 + (exc.signum if isinstance(exc, Terminated) else signal.SIGINT)


def register_stopper(stop: Callable[[], None]) -> None:
    """Called (once) by the client driver: ``stop()`` closes every open bus with ``stop_on_close``."""
    if stop not in _stoppers:
        _stoppers.append(stop)


def stop_open_buses() -> None:
    """Close every open bus with ``stop_on_close`` now (for a program's own signal handler)."""
    for stop in list(_stoppers):
        stop()


class _Flags:
    """What the handlers have seen. Plain attributes, not :class:`threading.Event`: a handler runs between
    two bytecodes of the main thread, possibly inside another handler's ``Event.set()`` holding its lock,
    which a second ``set()`` would then wait for forever."""

    stopping = False
    terminating = False
    hurry = False


def _stop_and_chain(signum: int, frame: FrameType | None) -> None:
    if _Flags.stopping:
        return  # a repeated signal must not interrupt the closing the first one started
    _Flags.stopping = True
    try:
        stop_open_buses()
    finally:
        _Flags.stopping = False
    previous = _previous.get(signum)
    if callable(previous):
        previous(signum, frame)
        return
    raise SystemExit(128 + signum)


_stop_and_chain._drempower_stops = True  # type: ignore[attr-defined]


def install_stop_handlers() -> None:
    """Make SIGTERM and SIGHUP close the open buses first (see the module docstring). Idempotent."""
    if threading.current_thread() is not threading.main_thread():
        return
    for signum in TERMINATING_SIGNALS:
        current = signal.getsignal(signum)
        if current is signal.SIG_IGN or current is None or getattr(current, "_drempower_stops", False):
            continue  # ignored on purpose, set outside Python, or already stopping the buses
        _previous[signum] = current
        signal.signal(signum, _stop_and_chain)


def hurried() -> bool:
    """Whether a second signal arrived while a command was stopping: skip what only waits, never a stop frame."""
    return _Flags.hurry


def _raise_terminated(signum: int, frame: FrameType | None) -> None:
    if _Flags.terminating:
        # a repeated signal (SIGINT or SIGTERM twice, or one of each) must not interrupt the stopping the
        # first one started: it only asks the stop to leave out its waiting niceties
        _Flags.hurry = True
        return
    _Flags.terminating = True
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Terminated(signum)


_raise_terminated._drempower_stops = True  # type: ignore[attr-defined]


def _replace_handlers(handler: Callable[[int, FrameType | None], Any], saved: dict[int, _Handler]) -> None:
    """Install ``handler`` for SIGINT, SIGTERM and SIGHUP, but where a signal is ignored (``nohup``'s
    SIGHUP stays ignored); notes in ``saved`` each handler it replaced, as it goes, for :func:`_put_back`."""
    for signum in (signal.SIGINT, *TERMINATING_SIGNALS):
        current = signal.getsignal(signum)
        if current is not signal.SIG_IGN:
            saved[signum] = current
            signal.signal(signum, handler)


def _put_back(saved: dict[int, _Handler]) -> None:
    """Reinstall the handlers :func:`_replace_handlers` replaced (one set outside Python: the default)."""
    for number, handler in saved.items():
        signal.signal(number, handler if handler is not None else signal.SIG_DFL)


@contextmanager
def signals_interrupt(*, until_exit: bool = False) -> Iterator[None]:
    """While inside: SIGINT, SIGTERM and SIGHUP raise in the main thread (the handlers restored afterwards).

    The first of them raises :class:`KeyboardInterrupt` (SIGINT) or
    :class:`Terminated`; any later one only sets :func:`hurried`, so that a
    second Ctrl-C or a SIGTERM right after it never cuts the stopping short. A
    signal that is ignored (SIGHUP under ``nohup``) stays ignored. Outside
    the main thread this does nothing.

    ``until_exit`` is for a program that ends when the block does (the
    ``drempower`` command): once a signal has ended the block, the handlers
    are not put back, so a second signal arriving late (after the stop, while
    the program reports it) is absorbed too and the exit code stays 128 + the
    first signal's number instead of the default action killing the process.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _Flags.terminating = _Flags.hurry = False
    saved: dict[int, _Handler] = {}
    try:
        _replace_handlers(_raise_terminated, saved)
        yield
    finally:
        if not (until_exit and _Flags.terminating):
            _put_back(saved)
            _Flags.terminating = _Flags.hurry = False


class SignalLatch:
    """SIGINT, SIGTERM and SIGHUP noted for a server's wait loop, without a lock.

    A handler runs between two bytecodes of the main thread. One that calls
    :meth:`threading.Event.set` can run while that same thread is inside the
    event's ``wait()`` holding its lock, and then waits for itself forever (a
    server that never stops). This handler only keeps the first signal number
    and sends a byte to a socket pair, whose other end :meth:`wait` reads.

    :meth:`install` it (or enter it as a context manager) from the main
    thread; elsewhere it notes nothing and :meth:`wait` only sleeps. A signal
    that is ignored (SIGHUP under ``nohup``) stays ignored. :meth:`close` puts
    back the handlers it replaced.
    """

    def __init__(self) -> None:
        self.signum: int | None = None
        """The first signal received, or ``None``."""
        self._read, self._write = socket.socketpair()
        self._write.setblocking(False)
        self._saved: dict[int, _Handler] = {}

    def _note(self, signum: int, _frame: FrameType | None) -> None:
        if self.signum is None:
            self.signum = signum
        try:
            self._write.send(b"\0")
        except OSError:
            pass  # full: a wake-up is already waiting

    def install(self) -> None:
        """Note SIGINT, SIGTERM and SIGHUP from now on (in the main thread; elsewhere nothing)."""
        if threading.current_thread() is threading.main_thread() and not self._saved:
            _replace_handlers(self._note, self._saved)

    def wait(self, timeout: float) -> bool:
        """Wait up to ``timeout`` seconds for a signal; whether one has been received (now or before)."""
        if self.signum is None:
            try:
                self._read.settimeout(timeout)
                self._read.recv(64)
            except OSError:  # the timeout (or a closed pair: nothing more to wait for)
                pass
        return self.signum is not None

    def close(self) -> None:
        """Put back the handlers it replaced and close the socket pair. Idempotent."""
        _put_back(self._saved)
        self._saved = {}
        self._read.close()
        self._write.close()

    def __enter__(self) -> SignalLatch:
        self.install()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
