"""The dashboard's side of the bus: samples, motor cards, control actions and the stop rules.

Everything goes through the client's public API (:class:`~drempower.client.Bus`,
:class:`~drempower.client.Motor`): state frames arrive through
:meth:`Bus.subscribe` (fast reads polled here, or the motors' heartbeats), control
through the motor methods. Methods named ``do_*`` block (they wait for replies)
and are run in a worker thread by the web server.
"""

from __future__ import annotations

import math
import os
import re
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .. import actions
from ..actions import bandwidth_range
from ..client import Bus, ConfigBackup, Motor, MotorState
from ..client.engine.stops import hold_frames
from ..errors import DrEmpowerError, FieldRangeError, MotorIdleError, SoftLimitError, ValidationError
from ..naming import COLUMNS, TIME_COLUMN, motor_name, motor_names, state_name
from ..protocol import ERROR_WORDS, FastRead, flag_info
from ..protocol.enums import AxisState
from ..protocol.parameters import Parameter, find_parameter, parameters
from ..robot.joint import Gearing
from . import tuning
from .logline import log
from .units import ROW_KINDS, JointUnits

if TYPE_CHECKING:
    from ..client.engine.supervisor import HealthEvent
    from ..robot import Robot

__all__ = ["Hub", "Sample", "bandwidth_range", "param_table"]

Sample = tuple[int, float, float, float, float, int, float | None, float | None, float | None]
"""(key, t s, angle deg, speed r/min, torque Nm, flags (1 = T, 2 = E), target angle, speed, torque)."""

KEYS_PER_BUS = 64
"""A motor's key on the page: ``bus index * KEYS_PER_BUS + motor id`` (on one bus: the motor id)."""

_HEARTBEAT = "can.config.heartbeat_ms"
_STATE = "axis0.current_state"
_CARD_READS = (
    ("vbus", "vbus_voltage"),
    ("state", _STATE),
)
TREND_POINTS = 600
HEALTH_EVENTS_SHOWN = 5
"""The latest supervisor events a card (and its row of the Health view) shows."""
"""Health readings kept per motor for the Health view's trends (one per card refresh: 10 minutes at 1 s)."""
_LIMIT_READS = (
    ("speed", "axis0.output_shaft.vel_limit"),
    ("torque", "axis0.output_shaft.torque_lim"),
    ("current", "axis0.motor.config.current_lim"),
    ("torque_constant", "axis0.output_shaft.torque_constant"),
)
"""The limits a motor holds that bound the Control inputs (read at scan and after a write of one)."""
_BANDWIDTH = "axis0.controller.config.input_filter_bandwidth"
"""The motor's T-mode input filter bandwidth (1/s): a step from the page or the Tuning view without
one goes through it."""
_CSV_COLUMNS = ("id", "position", "speed", "torque", "done", "error")
"""The readings of a sample in the page's CSV (then the targets of position, speed and torque)."""
_CONFIRMED = {"enable": actions.why_not_enabled, "clear": actions.why_not_cleared}
"""The rows whose end the dashboard checks before it reports success, and how."""
PAGE_ROWS = {"stop": "stop", "idle": "idle", "enable": "enable", "clear_errors": "clear"}
"""The page's buttons that are rows of :mod:`drempower.actions` (the page's name: the row's)."""
PAGE_CONTROLS: dict[str, tuple[str, dict[str, str], dict[str, Any]]] = {
    "T": ("move", {"angle": "angle", "param": "bandwidth"}, {"mode": "T"}),
    "Q": ("move", {"angle": "angle", "speed": "speed", "param": "accel"}, {"mode": "Q"}),
    "P": ("move", {"angle": "angle", "speed": "speed_ff", "param": "torque_ff"}, {"mode": "P"}),
    "jog": ("step", {"delta": "angle", "speed": "speed", "param": "accel"}, {"mode": "Q"}),
    "step": ("step", {"delta": "angle", "param": "bandwidth"}, {"mode": "T"}),
    "V": ("speed", {"speed": "speed", "mode": "mode"}, {}),
    "C": ("torque", {"torque": "torque", "mode": "mode"}, {}),
    "impedance": ("impedance", {"angle": "pos", "speed": "vel", "torque": "tff", "kp": "kp", "kd": "kd"}, {}),
}
"""The page's controls that are rows of :mod:`drempower.actions`: the row, the row's argument for each
field the page sends, and the arguments the control fixes (its mode). The T-mode speed the page sends is
not passed: the motor does not use it."""
PAGE_PARAM: dict[str, dict[int, str]] = {"V": {1: "torque_ff", 2: "ramp"}, "C": {6: "ramp"}}
"""The row's argument for the page's ``param`` of the velocity and torque controls, by mode (direct
torque, mode 1, has none: the motor does not use it)."""
_LABEL = {w.name: w.label for w in ERROR_WORDS}
BITS_PER_FRAME = 130
"""Bits on the wire of one 8-byte standard CAN frame with stuffing (about), for the bus load."""
ASSUMED_BITRATE = 1_000_000
"""The CAN bit rate (bit/s) the bus load is reckoned against when the transport does not know it."""
POLL_BUDGET = 0.30
"""Share of a bus the dashboard's polling (state fast reads and parameter plots of every browser
together, request and reply frames) may take."""
_TIMEOUT_MS = "can.config.timeout_ms"
"""The motor's CAN timeout (ms): with ``--watchdog`` a motor idles by itself when the dashboard is gone."""


def param_table() -> list[dict[str, Any]]:
    """Every parameter as the page shows it: name, group, address, type, unit, access, description."""
    return [
        {
            "name": p.name,
            "group": p.name.rsplit(".", 1)[0] if "." in p.name else "(top)",
            "address": p.address,
            "type": p.dtype.name.lower(),
            "unit": p.unit,
            "access": p.access.value,
            "bool": p.is_bool,
            "description": p.description,
            "min": p.minimum,
            "max": p.maximum,
            "allowed": list(p.allowed),
            "hard": p.hard,
            "domain": p.domain_text() if p.has_domain else "",
        }
        for p in parameters()
    ]


def _num(args: dict[str, Any], key: str, default: float | None = None) -> float:
    value = args.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValidationError(f"{key}={value!r}: expected a finite number")
    return float(value)


def motor_id(args: dict[str, Any], key: str = "id") -> int:
    """``args[key]`` as a motor id: a whole number 1..63 (nothing rounded)."""
    value = args.get(key)
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 63:
        raise ValidationError(f"{key}={value!r}: expected a motor id 1..63")
    return value


def bounds(raw: dict[str, float | None]) -> dict[str, Any]:
    """Control-input bounds from the limits a motor holds: ``speed`` r/min and ``torque`` Nm (magnitudes,
    None: unknown), ``bandwidth`` [low, high] 1/s; the torque bound is the smaller of the torque
    limit and the current limit times the output torque constant."""
    speed, torque, current, kt = (raw.get(k) for k in ("speed", "torque", "current", "torque_constant"))
    by_current = current * kt if current is not None and kt is not None and kt > 0 else None
    if torque is None or (by_current is not None and by_current < torque):
        torque = by_current
    return {"speed": speed, "torque": torque, "current": current, "bandwidth": list(bandwidth_range())}


