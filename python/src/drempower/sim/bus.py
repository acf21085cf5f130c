"""The simulated CAN bus: motors, a simulated clock, frame delivery, timing and faults.

:class:`SimBus` is pure (no threads, sockets or wall clock) and thread-safe: one
lock guards ``send``, ``advance`` and the listeners. Host frames enter with
:meth:`SimBus.send`; every frame a motor puts on the bus goes to the listeners.

Without a bit rate, delivery is instant: the motors handle a host frame inside
``send`` and their answers reach the listeners before ``send`` returns. With a
bit rate, frames are serialised one at a time in arbitration order (lowest id
first) and each occupies the bus for :func:`~drempower.sim.timing.frame_bits`
bit times; a frame takes effect when its transmission ends, during ``advance``.

Each host (each attachment, and the in-process client) has its own transmit
queue, modelled as ``host_queue``: ``"fifo"`` (one buffer: the host's frames
leave in the order sent) or ``"priority:N"`` (N transmit mailboxes, filled in
the order sent, that arbitrate by identifier like bxCAN, so a later frame with
a lower id may overtake earlier ones still waiting). Motors send in order.
"""

from __future__ import annotations

import heapq
import itertools
import math
import os
import random
import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import ValidationError
from ..protocol.ids import Frame
from ..protocol.limits import MAX_NODE, MIN_MOTOR
from .decoding import Decoder
from .defaults import MotorModel
from .faults import Faults
from .firmware import Firmware, firmware_from
from .motor import SimMotor
from .noise import Readings, SensorNoise, sensor_noise
from .thermal import ThermalModel, thermal_model
from .timing import BusStats
from .wire import Wire

__all__ = ["SimBus", "Listener", "DEFAULT_HOST_QUEUE", "HOST_QUEUES", "parse_host_queue"]

Listener = Callable[[Frame], None]
"""Called with every frame a motor puts on the bus."""

_EPS = 1e-9
HOST_QUEUES = ("fifo", "priority:N")
"""The host transmit-queue models (N = 1..32 mailboxes)."""
DEFAULT_HOST_QUEUE = "priority:3"
"""A bxCAN-style controller (STM32, candleLight/gs_usb, most USB-CAN dongles): three mailboxes."""


def parse_host_queue(text: str) -> int:
    """Mailboxes of a host queue model: ``"fifo"`` is 1, ``"priority:N"`` is N (1..32)."""
    if text == "fifo":
        return 1
    kind, _, count = text.partition(":")
    if kind == "priority" and count.isascii() and count.isdigit() and 1 <= int(count) <= 32:
        return int(count)
    raise ValueError(f"host_queue={text!r}: 'fifo' or 'priority:N' with N mailboxes 1..32, e.g. 'priority:3'")


