"""The simulated CAN bus: motors, a simulated clock, frame delivery, timing and faults.

:class:`SimBus` is pure (no threads, sockets or wall clock) and thread-safe: one
lock guards ``send``, ``advance`` and the listeners. Host frames enter with
:meth:`SimBus.send`; every frame a motor puts on the bus goes to the listeners.

Without a bit rate, delivery is instant: the motors handle a host frame inside
``send`` and their answers reach the listeners before ``send`` returns. With a
bit rate, frames are serialised one at a time in arbitration order (lowest id
first) and each occupies the bus for :func:`~drempower.sim.timing.frame_bits`
bit times; a frame takes effect when its transmission ends, during ``advance``.
"""

from __future__ import annotations

import heapq
import itertools
import os
import random
import threading
from collections.abc import Callable, Iterable
from pathlib import Path

from ..errors import DrEmpowerError, ValidationError
from ..protocol.ids import MAX_NODE, Frame
from ..protocol.messages import Command, decode_command
from .defaults import MotorModel
from .faults import Faults
from .motor import SimMotor
from .timing import BusStats, frame_bits

__all__ = ["SimBus", "Listener"]

Listener = Callable[[Frame], None]
"""Called with every frame a motor puts on the bus."""

_EPS = 1e-9


class SimBus:
    """Simulated motors ``ids`` (1..63) on one CAN bus.

    ``bitrate`` None delivers frames instantly; a bit rate (e.g. 1_000_000)
    serialises them with real frame lengths. ``faults`` (see
    :class:`~drempower.sim.faults.Faults`) draw from a generator seeded with
    ``seed``. ``config_dir`` keeps each motor's saved configuration in
    ``motor-<id>.json`` (by the id the motor was created with). ``model`` sets
    the physical properties of every motor.
    """

    STEP = 0.001
    """Fixed simulation step (s)."""

    def __init__(
        self,
        ids: Iterable[int] = (1,),
        *,
        bitrate: int | None = None,
        faults: Faults | None = None,
        seed: int = 0,
        config_dir: str | os.PathLike[str] | None = None,
        model: MotorModel | None = None,
    ) -> None:
        ids = list(ids)
        if not ids or any(not 1 <= i <= MAX_NODE for i in ids) or len(set(ids)) != len(ids):
            raise ValidationError(f"ids={ids!r}: motor ids must be distinct and in 1..{MAX_NODE}")
        if bitrate is not None and bitrate <= 0:
            raise ValidationError(f"bitrate={bitrate!r}: must be > 0 bit/s (or None for instant delivery)")
        self.bitrate = bitrate
        self.faults = faults if faults is not None else Faults()
        self.rng = random.Random(seed)
        """The generator of every random fault."""
        self.lock = threading.RLock()
        self.now = 0.0
        """Simulated time (s)."""
        folder = Path(config_dir) if config_dir is not None else None
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
        self.motors: dict[int, SimMotor] = {}
        """The motors by the id they were created with (their node id may change)."""
        self._replies: dict[int, Callable[[Frame], None]] = {}
        self._uart_taps: dict[int, list[Listener]] = {}
        for i in ids:
            m = SimMotor(i, model=model, config_path=folder / f"motor-{i}.json" if folder else None)
            self.motors[i] = m
            self._replies[i] = self._replier(m)
            m.emit = self._heartbeat_sink(m)
        self._order = list(self.motors.values())
        self._listeners: tuple[Listener, ...] = ()
        self._taps: tuple[Listener, ...] = ()
        self._steps = 0
        self._seq = itertools.count()
        self._events: list[tuple[float, int, Callable[[], None]]] = []
        self._ready: list[tuple[int, int, Frame, SimMotor | None, Listener | None]] = []
        self._tx: tuple[float, Frame, SimMotor | None, Listener | None] | None = None
        self._stats = BusStats()

    # ------------------------------------------------------------------ public

    @property
    def stats(self) -> BusStats:
        """Frames and bits carried, busy time and utilisation so far (busy time needs a bit rate)."""
        with self.lock:
            s = self._stats
            return BusStats(s.frames, s.bits, s.busy, self.now)

    def add_listener(self, listener: Listener, *, host_frames: bool = False) -> None:
        """Call ``listener(frame)`` for every frame a motor puts on the bus.

        With ``host_frames`` it also gets the frames of hosts, except those it sent
        itself (see :meth:`send`), as a CAN node sees every frame on the bus: for
        attachments through which a host reaches the bus.
        """
        with self.lock:
            self._listeners = (*self._listeners, listener)
            if host_frames:
                self._taps = (*self._taps, listener)

    def remove_listener(self, listener: Listener) -> None:
        """Stop calling ``listener`` (no error when it is not registered)."""
        with self.lock:
            self._listeners = tuple(x for x in self._listeners if x != listener)
            self._taps = tuple(x for x in self._taps if x != listener)

    def send(self, frame: Frame, origin: Listener | None = None) -> None:
        """A host puts ``frame`` on the bus at ``now``.

        ``origin`` is the listener of the attachment the host sent it through: the
        frame goes to every other listener registered with ``host_frames``, not back.
        """
        with self.lock:
            self._enter(frame, None, origin)

    def schedule(self, at: float, action: Callable[[], None]) -> None:
        """Run ``action()`` when simulated time reaches ``at`` (s), e.g. to raise an error mid-move."""
        with self.lock:
            heapq.heappush(self._events, (at, next(self._seq), action))

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` of simulated time pass: step every motor and deliver what falls due."""
        with self.lock:
            target = self.now + seconds
            step = self.STEP
            order = self._order
            events = self._events
            while True:
                t_step = (self._steps + 1) * step
                t = t_step
                if events and events[0][0] < t:
                    t = events[0][0]
                tx = self._tx
                if tx is not None and tx[0] < t:
                    t = tx[0]
                if t > target + _EPS:
                    break
                if t > self.now:
                    self.now = t
                if tx is not None and tx[0] <= t:
                    self._finish_tx()
                elif events and events[0][0] <= t:
                    heapq.heappop(events)[2]()
                else:
                    self._steps += 1
                    for m in order:
                        m.step(step, t)
            if target > self.now:
                self.now = target

    def uart_request(self, ident: int, frame: Frame) -> list[Frame]:
        """Deliver ``frame`` through the UART of motor ``ident`` only; returns its answers."""
        out: list[Frame] = []
        with self.lock:
            msg = _decode(frame)
            m = self.motors[ident]
            if msg is not None and (msg.node == 0 or msg.node == m.node_id):
                m.receive(msg, out.append)
            return [] if ident in self.faults.silent else out

    def add_uart_tap(self, ident: int, listener: Listener) -> None:
        """Also send the heartbeats of motor ``ident`` to ``listener`` (its UART)."""
        with self.lock:
            self._uart_taps.setdefault(ident, []).append(listener)

    def remove_uart_tap(self, ident: int, listener: Listener) -> None:
        with self.lock:
            taps = self._uart_taps.get(ident, [])
            if listener in taps:
                taps.remove(listener)

    # ------------------------------------------------------------------ delivery

    def _replier(self, m: SimMotor) -> Callable[[Frame], None]:
        def reply(frame: Frame) -> None:
            self._from_motor(m, frame)

        return reply

    def _heartbeat_sink(self, m: SimMotor) -> Callable[[Frame], None]:
        def emit(frame: Frame) -> None:
            if m.ident not in self.faults.silent:
                for tap in self._uart_taps.get(m.ident, ()):
                    tap(frame)
            self._from_motor(m, frame)

        return emit

    def _from_motor(self, m: SimMotor, frame: Frame) -> None:
        f = self.faults
        if m.ident in f.silent or (self.bitrate is not None and m.bitrate != self.bitrate):
            return
        delay = f.reply_delay + (self.rng.uniform(0.0, f.reply_jitter) if f.reply_jitter > 0 else 0.0)
        if delay > 0:
            heapq.heappush(self._events, (self.now + delay, next(self._seq), lambda: self._enter(frame, m)))
        else:
            self._enter(frame, m)

    def _enter(self, frame: Frame, source: SimMotor | None, origin: Listener | None = None) -> None:
        """A frame is offered to the bus by the host (``source`` None) or a motor."""
        f = self.faults
        if f.drop_rate > 0 and self.rng.random() < f.drop_rate:
            return
        if f.corrupt_rate > 0 and frame.data and self.rng.random() < f.corrupt_rate:
            bit = self.rng.randrange(len(frame.data) * 8)
            data = bytearray(frame.data)
            data[bit >> 3] ^= 1 << (bit & 7)
            frame = frame._replace(data=bytes(data))
        if self.bitrate is None:
            self._stats.frames += 1
            self._deliver(frame, source, origin)
            return
        heapq.heappush(self._ready, (frame.arbitration_id, next(self._seq), frame, source, origin))
        if self._tx is None:
            self._start_tx()

    def _start_tx(self) -> None:
        _, _, frame, source, origin = heapq.heappop(self._ready)
        bits = frame_bits(frame.arbitration_id, frame.data, frame.is_extended)
        assert self.bitrate is not None
        duration = bits / self.bitrate
        s = self._stats
        s.frames += 1
        s.bits += bits
        s.busy += duration
        self._tx = (self.now + duration, frame, source, origin)

    def _finish_tx(self) -> None:
        assert self._tx is not None
        _, frame, source, origin = self._tx
        self._tx = None
        if self._ready:
            self._start_tx()
        self._deliver(frame, source, origin)

    def _deliver(self, frame: Frame, source: SimMotor | None, origin: Listener | None = None) -> None:
        if source is not None:
            node = frame.arbitration_id >> 5
            for m in self._order:
                if m is not source:
                    m.saw_frame(node)
            for listener in self._listeners:
                listener(frame)
            return
        for tap in self._taps:
            if tap != origin:
                tap(frame)
        msg = _decode(frame)
        if msg is None:
            return
        node = msg.node
        rate = self.bitrate
        for m in self._order:
            if (node == 0 or m.node_id == node) and (rate is None or m.bitrate == rate):
                m.receive(msg, self._replies[m.ident])


def _decode(frame: Frame) -> Command | None:
    if frame.is_extended or frame.is_remote:
        return None
    try:
        return decode_command(frame.arbitration_id, frame.data)
    except DrEmpowerError:
        return None