def _within(key: str, value: float, bound: float | None, unit: str, what: str) -> None:
    if bound is not None and abs(value) > bound:
        raise ValidationError(f"{key}={value:g}: outside -{bound:g}..{bound:g} {unit}, the {what}")


def _ids(args: dict[str, Any], key: str = "ids") -> list[int]:
    ids = args.get(key)
    if (
        not isinstance(ids, list)
        or not ids
        or not all(isinstance(i, int) and not isinstance(i, bool) and 1 <= i <= 63 for i in ids)
    ):
        raise ValidationError(f"{key}={ids!r}: expected a list of motor ids 1..63")
    return list(ids)


class Hub:
    """Bus-side state of one dashboard: over one :class:`Bus`, or over every bus of a :class:`Robot`.

    Motors are known by a key: the motor id on one bus; ``bus index * 64 + id``
    over a robot's buses (in file order). ``poll_hz``: fast reads per second per
    motor while the motors send no heartbeat; ``read_only``: refuse every action
    that sends a command.
    """

    def __init__(
        self, bus: Bus | Robot, *, read_only: bool = False, poll_hz: float = 50.0, watchdog_ms: int | None = None
    ) -> None:
        self.robot: Robot | None = None if isinstance(bus, Bus) else bus
        self.buses: list[tuple[str, Bus]] = [("", bus)] if isinstance(bus, Bus) else list(bus.buses.items())
        self.bus = self.buses[0][1]
        self.joints: dict[int, dict[str, Any]] = {}
        """Robot joints by key: ``{"joint", "bus", "id"}``."""
        self.units: dict[int, JointUnits] = {}
        """The page's units of each robot joint by key (deg, r/min, Nm at the joint); a bare motor's are its own."""
        if self.robot is not None:
            index = {name: k for k, (name, _) in enumerate(self.buses)}
            for j in self.robot.spec.joints.values():
                self.joints[index[j.bus] * KEYS_PER_BUS + j.id] = {"joint": j.name, "bus": j.bus, "id": j.id}
                self.units[index[j.bus] * KEYS_PER_BUS + j.id] = JointUnits(Gearing(j))
        self.read_only = read_only
        self.poll_hz = poll_hz
        self.watchdog_ms = watchdog_ms
        """With a value, each motor found gets this CAN timeout (ms) while the dashboard runs."""
        self.watchdog_before: dict[int, int] = {}
        """The CAN timeout each armed motor held before (put back by :meth:`close`)."""
        self._tokens = [0.0 for _ in self.buses]
        self._scan_lock = threading.Lock()
        self.t0 = time.monotonic()
        self.samples: deque[Sample] = deque()
        self.samples_total = 0
        self.motors: dict[int, dict[str, Any]] = {}
        self.targets: dict[int, list[float | None]] = {}
        self.commanded: set[int] = set()
        self.commanders: dict[int, str] = {}
        """Per motor key, the page that last set it moving (see :meth:`idle_of`)."""
        self.heartbeat_ms = 0
        self.scanning = False
        self.saved: dict[int, dict[str, float]] = {}
        self.limits: dict[int, dict[str, Any]] = {}
        self.trends: dict[int, deque[tuple[float, float, float, float]]] = {}
        """Per motor key, its health readings (s since start, winding degC, board degC, derating 0..1)."""
        self._t0 = time.monotonic()
        self._watch: dict[tuple[int, str], tuple[float, float]] = {}
        self.param_samples: deque[tuple[int, str, float, float]] = deque()
        self._proposals: dict[int, Any] = {}
        """The Tuning view's gains proposed and not yet written, by key (:mod:`drempower.dash.propose`)."""
        self._stop = threading.Event()
        self._halt = threading.Event()
        self._estops = 0
        """ESTOPs pressed so far: a request issued before the latest is fenced (see :meth:`issued`)."""
        self._issued = threading.local()
        """The ESTOP count when the request the calling worker runs was issued (None: not a page's)."""
        self._subs = [b.subscribe(self._sink(k * KEYS_PER_BUS)) for k, (_, b) in enumerate(self.buses)]
        self._poller = threading.Thread(target=self._poll_loop, name="dash poll", daemon=True)
        self._poller.start()
        self._frames_mark = [(time.monotonic(), b.stats["frames_received"]) for _, b in self.buses]
        self.load = 0.0
        self.frame_rate = 0.0
        self.health_events: deque[tuple[int, float, HealthEvent]] = deque(maxlen=500)
        """The robot's health supervisor's events (key, wall s since start, event), when the file has ``[health]``."""
        self._health_run = None if self.robot is None else self.robot.health_run
        self._health_seen: set[HealthEvent] = set()
        if self._health_run is not None:
            self._health_run.add_listener(self._on_health)
            for e in list(self._health_run.events):  # those of its steps before this dashboard listened
                self._on_health(e)

    def _on_health(self, event: HealthEvent) -> None:
        """An event of the robot's health supervisor: kept for the cards and the Health view, logged (once)."""
        key = next((k for k, j in self.joints.items() if j["joint"] == event.joint), None)
        if key is None or event in self._health_seen:
            return
        self._health_seen.add(event)
        self.health_events.append((key, round(time.monotonic() - self._t0, 2), event))
        log(f"health: {event}")

    def _sink(self, off: int) -> Callable[[MotorState], None]:
        """The subscriber of the bus whose keys start at ``off``."""
        return lambda st: self._on_state(st, off)

    # ------------------------------------------------------------------ keys

    def where(self, key: int) -> tuple[Bus, int]:
        """The bus and motor id of ``key``."""
        k, i = divmod(key, KEYS_PER_BUS)
        return self.buses[k][1], i

    def motor(self, key: int) -> Motor:
        bus, i = self.where(key)
        return bus.motor(i)

    def key(self, args: dict[str, Any], field: str = "id") -> int:
        """``args[field]`` as a motor key of this dashboard (a whole number, nothing rounded)."""
        value = args.get(field)
        if len(self.buses) == 1:
            return motor_id(args, field)
        if (
            isinstance(value, bool)
            or not isinstance(value, int)
            or not 1 <= value % KEYS_PER_BUS <= 63
            or not 0 <= value // KEYS_PER_BUS < len(self.buses)
        ):
            raise ValidationError(f"{field}={value!r}: not a motor of this dashboard's buses")
        return value

    def keys(self, args: dict[str, Any], field: str = "ids") -> list[int]:
        ids = args.get(field)
        if not isinstance(ids, list) or not ids:
            raise ValidationError(f"{field}={ids!r}: expected a list of motors")
        if len(self.buses) == 1:
            return _ids(args, field)
        return [self.key({field: i}, field) for i in ids]

    def label(self, key: int) -> str:
        """How messages and log lines name a motor: by :mod:`drempower.naming` (``motor_2``); a joint of
        the robot file by its name, with its bus and motor (``elbow (bus right, motor 1)``)."""
        if self.robot is None:
            return motor_name(key)
        bus, i = self.buses[key // KEYS_PER_BUS][0], key % KEYS_PER_BUS
        j = self.joints.get(key)
        return (
            f"{j['joint']} (bus {bus}, motor {i})" if j else self.names().get(key, {}).get("name", f"{bus}/motor_{i}")
        )

    def description(self) -> str:
        """The bus, or every bus of the robot by name."""
        if self.robot is None:
            return self.bus.transport.description
        return f"robot {os.path.basename(self.robot.spec.source)}: " + "; ".join(
            f"{name}: {bus.transport.description}" for name, bus in self.buses
        )

    def bitrate(self) -> int | None:
        """The CAN bit rate (bit/s) when the transport knows it (the slowest bus's over a robot); a serial
        link's baud rate is not the CAN bit rate and is never taken for it."""
        rates = [b.transport.wire_bitrate for _, b in self.buses]
        known = [r for r in rates if r]
        return min(known) if known and len(known) == len(rates) else None

    def budget(self, k: int = 0) -> float:
        """Requests per second the dashboard's polling may send on bus ``k`` (each has a reply):
        POLL_BUDGET of its bit rate (ASSUMED_BITRATE when unknown) in frames of BITS_PER_FRAME."""
        rate = self.buses[k][1].transport.wire_bitrate or ASSUMED_BITRATE
        return POLL_BUDGET * rate / BITS_PER_FRAME / 2

    def budget_text(self) -> str:
        """The polling budget as the page and the docs word it."""
        return f"{POLL_BUDGET * 100:.0f} % of the bus ({self.budget():.0f} requests/s with their replies)"

    def _planned(self, k: int) -> float:
        """Requests per second bus ``k``'s polling asks for: the state fast reads and the parameter plots."""
        ids = [key for key in self.motors if key // KEYS_PER_BUS == k]
        state = 0.0 if self.heartbeat_ms else len(ids) * self.poll_hz
        plots = sum(1.0 / period for (i, _), (period, _) in self._watch.items() if i // KEYS_PER_BUS == k)
        return state + plots

    def names(self) -> dict[int, dict[str, Any]]:
        """How the page names each motor it knows (the joints of a robot file, the motors found), by key:
        ``{"name", "joint", "bus", "id"}``, ``name`` by :mod:`drempower.naming` (``motor_<id>``, a joint's
        name, ``<bus>/motor_<id>`` where buses would collide)."""
        where = {k: (self.buses[k // KEYS_PER_BUS][0], k % KEYS_PER_BUS) for k in sorted({*self.joints, *self.motors})}
        joints = {(j["bus"], j["id"]): j["joint"] for j in self.joints.values()}
        named = motor_names(where.values(), joints)
        return {
            k: {"name": named[p], "joint": joints.get(p), "bus": p[0], "id": p[1]}
            | (self.units[k].describe() if k in self.units else {"units": "motor"})
            for k, p in where.items()
        }

    @staticmethod
    def columns() -> dict[str, str]:
        """The keys (with units) of the page's CSV, as ``monitor --csv`` and ``state --json`` name them."""
        return {"time": TIME_COLUMN[0], "name": "name"} | {c: COLUMNS[c][0] for c in _CSV_COLUMNS}

    # ------------------------------------------------------------------ samples

    def _on_state(self, st: MotorState, off: int = 0) -> None:
        key = off + st.node
        tg = self.targets.get(key)
        flags = int(st.trajectory_done) | (int(st.error) << 1)
        t = st.timestamp - self.t0
        u = self.units.get(key)  # a joint's samples and targets at the joint
        if u is None:
            angle, speed, torque = st.angle, st.speed, st.torque
        else:
            angle, speed, torque = u.angle(st.angle), u.speed(st.speed), u.torque(st.torque)
        if tg is None:
            self.samples.append((key, t, angle, speed, torque, flags, None, None, None))
        elif u is None:
            self.samples.append((key, t, angle, speed, torque, flags, tg[0], tg[1], tg[2]))
        else:
            a, v, q = (None if x is None else f(x) for x, f in zip(tg, (u.angle, u.speed, u.torque), strict=True))
            self.samples.append((key, t, angle, speed, torque, flags, a, v, q))
        self.samples_total += 1

    def take_samples(self) -> list[Sample]:
        """Every sample that arrived since the last call, oldest first (none is dropped)."""
        q = self.samples
        return [q.popleft() for _ in range(len(q))]

    def _spend(self, k: int, n: int) -> bool:
        """Take ``n`` requests from bus ``k``'s polling budget; False (nothing taken) when it lacks them."""
        if self._tokens[k] < n:
            return False
        self._tokens[k] -= n
        return True

    def _poll_loop(self) -> None:
        next_t = last = time.monotonic()
        keep_alive = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            for k in range(len(self.buses)):  # the budget refills; at most 0.1 s of it is saved up
                self._tokens[k] = min(self._tokens[k] + (now - last) * self.budget(k), self.budget(k) * 0.1)
            last = now
            # with --watchdog and heartbeats on, a fast read every third of the timeout keeps the motors going
            alive = bool(self.watchdog_before) and now >= keep_alive
            if alive:
                keep_alive = now + (self.watchdog_ms or 0) / 3000.0
            if self.motors and (alive or (not self.heartbeat_ms and not self.scanning)):
                keys = sorted(set(self.motors) | set(self.watchdog_before))
                for k, (_, bus) in enumerate(self.buses):
                    ids = [key % KEYS_PER_BUS for key in keys if key // KEYS_PER_BUS == k]
                    if ids and not bus.closed and (self._spend(k, len(ids)) or alive):
                        try:
                            bus.request([FastRead(i) for i in ids], missing_ok=True)
                        except DrEmpowerError:
                            pass
            if self._watch and not self.scanning:
                self._read_watched()
            next_t = max(next_t + 1.0 / self.poll_hz, time.monotonic())
            self._stop.wait(max(0.0, next_t - time.monotonic()))

    def watch(self, i: int, name: str, hz: float) -> None:
        """Read parameter ``name`` of motor ``i`` ``hz`` times a second (0 stops) into :attr:`param_samples`."""
        p = find_parameter(name)
        if p is None:
            raise ValidationError(f"parameter {name!r}: no such parameter")
        self.key({"id": i})
        if not 0 <= hz <= self.poll_hz:
            raise ValidationError(f"rate={hz!r}: 0 (stop) or up to {self.poll_hz:g} readings/s")
        if hz == 0:
            self._watch.pop((i, p.name), None)
            return
        k = i // KEYS_PER_BUS
        old = self._watch.get((i, p.name))
        planned = self._planned(k) - (1.0 / old[0] if old else 0.0) + hz
        if planned > self.budget(k):
            raise ValidationError(
                f"rate={hz:g}: plotting {p.name} would take this dashboard's polling to {planned:.0f} requests/s, "
                f"over its budget of {self.budget_text()} for every browser together; "
                "stop another parameter plot or choose a lower rate"
            )
        self._watch[(i, p.name)] = (1.0 / hz, time.monotonic())

    def _read_watched(self) -> None:
        now = time.monotonic()
        for key, (period, due) in list(self._watch.items()):
            if now < due:
                continue
            i, name = key
            if not self._spend(i // KEYS_PER_BUS, 1):
                continue  # over budget: this reading waits for a later round
            try:
                value = self.motor(i).read_property(name, timeout=0.1)
            except DrEmpowerError:
                continue
            finally:
                if key in self._watch:
                    self._watch[key] = (period, max(due + period, now))
            self.param_samples.append((i, name, time.monotonic() - self.t0, value))

    def watched(self) -> list[list[Any]]:
        """``[id, name, rate]`` of every watched parameter."""
        return [[i, n, round(1.0 / period, 3)] for (i, n), (period, _) in sorted(self._watch.items())]

    def take_param_samples(self) -> list[tuple[int, str, float, float]]:
        q = self.param_samples
        return [q.popleft() for _ in range(len(q))]

    def measure_load(self) -> None:
        """Update :attr:`load` (fraction of a 1 Mbit/s bus; the busiest bus) and :attr:`frame_rate`
        (received frames/s, every bus) from received frames."""
        now = time.monotonic()
        if now - self._frames_mark[0][0] < 0.2:
            return
        rates = []
        for k, (_, bus) in enumerate(self.buses):
            t, f = self._frames_mark[k]
            frames = bus.stats["frames_received"]
            rates.append((frames - f) / (now - t))
            self._frames_mark[k] = (now, frames)
        self.frame_rate = sum(rates)
        self.load = max(
            r * BITS_PER_FRAME / (b.transport.wire_bitrate or ASSUMED_BITRATE)
            for r, (_, b) in zip(rates, self.buses, strict=True)
        )

    # ------------------------------------------------------------------ bus view

    def do_scan(self, progress: Callable[[int, int, list[dict[str, Any]]], None]) -> list[dict[str, Any]]:
        """Scan ids 1-63 of every bus in four groups, calling ``progress(done, 63 * buses, found)`` after each."""
        with self._scan_lock:
            found = self._scan(progress)
        self.motors = {m["id"]: m for m in found}
        for i in self.motors:
            self.do_limits(i)
        if self.watchdog_ms:
            self.arm_watchdog(sorted(self.motors))
        return found

    def _scan(self, progress: Callable[[int, int, list[dict[str, Any]]], None]) -> list[dict[str, Any]]:
        found: list[dict[str, Any]] = []
        self.scanning = True
        try:
            for k, (name, bus) in enumerate(self.buses):
                timeout = min(bus.timeout, 0.2)
                for lo in range(1, 64, 16):
                    group = range(lo, min(lo + 16, 64))
                    for info in bus.scan(group, timeout=timeout, versions=True):
                        key = k * KEYS_PER_BUS + info.id
                        entry: dict[str, Any] = {"id": key, "hw": info.hw_version, "fw": info.fw_version}
                        if self.robot is not None:
                            joint = self.joints.get(key, {}).get("joint")
                            entry.update(bus=name, motor=info.id, joint=joint)
                        found.append(entry)
                    progress(k * 63 + group[-1], 63 * len(self.buses), found)
        finally:
            self.scanning = False
        return found

    def arm_watchdog(self, keys: list[int]) -> None:
        """Give each motor of ``keys`` not yet armed the CAN timeout ``watchdog_ms``, keeping what it held
        before: killed or cut off, the dashboard leaves no motor driving for longer than that."""
        for i in keys:
            if i in self.watchdog_before or self.watchdog_ms is None:
                continue
            m = self.motor(i)
            try:
                before = int(m.read_property(_TIMEOUT_MS))
                m.write_property(_TIMEOUT_MS, self.watchdog_ms, verify=True)
            except DrEmpowerError as exc:
                log(f"{self.label(i)}: could not arm the watchdog ({_TIMEOUT_MS} = {self.watchdog_ms}): {exc}")
                continue
            self.watchdog_before[i] = before
            log(f"{self.label(i)}: watchdog armed: {_TIMEOUT_MS} = {self.watchdog_ms} (was {before})")

    def restore_watchdog(self) -> None:
        """Put back the CAN timeout each armed motor held before."""
        for i, ms in sorted(self.watchdog_before.items()):
            if self.where(i)[0].closed:
                continue
            try:
                self.motor(i).write_property(_TIMEOUT_MS, ms, verify=True)
            except DrEmpowerError as exc:
                log(f"{self.label(i)}: could not restore {_TIMEOUT_MS} to {ms}: {exc}")
        self.watchdog_before.clear()

    def do_limits(self, i: int) -> dict[str, Any]:
        """Read the limits motor ``i`` holds and keep the Control-input :func:`bounds` they give."""
        m = self.motor(i)
        raw: dict[str, float | None] = {}
        for key, name in _LIMIT_READS:
            try:
                raw[key] = float(m.read_property(name, timeout=0.2))
            except DrEmpowerError:
                raw[key] = None
        out = bounds(raw)
        bus, node = self.where(i)
        gate = bus.limits(node)  # a robot file's limits (and its model's range), in motor units
        for key in ("speed", "torque"):
            lim = gate.get(key)
            if lim is not None and (out[key] is None or lim.high < out[key]):
                out[key] = lim.high
                out.setdefault("set_by", {})[key] = lim.where
        pos = gate.get("position")
        if pos is not None:
            out["position"] = [pos.low, pos.high]
            out.setdefault("set_by", {})["position"] = pos.where
        self.limits[i] = out
        return out

    def shown_limits(self, i: int) -> dict[str, Any] | None:
        """Motor ``i``'s limits as the page shows them: at the joint for a robot joint (with its units)."""
        lim = self.limits.get(i)
        if lim is None:
            return None
        u = self.units.get(i)
        return u.limits(lim) if u is not None else {**lim, "units": "motor"}

    def joint_words(self, key: int, exc: DrEmpowerError) -> DrEmpowerError:
        """A refusal of a robot joint's value, which the page gave at the joint, in the joint's units: a
        soft limit (the gate's words, motor units) or a field's range (the wire's, at the motor) with the
        value typed and the range at the joint, the motor's figures after them; others as they are."""
        u = self.units.get(key)
        if u is None or not isinstance(exc, FieldRangeError) or not isinstance(exc.value, (int, float)):
            return exc
        who = self.label(key)
        if isinstance(exc, SoftLimitError):
            at = u.refusal(exc.limit, float(exc.value), exc.low, exc.high)
            if at is None:
                return exc
            v, lo, hi, unit = at
            return ValidationError(
                f"joint {who}: {exc.limit} {v:g} {unit} at the joint is beyond its soft limit {lo:g}..{hi:g} "
                f"{unit} at the joint (set by {exc.where}; {exc.value:g}, {exc.low:g}..{exc.high:g} at the motor)"
            )
        kind = "angle" if exc.field in ("angle", "pos") else ROW_KINDS.get(exc.field)
        if kind is None:
            return exc
        f = {"angle": u.angle, "speed": u.speed, "torque": u.torque}[kind]
        a, b = f(exc.low), f(exc.high)
        return ValidationError(
            f"joint {who}: {exc.field}={f(float(exc.value)):g} at the joint is out of range: allowed "
            f"{min(a, b):g}..{max(a, b):g} at the joint ({exc.value:g}, {exc.low:g}..{exc.high:g} at the motor)"
        )

    def words(self, text: str, key: int | None) -> str:
        """A message about motor key ``key`` with its joint named: ``motor 3: ...`` -> ``joint elbow (motor
        3): ...`` on a robot (the library's words otherwise unchanged)."""
        j = self.joints.get(key) if key is not None else None
        if j is None or re.search(rf"\b{re.escape(j['joint'])}\b", text):
            return text
        return re.sub(rf"\bmotor {j['id']}\b", f"joint {j['joint']} (motor {j['id']})", text, count=1)

    def _speed(self, i: int, key: str, value: float) -> float:
        lim = self.limits.get(i, {}).get("speed")
        by = self.limits.get(i, {}).get("set_by", {}).get("speed")
        held = "holds (axis0.output_shaft.vel_limit)" if by is None else f"has (set by {by})"
        u = self.units.get(i)
        if u is not None and lim is not None:  # the page's value and the limit at the joint
            _within(key, u.speed(value), abs(u.speed(lim)), "r/min at the joint", f"speed limit {self.label(i)} {held}")
        _within(key, value, lim, "r/min", f"speed limit {self.label(i)} {held}")
        return value

    def _torque(self, i: int, key: str, value: float) -> float:
        lim = self.limits.get(i, {}).get("torque")
        by = self.limits.get(i, {}).get("set_by", {}).get("torque")
        what = f"torque limit {self.label(i)} " + (
            "holds (output_shaft.torque_lim, current_lim x torque_constant)" if by is None else f"has (set by {by})"
        )
        u = self.units.get(i)
        if u is not None and lim is not None:  # the page's value and the limit at the joint
            _within(key, u.torque(value), abs(u.torque(lim)), "Nm at the joint", what)
        _within(key, value, lim, "Nm", what)
        return value

    def do_cards(self) -> dict[int, dict[str, Any]]:
        """Supply voltage, axis state, temperatures and decoded error flags of every known motor."""
        cards: dict[int, dict[str, Any]] = {}
        for i in sorted(self.motors):
            m = self.motor(i)
            found = self.motors.get(i, {})
            card: dict[str, Any] = {"id": i, "fw": found.get("fw"), "hw": found.get("hw")}
            for key, name in _CARD_READS:
                try:
                    card[key] = m.read_property(name, timeout=0.2)
                except DrEmpowerError:
                    card[key] = None
            card["state_name"] = state_name(card["state"])
            card["limits"] = self.shown_limits(i)
            st = m.state
            card["errors"] = []
            try:  # temperatures, effective current limit, derating and errors with their fixes (5 reads, +7 faulted)
                h = m.health(timeout=0.2)
            except DrEmpowerError:
                h = None
            if h is not None:
                card.update(
                    fet_temp=h.driver_temp_c,
                    motor_temp=h.motor_temp_c,
                    current_limit=h.current_limit_a,
                    derating=h.derating,
                )
                trend = self.trends.setdefault(i, deque(maxlen=TREND_POINTS))
                trend.append((round(time.monotonic() - self._t0, 2), round(h.motor_temp_c, 2),
                              round(h.driver_temp_c, 2), round(h.derating, 4)))  # fmt: skip
                card["trend"] = list(trend)
                card["errors"] = [
                    {"word": f.word, "flag": f.flag, "meaning": f.meaning, "advice": f.fix} for f in h.faults
                ]
            else:
                card.update(fet_temp=None, motor_temp=None, current_limit=None, derating=None)
            if h is None and st is not None and st.error:
                try:
                    report = m.dump_error(timeout=0.2)
                    card["errors"] = []
                    for w, names in report.flags.items():
                        for f in names:
                            info = flag_info(_LABEL[w], f)
                            card["errors"].append(
                                {"word": w, "flag": f, "meaning": info.meaning, "advice": info.action}
                            )
                except DrEmpowerError:
                    card["errors"] = [{"word": "?", "flag": "error (unread)", "advice": "read again"}]
            self._card_health(i, card)
            cards[i] = card
        return cards

    def _card_health(self, key: int, card: dict[str, Any]) -> None:
        """The robot's health supervisor's say on motor ``key``: its level and latest events (with what it did)."""
        run = self._health_run
        if run is None:
            return
        j = self.joints.get(key)
        card["level"] = None if j is None else run.levels().get((j["bus"], j["id"]))
        card["events"] = [
            {"t": t, "kind": e.kind, "level": e.level, "action": e.action, "text": str(e)}
            for k, t, e in list(self.health_events)
            if k == key
        ][-HEALTH_EVENTS_SHOWN:]

    # ------------------------------------------------------------------ control

    def ticket(self) -> int:
        """What a request issued now carries (the count of ESTOPs pressed so far): take it when the
        request arrives, before it waits for a worker, and run it with :meth:`issued`."""
        return self._estops

    def fence(self) -> None:
        """An ESTOP was pressed: every request issued before it is fenced from now on, whichever page or
        front end issued it; those issued after (a clear, an enable) run as usual."""
        self._estops += 1

    def issued(self, ticket: int, fn: Callable[..., Any], *args: Any) -> Any:
        """Run ``fn(*args)`` in this worker as a request issued with ``ticket``: once an ESTOP came after
        it was issued, each of its commands but the stopping ones (stop, idle, estop) is refused."""
        self._issued.ticket = ticket
        try:
            return fn(*args)
        finally:
            self._issued.ticket = None

    def fenced(self) -> bool:
        """True when the request this worker runs was issued before the latest ESTOP."""
        ticket = getattr(self._issued, "ticket", None)
        return ticket is not None and ticket < self._estops

    def check_fence(self) -> None:
        """Refuse the rest of a request issued before the latest ESTOP (nothing more is sent)."""
        if self.fenced():
            raise ValidationError("an ESTOP was pressed after this request was issued: it was not carried out")

    def _control(self, who: str, what: str) -> None:
        if self.read_only:
            raise ValidationError("this dashboard is read-only (--read-only)")
        self.check_fence()
        log(f"{who}: {what}")

    def require_enabled(self, keys: list[int]) -> None:
        """Refuse a motion to a motor that is not in closed loop (it would ignore it): one read of each
        motor's axis state; then, with ``--watchdog``, arm the motors not armed yet."""
        if self._halt.is_set():
            raise ValidationError("the dashboard is stopping: no motion is started any more")
        self.check_fence()
        idle: list[tuple[int, int]] = []
        idle_keys: list[int] = []
        for i in keys:
            state = int(self.motor(i).read_property(_STATE, timeout=0.2))
            if state != AxisState.CLOSED_LOOP_CONTROL:
                idle.append((self.where(i)[1], state))
                idle_keys.append(i)
        if idle:  # the library's refusal, in the library's words (the API, CLI and bridge say the same)
            nodes = ",".join(str(n) for n, _ in idle)
            fix = f"(the Enable button, or drempower enable {nodes})"
            if self.robot is not None:  # a hint that works: the joints by name, on the robot file
                names = ",".join(
                    self.joints[i]["joint"] if i in self.joints else str(self.where(i)[1]) for i in idle_keys
                )
                fix = f"(the Enable button, or drempower enable {names} --robot {self.robot.spec.source})"
            raise MotorIdleError([n for n, _ in idle], [s for _, s in idle], fix=fix)
        if self.watchdog_ms:
            self.arm_watchdog(keys)

    def _confirm(self, i: int, why_not: Callable[..., dict[int, str]]) -> None:
        """After an enable or a clear: motor ``i`` got there (``why_not``: :func:`~drempower.actions.why_not_enabled`
        or ``why_not_cleared``), or why not (never a silent success)."""
        bus, node = self.where(i)
        why = why_not(bus, [node]).get(node)
        if why is not None:
            raise DrEmpowerError(f"{self.label(i)} {why}")

    def _target(
        self, i: int, angle: float | None = None, speed: float | None = None, torque: float | None = None
    ) -> None:
        self.targets[i] = [angle, speed, torque]
        self.commanded.add(i)

    def do_control(self, who: str, args: dict[str, Any]) -> Any:
        """One control action from a page: ``args["action"]`` names it; returns what the page shows.

        Every control is a row of :mod:`drempower.actions` run by :meth:`do_action`: with
        ``args["args"]`` (an object) the row named (the Actions panel); the buttons Enable, Stop,
        Idle and Clear errors (:data:`PAGE_ROWS`); the position modes, jog, step, velocity, torque
        and impedance (:data:`PAGE_CONTROLS`: the page's fields renamed to the row's arguments).
        The synchronised move is :meth:`do_sync_move` (each motor checked by row ``move``)."""
        action = args.get("action")
        if "args" in args:
            row_args = args["args"]
            if not isinstance(row_args, dict):
                raise ValidationError(f"args={row_args!r}: expected an object of argument names and values")
            return self.do_action(who, str(action), row_args)
        if isinstance(action, str) and action in PAGE_ROWS:
            return self.do_action(who, PAGE_ROWS[action], {"id": args.get("id")})
        if action == "sync_move":
            return self.do_sync_move(who, args)
        if not isinstance(action, str) or action not in PAGE_CONTROLS:
            raise ValidationError(f"action={action!r}: unknown control action")
        row, fields, fixed = PAGE_CONTROLS[action]
        row_args = {"id": args.get("id"), **fixed}
        row_args.update({arg: args[field] for field, arg in fields.items() if field in args})
        if action in PAGE_PARAM and "param" in args:  # its meaning is the mode's (the row's words for a bad mode)
            mode = actions.get(row).arg("mode")
            given = args.get("mode")
            name = PAGE_PARAM[action].get(mode.default if given is None else mode.check(given))
            if name is not None:
                row_args[name] = args["param"]
        elif action == "step" and "param" not in args:  # a T step through the motor's own filter
            row_args["bandwidth"] = float(self.motor(self.key(args)).read_property(_BANDWIDTH))
        key = self._joint_key(args)
        if key is None:
            return self.do_action(who, row, row_args)
        try:  # a robot joint's values are at the joint: the row runs on the motor's
            return self.do_action(who, row, self.units[key].to_motor(row, row_args))
        except FieldRangeError as exc:
            raise self.joint_words(key, exc) from None

    def _joint_key(self, args: dict[str, Any]) -> int | None:
        """The key of ``args["id"]`` when it is a robot joint (its page values are at the joint), else None."""
        if not self.units:
            return None
        try:
            key = self.key(args)
        except ValidationError:
            return None
        return key if key in self.units else None

    def do_action(self, who: str, name: str, args: dict[str, Any]) -> Any:
        """Run row ``name`` of :mod:`drempower.actions` with ``args`` (``id``: a motor key of this
        dashboard; 0: every motor on every bus, for the rows that take it); returns its result as
        JSON-ready values. Validated by the table (its words), then the dashboard's checks: read-only
        refuses all but reading and stopping, a motion needs a motor in closed loop (or
        ``enable``) and stays within the limits the motor holds; logged, and the targets kept."""
        act = actions.get(name)
        if self.read_only and act.safety not in ("read", "stop"):  # first: whatever else, it is never carried out
            raise ValidationError("this dashboard is read-only (--read-only)")
        if act.safety != "stop":
            self.check_fence()
        raw = args.get("id")
        if raw == 0 or len(self.buses) == 1:  # the motor id is the key (0: each bus's broadcast)
            places = [(b, 0) for _, b in self.buses] if raw == 0 else [(self.bus, -1)]
            typed = actions.validate(act, args)
            key = typed["id"]
        else:
            key = self.key(args)
            bus, node = self.where(key)
            places = [(bus, node)]
            typed = actions.validate(act, {**args, "id": node})
        if act.safety == "motion":
            if typed.get("enable"):
                if self._halt.is_set():
                    raise ValidationError("the dashboard is stopping: no motion is started any more")
                if self.watchdog_ms:
                    self.arm_watchdog([key])
            else:
                self.require_enabled([key])
            self._within_limits(act, key, typed)
        shown = ", ".join(f"{k}={v}" for k, v in typed.items() if k != "id" and v is not None)
        log(f"{who}: {'every motor' if key == 0 else self.label(key)} {act.name}({shown})")
        base = self._base(key) if act.name == "step" else 0.0
        results = [actions.run(bus, act, typed if node < 0 else {**typed, "id": node}) for bus, node in places]
        self._track(act, key, typed, base)
        if act.safety == "motion":
            for k in sorted(self.commanded) if key == 0 else [key]:
                self.commanders[k] = who
        if act.name in _CONFIRMED and key != 0:
            self._confirm(key, _CONFIRMED[act.name])  # never a silent success: got there, or why not
        if all(r is None for r in results):  # a command (one frame per bus for a broadcast): sent
            return None
        return actions.plain(results[0] if len(results) == 1 else results)

    def do_row(self, who: str, req: dict[str, Any]) -> dict[str, Any]:
        """The Actions view's request: row ``req["action"]`` with the object ``req["args"]``, run by
        :meth:`do_control`; returns its ``result`` and ``said``, what it came to in the words the
        command line prints (:func:`drempower.actions.outcome`; None for a record or a list)."""
        name = str(req.get("action"))
        result = self.do_control(who, {"action": name, "args": req.get("args")})
        said = actions.outcome(name, result)
        return {"result": result, "said": None if said is None else name + said}

    def _within_limits(self, act: actions.Action, key: int, typed: dict[str, Any]) -> None:
        """A motion's speeds and torques (targets and feed-forwards) within the limits motor ``key`` holds."""
        for field in ("speed", "vel", "speed_ff"):
            if typed.get(field) is not None and act.arg(field).unit == "r/min":
                self._speed(key, field, typed[field])
        for field in ("torque", "tff", "torque_ff"):
            if typed.get(field) is not None:
                self._torque(key, field, typed[field])

    def do_sync_move(self, who: str, args: dict[str, Any]) -> dict[str, Any]:
        """A synchronised Q move of ``args["ids"]`` to ``args["angles"]`` (deg), cruise ``speed``, ``accel``:
        each motor's values checked by row ``move`` of :mod:`drempower.actions` (its words) and the
        limits it holds, every motor in closed loop, then one ``set_angles`` (the table's rows act on one
        motor each: a move that starts motors together, across buses by the robot's joints, is no row)."""
        keys = self.keys(args)
        angles = args.get("angles")
        if not isinstance(angles, list) or len(angles) != len(keys):
            raise ValidationError(f"angles={angles!r}: one angle per motor of ids={keys}")
        move = actions.get("move")
        shared = {"mode": "Q", "speed": args.get("speed"), "accel": args.get("accel")}
        gears = [abs(self.units[k].gear) for k in keys if k in self.units]
        scale = min(gears) if gears and len(gears) == len(keys) else 1.0  # rates at the joints: none faster
        typed = []
        for k, a in zip(keys, angles, strict=True):
            u = self.units.get(k)
            given = {"id": self.where(k)[1], "angle": a, **shared}
            if u is not None:  # a robot joint's angle at the joint; the rates by the smallest gear
                given = u.to_motor("move", {**given, "speed": None, "accel": None}) | {
                    r: v * scale if isinstance(v, (int, float)) and not isinstance(v, bool) else v
                    for r, v in shared.items()
                    if r != "mode"
                }
            try:
                typed.append(actions.validate(move, given))
            except FieldRangeError as exc:
                raise self.joint_words(k, exc) from None
        if self.read_only:
            raise ValidationError("this dashboard is read-only (--read-only)")
        self.require_enabled(keys)
        for k, t in zip(keys, typed, strict=True):
            self._within_limits(move, k, t)
        speed, accel = typed[0]["speed"], typed[0]["accel"]
        seconds = self._sync_move(who, keys, [t["angle"] for t in typed], speed, accel)
        for k, t in zip(keys, typed, strict=True):
            self._target(k, angle=t["angle"])
        return {"seconds": seconds}

    def _base(self, key: int) -> float:
        """Where a relative move starts from: the last target, else the last angle read."""
        base = self.targets.get(key, [None])[0]
        if base is None:
            st = self.motor(key).state
            base = st.angle if st is not None else 0.0
        return base

    def _track(self, act: actions.Action, key: int, typed: dict[str, Any], base: float) -> None:
        """Keep the targets (plotted beside the samples) and the motors commanded after row ``act`` ran."""
        keys = sorted(self.commanded | set(self.targets)) if key == 0 else [key]
        if act.name in ("idle", "estop"):
            for k in keys:
                self.commanded.discard(k)
                self.targets.pop(k, None)
        elif act.name == "stop":
            for k in keys:
                self._target(k, speed=0.0)
        elif act.safety == "motion":
            angle = {"move": typed.get("angle"), "step": base + typed.get("angle", 0.0), "impedance": typed.get("pos")}
            self._target(key, angle.get(act.name), typed.get("speed") if act.name == "speed" else None)
            if act.name == "torque":
                self._target(key, torque=typed["torque"])

    def _sync_move(self, who: str, keys: list[int], angles: list[float], speed: float, accel: float) -> float | None:
        """One synchronised Q-mode move: on one bus its ``set_angles``; across buses the robot's, by joint."""
        buses = {k // KEYS_PER_BUS for k in keys}
        if len(buses) == 1:
            bus, ids = self.buses[buses.pop()][1], [k % KEYS_PER_BUS for k in keys]
            where = "" if self.robot is None else f" on bus {self.buses[keys[0] // KEYS_PER_BUS][0]}"
            self._control(who, f"set_angles({ids}, {angles}, speed={speed}, param={accel}, mode=1){where}")
            return bus.set_angles(ids, angles, speed, accel, 1)
        assert self.robot is not None
        strangers = [self.label(k) for k in keys if k not in self.joints]
        if strangers:
            raise ValidationError(f"a move across buses takes joints of the robot file; not: {', '.join(strangers)}")
        targets = {self.joints[k]["joint"]: a for k, a in zip(keys, angles, strict=True)}
        self._control(who, f"robot set_angles({targets}, speed={speed}, param={accel}, mode=1)")
        move = self.robot.set_angles(targets, speed, accel, 1)
        return move.move_time

    def estop(self, who: str) -> None:
        """Emergency-stop every motor on every bus (one broadcast frame per bus, all at once);
        allowed even when read-only."""
        self.fence()
        if self.robot is None:
            log(f"{who}: ESTOP (broadcast emergency stop)")
            self.bus.estop()
        else:
            log(f"{who}: ESTOP (broadcast emergency stop on buses {', '.join(n for n, _ in self.buses)})")
            self.robot.estop()
        self.targets.clear()

    def idle_of(self, who: str, why: str) -> list[int]:
        """Put into IDLE the motors page ``who`` was the last to set moving (it went away: a page is a
        controller, and its motion ends with it); returns their keys."""
        keys = sorted(k for k, w in list(self.commanders.items()) if w == who and k in self.commanded)
        for k in keys:
            self.commanded.discard(k)
            self.commanders.pop(k, None)
            self.targets.pop(k, None)
            try:
                self.motor(k).set_mode(1)
            except DrEmpowerError as exc:
                log(f"idling {self.label(k)} failed: {exc}")
        if keys:
            log(f"{why}: idled {', '.join(map(self.label, keys))}")
        return keys

    def idle_commanded(self, why: str) -> list[int]:
        """Put the motors this dashboard moved into IDLE (a robot file's joint that holds: speed 0, so an arm
        is not dropped); returns their ids."""
        ids = sorted(self.commanded)
        self.commanded.clear()  # a second caller meanwhile finds nothing to do
        held: list[int] = []
        for i in ids:
            bus, node = self.where(i)
            try:
                if node in bus.held_on_close:
                    bus.send_frames(hold_frames([node]))
                    held.append(i)
                else:
                    self.motor(i).set_mode(1)
            except DrEmpowerError as exc:
                log(f"stopping {self.label(i)} failed: {exc}")
        idled = [i for i in ids if i not in held]
        if idled:
            log(f"{why}: idled {', '.join(map(self.label, idled))}")
        if held:
            log(f"{why}: held {', '.join(map(self.label, held))} (speed 0: the robot file's on_timeout)")
        self.commanded.clear()
        self.targets.clear()
        return ids

    def do_rate(self, who: str, hz: float) -> None:
        """Sample rate per motor: ``hz`` > 0 turns the motors' heartbeats on (period 1000/hz ms), 0 off."""
        if not 0 <= hz <= 1000:
            raise ValidationError(f"rate={hz!r}: 0 (poll at {self.poll_hz:g}/s) or 1..1000 samples/s")
        ms = 0 if hz == 0 else max(1, round(1000 / hz))
        self._control(who, f"{_HEARTBEAT} = {ms} on motors {sorted(self.motors)}")
        for i in sorted(self.motors):
            self.motor(i).write_property(_HEARTBEAT, ms)
        self.heartbeat_ms = ms

    # ------------------------------------------------------------------ parameters

    def do_read_params(self, i: int) -> dict[str, Any]:
        """Every readable parameter of motor ``i`` (one backup read), with which changed this session.

        The motor cannot tell what its flash holds, so the baseline is this dashboard's first
        read of the motor, replaced by what it holds after each *Save to flash* from here.
        """
        values = self.motor(i).backup().values()
        saved = self.saved.setdefault(i, {})
        for k, v in values.items():  # the first read of each value is its baseline
            saved.setdefault(k, v)
        changed = [k for k, v in values.items() if k in saved and saved[k] != v]
        return {"id": i, "values": values, "changed": changed}

    def do_write_param(self, who: str, i: int, name: str, value: Any, force: bool = False) -> dict[str, Any]:
        """Write one parameter, then read it back.

        The value is checked first against the parameter's type, wire range and domain
        (:meth:`Parameter.check`): outside it, the :class:`DomainError` and nothing is sent.
        ``force`` lets a value outside a soft domain through, never outside a hard one.
        """
        p: Parameter | None = find_parameter(name) if isinstance(name, str) else None
        if p is None:
            raise ValidationError(f"parameter {name!r}: no such parameter")
        if not p.writable:
            raise ValidationError(f"parameter {name}: read-only")
        v = _num({name: value}, name)
        if p.dtype.name != "F32" and v != int(v):
            raise ValidationError(f"{name}={value!r}: expected a whole number ({p.dtype.name.lower()})")
        sent = p.check(int(v) if p.dtype.name != "F32" else v, force)  # DomainError naming the domain
        forced = ", force=True" if force and p.has_domain and not p.in_domain(sent) else ""
        self._control(who, f"{self.label(i)} write_property({name!r}, {value}{forced})")
        m = self.motor(i)
        baseline = self.saved.setdefault(i, {})
        if p.name not in baseline:  # what it held before this session's first write of it
            baseline[p.name] = m.read_property(name)
        m.write_property(name, sent, force=bool(forced))
        back = m.read_property(name)
        if any(name == n for _, n in _LIMIT_READS):
            self.do_limits(i)
        changed = back != baseline[p.name]
        return {"id": i, "name": name, "value": back, "limits": self.shown_limits(i), "changed": changed}

    def do_save(self, who: str, i: int) -> None:
        """Store motor ``i``'s RAM configuration in flash; what it holds becomes the saved set."""
        self._control(who, f"{self.label(i)} save_config()")
        self.motor(i).save_config()
        self.saved[i] = self.motor(i).backup().values()

    def do_backup(self, i: int) -> dict[str, Any]:
        return self.motor(i).backup().to_json()

    def do_restore(self, who: str, i: int, doc: Any, dry_run: bool) -> dict[str, Any]:
        """Restore a backup document: with ``dry_run`` only the diff (name, now, backup) is returned."""
        if not isinstance(doc, dict):
            raise ValidationError("restore: expected a backup document (JSON object)")
        backup = ConfigBackup.from_json(doc)
        if not dry_run:
            self._control(who, f"{self.label(i)} restore(backup of motor {backup.node} from {backup.created})")
        report = self.motor(i).restore(backup, dry_run=dry_run)
        return {
            "id": i,
            "dry_run": dry_run,
            "diff": [list(w) for w in report.written],
            "failed": [list(f) for f in report.failed],
        }

    # ------------------------------------------------------------------ tuning

    def do_step(self, who: str, args: dict[str, Any]) -> dict[str, Any]:
        """A step response of one motor: position (T mode with ``bandwidth`` 1/s, default the motor's
        input filter bandwidth) or velocity. A velocity step ends here at its duration (speed 0), however
        the run ends; a position step leaves the motor holding its target.

        Returns the actual series (``t`` s from the step, ``y`` deg or r/min) and its figures.
        """
        if self.read_only:
            raise ValidationError("this dashboard is read-only (--read-only)")
        i = self.key(args)
        mode = args.get("mode", "position")
        amp, duration = _num(args, "amplitude"), _num(args, "duration", 1.0)
        if mode not in ("position", "velocity"):
            raise ValidationError(f"mode={mode!r}: position or velocity")
        if not 0.1 <= duration <= 10:
            raise ValidationError(f"duration={duration}: 0.1..10 s")
        m = self.motor(i)
        bandwidth = None
        if mode == "position":
            given = args.get("bandwidth")  # checked as row move's T-mode bandwidth, in its words
            bandwidth = float(m.read_property(_BANDWIDTH)) if given is None else actions.BANDWIDTH.check(given)
        self.require_enabled([i])
        st = m.get_state()
        u = self.units.get(i)  # a robot joint steps at the joint (deg, r/min there), a bare motor at the motor
        base = st.angle if mode == "position" else st.speed
        if u is not None:
            base = u.angle(st.angle) if mode == "position" else u.speed(st.speed)
        target = base + amp
        got: list[MotorState] = []
        bus, node = self.where(i)
        sub = bus.subscribe(got.append, node)
        fast = not self.heartbeat_ms  # 500 samples/s for the run (the motor's heartbeat), off afterwards
        try:
            if fast:
                m.write_property(_HEARTBEAT, 2)
            start = time.monotonic()
            if mode == "position":
                self.do_control(who, {"action": "T", "id": i, "angle": target, "param": bandwidth})
            else:
                self.do_control(who, {"action": "V", "id": i, "speed": target})
            end = time.monotonic() + duration
            while not self._halt.is_set() and not self.fenced() and time.monotonic() < end:
                self._halt.wait(min(0.02, max(0.0, end - time.monotonic())))  # an ESTOP ends the run too
        finally:
            sub.cancel()
            try:
                if mode == "velocity" and i in self.commanded:  # the step ends here, not in the page
                    log(f"{who}: {self.label(i)} velocity step ended: set_speed(0)")
                    m.set_speed(0.0)
                    self._target(i, speed=0.0)
            finally:
                if fast:
                    m.write_property(_HEARTBEAT, 0)
        key = 1 if mode == "position" else 2
        ts = [s.timestamp - start for s in got if s.timestamp >= start]
        ys = [s[key] for s in got if s.timestamp >= start]
        if u is not None:
            ys = [u.angle(y) if mode == "position" else u.speed(y) for y in ys]
        fig = tuning.step_figures(ts, ys, base, target)
        units = "joint" if u is not None else "motor"
        return {"id": i, "mode": mode, "units": units, "base": base, "target": target, "t": ts, "y": ys, "figures": fig}

    def do_propose(self, who: str, args: dict[str, Any]) -> dict[str, Any]:
        """Propose gains for ``args["bandwidth"]`` Hz (the joint is identified and stepped; nothing is
        written): see :mod:`drempower.dash.propose`."""
        from . import propose

        if self.read_only:
            raise ValidationError("this dashboard is read-only (--read-only)")
        return propose.propose(self, who, args, self._proposals)

    def do_apply_gains(self, who: str, args: dict[str, Any]) -> dict[str, Any]:
        """Write the proposed gains (the user confirmed) and step again: the figures before and after."""
        from . import propose

        return propose.apply(self, who, args, self._proposals)

    # ------------------------------------------------------------------ lifetime

    def halt(self) -> None:
        """End the step runs under way now (the dashboard is stopping)."""
        self._halt.set()

    def close(self) -> None:
        self._halt.set()
        self._stop.set()
        if self._health_run is not None:
            self._health_run.remove_listener(self._on_health)
        for sub in self._subs:
            sub.cancel()
        self._poller.join(2.0)
        self.restore_watchdog()
        if self.heartbeat_ms:
            for i in sorted(self.motors):
                if self.where(i)[0].closed:
                    continue
                try:
                    self.motor(i).write_property(_HEARTBEAT, 0)
                except DrEmpowerError:
                    pass