class SimBus:
    """Simulated motors ``ids`` (1..63) on one CAN bus.

    ``bitrate`` None delivers frames instantly; a bit rate (e.g. 1_000_000)
    serialises them with real frame lengths. ``faults`` (see
    :class:`~drempower.sim.faults.Faults`) draw from a generator seeded with
    ``seed``. ``config_dir`` keeps each motor's saved configuration in
    ``motor-<id>.json`` (by the id the motor was created with). ``model`` sets
    the physical properties of every motor. ``host_queue`` models each host's
    transmit queue when there is a bit rate: ``"fifo"`` or ``"priority:N"``
    (default ``"priority:3"``, see the module docstring). ``firmware`` and the knobs after it
    (``status_bits``, ``boot_s``, ``reply_state``, ``fast_read``, ``q_time_zero``, ``heartbeat``,
    ``factory_id``) pick the motors' reading of the vendor's document (:class:`~drempower.sim.firmware.Firmware`).
    ``thermal`` (a :class:`~drempower.sim.thermal.ThermalModel`, or some of its constants by name) sets every
    motor's heat constants, ``motor_thermal`` (``{motor id: {name: value}}``) one motor's over those (a robot
    file's ``[joints.NAME.thermal]``); each constant in the range of :data:`~drempower.robotfile.THERMAL_KEYS`.
    ``noise`` (a :class:`~drempower.sim.noise.SensorNoise`, or its fields by name) adds sensor noise to the
    motors' state frames, seeded by its own ``seed`` or else ``seed``.
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
        host_queue: str = DEFAULT_HOST_QUEUE,
        firmware: Firmware | Mapping[str, Any] | None = None,
        status_bits: str | None = None,
        boot_s: float | None = None,
        reply_state: str | None = None,
        fast_read: bool | None = None,
        q_time_zero: str | None = None,
        heartbeat: bool | None = None,
        factory_id: int | None = None,
        thermal: ThermalModel | Mapping[str, float] | None = None,
        motor_thermal: Mapping[int, Mapping[str, float]] | None = None,
        noise: SensorNoise | Mapping[str, Any] | None = None,
    ) -> None:
        self.firmware = firmware_from(
            firmware,
            {
                "status_bits": status_bits,
                "boot_s": boot_s,
                "reply_state": reply_state,
                "fast_read": fast_read,
                "q_time_zero": q_time_zero,
                "heartbeat": heartbeat,
                "factory_id": factory_id,
            },
        )
        """The firmware profile of every motor (:mod:`drempower.sim.firmware`)."""
        ids = list(ids)
        if not ids or any(not MIN_MOTOR <= i <= MAX_NODE for i in ids) or len(set(ids)) != len(ids):
            raise ValidationError(f"ids={ids!r}: motor ids must be distinct and in {MIN_MOTOR}..{MAX_NODE}")
        if bitrate is not None and bitrate <= 0:
            raise ValidationError(f"bitrate={bitrate!r}: must be > 0 bit/s (or None for instant delivery)")
        self.bitrate = bitrate
        self.host_queue = host_queue
        host_slots = parse_host_queue(host_queue)
        self.faults = faults if faults is not None else Faults()
        self.rng = random.Random(seed)
        """The generator of every random fault."""
        given = sensor_noise(noise)
        self.readings = None if given is None else Readings(given, seed)
        """The noise on the motors' state frames (:mod:`drempower.sim.noise`), or None."""
        self.lock = threading.RLock()
        self.tx_done = threading.Condition(self.lock)
        """Notified (under ``lock``) each time a host frame has left its host (end of its transmission)."""
        self.now = 0.0
        """Simulated time (s)."""
        folder = Path(config_dir) if config_dir is not None else None
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
        self.motors: dict[int, SimMotor] = {}
        """The motors by the id they were created with (their node id may change)."""
        self._replies: dict[int, Callable[[Frame], None]] = {}
        self._uart_taps: dict[int, list[Listener]] = {}
        base = model or MotorModel()
        bus_heat = thermal_model(base.thermal, thermal, "thermal")
        for i in motor_thermal or {}:
            if i not in ids:
                raise ValidationError(f"motor_thermal: motor {i} is not simulated on this bus (motors {ids})")
        for i in ids:
            heat = thermal_model(bus_heat, (motor_thermal or {}).get(i), f"motor_thermal: motor {i}")
            m = SimMotor(
                i,
                model=base if heat is base.thermal else replace(base, thermal=heat),
                config_path=folder / f"motor-{i}.json" if folder else None,
                firmware=self.firmware,
            )
            self.motors[i] = m
            self._replies[i] = self._replier(m)
            m.emit = self._heartbeat_sink(m)
        self._order = list(self.motors.values())
        self._listeners: tuple[Listener, ...] = ()
        self._taps: tuple[Listener, ...] = ()
        self._steps = 0
        self._seq = itertools.count()
        self._events: list[tuple[float, int, Callable[[], None]]] = []
        self._stats = BusStats()
        self._wire: Wire[SimMotor, Listener] | None = (
            None if bitrate is None else Wire(bitrate, host_slots, self._seq, self._stats, self._host_sent)
        )
        """The frames' contention for the wire and their lengths (None: instant delivery)."""
        self.clock_sync: Callable[[], None] | None = None
        """Called (under the lock) before a host frame enters: a runner brings ``now`` up to wall time."""
        self.on_activity: Callable[[], None] | None = None
        """Called after a host frame entered: a runner wakes to deliver it at its completion time."""
        self._decoder = Decoder()

    @property
    def ignored(self) -> int:
        """Host frames the simulated firmware could not act on (see :meth:`~drempower.sim.decoding.Decoder.ignore`)."""
        return self._decoder.ignored

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
            sync = self.clock_sync
            if sync is not None:
                sync()
            self._enter(frame, None, origin)
        wake = self.on_activity
        if wake is not None:
            wake()

    def next_due(self) -> float:
        """Simulated time (s) of the next thing that must happen at its own time: the end of the
        frame on the wire, a scheduled event or a motor timer (heartbeat, watchdog...); inf if none."""
        with self.lock:
            due = min((m.next_wake for m in self._order), default=math.inf)
            tx = None if self._wire is None else self._wire.tx
            if tx is not None:
                due = min(due, tx[0])
            if self._events:
                due = min(due, self._events[0][0])
            return due

    def host_pending(self, origin: Listener | None = None) -> int:
        """Frames the host sending through ``origin`` has queued that are not yet fully on the wire."""
        with self.lock:
            return 0 if self._wire is None else self._wire.host_pending(origin)

    def schedule(self, at: float, action: Callable[[], None]) -> None:
        """Run ``action()`` when simulated time reaches ``at`` (s), e.g. to raise an error mid-move."""
        with self.lock:
            heapq.heappush(self._events, (at, next(self._seq), action))

    def advance(self, seconds: float, stop: Callable[[], bool] | None = None) -> bool:
        """Let ``seconds`` of simulated time pass: step every motor and deliver what falls due.

        With ``stop``, checked after each thing that happens (a frame's end, an event, a step),
        the advance ends early, at the time of that thing, once ``stop()`` is true. Returns
        True when it ended early.
        """
        with self.lock:
            target = self.now + seconds
            step = self.STEP
            order = self._order
            events = self._events
            wire = self._wire
            while True:
                t_step = (self._steps + 1) * step
                t = t_step
                if events and events[0][0] < t:
                    t = events[0][0]
                tx = None if wire is None else wire.tx
                if tx is not None and tx[0] < t:
                    t = tx[0]
                if t > target + _EPS:
                    break
                if t > self.now:
                    self.now = t
                if tx is not None and tx[0] <= t:
                    assert wire is not None
                    self._deliver(*wire.finish(self.now))
                elif events and events[0][0] <= t:
                    heapq.heappop(events)[2]()
                else:
                    self._steps += 1
                    for m in order:
                        try:
                            m.step(step, t)
                        except Exception as exc:
                            self._decoder.ignore(None, f"motor {m.ident}: {type(exc).__name__}: {exc}")
                if stop is not None and stop():
                    return True
            if target > self.now:
                self.now = target
            return False

    def uart_request(self, ident: int, frame: Frame) -> list[Frame]:
        """Deliver ``frame`` through the UART of motor ``ident`` only, at ``now``; returns its answers.

        As :meth:`send` does, the clock is first brought up to the time of the
        request (by a runner's ``clock_sync``), so answers carry the state of now.
        ``drop_rate`` and ``corrupt_rate`` apply to the request here; a UART
        attachment sends the answers through :meth:`uart_reply` for the rest.
        """
        out: list[Frame] = []
        with self.lock:
            sync = self.clock_sync
            if sync is not None:
                sync()
            faulty = self._fault(frame)
            if faulty is None:
                return out
            msg = self._decoder.command(faulty)
            m = self.motors[ident]
            if msg is not None and (msg.node == 0 or msg.node == m.node_id):
                try:
                    m.receive(msg, out.append)
                except Exception as exc:
                    self._decoder.ignore(faulty, f"{type(exc).__name__}: {exc}")
            if ident in self.faults.silent:
                return []
            readings = self.readings
            return out if readings is None else [readings.report(f) for f in out]

    def uart_reply(self, frame: Frame, sink: Listener) -> None:
        """Send a motor frame out of a UART attachment as the faults allow: lost, corrupted, or late.

        ``sink(frame)`` runs now, or after ``reply_delay`` (+ jitter) of
        simulated time; not at all when the frame is dropped.
        """
        with self.lock:
            f = self.faults
            faulty = self._fault(frame)
            if faulty is None:
                return
            delay = f.reply_delay + (self.rng.uniform(0.0, f.reply_jitter) if f.reply_jitter > 0 else 0.0)
            if delay > 0:
                heapq.heappush(self._events, (self.now + delay, next(self._seq), lambda: sink(faulty)))
                return
        sink(faulty)

    def _fault(self, frame: Frame) -> Frame | None:
        """``frame`` as the random faults leave it: None when lost, or with one bit flipped."""
        f = self.faults
        if f.drop_rate > 0 and self.rng.random() < f.drop_rate:
            return None
        if f.corrupt_rate > 0 and frame.data and self.rng.random() < f.corrupt_rate:
            bit = self.rng.randrange(len(frame.data) * 8)
            data = bytearray(frame.data)
            data[bit >> 3] ^= 1 << (bit & 7)
            frame = frame._replace(data=bytes(data))
        return frame

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
            if self.readings is not None:
                frame = self.readings.report(frame)
            self._from_motor(m, frame)

        return reply

    def _heartbeat_sink(self, m: SimMotor) -> Callable[[Frame], None]:
        def emit(frame: Frame) -> None:
            if self.readings is not None:
                frame = self.readings.report(frame)
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
        faulty = self._fault(frame)
        if faulty is None:
            return
        frame = faulty
        wire = self._wire
        if wire is None:
            self._stats.frames += 1
            self._deliver(frame, source, origin)
            return
        wire.offer(frame, source, origin, self.now)

    def _host_sent(self) -> None:
        """A host frame has left its host (the end of its transmission)."""
        with self.tx_done:
            self.tx_done.notify_all()

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
        msg = self._decoder.command(frame)
        if msg is None:
            return
        node = msg.node
        rate = self.bitrate
        for m in self._order:
            if (node == 0 or m.node_id == node) and (rate is None or m.bitrate == rate):
                try:
                    m.receive(msg, self._replies[m.ident])
                except Exception as exc:
                    self._decoder.ignore(frame, f"{type(exc).__name__}: {exc}")
