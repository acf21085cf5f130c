"""The dashboard's side of the bus: control actions and the stop rules, over parts that hold the rest.

Everything goes through the client's public API (:class:`~drempower.client.Bus`,
:class:`~drempower.client.Motor`) and the rows of :mod:`drempower.actions`, run by one
:class:`~drempower.actions.Service` whose hooks are the dashboard's policy (read-only, the
ESTOP fence, the Enable button's words, the limits each motor holds, the watchdog).
The parts: :mod:`.keys` (where each motor lives and its name), :mod:`.sampling`
(samples, polling, plots, bus load), :mod:`.targets` (what was set moving, by whom),
:mod:`.limits`, :mod:`.cards`, :mod:`.params`, :mod:`.watchdog`, :mod:`.fence` and
:mod:`.controls` (the page's controls as rows). Methods named
``do_*`` block (they wait for replies) and are run in a worker thread by the web server.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from .. import actions
from ..actions import bandwidth_range
from ..client import Bus, MotorState
from ..errors import DrEmpowerError, FieldRangeError, ValidationError
from ..naming import COLUMNS, TIME_COLUMN
from . import tuning
from .cards import Cards
from .controls import PAGE_CONTROLS, PAGE_ROWS, page_row
from .fence import Fence
from .keys import KEYS_PER_BUS, MotorKeys, motor_id
from .limits import MotorLimits, bounds
from .logline import log
from .params import Params, number, param_table
from .sampling import Sample, Sampler
from .targets import Targets
from .watchdog import Watchdog

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["KEYS_PER_BUS", "Hub", "Sample", "bandwidth_range", "bounds", "motor_id", "param_table"]

_HEARTBEAT = "can.config.heartbeat_ms"
_BANDWIDTH = "axis0.controller.config.input_filter_bandwidth"
"""The motor's T-mode input filter bandwidth (1/s): a step from the page or the Tuning view without
one goes through it."""
_CSV_COLUMNS = ("id", "position", "speed", "torque", "done", "error")
"""The readings of a sample in the page's CSV (then the targets of position, speed and torque)."""
_READ_ONLY = "this dashboard is read-only (--read-only)"
_STOPPING = "the dashboard is stopping: no motion is started any more"


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
        self.read_only = read_only
        # the parts, each holding only what it needs; their state and methods are also the Hub's, under the
        # names the server, the views and the tests use
        self.motor_keys = keys = MotorKeys(bus)
        self.robot, self.buses, self.bus = keys.robot, keys.buses, keys.bus
        self.joints, self.units = keys.joints, keys.units
        self.where, self.motor, self.label = keys.where, keys.motor, keys.label
        self.key, self.keys, self.names = keys.key, keys.keys, keys.names
        self.description, self.words, self.bitrate = keys.description, keys.words, keys.bitrate
        self.watchdog = Watchdog(keys, watchdog_ms)
        self.arm_watchdog, self.restore_watchdog = self.watchdog.arm, self.watchdog.restore
        self.tracking = Targets(keys)
        self.targets, self.commanded = self.tracking.targets, self.tracking.commanded
        self.commanders = self.tracking.commanders
        self.idle_of, self.idle_commanded = self.tracking.idle_of, self.tracking.idle_commanded
        self.motor_limits = lim = MotorLimits(keys)
        self.limits, self.do_limits, self.shown_limits = lim.limits, lim.read, lim.shown
        self.joint_words = lim.joint_words
        self.cards = Cards(keys, lim, None if self.robot is None else self.robot.health_run)
        self.do_cards, self.health_events = self.cards.read, self.cards.health_events
        self.params = Params(keys, lim, self._control)
        self.do_read_params, self.do_write_param = self.params.read, self.params.write
        self.do_save, self.do_backup, self.do_restore = self.params.save, self.params.backup, self.params.restore
        self._scan_lock = threading.Lock()
        self._proposals: dict[int, Any] = {}
        """The Tuning view's gains proposed and not yet written, by key (:mod:`drempower.dash.propose`)."""
        self._halt = threading.Event()
        self.fencing = Fence()
        self.ticket, self.fence, self.issued = self.fencing.ticket, self.fencing.fence, self.fencing.issued
        self.fenced, self.check_fence = self.fencing.fenced, self.fencing.check
        self.service = actions.Service(
            keys,
            actions.Policy(
                read_only=lambda: _READ_ONLY if self.read_only else None,
                fence=self._fence_row,
                enable_fix=keys.enable_fix,
                limits=lim.check,
                ready=self._ready,
                log=log,
                state_timeout=0.2,
                interrupted=self.fenced,
            ),
        )
        """The command service every row of a page goes through."""
        self.sampler = s = Sampler(keys, self.tracking, self.watchdog, poll_hz)
        self.t0, self.take_samples, self.watch, self.watched = s.t0, s.take_samples, s.watch, s.watched
        self.take_param_samples, self.measure_load = s.take_param_samples, s.measure_load
        self.budget_text = s.budget_text

    # state that the parts own and a caller may set

    @property
    def motors(self) -> dict[int, dict[str, Any]]:
        """The motors the scan found, by key."""
        return self.motor_keys.found

    @motors.setter
    def motors(self, found: dict[int, dict[str, Any]]) -> None:
        self.motor_keys.found = found

    @property
    def watchdog_ms(self) -> int | None:
        return self.watchdog.ms

    @watchdog_ms.setter
    def watchdog_ms(self, ms: int | None) -> None:
        self.watchdog.ms = ms

    @property
    def poll_hz(self) -> float:
        return self.sampler.poll_hz

    @property
    def heartbeat_ms(self) -> int:
        return self.sampler.heartbeat_ms

    @property
    def scanning(self) -> bool:
        return self.sampler.scanning

    @property
    def load(self) -> float:
        return self.sampler.load

    @property
    def frame_rate(self) -> float:
        return self.sampler.frame_rate

    @staticmethod
    def columns() -> dict[str, str]:
        """The keys (with units) of the page's CSV, as ``monitor --csv`` and ``state --json`` name them."""
        return {"time": TIME_COLUMN[0], "name": "name"} | {c: COLUMNS[c][0] for c in _CSV_COLUMNS}

    # ------------------------------------------------------------------ bus view

    def do_scan(self, progress: Callable[[int, int, list[dict[str, Any]]], None]) -> list[dict[str, Any]]:
        """Scan ids 1-63 of every bus in four groups, calling ``progress(done, 63 * buses, found)`` after each."""
        with self._scan_lock:
            self.sampler.scanning = True
            try:
                found = self.motor_keys.scan(progress)
            finally:
                self.sampler.scanning = False
        self.motors = {m["id"]: m for m in found}
        for i in self.motors:
            self.do_limits(i)
        if self.watchdog_ms:
            self.arm_watchdog(sorted(self.motors))
        return found

    def do_rate(self, who: str, hz: float) -> None:
        """Sample rate per motor: ``hz`` > 0 turns the motors' heartbeats on (period 1000/hz ms), 0 off."""
        if not 0 <= hz <= 1000:
            raise ValidationError(f"rate={hz!r}: 0 (poll at {self.poll_hz:g}/s) or 1..1000 samples/s")
        ms = 0 if hz == 0 else max(1, round(1000 / hz))
        self._control(who, f"{_HEARTBEAT} = {ms} on motors {sorted(self.motors)}")
        for i in sorted(self.motors):
            self.motor(i).write_property(_HEARTBEAT, ms)
        self.sampler.heartbeat_ms = ms

    # ------------------------------------------------------------------ control

    def _control(self, who: str, what: str) -> None:
        """Refuse a command when read-only or fenced, else log it."""
        if self.read_only:
            raise ValidationError(_READ_ONLY)
        self.check_fence()
        log(f"{who}: {what}")

    def _fence_row(self, act: actions.Action) -> None:
        """The service's fence: a request issued before the latest ESTOP, or a motion once stopping."""
        self.check_fence()
        if act.safety == "motion" and self._halt.is_set():
            raise ValidationError(_STOPPING)

    def _ready(self, keys: Sequence[int]) -> None:
        """A motion passed every check: with ``--watchdog``, arm the motors not armed yet."""
        if self.watchdog.ms:
            self.watchdog.arm(keys)

    def require_enabled(self, keys: list[int]) -> None:
        """Refuse a motion to a motor that is not in closed loop (it would ignore it): one read of each
        motor's axis state (the service's check); then, with ``--watchdog``, arm the motors not armed yet."""
        if self._halt.is_set():
            raise ValidationError(_STOPPING)
        self.check_fence()
        self.service.require_closed_loop(keys)
        self._ready(keys)

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
        row, row_args, key = self._page_row(args)
        with self._at_joint(key):
            return self._run(who, row, row_args).plain

    def _page_row(self, args: dict[str, Any]) -> tuple[str, dict[str, Any], int | None]:
        """The row of a page's control (:data:`PAGE_CONTROLS`), its arguments at the motor, and the key of
        the robot joint whose units the page's values are in (None: a bare motor's)."""
        row, row_args = page_row(args, lambda: float(self.motor(self.key(args)).read_property(_BANDWIDTH)))
        key = self._joint_key(args)
        if key is not None:  # a robot joint's values are at the joint: the row runs on the motor's
            with self._at_joint(key):
                row_args = self.units[key].to_motor(row, row_args)
        return row, row_args, key

    @contextmanager
    def _at_joint(self, key: int | None) -> Iterator[None]:
        """A value refused for robot joint ``key`` (given at the joint) in the joint's units."""
        try:
            yield
        except FieldRangeError as exc:
            if key is None:
                raise
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
        dashboard; 0: every motor on every bus, for the rows that take it) through :attr:`service`;
        returns its result as JSON-ready values. Validated by the table (its words), then the dashboard's
        checks: read-only refuses all but reading and stopping, a motion needs a motor in closed loop (or
        ``enable``) and stays within the limits the motor holds; logged, confirmed, and the targets kept."""
        return self._run(who, name, args).plain

    def _run(self, who: str, name: str, args: dict[str, Any]) -> actions.Outcome:
        checked = self.service.check(name, args)
        self.service.admit([checked])
        return self._send(who, checked)

    def _send(self, who: str, checked: actions.Checked) -> actions.Outcome:
        """An admitted row sent, tracked (whether or not the service then confirms it), concluded."""
        base = self.tracking.base(checked.key) if checked.action.name == "step" else 0.0
        result = self.service.send(who, checked)
        self.tracking.track(who, checked.action, checked.key, checked.args, base)
        return self.service.conclude(checked, result)

    def do_row(self, who: str, req: dict[str, Any]) -> dict[str, Any]:
        """The Actions view's request: row ``req["action"]`` with the object ``req["args"]``, run by
        :meth:`do_action`; returns its ``result`` and ``said``, what it came to in the words the
        command line prints (:func:`drempower.actions.outcome`; None for a record or a list)."""
        row_args = req.get("args")
        if not isinstance(row_args, dict):
            raise ValidationError(f"args={row_args!r}: expected an object of argument names and values")
        out = self._run(who, str(req.get("action")), row_args)
        return {"result": out.plain, "said": out.said}

    def do_sync_move(self, who: str, args: dict[str, Any]) -> dict[str, Any]:
        """A synchronised Q move of ``args["ids"]`` to ``args["angles"]`` (deg), cruise ``speed``, ``accel``:
        each motor's values checked by row ``move`` of :mod:`drempower.actions` (its words) and the
        limits it holds, every motor in closed loop (one read each, for all together), then one
        ``set_angles`` (the table's rows act on one motor each: a move that starts motors together, across
        buses by the robot's joints, is no row)."""
        keys = self.keys(args)
        angles = args.get("angles")
        if not isinstance(angles, list) or len(angles) != len(keys):
            raise ValidationError(f"angles={angles!r}: one angle per motor of ids={keys}")
        shared = {"mode": "Q", "speed": args.get("speed"), "accel": args.get("accel")}
        gears = [abs(self.units[k].gear) for k in keys if k in self.units]
        scale = min(gears) if gears and len(gears) == len(keys) else 1.0  # rates at the joints: none faster
        checked = []
        for k, a in zip(keys, angles, strict=True):
            u = self.units.get(k)
            given = {"id": k, "angle": a, **shared}
            if u is not None:  # a robot joint's angle at the joint; the rates by the smallest gear
                given = u.to_motor("move", {**given, "speed": None, "accel": None}) | {
                    r: v * scale if isinstance(v, (int, float)) and not isinstance(v, bool) else v
                    for r, v in shared.items()
                    if r != "mode"
                }
            with self._at_joint(k):
                checked.append(self.service.check("move", given))
        self.service.admit(checked)  # closed loop (the one check: set_angles pays no second), limits, watchdog
        typed = [c.args for c in checked]
        seconds = self._sync_move(who, keys, [t["angle"] for t in typed], typed[0]["speed"], typed[0]["accel"])
        for k, t in zip(keys, typed, strict=True):
            self.tracking.set(k, angle=t["angle"])
        return {"seconds": seconds}

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

    # ------------------------------------------------------------------ tuning

    def do_step(self, who: str, args: dict[str, Any]) -> dict[str, Any]:
        """A step response of one motor: position (T mode with ``bandwidth`` 1/s, default the motor's
        input filter bandwidth) or velocity. A velocity step ends here at its duration (speed 0), however
        the run ends; a position step leaves the motor holding its target.

        Returns the actual series (``t`` s from the step, ``y`` deg or r/min) and its figures.
        """
        if self.read_only:
            raise ValidationError(_READ_ONLY)
        i = self.key(args)
        mode = args.get("mode", "position")
        amp, duration = number(args, "amplitude"), number(args, "duration", 1.0)
        if mode not in ("position", "velocity"):
            raise ValidationError(f"mode={mode!r}: position or velocity")
        if not 0.1 <= duration <= 10:
            raise ValidationError(f"duration={duration}: 0.1..10 s")
        m = self.motor(i)
        bandwidth = None
        if mode == "position":
            given = args.get("bandwidth")  # checked as row move's T-mode bandwidth, in its words
            bandwidth = float(m.read_property(_BANDWIDTH)) if given is None else actions.BANDWIDTH.check(given)
        st = m.get_state()
        u = self.units.get(i)  # a robot joint steps at the joint (deg, r/min there), a bare motor at the motor
        base = st.angle if mode == "position" else st.speed
        if u is not None:
            base = u.angle(st.angle) if mode == "position" else u.speed(st.speed)
        target = base + amp
        position = {"action": "T", "id": i, "angle": target, "param": bandwidth}
        row, row_args, key = self._page_row(
            position if mode == "position" else {"action": "V", "id": i, "speed": target}
        )
        with self._at_joint(key):
            checked = self.service.check(row, row_args)
            self.service.admit([checked])  # the one closed-loop check: refused before anything is sent
        got: list[MotorState] = []
        bus, node = self.where(i)
        sub = bus.subscribe(got.append, node)
        fast = not self.heartbeat_ms  # 500 samples/s for the run (the motor's heartbeat), off afterwards
        try:
            if fast:
                m.write_property(_HEARTBEAT, 2)
            start = time.monotonic()
            self._fence_row(checked.action)  # an ESTOP meanwhile: the step is not sent
            with self._at_joint(key):
                self._send(who, checked)
            end = time.monotonic() + duration
            while not self._halt.is_set() and not self.fenced() and time.monotonic() < end:
                self._halt.wait(min(0.02, max(0.0, end - time.monotonic())))  # an ESTOP ends the run too
        finally:
            sub.cancel()
            try:
                if mode == "velocity" and i in self.commanded:  # the step ends here, not in the page
                    log(f"{who}: {self.label(i)} velocity step ended: set_speed(0)")
                    m.set_speed(0.0)
                    self.tracking.set(i, speed=0.0)
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
            raise ValidationError(_READ_ONLY)
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
        self.cards.close()
        self.sampler.close()
        self.watchdog.restore()
        if self.heartbeat_ms:
            for i in sorted(self.motors):
                if self.where(i)[0].closed:
                    continue
                try:
                    self.motor(i).write_property(_HEARTBEAT, 0)
                except DrEmpowerError:
                    pass
