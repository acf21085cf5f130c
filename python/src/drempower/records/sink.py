"""The common part of every frame sink: taps on buses, a queue, and one writer thread."""

from __future__ import annotations

import math
import queue
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from functools import partial
from types import TracebackType
from typing import TYPE_CHECKING, Any, TypeVar

from ..errors import DrEmpowerError
from ..protocol.ids import Frame
from .events import FrameEvents
from .ros2_types import counter_of

if TYPE_CHECKING:
    from ..robotfile import JointSpec

__all__ = ["FrameSink", "SinkStats"]

_S = TypeVar("_S", bound="FrameSink")


_MONOTONIC_TO_EPOCH = time.time() - time.monotonic()
"""Added to a time on the monotonic scale (s) to make it Unix time: one offset for every stamp, so that
the stamps keep the spacing of the monotonic clock (the wall clock may be stepped meanwhile)."""


class _Stamps:
    """The times to record one bus's frames at (Unix ns).

    A received frame is stamped with its transport's own time where the transport gives one (a
    :class:`~drempower.protocol.ids.TimedFrame`: the simulator's clock, a socketcand server's stamp, a
    python-can receive timestamp); a sent frame (and a received one without a time) with now on that
    same clock: the monotonic clock less how far the transport's clock was behind it at the last
    received frame (a simulator that fell behind a busy host, a hop's latency). The order of cause and
    effect is kept (by 1 µs at least): a received frame comes after the last frame sent on its bus (a
    reply after its request, which the bus reports once sent), a sent frame after every frame before it
    (the host sent it after it had them)."""

    __slots__ = ("lag", "latest", "sent")

    def __init__(self) -> None:
        self.lag = 0.0
        self.sent = -math.inf
        self.latest = -math.inf

    def __call__(self, frame: Frame, tx: bool) -> int:
        now = time.monotonic()
        own = None if tx else getattr(frame, "time", None)
        if own is None:
            at = now - self.lag
        else:
            self.lag = now - own
            at = own
        if tx:
            if at <= self.latest:
                at = self.latest + 1e-6
            self.sent = at
        elif at <= self.sent:
            at = self.sent + 1e-6
        if at > self.latest:
            self.latest = at
        return round((at + _MONOTONIC_TO_EPOCH) * 1e9)


class SinkStats:
    """Counters of a sink: frames handed to it and messages written, by kind."""

    __slots__ = ("errors", "frames_in", "frames_written", "parameters", "states")

    def __init__(self) -> None:
        self.frames_in = 0
        """Frames taken from the sink's queue (from taps and :meth:`FrameSink.record`)."""
        self.frames_written = 0
        """Raw frames written (on ``/can/tx`` and ``/can/rx``)."""
        self.states = 0
        self.parameters = 0
        self.errors = 0

    @property
    def frames_lost(self) -> int:
        return self.frames_in - self.frames_written

    def as_dict(self) -> dict[str, int]:
        return {k: getattr(self, k) for k in (*self.__slots__, "frames_lost")}


class FrameSink(ABC):
    """Takes the frames of attached buses and writes their messages (see :mod:`.events`) in its own thread.

    The buses' threads only queue each frame with its time (see :class:`_Stamps`), so a sink never
    slows a bus down; :meth:`close` writes what is queued, then finishes.
    """

    what = "sink"

    def __init__(self, names: Mapping[int, str] | None, channel: str) -> None:
        self._events: dict[str | None, FrameEvents] = {None: FrameEvents(names, channel)}
        self._stamps: dict[str | None, _Stamps] = {None: _Stamps()}
        """The time stamps of each bus's frames (the keys of ``_events``)."""
        """The frame decoders: None for buses attached without a name, else one per named bus."""
        self.stats = SinkStats()
        self._queue: queue.SimpleQueue[tuple[int, Frame, bool, str | None] | None] = queue.SimpleQueue()
        self._buses: list[tuple[Any, Any]] = []
        self._closed = False
        self._failure: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=f"drempower {self.what}", daemon=True)
        self._thread.start()

    @abstractmethod
    def _emit(self, topic: str, ns: int, message: dict[str, Any]) -> None:
        """Write one message of ``topic`` stamped ``ns`` (Unix ns)."""

    @abstractmethod
    def _finish(self) -> None:
        """Finish the output once everything queued is written."""

    # ------------------------------------------------------------------ input

    def attach(self: _S, bus: Any, *, name: str | None = None, joints: Sequence[JointSpec] = ()) -> _S:
        """Take every frame ``bus`` (a Bus, AsyncBus, or anything with ``add_tap``) sends and receives from now on.

        ``name`` (a robot's bus name) puts its raw frames on ``/can/<name>/tx`` and
        ``/can/<name>/rx`` (``frame_id`` ``name``) instead of ``/can/tx`` and ``/can/rx``;
        ``joints`` (that bus's joints of the robot file) then name its states and
        give them at the joint, after gear and offset (as :class:`drempower.robot.Gearing`).
        """
        if name is None:
            if joints:
                raise DrEmpowerError("joints: give the bus's name too (attach(bus, name=..., joints=...))")
            tap: Any = self.tap
        else:
            if name in self._events:
                raise DrEmpowerError(f"bus {name!r} is attached already")
            self._events[name] = FrameEvents(
                {j.id: j.name for j in joints},
                name,
                topic_prefix=f"/can/{name}",
                gears={j.id: (j.gear, j.offset) for j in joints},
            )
            self._stamps[name] = _Stamps()
            tap = partial(self._tap_named, name)
        bus.add_tap(tap)
        self._buses.append((bus, tap))
        return self

    def detach(self) -> None:
        """Stop taking the frames of the attached buses (the output stays open)."""
        for bus, tap in self._buses:
            bus.remove_tap(tap)
        self._buses.clear()

    def tap(self, frame: Frame, tx: bool) -> None:
        """A bus's frame tap: queue ``frame`` stamped with its transport's own time where it has one."""
        self._queue.put((self._stamps[None](frame, tx), frame, tx, None))

    def _tap_named(self, name: str, frame: Frame, tx: bool) -> None:
        self._queue.put((self._stamps[name](frame, tx), frame, tx, name))

    def record(self, frame: Frame, tx: bool, timestamp: float | None = None) -> None:
        """Queue one frame seen elsewhere; ``timestamp`` is Unix time (s), default now."""
        if self._closed:
            raise DrEmpowerError(f"the {self.what} is closed")
        ns = time.time_ns() if timestamp is None else round(timestamp * 1e9)
        self._queue.put((ns, frame, tx, None))

    # ------------------------------------------------------------------ writing

    def _run(self) -> None:
        get, events, emit, stats = self._queue.get, self._events, self._emit, self.stats
        try:
            while True:
                item = get()
                if item is None:
                    return
                stats.frames_in += 1
                ns, frame, tx, name = item
                for topic, message in events[name](ns, frame, tx):
                    emit(topic, ns, message)
                    kind = counter_of(topic)
                    setattr(stats, kind, getattr(stats, kind) + 1)
        except BaseException as exc:  # keep the bus running; close() reports it
            self._failure = exc

    # ------------------------------------------------------------------ closing

    def close(self) -> None:
        """Detach, write every queued frame and finish. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self.detach()
        self._queue.put(None)
        self._thread.join()
        self._finish()
        if self._failure is not None:
            raise DrEmpowerError(f"the {self.what} failed: {self._failure}") from self._failure

    def __enter__(self: _S) -> _S:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
