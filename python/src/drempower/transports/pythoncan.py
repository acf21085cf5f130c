"""Transport over python-can: any interface and channel python-can supports."""

from __future__ import annotations

import collections
import os
import queue
import select
import socket
import threading
import time
import weakref
from typing import Any

import can
import can.interfaces.virtual
import can.util
import serial
from can.interfaces import VALID_INTERFACES

from ..protocol.ids import Frame, parse_int, timed
from .base import Transport
from .errors import TransportError, TransportOptionError
from .fds import close_fds, drain_close, nonblocking_pipe

__all__ = ["PythonCanTransport", "SEND_TIMEOUT", "CONNECT_TIMEOUT"]

SEND_TIMEOUT = 1.0
"""Default bound (s) of one send: a device that does not take the frame in this time fails the send."""
CONNECT_TIMEOUT = 2.0
"""How long (s) a socketcand server gets to accept the connection and greet."""
_CLOSE_WRITE_TIMEOUT = 0.25
"""Bound (s) of what an interface writes while shutting down (slcan's close command)."""
_SERIAL_PORTS = ("serialPortOrig", "_ser")
"""Where python-can's serial-port interfaces keep their pyserial port (slcan, serial)."""
_KEYS = ("interface", "channel", "bitrate")
_TIMEOUTS = (serial.SerialTimeoutException, TimeoutError)
_new_frame = tuple.__new__
_RECV_ERRORS = (can.CanError, OSError, ValueError, AttributeError, TypeError)
_FD_INTERFACES = frozenset(("socketcan",))
"""python-can interfaces whose own ``fileno()`` turns readable exactly when ``recv(0)`` has a message
to give (their buffers hold no whole message while it is not)."""


def _shown(settings: dict[str, Any]) -> str:
    """``interface=..., channel=..., bitrate=...`` of those in ``settings``."""
    return ", ".join(f"{k}={settings[k]!r}" for k in _KEYS if k in settings)


_EPOCH_TO_MONOTONIC = time.monotonic() - time.time()
"""Added to a python-can receive timestamp (s since the epoch) to put it on the monotonic scale."""


def _frame(msg: can.Message) -> Frame:
    """The frame a python-can message carries, with its receive timestamp when the interface gives one."""
    frame: Frame = _new_frame(Frame, (msg.arbitration_id, bytes(msg.data), msg.is_extended_id, msg.is_remote_frame))
    at = msg.timestamp + _EPOCH_TO_MONOTONIC
    if abs(at - time.monotonic()) < 10.0:  # seconds since the epoch (others: 0, or the device's own scale)
        return timed(frame, at)
    return frame


