"""Record a bus to an MCAP file: raw frames both ways, joint states, parameter values and errors.

The file follows the ROS 2 MCAP profile (CDR messages, ``ros2msg`` schemas), so
``ros2 bag``, rosbags, Foxglove and PlotJuggler open it; see
:mod:`drempower.records.ros2_types` for the topics.
"""

from __future__ import annotations

import math
import os
import queue
import threading
import time
from collections.abc import Mapping
from types import TracebackType
from typing import Any

from ..errors import DrEmpowerError, ProtocolError
from ..protocol.flags import ERROR_WORDS, decode_error_word
from ..protocol.ids import Frame
from ..protocol.messages import ParamValue, State, decode_reply
from ..protocol.parameters import find_parameter
from . import missing_extra
from .ros2_types import DEFINITIONS, TOPICS

__all__ = ["Recorder", "RecorderStats"]

_DEG = math.pi / 180.0
_RPM = 2.0 * math.pi / 60.0
_ERROR_WORDS = {w.address: w for w in ERROR_WORDS}
_STOP = None


class RecorderStats:
    """Counters of a recording: frames handed to the recorder and messages written, by kind."""

    __slots__ = ("errors", "frames_in", "frames_written", "parameters", "states")

    def __init__(self) -> None:
        self.frames_in = 0
        """Frames taken from the recorder's queue (from taps and :meth:`Recorder.record`)."""
        self.frames_written = 0
        """Raw frames written to the file (on ``/can/tx`` and ``/can/rx``)."""
        self.states = 0
        self.parameters = 0
        self.errors = 0

    @property
    def frames_lost(self) -> int:
        return self.frames_in - self.frames_written

    def as_dict(self) -> dict[str, int]:
        return {k: getattr(self, k) for k in (*self.__slots__, "frames_lost")}


def _stamp(ns: int) -> dict[str, Any]:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


