"""A remote bus: the frames of a bus served by ``drempower bridge``, tunnelled over Zenoh."""

from __future__ import annotations

import itertools
import json
import threading
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from ..protocol.ids import Frame
from .base import QueuedTransport
from .capabilities import Capabilities
from .errors import TransportError

__all__ = ["ZenohTransport", "OPEN_TIMEOUT"]

OPEN_TIMEOUT = 2.0
"""s to wait for the bridge to answer when opening."""


def _endpoints(value: str | Sequence[str] | None) -> list[str] | None:
    if value is None:
        return None
    return [value] if isinstance(value, str) else list(value)


class ZenohTransport(QueuedTransport):
    """The bus a bridge serves under key prefix ``channel``, reached through Zenoh.

    ``connect``/``listen``: Zenoh endpoints (one or a list; ``connect`` defaults
    to the local router ``tcp/localhost:7447``); ``scout`` turns on multicast
    scouting, ``gossip`` (default on) Zenoh's gossip scouting. Emergency stops
    travel on their own key at Zenoh's real-time priority. The bridge watches
    this client through a liveliness token (closed, killed, or its network lost
    for the lease time) and through its command timeout: once this client has
    sent a frame that sets a motor moving, it sends a keep-alive every quarter of
    the bridge's ``command_timeout`` until closed, and when nothing of it arrives
    for that long (the process frozen, the link cut) the bridge idles the motors
    it set moving.
    """

    tx_latency = 0.05
    """Margin (s) before a batch's start: a frame crosses the network, then waits in the bridge's own bus."""

    def __init__(
        self,
        channel: str | None = None,
        *,
        connect: str | Sequence[str] | None = None,
        listen: str | Sequence[str] | None = None,
        scout: bool = False,
        gossip: bool = True,
        open_timeout: float = OPEN_TIMEOUT,
    ) -> None:
        try:
            import zenoh
        except ImportError as exc:
            raise TransportError("interface 'zenoh' needs eclipse-zenoh: pip install 'drempower[bridge]'") from exc
        from .zenoh_config import open_session
        from .zenoh_wire import DEFAULT_PREFIX, decode_frames, driven_nodes, encode_frames, is_estop, join_origin, keys

        prefix = DEFAULT_PREFIX if channel is None else str(channel)
        try:
            self._keys = keys(prefix)
        except ValueError as exc:
            raise TransportError(f"cannot open remote bus: channel {exc}") from exc
        self._encode, self._decode, self._is_estop, self._join = encode_frames, decode_frames, is_estop, join_origin
        self._driven_nodes = driven_nodes
        self._keepalive: threading.Thread | None = None
        self._stop = threading.Event()
        self._seq = itertools.count(1)  # thread-safe: one number per sample, tx and estop alike
        super().__init__()
        self._close_lock = threading.Lock()
        where = ", ".join([*(_endpoints(connect) or ["tcp/localhost:7447"]), *(_endpoints(listen) or [])])
        self._session: Any
        try:
            self._session = open_session(_endpoints(connect), _endpoints(listen) or (), scout=scout, gossip=gossip)
        except ValueError as exc:
            raise TransportError(f"cannot open remote bus {prefix!r}: {exc}") from exc
        except TransportError as exc:
            raise TransportError(f"cannot open remote bus {prefix!r}: {exc}") from exc
        try:
            self._id = str(self._session.zid()).encode()
            self._sub = self._session.declare_subscriber(self._keys["rx"], self._on_rx)
            self._tx = self._session.declare_publisher(
                self._keys["tx"],
                priority=zenoh.Priority.DATA,
                express=True,
                congestion_control=zenoh.CongestionControl.BLOCK,
            )
            self._estop = self._session.declare_publisher(
                self._keys["estop"],
                priority=zenoh.Priority.REAL_TIME,
                express=True,
                congestion_control=zenoh.CongestionControl.BLOCK,
            )
            self._alive = self._session.declare_publisher(
                self._keys["alive"],
                priority=zenoh.Priority.DATA_HIGH,
                express=True,
                congestion_control=zenoh.CongestionControl.DROP,
            )
            self._token = self._session.liveliness().declare_token(f"{self._keys['clients']}/{self._id.decode()}")
            info = self._info(open_timeout)
        except BaseException:
            self._session.close()
            raise
        if info is None:
            self._session.close()
            raise TransportError(
                f"cannot open remote bus {prefix!r}: no drempower bridge answered on {self._keys['info']} "
                f"within {open_timeout:g} s (endpoints: {where})"
            )
        self.info: dict[str, Any] = info
        """What the bridge said of its bus: description, default_timeout, motors, joints."""
        timeout = info.get("default_timeout")
        self.default_timeout = float(timeout) if isinstance(timeout, (int, float)) else None
        watch = info.get("command_timeout")
        self.keepalive_period: float | None = (
            float(watch) / 4 if isinstance(watch, (int, float)) and watch > 0 else None
        )
        """s between keep-alives once this client drove a motor (None: the bridge watches liveliness only)."""
        self.description = f"zenoh {prefix} via {where}: {info.get('description', '?')}"
        limits = info.get("limits")
        self.limits: dict[int, dict[str, Any]] = (
            {int(k): dict(v) for k, v in limits.items() if isinstance(v, dict)} if isinstance(limits, dict) else {}
        )
        """The soft limits the bridge holds its motors to (motor units, its robot file's): the bus on this
        transport holds its commands to them too, so a refusal is an error here, not a silent drop there."""

    @property
    def capabilities(self) -> Capabilities:
        """A remote bus's: the soft limits its bridge holds the motors to."""
        return replace(super().capabilities, limits=self.limits)

    def _info(self, timeout: float) -> dict[str, Any] | None:
        for reply in self._session.get(self._keys["info"], timeout=timeout):
            if reply.ok is not None:
                try:
                    data = json.loads(reply.ok.payload.to_bytes())
                except ValueError:
                    continue
                if isinstance(data, dict):
                    return data
        return None

    def _on_rx(self, sample: Any) -> None:
        origin = sample.attachment.to_bytes() if sample.attachment is not None else b""
        if origin == self._id:
            return
        try:
            frames = self._decode(sample.payload.to_bytes())
        except ValueError:
            return
        for f in frames:
            self._queue.put(f)

    def send(self, frame: Frame) -> None:
        if self._closed:
            raise TransportError(f"remote bus {self._keys['tx']} is closed")
        pub = self._estop if self._is_estop(frame) else self._tx
        try:
            pub.put(self._encode((frame,)), attachment=self._join(self._id, next(self._seq)))
        except Exception as exc:
            raise TransportError(f"remote bus {self._keys['tx']}: sending failed: {exc}") from exc
        if self._keepalive is None and self.keepalive_period is not None and self._driven_nodes((frame,)):
            self._start_keepalive()

    def _start_keepalive(self) -> None:
        with self._close_lock:
            if self._keepalive is not None or self._closed:
                return
            self._keepalive = threading.Thread(
                target=self._keepalive_loop, name="drempower zenoh keep-alive", daemon=True
            )
            self._keepalive.start()

    def _keepalive_loop(self) -> None:
        period = self.keepalive_period or 0.05
        while not self._stop.wait(period):
            try:
                self._alive.put(b"", attachment=self._id)
            except Exception:
                if self._stop.is_set():
                    return

    def close(self) -> None:
        with self._close_lock:
            if self._closed:
                return
            self._closed = True
        self._stop.set()
        if self._keepalive is not None and self._keepalive is not threading.current_thread():
            self._keepalive.join(1.0)
        self._wake()
        try:
            self._token.undeclare()
        finally:
            self._session.close()
