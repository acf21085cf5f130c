"""Record a bus to an MCAP file: raw frames both ways, joint states, parameter values and errors.

The file follows the ROS 2 MCAP profile (CDR messages, ``ros2msg`` schemas), so
``ros2 bag``, rosbags, Foxglove and PlotJuggler open it; see
:mod:`drempower.records.ros2_types` for the topics.
"""

from __future__ import annotations

import os
import queue
import threading
import time
from collections.abc import Mapping
from types import TracebackType
from typing import Any

from ..errors import DrEmpowerError
from ..protocol.ids import Frame
from . import missing_extra
from .events import FrameEvents
from .ros2_types import DEFINITIONS, TOPICS

__all__ = ["Recorder", "RecorderStats"]

_STOP = None
_COUNTERS = {
    "/can/tx": "frames_written",
    "/can/rx": "frames_written",
    "/joint_states": "states",
    "/drempower/parameters": "parameters",
    "/drempower/errors": "errors",
}


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
        self._events = FrameEvents(names, channel)
        self.stats = RecorderStats()
        self._queue: queue.SimpleQueue[tuple[int, Frame, bool] | None] = queue.SimpleQueue()
        self._cores: list[Any] = []
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

    def _write(self, ns: int, frame: Frame, tx: bool) -> None:
        stats = self.stats
        for topic, message in self._events(ns, frame, tx):
            self._writer.write_message(topic, self._schemas[TOPICS[topic]], message, log_time=ns, publish_time=ns)
            kind = _COUNTERS[topic]
            setattr(stats, kind, getattr(stats, kind) + 1)

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
