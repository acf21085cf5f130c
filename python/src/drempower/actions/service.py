"""One way in for every front end: a row of the table validated, gated, carried out, confirmed and worded.

Each front end (the CLI, the dashboard, the bridge, ``compat``) runs rows through one
:class:`Service`; what differs between them is given as small collaborators, never as a
second copy of the pipeline::

    from drempower import actions
    service = actions.Service(actions.OneBus(bus), actions.Policy(log=print))
    out = service.run("cli", "move", {"id": 1, "angle": 90})
    out.said                                     # 'move sent'

:meth:`Service.run` goes, in this order, and sends nothing before the step that acts:

1. **validate**: the table's words for a bad argument (field, value, domain);
2. **gate**: a read-only front end refuses all but reading and stopping; a request the
   front end fences (an ESTOP pressed since it was issued) is refused but a stop;
3. **confirm before acting** (motion): every motor in closed loop, read once (the states of
   a bus's motors in one exchange, which the bus's safety gate learns: the motion command
   pays no second read), refused with the front end's fix (none needed with ``enable``);
   the front end's own limits; then its ``ready`` hook (e.g. arming a watchdog);
4. **act**: the row's operation on each bus the motor key names;
5. **confirm the outcome**: an ``enable`` reached closed loop, a ``clear`` cleared the
   error flags (:func:`~drempower.actions.why_not_enabled` / ``why_not_cleared``), else a
   :class:`~drempower.errors.DrEmpowerError` saying why: never a silent success;
6. **word** it as every front end does (:func:`~drempower.actions.outcome`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from ..errors import DrEmpowerError, MotorIdleError, ValidationError
from ..naming import motor_name
from ..protocol.addresses import AXIS0_CURRENT_STATE
from ..protocol.enums import AxisState
from ..protocol.messages import ReadParam
from ..protocol.parameters import DataType
from .settle import ENABLE_SETTLE, why_not_cleared, why_not_enabled
from .table import Action, get
from .validate import validate
from .words import outcome, plain

__all__ = ["Checked", "Motors", "OneBus", "Outcome", "Policy", "Service"]

CONFIRMED: Mapping[str, Callable[..., dict[int, str]]] = {"enable": why_not_enabled, "clear": why_not_cleared}
"""The rows whose end is checked before success is reported, and how."""


class Motors(Protocol):
    """Where the motors a front end names by key live (a key is what its requests carry as ``id``)."""

    def every_bus(self) -> Sequence[Any]:
        """Every bus, in key order (a key of 0 is every motor on each of them)."""
        ...

    def key(self, args: dict[str, Any]) -> int:
        """``args["id"]`` as a key of a motor on one of several buses (a ValidationError naming it if not)."""
        ...

    def where(self, key: int) -> tuple[Any, int]:
        """The bus and motor id of ``key``."""
        ...

    def label(self, key: int) -> str:
        """How messages name the motor of ``key`` (``motor_2``, ``elbow (bus right, motor 1)``)."""
        ...


class OneBus:
    """The motors of one threaded bus, keyed by their ids."""

    def __init__(self, bus: Any) -> None:
        self.bus = bus

    def every_bus(self) -> Sequence[Any]:
        return [self.bus]

    def key(self, args: dict[str, Any]) -> int:
        return int(args["id"])  # pragma: no cover - one bus: the table checks the id

    def where(self, key: int) -> tuple[Any, int]:
        return self.bus, key

    def label(self, key: int) -> str:
        return motor_name(key)


def _nothing(*_: Any) -> None:
    return None


@dataclass(frozen=True)
class Policy:
    """What a front end adds to the pipeline, each a hook that refuses by raising (defaults: nothing)."""

    read_only: Callable[[], str | None] = _nothing
    """The words refusing a command when the front end only reads now (reading and stopping still run)."""
    fence: Callable[[Action], None] = _nothing
    """Refuse a row that may not run any more (an ESTOP since it was issued, the front end stopping); not
    asked for a stop."""
    enable_fix: Callable[[Sequence[int]], str | None] = _nothing
    """How to enable the idle motors of ``keys`` in the caller's terms (a button, a command line; None: the
    library's words)."""
    limits: Callable[[Action, int, Mapping[str, Any]], None] = _nothing
    """Refuse a motion's typed arguments beyond a limit the front end holds for motor ``key``."""
    ready: Callable[[Sequence[int]], None] = _nothing
    """Called with the motor keys of a motion that passed every check, just before it is sent."""
    log: Callable[[str], None] = _nothing
    """Where a line saying who ran what goes."""
    closed_loop: bool = True
    """Refuse a motion to a motor not in closed loop (False: the motor's own refusal is enough)."""
    state_timeout: float | None = None
    """How long (s) the closed-loop check waits for the states (None: the bus's timeout)."""
    settle: float = ENABLE_SETTLE
    """How long (s) an enable or a clear is given to show in the motors' states before it is reported failed."""
    interrupted: Callable[[], bool] | None = None
    """True ends that wait early (an ESTOP since the request was issued): the motors not there yet are named."""