def _why(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _probe_socketcand(host: object, port: object, timeout: float) -> None:
    """Connect to a socketcand server and wait for its greeting, or raise TransportError naming host:port.

    python-can itself retries a refused connection for 10 s, logging a warning
    each time, and waits for the greeting without a timeout.
    """
    where = f"{host}:{port}"
    if host is None or port is None:
        raise TransportError(f"cannot open python-can socketcand bus: give host= and port= of the server (got {where})")
    try:
        conn = socket.create_connection((str(host), parse_int(str(port), "port")), timeout=timeout)
    except TimeoutError as exc:
        raise TransportError(f"cannot reach socketcand at {where}: no connection in {timeout:g} s") from exc
    except (OSError, ValueError) as exc:
        raise TransportError(f"cannot reach socketcand at {where}: {_why(exc)}") from exc
    greeting = b""
    with conn:
        deadline = time.monotonic() + timeout
        try:
            while b">" not in greeting and len(greeting) < 256:
                conn.settimeout(max(0.001, deadline - time.monotonic()))
                chunk = conn.recv(256)
                if not chunk:
                    break
                greeting += chunk
        except OSError:
            pass
    if not greeting.strip().startswith(b"< hi >"):
        got = f"got {greeting!r}" if greeting else f"got nothing in {timeout:g} s"
        raise TransportError(
            f"cannot open python-can socketcand bus at {where}: the server did not greet with '< hi >' ({got}); "
            "is it a socketcand server?"
        )


SOCKETCAND_TX_LATENCY = 0.02
"""Margin (s) a socketcand link adds before a batch's start (see ``Transport.tx_latency``)."""


class _SignalQueue(queue.Queue):  # type: ignore[type-arg]
    """python-can's virtual bus queue that also writes a byte to a pipe for each message put in it, so
    that the pipe's read end turns readable when messages arrive (a reader empties the pipe, then the queue)."""

    def __init__(self, signal_w: int, maxsize: int = 0) -> None:
        super().__init__(maxsize)
        self._signal_w = signal_w
        self.signal_r = -1
        """The pipe's read end."""

    def put(self, item: Any, block: bool = True, timeout: float | None = None) -> None:
        super().put(item, block, timeout)
        try:  # after the queue's lock is released: the woken reader takes the message at once
            os.write(self._signal_w, b"\0")
        except OSError:  # full: a byte is already waiting; closed: nobody reads
            pass


def _virtual_put(bus: can.BusABC) -> bool:
    """True when python-can's virtual ``bus`` is laid out as python-can 4 lays it out, so that a frame can
    be put in its peers' queues directly (:meth:`PythonCanTransport._send_virtual`)."""
    return (
        isinstance(getattr(bus, "channel", None), list)
        and isinstance(getattr(bus, "_open", None), bool)
        and isinstance(getattr(bus, "receive_own_messages", None), bool)
        and getattr(bus, "preserve_timestamps", None) is False
        and hasattr(bus, "channel_id")
        and isinstance(getattr(bus, "queue", None), queue.Queue)
        and getattr(type(bus), "send", None) is can.interfaces.virtual.VirtualBus.send
    )


def _signal_virtual(bus: can.BusABC) -> _SignalQueue | None:
    """Give python-can's virtual ``bus`` a queue whose pipe turns readable when a message reaches it;
    None when the bus is not laid out as python-can 4 lays it out (the bus is then left as is)."""
    from can.interfaces import virtual

    old = getattr(bus, "queue", None)
    peers = getattr(bus, "channel", None)
    lock = getattr(virtual, "channels_lock", None)
    if type(old) is not queue.Queue or not isinstance(peers, list) or lock is None:
        return None
    r, w = nonblocking_pipe()
    new = _SignalQueue(w, old.maxsize)
    with lock:
        index = next((i for i, q in enumerate(peers) if q is old), None)
        if index is None:
            close_fds(r, w)
            return None
        peers[index] = new
        bus.queue = new  # type: ignore[attr-defined]
    while True:  # what reached the old queue before the swap
        try:
            new.put_nowait(old.get_nowait())
        except (queue.Empty, queue.Full):
            break
    weakref.finalize(new, close_fds, r, w)  # with the queue: a sender that still holds it writes to its pipe
    new.signal_r = r
    return new


class PythonCanTransport(Transport):
    """A python-can bus carrying DrEmpower frames.

    ``interface``, ``channel`` and ``bitrate`` follow python-can; any that are
    None are left out, so python-can's own configuration (its config file and
    ``CAN_INTERFACE``/``CAN_CHANNEL``/``CAN_BITRATE`` environment variables)
    fills them in. The configuration is resolved first, so an error names the
    interface, channel and bitrate actually tried. Other keyword arguments go
    to :class:`can.Bus` unchanged. Error frames are skipped.

    A send that the device does not take within ``send_timeout`` seconds
    raises :class:`TransportError` (the timeout goes to ``bus.send`` and, for
    interfaces on a serial port such as slcan and python-can's ``serial``, to
    the port's write timeout; for socketcand to the socket). A socketcand
    server is probed first (connection and greeting within
    :data:`CONNECT_TIMEOUT`), so a missing one fails at once naming host:port.

    ``socketcan``, ``socketcand`` and ``virtual`` buses offer a descriptor
    (:meth:`fileno`) that callers wait on in ``select`` and read with
    :meth:`read_nowait`, with no thread handoff; other interfaces are read by
    the bus's receive thread.
    """

    def __init__(
        self,
        interface: str | None = None,
        channel: str | int | None = None,
        bitrate: int | None = None,
        *,
        send_timeout: float = SEND_TIMEOUT,
        **kwargs: Any,
    ) -> None:
        if isinstance(send_timeout, bool) or not isinstance(send_timeout, int | float) or not send_timeout > 0:
            raise TransportError(f"send_timeout={send_timeout!r}: give a number of seconds > 0 (a send must not hang)")
        self._send_timeout = float(send_timeout)
        given = dict(kwargs)
        for key, value in zip(_KEYS, (interface, channel, bitrate), strict=True):
            if value is not None:
                given[key] = value
        cfg = self._resolve(given)
        tried = _shown({k: v for k, v in cfg.items() if v is not None})
        configured = [k for k in _KEYS if k not in given and cfg.get(k) is not None]
        if configured:
            tried += f"; {', '.join(configured)} from python-can's configuration"
        name = cfg["interface"]
        if name == "socketcand":
            _probe_socketcand(cfg.get("host"), cfg.get("port"), CONNECT_TIMEOUT)
        try:
            self._bus = can.Bus(ignore_config=True, **cfg)
        except can.CanInterfaceNotImplementedError as exc:
            raise TransportError(f"cannot open python-can bus ({tried}): {exc}") from exc
        except Exception as exc:  # drivers fail in many ways (a missing vendor library can raise NameError)
            raise TransportError(f"cannot open python-can bus ({tried}): {_why(exc)}") from exc
        self._bound_writes(self._send_timeout)
        self._closing = threading.Event()
        self._recv_lock = threading.Lock()
        self._send_lock = threading.Lock()
        rate = cfg.get("bitrate")
        self.wire_bitrate = rate if isinstance(rate, int) and rate > 0 else None
        self._signal_r: int | None = None
        self._queue: queue.Queue[can.Message] | None = None
        """The virtual bus's queue, read directly (no filters: python-can's recv would take every message)."""
        self._socket: socket.socket | None = None
        self._parsed: collections.deque[can.Message] | None = None
        """socketcand's messages parsed and not yet returned by its ``recv``: empty, the socket tells the rest."""
        self._fd = self._descriptor(name)
        # python-can's virtual send walks the channel's list of queues without a lock while a bus shutting
        # down removes its queue from it (under channels_lock): the walk then skips the queue after it
        self._send_guard: threading.RLock | None = can.interfaces.virtual.channels_lock if name == "virtual" else None
        self._direct = name == "virtual" and _virtual_put(self._bus)
        """Frames go straight into the virtual channel's queues, one new message each (python-can's own send
        deep-copies the message for each, which costs more than the rest of a request)."""
        if name == "socketcand":  # a TCP hop and the server's own queue before the bus
            self.tx_latency = SOCKETCAND_TX_LATENCY
            self.unbounded_latency = True
        info = str(getattr(self._bus, "channel_info", "") or "")
        chan = cfg.get("channel")
        if info and info != "unknown" and (chan is None or str(chan) in info):
            self.description = f"python-can {info}"
        else:
            self.description = f"python-can {name} {chan}" if chan is not None else f"python-can {name}"

    def _descriptor(self, name: str) -> int | None:
        """The descriptor that turns readable when :meth:`read_nowait` has frames to give, or None.

        None where python-can filters in software (``can_filters`` on ``virtual`` or ``socketcand``): its
        ``recv(0)`` then returns None at a message it drops, with more held, so the thread path is used.
        """
        bus = self._bus
        sock = getattr(bus, "_SocketCanDaemonBus__socket", None) if name == "socketcand" else None
        if isinstance(sock, socket.socket):
            self._socket = sock  # (also read by threads: wait_frame tells a server gone by it)
        if getattr(bus, "_filters", None) and name in ("virtual", "socketcand"):
            return None
        if name == "virtual":
            signalled = _signal_virtual(bus)
            if signalled is None:
                return None
            self._queue = signalled
            self._signal_r = signalled.signal_r
            return self._signal_r
        if name == "socketcand":
            if isinstance(sock, socket.socket):
                parsed = getattr(bus, "_SocketCanDaemonBus__message_buffer", None)
                self._parsed = parsed if isinstance(parsed, collections.deque) else None
                return sock.fileno()
            return None
        if name in _FD_INTERFACES:
            try:
                fd = bus.fileno()
            except (NotImplementedError, can.CanError, OSError, ValueError):
                return None
            return fd if isinstance(fd, int) and fd >= 0 else None
        return None

    @staticmethod
    def _resolve(given: dict[str, Any]) -> dict[str, Any]:
        """python-can's configuration (what is given, can.rc, CAN_* variables, config files) as can.Bus resolves it."""
        context = given.pop("config_context", None)
        if given.pop("ignore_config", False):
            cfg = dict(given)
            cfg.setdefault("interface", None)
            cfg.setdefault("channel", None)
        else:
            try:
                cfg = dict(can.util.load_config(config=dict(given), context=context))
            except can.CanInterfaceNotImplementedError as exc:  # the interface is missing or unknown
                if "interface" in given or '"None"' in str(exc):
                    cfg = {"interface": given.get("interface")}
                else:
                    raise TransportError(
                        f"cannot open python-can bus: python-can's configuration names an unknown interface: {exc}. "
                        f"Interfaces python-can knows: {', '.join(sorted(VALID_INTERFACES))}"
                    ) from exc
            except Exception as exc:
                raise TransportError(
                    f"cannot open python-can bus ({_shown(given) or 'nothing given'}): "
                    f"python-can's configuration is invalid: {_why(exc)}"
                ) from exc
        name = cfg.get("interface")
        if name is None:
            raise TransportError(
                "cannot open python-can bus: no interface given, and python-can's configuration names "
                f"no interface (config files {', '.join(can.util.CONFIG_FILES)}, or CAN_INTERFACE). "
                "Give interface= (and channel=), e.g. 'socketcan' 'can0'"
            )
        if name not in VALID_INTERFACES:  # a typo (simm) is the user's to fix: a TransportOptionError (exit 2)
            raise TransportOptionError(
                f"cannot open python-can bus ({_shown(given)}): unknown interface {name!r}. Interfaces "
                f"python-can knows: {', '.join(sorted(VALID_INTERFACES))}; drempower adds 'adapter', 'serial', "
                "'uart' and 'sim'"
            )
        return cfg

    def _bound_writes(self, seconds: float) -> None:
        """Give the interface's own serial port or socket a write timeout, where it has one."""
        for attr in _SERIAL_PORTS:
            port = getattr(self._bus, attr, None)
            if port is not None and hasattr(port, "write_timeout"):
                try:
                    port.write_timeout = seconds
                except (OSError, ValueError):
                    pass
        sock = getattr(self._bus, "_SocketCanDaemonBus__socket", None)
        if isinstance(sock, socket.socket):
            try:
                sock.settimeout(seconds)
            except OSError:
                pass

    @property
    def bus(self) -> can.BusABC:
        """The underlying python-can bus."""
        return self._bus

    def send(self, frame: Frame) -> None:
        if self._direct:
            self._send_virtual(frame)
            return
        msg = can.Message(
            arbitration_id=frame[0],
            data=frame[1],
            is_extended_id=frame[2],
            is_remote_frame=frame[3],
        )
        with self._send_lock:
            if self._closing.is_set():
                raise TransportError(f"{self.description}: closed, frame not sent")
            try:
                guard = self._send_guard
                if guard is None:
                    self._bus.send(msg, timeout=self._send_timeout)
                else:
                    with guard:
                        self._bus.send(msg, timeout=self._send_timeout)
            except (can.CanError, OSError, ValueError) as exc:
                cause = exc.__cause__
                if isinstance(exc, can.CanTimeoutError | TimeoutError) or isinstance(cause, _TIMEOUTS):
                    raise TransportError(
                        f"{self.description}: send did not complete in {self._send_timeout:g} s "
                        "(the device is not taking data)"
                    ) from exc
                why = _why(exc) if cause is None else f"{_why(exc)} ({_why(cause)})"
                raise TransportError(f"{self.description}: send failed: {why}") from exc

    def _send_virtual(self, frame: Frame) -> None:
        """:meth:`send` on python-can's virtual bus: what its ``send`` does (a message per other bus of the
        channel, and its own with ``receive_own_messages``, stamped now, ``is_rx`` set; an error when a full
        queue refused it), without the deep copy."""
        bus: Any = self._bus
        arb, data, ext, rtr = frame
        if data.__class__ is not bytes:  # a bytearray would be shared by every receiver (python-can copies)
            data = bytes(data)
        with self._send_lock:
            if self._closing.is_set():
                raise TransportError(f"{self.description}: closed, frame not sent")
            assert self._send_guard is not None
            with self._send_guard:
                if not bus._open:
                    raise TransportError(f"{self.description}: send failed: the python-can bus is shut down")
                now = time.time()
                own, own_too, channel_id = bus.queue, bus.receive_own_messages, bus.channel_id
                refused = 0
                for q in bus.channel:
                    if q is own and not own_too:
                        continue
                    msg = can.Message(
                        timestamp=now,
                        arbitration_id=arb,
                        is_extended_id=ext,
                        is_remote_frame=rtr,
                        data=data,
                        channel=channel_id,
                        is_rx=q is not own,
                    )
                    try:
                        q.put(msg, True, self._send_timeout)
                    except queue.Full:
                        refused += 1
            if refused:
                raise TransportError(
                    f"{self.description}: send did not complete in {self._send_timeout:g} s "
                    f"({refused} receiving bus(es) of the virtual channel full)"
                )

    def is_closed(self) -> bool:
        return self._closing.is_set()

    def wait_frame(self, timeout: float) -> Frame | None:
        """One receive of the python-can bus (error frames are skipped: None, the loop waits again)."""
        try:
            with self._recv_lock:
                if self._closing.is_set():
                    return None
                msg = self._bus.recv(timeout)
                if msg is None and self._socket is not None:  # python-can's socketcand misses a server gone
                    self._check_connected(self._socket)
        except _RECV_ERRORS as exc:
            if self._closing.is_set():
                return None
            raise TransportError(f"{self.description}: receive failed: {exc}") from exc
        if msg is None or msg.is_error_frame:
            return None
        return _frame(msg)

    def fileno(self) -> int | None:
        """A descriptor that turns readable when :meth:`read_nowait` has frames to give: the socket of
        ``socketcan`` and ``socketcand``, a pipe signalled by the ``virtual`` bus's queue; None for other
        interfaces (frames are then received in a thread)."""
        return self._fd

    def read_nowait(self) -> list[Frame]:
        """Every frame python-can has for us now, without waiting (error frames are skipped)."""
        if self._signal_r is not None:
            try:  # first: a message that arrives meanwhile leaves the pipe readable
                os.read(self._signal_r, 4096)
            except OSError:  # empty (non-blocking), or closed
                pass
        out: list[Frame] = []
        q = self._queue
        try:
            with self._recv_lock:
                if self._closing.is_set():
                    return out
                if q is not None:
                    # this bus is the queue's only reader (under _recv_lock): a message counted is there to
                    # get, and looking at the count spares the failed get (and its exception) that ends a loop
                    waiting = q.queue
                    while waiting:
                        queued = q.get_nowait()
                        if not queued.is_error_frame:
                            out.append(_frame(queued))
                    return out
                recv, parsed = self._bus.recv, self._parsed
                while (msg := recv(0.0)) is not None:
                    if not msg.is_error_frame:
                        out.append(_frame(msg))
                    if parsed is not None and not parsed:
                        break  # nothing parsed is left: more leaves the socket readable (no recv finding none)
                if not out and self._socket is not None:
                    self._check_connected(self._socket)
        except _RECV_ERRORS as exc:
            if self._closing.is_set():
                return out
            raise TransportError(f"{self.description}: receive failed: {exc}") from exc
        return out

    def _check_connected(self, sock: socket.socket) -> None:
        """Raise TransportError when the server closed the connection (python-can's socketcand does not
        notice: its socket stays readable with nothing to read)."""
        if not select.select([sock], [], [], 0)[0]:
            return  # nothing to read: open (a socket with a timeout would wait in recv, whatever the flags)
        if sock.recv(1, socket.MSG_PEEK) == b"":
            raise TransportError(f"{self.description}: the socketcand server closed the connection")

    def close(self) -> None:
        """Shut the python-can bus down; bounded even when the device stopped reading."""
        if self._closing.is_set():
            return
        self._closing.set()
        self._bound_writes(min(self._send_timeout, _CLOSE_WRITE_TIMEOUT))
        # let a send or a receive in progress end first: some interfaces fail loudly otherwise
        sending = self._send_lock.acquire(timeout=self._send_timeout + 0.5)
        receiving = self._recv_lock.acquire(timeout=1.0)
        try:
            if self._socket is not None:  # socketcand: the last frames sent (the stops) must not be reset
                try:
                    drain_close(self._socket)
                except Exception:  # whatever happens, python-can's own shutdown runs
                    pass
            self._bus.shutdown()
        except Exception:  # e.g. slcan's close command timing out: release the port anyway
            for attr in _SERIAL_PORTS:
                port = getattr(self._bus, attr, None)
                if port is not None and hasattr(port, "close"):
                    try:
                        port.close()
                    except Exception:  # closing what is left, best effort
                        pass
        finally:
            if receiving:
                self._recv_lock.release()
            if sending:
                self._send_lock.release()
