"""One bus shared by the bridge and its remote clients, as hosts share a CAN bus.

The hub owns the real transport. Frames from the bus go to every host; a
frame one host sends goes on the bus and, as on a CAN bus, is seen by the other
hosts (never echoed to its sender). The bridge's own :class:`~drempower.client.Bus`
is attached through :attr:`BusHub.local`; remote hosts through :meth:`send`
and the ``publish`` callback.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Sequence

from ..errors import DrEmpowerError
from ..protocol.addresses import AXIS0_REQUESTED_STATE
from ..protocol.ids import Cmd, Frame
from ..protocol.limits import OPEN_LOOP_SYS_CMDS
from ..protocol.messages import WriteParam, decode_command
from ..transports.base import QueuedTransport, Transport
from ..transports.zenoh_wire import BRIDGE_ORIGIN, driven_nodes

__all__ = ["BusHub", "HubPort", "axis_changed", "driven_nodes"]

_log = logging.getLogger("drempower.bridge")
Publish = Callable[[Sequence[Frame], bytes], None]
"""Called with frames and their origin (empty: from the bus) for the remote hosts."""


def axis_changed(frames: Sequence[Frame]) -> set[int]:
    """Motors (0 = every motor) whose axis state these frames may change: idle and enable requests
    (``axis0.requested_state``), estops, clears, reboots and configuration resets."""
    nodes = set()
    for f in frames:
        if f.is_extended or f.arbitration_id > 0x7FF:
            continue
        node, cmd = f.arbitration_id >> 5, f.arbitration_id & 0x1F
        if cmd == Cmd.SYSTEM and f.data[:1] and f.data[0] in OPEN_LOOP_SYS_CMDS:
            nodes.add(node)
        elif cmd == Cmd.WRITE:
            try:
                msg = decode_command(f.arbitration_id, bytes(f.data))
            except (DrEmpowerError, ValueError):
                continue
            if isinstance(msg, WriteParam) and msg.address == AXIS0_REQUESTED_STATE:
                nodes.add(node)
    return nodes


class HubPort(QueuedTransport):
    """The bridge's own attachment to the hub: a transport for its :class:`~drempower.client.Bus`."""

    def __init__(self, hub: BusHub) -> None:
        super().__init__()
        self._hub = hub
        self.description = f"bridge hub on {hub.transport.description}"
        self.default_timeout = hub.transport.default_timeout

    def deliver(self, frame: Frame) -> None:
        if not self._closed:
            self._queue.put(frame)

    def send(self, frame: Frame) -> None:
        self._hub.send([frame], BRIDGE_ORIGIN)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._wake()


class BusHub:
    """Shares ``transport`` between the bridge (:attr:`local`) and remote hosts (:meth:`send`, ``publish``).

    ``on_sent(origin, frames)`` is called after frames of a remote host went on
    the bus (the bridge watches which motors each client drives).
    """

    def __init__(
        self,
        transport: Transport,
        publish: Publish,
        on_sent: Callable[[bytes, Sequence[Frame]], None] | None = None,
    ) -> None:
        self.transport = transport
        self._publish = publish
        self._on_sent = on_sent
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self.local = HubPort(self)
        """Transport of the bridge's own bus."""
        self.failure: BaseException | None = None
        """Why the bus stopped, once it did (the bridge then has nothing left to serve)."""
        self._thread = threading.Thread(target=self._rx_loop, name="drempower bridge rx", daemon=True)
        self._thread.start()

    def send(self, frames: Sequence[Frame], origin: bytes) -> None:
        """Put ``frames`` of host ``origin`` on the bus, in order, and show them to the other hosts.

        The lock is held only while writing, so an emergency stop arriving on
        another thread waits for at most the frame being written.
        """
        if self._closed.is_set():
            return
        with self._lock:
            for f in frames:
                self.transport.send(f)
        if origin != BRIDGE_ORIGIN:
            for f in frames:
                self.local.deliver(f)
            if self._on_sent is not None:
                self._on_sent(origin, frames)
        self._publish(frames, origin)

    def _rx_loop(self) -> None:
        recv, deliver, publish = self.transport.recv, self.local.deliver, self._publish
        while not self._closed.is_set():
            try:
                frame = recv(0.25)
            except Exception as exc:
                if not self._closed.is_set():
                    _log.error("the bus stopped: %s", exc)
                    self.failure = exc
                    self.local.close()
                return
            if frame is None:
                continue
            deliver(frame)
            try:
                publish((frame,), b"")
            except Exception as exc:  # a closed session while stopping
                _log.debug("publishing a bus frame failed: %s", exc)

    def close(self) -> None:
        """Stop the receive thread and the local port (the transport stays open: its owner closes it)."""
        self._closed.set()
        self.local.close()
        if self._thread is not threading.current_thread():
            self._thread.join(1.0)