@dataclass(frozen=True)
class Checked:
    """A row ready to run: its ``action``, the motor ``key``, the ``args`` typed for the motor (``id`` its
    id on its bus) and the ``places`` (bus, motor id) it goes to (a key of 0: every bus's broadcast)."""

    action: Action
    key: int
    args: dict[str, Any]
    places: tuple[tuple[Any, int], ...] = field(repr=False)


@dataclass(frozen=True)
class Outcome:
    """What a row came to: ``result`` as its operation returned it (a list, one a bus, for a broadcast
    over several; None for a command), and ``said``, the row's name and :func:`~drempower.actions.outcome`
    (None for a record or a list, which each front end shows in its own form)."""

    checked: Checked
    result: Any
    said: str | None

    @property
    def plain(self) -> Any:
        """``result`` as JSON-ready values (:func:`~drempower.actions.plain`)."""
        return plain(self.result)


class Service:
    """The command service of one front end: ``Service(motors, policy).run(who, name, args)``."""

    def __init__(self, motors: Motors, policy: Policy | None = None) -> None:
        self.motors = motors
        self.policy = policy or Policy()

    def run(self, who: str, name: str | Action, args: Mapping[str, Any]) -> Outcome:
        """Row ``name`` with ``args`` for ``who`` (a page, a command line, a caller): validated, gated,
        carried out, confirmed and worded; refusals raise with nothing sent."""
        checked = self.check(name, args)
        return self.conclude(checked, self.act(who, checked))

    def act(self, who: str, checked: Checked) -> Any:
        """Steps 3 and 4: :meth:`admit` the row and :meth:`send` it."""
        self.admit([checked])
        return self.send(who, checked)

    def send(self, who: str, checked: Checked) -> Any:
        """Step 4 for an admitted row: log it for ``who`` and carry it out; returns what its operation
        returned (a list, one a bus, for a broadcast over several; None for a command)."""
        act, key = checked.action, checked.key
        shown = ", ".join(f"{k}={v}" for k, v in checked.args.items() if k != "id" and v is not None)
        self.policy.log(f"{who}: {'every motor' if key == 0 else self.motors.label(key)} {act.name}({shown})")
        results = [act.operation(bus, {**checked.args, "id": node}) for bus, node in checked.places]
        return None if all(r is None for r in results) else results[0] if len(results) == 1 else results

    def conclude(self, checked: Checked, result: Any) -> Outcome:
        """Steps 5 and 6: :meth:`confirm` what the row came to, and word it."""
        self.confirm(checked)
        said = outcome(checked.action, result)
        return Outcome(checked, result, None if said is None else checked.action.name + said)

    def check(self, name: str | Action, args: Mapping[str, Any]) -> Checked:
        """Steps 1 and 2: ``args`` typed for row ``name`` and the motor they name; refused when the front
        end only reads now or fences the row. Nothing is sent."""
        act = get(name) if isinstance(name, str) else name
        if act.safety not in ("read", "stop"):  # first: whatever else, it is never carried out
            words = self.policy.read_only()
            if words is not None:
                raise ValidationError(words)
        if act.safety != "stop":
            self.policy.fence(act)
        if not isinstance(args, Mapping):
            raise ValidationError(f"{act.name}: arguments are a mapping of names to values, got {args!r}")
        buses = self.motors.every_bus()
        if args.get("id") == 0 or len(buses) == 1:  # the motor id is the key (0: each bus's broadcast)
            typed = validate(act, args)
            key = int(typed["id"])
            places = tuple((b, 0) for b in buses) if key == 0 else (self.motors.where(key),)
        else:
            key = self.motors.key(dict(args))
            bus, node = self.motors.where(key)
            typed = validate(act, {**args, "id": node})
            places = ((bus, node),)
        return Checked(act, key, typed, places)

    def admit(self, rows: Sequence[Checked]) -> None:
        """Step 3 for rows to run together: each motor of a motion in closed loop (one check for all, or
        ``enable`` given), within the front end's limits; then ``ready``. Nothing is sent but state reads."""
        moving = [c for c in rows if c.action.safety == "motion"]
        if not moving:
            return
        waiting = [c.key for c in moving if not c.args.get("enable")]
        if self.policy.closed_loop and waiting:
            self.require_closed_loop(waiting)
        for c in moving:
            self.policy.limits(c.action, c.key, c.args)
        self.policy.ready([c.key for c in moving])

    def require_closed_loop(self, keys: Sequence[int]) -> None:
        """Refuse (:class:`~drempower.errors.MotorIdleError`, the front end's fix) unless every motor of
        ``keys`` reads closed loop now: one read of the states of each bus's motors together, which the
        bus's safety gate learns, so the motion command after it pays no second read."""
        by_bus: dict[int, tuple[Any, list[tuple[int, int]]]] = {}
        for key in keys:
            bus, node = self.motors.where(key)
            by_bus.setdefault(id(bus), (bus, []))[1].append((key, node))
        idle: list[tuple[int, int, int]] = []
        for bus, places in by_bus.values():
            reads = [ReadParam(node, AXIS0_CURRENT_STATE, DataType.U32) for _, node in places]
            for (key, node), reply in zip(places, bus.request(reads, self.policy.state_timeout), strict=True):
                if int(reply.value) != AxisState.CLOSED_LOOP_CONTROL:
                    idle.append((key, node, int(reply.value)))
        if idle:
            fix = self.policy.enable_fix([k for k, _, _ in idle])
            raise MotorIdleError([n for _, n, _ in idle], [s for _, _, s in idle], fix=fix)

    def confirm(self, checked: Checked) -> None:
        """Step 5: after an ``enable`` or a ``clear``, each motor got there, else a DrEmpowerError saying
        which did not and why (a broadcast: each motor its bus knows)."""
        self.confirm_all([checked])

    def confirm_all(self, rows: Sequence[Checked]) -> None:
        """Step 5 for rows run together (a front end that enables several motors at once, as the bridge's
        ``enable`` service does): the motors of each bus are read together and given ``policy.settle`` s in
        all (on each bus's clock), ``policy.interrupted`` ending the wait early; a DrEmpowerError names,
        in the rows' order, each motor that did not get there and why."""
        groups: dict[tuple[str, int], tuple[Callable[..., dict[int, str]], Any, list[tuple[str | None, int]]]] = {}
        for c in rows:
            why_not = CONFIRMED.get(c.action.name)
            if why_not is None:
                continue
            for bus, node in c.places:
                nodes = sorted(bus.known_motors()) if node == 0 else [node]
                group = groups.setdefault((c.action.name, id(bus)), (why_not, bus, []))
                group[2].extend((self.motors.label(c.key) if node != 0 else None, n) for n in nodes)
        started = {id(bus): bus.now() for _, bus, _ in groups.values()}
        failures: list[str] = []
        for why_not, bus, motors in groups.values():
            left = max(0.0, self.policy.settle - (bus.now() - started[id(bus)]))
            why = why_not(bus, [n for _, n in motors], left, self.policy.interrupted)
            failures.extend(f"{label or motor_name(n)} {why[n]}" for label, n in motors if n in why)
        if failures:
            raise DrEmpowerError("; ".join(failures))