class Recorder:
    """Write what passes on one or more buses to the MCAP file ``path``.

    ``attach(bus)`` records every frame an open :class:`~drempower.Bus` (or
    :class:`~drempower.AsyncBus`) sends and receives from then on. The frames are
    queued by the bus's threads and written by the recorder's own thread, so
    recording never slows the bus down; :meth:`close` writes what is queued and
    finishes the file. ``names`` maps motor ids to joint names (default
    ``motor<id>``); ``channel`` names the bus in the headers' ``frame_id``.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        names: Mapping[int, str] | None = None,
        channel: str = "can",
        compression: str = "zstd",
    ) -> None:
        try:
            from mcap.writer import CompressionType
            from mcap_ros2.writer import Writer
        except ImportError:
            raise missing_extra("mcap-ros2-support") from None
        try:
            comp = CompressionType[compression.upper()]
        except KeyError:
            raise DrEmpowerError(f"compression={compression!r}: 'zstd', 'lz4' or 'none'") from None
        self.path = os.fspath(path)
        try:
            self._fh = open(self.path, "wb")  # noqa: SIM115 - closed in close()
        except OSError as exc:
            raise DrEmpowerError(f"cannot write {self.path}: {exc.strerror}") from None
        self._writer = Writer(self._fh, compression=comp)
        self._schemas = {t: self._writer.register_msgdef(t, d) for t, d in DEFINITIONS.items()}
        self.names: dict[int, str] = dict(names or {})
        self.channel = channel
        self.stats = RecorderStats()
        self._queue: queue.SimpleQueue[tuple[int, Frame, bool] | None] = queue.SimpleQueue()
        self._cores: list[Any] = []
        self._error_bit: dict[int, bool] = {}
        self._closed = False
        self._failure: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="drempower recorder", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ input

    def attach(self, bus: Any) -> Recorder:
        """Record every frame ``bus`` (a Bus, AsyncBus or BusCore) sends and receives from now on."""
        core = getattr(bus, "core", bus)
        core.add_tap(self.tap)
        self._cores.append(core)
        return self

    def detach(self) -> None:
        """Stop recording the attached buses (the file stays open)."""
        for core in self._cores:
            core.remove_tap(self.tap)
        self._cores.clear()

    def tap(self, frame: Frame, tx: bool) -> None:
        """A bus's frame tap: queue ``frame`` stamped with the wall clock now."""
        self._queue.put((time.time_ns(), frame, tx))

    def record(self, frame: Frame, tx: bool, timestamp: float | None = None) -> None:
        """Queue one frame seen elsewhere; ``timestamp`` is Unix time (s), default now."""
        if self._closed:
            raise DrEmpowerError(f"the recording {self.path} is closed")
        ns = time.time_ns() if timestamp is None else round(timestamp * 1e9)
        self._queue.put((ns, frame, tx))

    # ------------------------------------------------------------------ writing

    def _run(self) -> None:
        get = self._queue.get
        write = self._write
        try:
            while True:
                item = get()
                if item is None:
                    return
                self.stats.frames_in += 1
                write(*item)
        except BaseException as exc:  # keep the bus running; close() reports it
            self._failure = exc

    def _msg(self, topic: str, ns: int, message: dict[str, Any]) -> None:
        self._writer.write_message(topic, self._schemas[TOPICS[topic]], message, log_time=ns, publish_time=ns)

    def _write(self, ns: int, frame: Frame, tx: bool) -> None:
        arb, data, ext, rtr = frame
        header = {"stamp": _stamp(ns), "frame_id": self.channel}
        raw = bytes(data).ljust(8, b"\0")[:8]
        self._msg(
            "/can/tx" if tx else "/can/rx",
            ns,
            {
                "header": header,
                "id": arb,
                "is_rtr": rtr,
                "is_extended": ext,
                "is_error": False,
                "dlc": len(data),
                "data": list(raw),
            },
        )
        self.stats.frames_written += 1
        if tx:
            return
        node = arb >> 5
        if ext or rtr or len(data) != 8 or not (arb & 1 or arb & 0x1F == 0x1E):
            self._error(ns, header, node, "frame", 0, f"not a DrEmpower reply: id 0x{arb:X} data {bytes(data).hex()}")
            return
        try:
            reply = decode_reply(arb, bytes(data))
        except ProtocolError as exc:
            self._error(ns, header, node, "frame", 0, str(exc))
            return
        if isinstance(reply, State):
            name = self.names.get(node) or f"motor{node}"
            self._msg(
                "/joint_states",
                ns,
                {
                    "header": header,
                    "name": [name],
                    "position": [reply.position * _DEG],
                    "velocity": [reply.speed * _RPM],
                    "effort": [reply.torque],
                },
            )
            self.stats.states += 1
            if reply.error != self._error_bit.get(node, False):
                self._error_bit[node] = reply.error
                text = "axis error set (E bit)" if reply.error else "axis error cleared (E bit)"
                self._error(ns, header, node, "state", int(reply.error), text)
        elif isinstance(reply, ParamValue):
            p = find_parameter(reply.address)
            self._msg(
                "/drempower/parameters",
                ns,
                {
                    "header": header,
                    "node": node,
                    "address": reply.address,
                    "name": p.name if p else "",
                    "unit": (p.unit or "") if p else "",
                    "value": float(reply.value),
                },
            )
            self.stats.parameters += 1
            word = _ERROR_WORDS.get(reply.address)
            if word is not None and isinstance(reply.value, int) and reply.value:
                flags = ", ".join(decode_error_word(word.name, reply.value & 0xFFFFFFFF))
                self._error(ns, header, node, word.name, reply.value & 0xFFFFFFFF, flags)

    def _error(self, ns: int, header: dict[str, Any], node: int, source: str, code: int, text: str) -> None:
        self._msg(
            "/drempower/errors",
            ns,
            {"header": header, "node": node, "source": source, "code": code, "text": text},
        )
        self.stats.errors += 1

    # ------------------------------------------------------------------ closing

    def close(self) -> None:
        """Detach, write every queued frame and finish the file. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self.detach()
        self._queue.put(_STOP)
        self._thread.join()
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]
        finally:
            self._fh.close()
        if self._failure is not None:
            raise DrEmpowerError(f"writing {self.path} failed: {self._failure}") from self._failure

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
