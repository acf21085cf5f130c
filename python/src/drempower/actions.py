"""What a person or a program can do to motors: one table, one validation, one way to run.

Each :class:`Action` names its operation (a call of the :class:`~drempower.AsyncMotor` /
:class:`~drempower.AsyncBus` API, which the threaded :class:`~drempower.Bus` shares), its
arguments with units and domains (motor ids from :mod:`drempower.protocol.limits`,
speeds and torques from the same place, parameters from ``spec/parameters.csv``), its
safety class and its help text. :func:`validate` turns loose arguments (numbers, or
the strings of a command line or a form) into typed ones with the same error words
everywhere (``field=value is out of range: allowed low..high (unit)``), and
:func:`run` / :func:`run_async` carry an action out on a bus::

    from drempower import actions
    actions.run(bus, "move", {"id": 1, "angle": 90})        # threaded bus
    await actions.run_async(abus, "speed", {"id": 1, "speed": 30, "duration": 2})

Motion actions pass the bus's safety gate (idle motors, soft limits; see
:mod:`drempower.client.engine.gate`). A new query is one operation plus one row::

    actions.register(actions.Action("volcur", "read", "supply voltage and current",
                                    (actions.MOTOR,), lambda bus, a: bus.motor(a["id"]).get_volcur()))

and front ends that list :func:`table` (the CLI's subcommands, the dashboard's controls)
offer it with no further change.
"""

from __future__ import annotations

import dataclasses
import enum
import inspect
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from .client.engine.commands import MAX_ANGLE, MAX_BANDWIDTH, PositionMode
from .errors import DrEmpowerError, FieldRangeError, ValidationError
from .naming import number_text, state_name
from .protocol.addresses import AXIS0_CURRENT_STATE
from .protocol.enums import AxisState, TorqueMode, VelocityMode
from .protocol.limits import MAX_NODE, MIN_MOTOR, S16_MAX, SPEED_RANGE, TORQUE_RANGE
from .protocol.messages import FastRead, ReadParam
from .protocol.parameters import DataType, find_parameter

__all__ = [
    "Arg",
    "Action",
    "Safety",
    "MOTOR",
    "bandwidth_range",
    "table",
    "get",
    "register",
    "validate",
    "run",
    "run_async",
    "plain",
    "describe",
]

Safety = Literal["read", "configure", "motion", "stop"]
"""How an action touches a motor: reads it, changes its configuration, moves it, or stops it."""
_REQUIRED = object()


@dataclass(frozen=True)
class Arg:
    """One argument: ``kind`` ``"int"``, ``"float"``, ``"bool"`` or ``"str"``, its ``unit``, its
    inclusive domain ``low``..``high`` (None: unbounded), ``default`` (absent: required), help text."""

    name: str
    kind: Literal["int", "float", "bool", "str"]
    unit: str = ""
    help: str = ""
    low: float | None = None
    high: float | None = None
    default: Any = _REQUIRED
    positive: bool = False
    """A magnitude > 0 after rounding to the wire's 0.01 step (0.006 goes as 0.01); ``low`` is then that step."""
    choices: tuple[Any, ...] = ()
    """The values allowed (none: any in the domain); text is matched ignoring case."""
    modes: tuple[Any, ...] = ()
    """The values of the row's ``mode`` argument this argument belongs to (none: every mode). Given
    in another mode it is refused; in its own, a missing one takes its default (none: it is missing)."""

    @property
    def required(self) -> bool:
        """Needed whatever the mode (an argument of some modes is needed only in them)."""
        return self.default is _REQUIRED and not self.modes

    def domain_text(self) -> str:
        """The domain in words, e.g. ``-327.68..327.67 r/min``, ``T, Q or P``."""
        if self.choices:
            return _either(self.choices)
        if self.kind == "bool":
            return "true or false"
        if self.kind == "str":
            return "text"
        low = "-inf" if self.low is None else f"{self.low:g}"
        high = "inf" if self.high is None else f"{self.high:g}"
        return f"{low}..{high}{' ' + self.unit if self.unit else ''}"

    def check(self, value: object) -> Any:
        """``value`` (a number, or its text) as this argument's type, in its domain; else a ValidationError."""
        if self.choices:
            return self._choice(value)
        if self.kind == "str":
            if not isinstance(value, str) or not value:
                raise ValidationError(f"{self.name}={value!r}: expected a name")
            return value
        if self.kind == "bool":
            if isinstance(value, bool):
                return value
            text = str(value).strip().lower()
            if text in ("1", "true", "yes", "on"):
                return True
            if text in ("0", "false", "no", "off"):
                return False
            raise ValidationError(f"{self.name}={value!r}: expected true or false")
        number = _number(self, value)
        low = -math.inf if self.low is None else self.low
        high = math.inf if self.high is None else self.high
        inside = round(number * 100) >= 1 and number <= high if self.positive else low <= number <= high
        if not inside:
            zero = self.positive and 0 < number < 0.01  # the motor takes steps of 0.01
            why = f"{self.unit}; the motor takes steps of 0.01: it would get 0" if zero else self.unit
            raise FieldRangeError(self.name, value, low, high, why)
        return number

    def _choice(self, value: object) -> Any:
        for choice in self.choices:
            if isinstance(choice, str) and isinstance(value, str) and value.strip().upper() == choice.upper():
                return choice
            if not isinstance(choice, str) and not isinstance(value, bool):
                try:
                    if _number(self, value) == choice:
                        return choice
                except ValidationError:
                    break
        raise ValidationError(f"{self.name}={value!r}: expected {_either(self.choices)}")


def _either(values: tuple[Any, ...]) -> str:
    """``("T", "Q", "P")`` -> ``"T, Q or P"``."""
    words = [str(v) for v in values]
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} or {words[-1]}"


def _number(arg: Arg, value: object) -> int | float:
    if isinstance(value, str):
        try:
            value = int(value) if arg.kind == "int" else float(value)
        except ValueError:
            raise ValidationError(
                f"{arg.name}={value!r}: expected {'a whole' if arg.kind == 'int' else 'a'} number"
            ) from None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValidationError(f"{arg.name}={value!r}: expected a number")
    if arg.kind == "int":
        if isinstance(value, float) and not value.is_integer():
            raise ValidationError(f"{arg.name}={value!r}: expected a whole number")
        return int(value)
    if not math.isfinite(value):
        raise ValidationError(f"{arg.name}={value!r}: expected a finite number")
    return float(value)


Operation = Callable[[Any, Mapping[str, Any]], Any]
"""``operation(bus, args)``: calls the bus API (threaded: the result; asyncio: an awaitable)."""


@dataclass(frozen=True)
class Action:
    """One thing to do to motors: its ``name``, ``safety`` class, ``help``, ``args`` and ``operation``;
    ``result`` names what the operation returns when that is a number (e.g. ``"move time"``), in
    ``result_unit``, so that every front end shows it with its meaning and unit."""

    name: str
    safety: Safety
    help: str
    args: tuple[Arg, ...]
    operation: Operation
    result: str = ""
    result_unit: str = ""

    def arg(self, name: str) -> Arg:
        for a in self.args:
            if a.name == name:
                return a
        raise ValidationError(f"{self.name}: no argument {name!r}")


# ---------------------------------------------------------------------- the arguments


MOTOR = Arg("id", "int", "", "the motor's id", MIN_MOTOR, MAX_NODE)
"""A motor id, 1..63."""
MOTOR_OR_ALL = Arg("id", "int", "", "the motor's id (0: every motor)", 0, MAX_NODE)
"""A motor id, or 0 for every motor (commands that need no answer)."""
VERIFY = Arg("verify", "bool", "", "read the value back (a single motor only)", default=True)
FORCE = Arg(
    "force", "bool", "", "write a parameter not meant for users, or a value outside its soft domain", default=False
)
ENABLE = Arg("enable", "bool", "", "enable the motor first if it is idle", default=False)
ANGLE = Arg("angle", "float", "deg", "target angle", -MAX_ANGLE, MAX_ANGLE)
STEP = Arg("angle", "float", "deg", "step from where the motor is", -MAX_ANGLE, MAX_ANGLE)
POSITION_MODE = Arg(
    "mode",
    "str",
    "",
    "T tracks through a filter (bandwidth), Q a trapezoid profile (speed, accel), P with feed-forward "
    "(speed_ff, torque_ff); default Q, or the mode of the arguments given",
    default="Q",
    choices=tuple(m.name for m in PositionMode),
)
CRUISE = Arg("speed", "float", "r/min", "Q: cruise speed", 0.01, S16_MAX, 10.0, positive=True, modes=("Q",))
ACCEL = Arg("accel", "float", "(r/min)/s", "Q: acceleration", 0.01, S16_MAX, 10.0, positive=True, modes=("Q",))


_BANDWIDTH = "axis0.controller.config.input_filter_bandwidth"


def bandwidth_range() -> tuple[float, float]:
    """The T-mode filter bandwidth's range (1/s): the domain of ``input_filter_bandwidth`` (spec/parameters.csv)."""
    p = find_parameter(_BANDWIDTH)
    lo = p.minimum if p is not None and p.minimum is not None else 0.0
    hi = p.maximum if p is not None and p.maximum is not None else MAX_BANDWIDTH
    return lo, hi


BANDWIDTH = Arg(
    "bandwidth",
    "float",
    "1/s",
    "T: input filter bandwidth (the motor keeps it)",
    0.01,
    bandwidth_range()[1],
    20.0,
    positive=True,
    modes=("T",),
)
"""The T-mode bandwidth: within the parameter's domain, and > 0 on the wire."""
SPEED_FF = Arg("speed_ff", "float", "r/min", "P: speed feed-forward", *SPEED_RANGE, 0.0, modes=("P",))
TORQUE_FF = Arg("torque_ff", "float", "Nm", "P: torque feed-forward", *TORQUE_RANGE, 0.0, modes=("P",))
SPEED = Arg("speed", "float", "r/min", "speed", *SPEED_RANGE)
SPEED_MODE = Arg(
    "mode",
    "int",
    "",
    "1: the speed at once, with torque_ff; 2: reached at the ramp rate; default 1, or 2 with ramp",
    default=int(VelocityMode.PASSTHROUGH),
    choices=tuple(int(m) for m in VelocityMode),
)
SPEED_TFF = Arg("torque_ff", "float", "Nm", "mode 1: torque feed-forward", *TORQUE_RANGE, 0.0, modes=(1,))
SPEED_RAMP = Arg("ramp", "float", "(r/min)/s", "mode 2: ramp rate", 0.01, S16_MAX, positive=True, modes=(2,))
TORQUE = Arg("torque", "float", "Nm", "torque", *TORQUE_RANGE)
TORQUE_MODE = Arg(
    "mode",
    "int",
    "",
    "1: the torque at once; 6: reached at the ramp rate; default 1, or 6 with ramp",
    default=int(TorqueMode.DIRECT),
    choices=tuple(int(m) for m in TorqueMode),
)
TORQUE_RAMP = Arg("ramp", "float", "Nm/s", "mode 6: ramp rate", 0.01, S16_MAX, positive=True, modes=(6,))
DURATION = Arg(
    "duration", "float", "s", "stop by itself after this long (none: until the next command)", 0.001, None, None
)
PARAM = Arg("name", "str", "", "parameter name or address (spec/parameters.csv)")
VALUE = Arg("value", "float", "", "the value, in the parameter's unit")
KP = Arg("kp", "float", "Nm/rad", "stiffness", 0, S16_MAX)
KD = Arg("kd", "float", "Nm/(rad/s)", "damping", 0, S16_MAX)
VEL = Arg("vel", "float", "r/min", "target speed", *SPEED_RANGE, 0.0)
TFF = Arg("tff", "float", "Nm", "torque feed-forward", *TORQUE_RANGE, 0.0)
POSITION_ARGS = (POSITION_MODE, CRUISE, ACCEL, BANDWIDTH, SPEED_FF, TORQUE_FF, ENABLE)
"""The arguments ``move`` and ``step`` share after the angle."""
_POSITION_FIELDS = {"T": (None, "bandwidth"), "Q": ("speed", "accel"), "P": ("speed_ff", "torque_ff")}
"""The ``speed`` and ``param`` of set_angle / step_angle in each position mode, by argument."""


def _motor(bus: Any, a: Mapping[str, Any]) -> Any:
    return bus.motor(a["id"])


def _position(a: Mapping[str, Any]) -> tuple[float, float, int]:
    """``speed``, ``param`` and ``mode`` of set_angle / step_angle from a move's arguments."""
    speed, param = _POSITION_FIELDS[a["mode"]]
    return 0.0 if speed is None else a[speed], a[param], int(PositionMode[a["mode"]])


def _param(a: Mapping[str, Any], *names: str) -> float:
    """The ``param`` of set_speed / set_torque: the first of ``names`` the mode has (none: 0, unused)."""
    return next((float(a[n]) for n in names if a.get(n) is not None), 0.0)


def _set(bus: Any, a: Mapping[str, Any]) -> Any:
    """Row ``set``: a parameter not meant for users needs ``force`` (the CLI's words); one that commands
    motion passes the safety gate in ``write_property``."""
    p = find_parameter(a["name"])
    if p is not None and p.writable and not (p.user_settable or a["force"]):
        raise ValidationError(f"{p.name} is not meant to be changed by users (add force to write it anyway)")
    force = a["force"]
    return _motor(bus, a).write_property(a["name"], a["value"], verify=a["verify"] and a["id"] != 0, force=force)


def _estop(bus: Any, a: Mapping[str, Any]) -> Any:
    return bus.estop(None if a["id"] == 0 else [a["id"]])


_TABLE: dict[str, Action] = {}


def register(action: Action) -> Action:
    """Add ``action`` to the table (a name once); returns it."""
    if action.name in _TABLE:
        raise ValidationError(f"action {action.name!r} exists already")
    if action.safety not in ("read", "configure", "motion", "stop"):
        raise ValidationError(f"action {action.name!r}: safety={action.safety!r}: read, configure, motion or stop")
    _TABLE[action.name] = action
    return action


def unregister(name: str) -> None:
    """Remove action ``name`` (for tests that add one)."""
    _TABLE.pop(name, None)


for _a in (
    Action(
        "state", "read", "angle, speed, torque and flags, read now", (MOTOR,), lambda b, a: _motor(b, a).get_state()
    ),
    Action("errors", "read", "the error words, decoded", (MOTOR,), lambda b, a: _motor(b, a).dump_error()),
    Action("get", "read", "read a parameter", (MOTOR, PARAM), lambda b, a: _motor(b, a).read_property(a["name"])),
    Action(
        "health",
        "read",
        "temperatures, effective current limit, derating and errors, with their fixes",
        (MOTOR,),
        lambda b, a: _motor(b, a).health(),
    ),
    Action(
        "set",
        "configure",
        "write a parameter (in RAM; save keeps it)",
        (MOTOR_OR_ALL, PARAM, VALUE, VERIFY, FORCE),
        lambda b, a: _set(b, a),
    ),
    Action(
        "move",
        "motion",
        "move to an angle (mode T, Q or P; default Q, a trapezoid profile)",
        (MOTOR, ANGLE, *POSITION_ARGS),
        lambda b, a: _motor(b, a).set_angle(a["angle"], *_position(a), enable=a["enable"]),
    ),
    Action(
        "step",
        "motion",
        "move by an angle from where the motor is (mode T, Q or P)",
        (MOTOR, STEP, *POSITION_ARGS),
        lambda b, a: _motor(b, a).step_angle(a["angle"], *_position(a), enable=a["enable"]),
        result="move time",  # mode Q's planned time; T and P return nothing
        result_unit="s",
    ),
    Action(
        "speed",
        "motion",
        "turn at a speed (mode 1 at once, mode 2 ramped)",
        (MOTOR, SPEED, SPEED_MODE, SPEED_TFF, SPEED_RAMP, DURATION, ENABLE),
        lambda b, a: _motor(b, a).set_speed(
            a["speed"], _param(a, "torque_ff", "ramp"), a["mode"], duration=a["duration"], enable=a["enable"]
        ),
    ),
    Action(
        "torque",
        "motion",
        "apply a torque (mode 1 at once, mode 6 ramped)",
        (MOTOR, TORQUE, TORQUE_MODE, TORQUE_RAMP, DURATION, ENABLE),
        lambda b, a: _motor(b, a).set_torque(
            a["torque"], _param(a, "ramp"), a["mode"], duration=a["duration"], enable=a["enable"]
        ),
    ),
    Action(
        "impedance",
        "motion",
        "hold a position like a spring: tff + kp*(pos - P) + kd*(vel - V)",
        (MOTOR, Arg("pos", "float", "deg", "spring's rest angle", -MAX_ANGLE, MAX_ANGLE), KP, KD, VEL, TFF, ENABLE),
        lambda b, a: _motor(b, a).impedance_control(a["pos"], a["vel"], a["tff"], a["kp"], a["kd"], enable=a["enable"]),
    ),
    Action("stop", "stop", "speed 0 (the motor holds where it is)", (MOTOR_OR_ALL,), lambda b, a: _motor(b, a).stop()),
    Action(
        "idle",
        "stop",
        "release the motor (it can be turned by hand)",
        (MOTOR_OR_ALL,),
        lambda b, a: _motor(b, a).idle(),
    ),
    Action("estop", "stop", "emergency stop (0: every motor)", (MOTOR_OR_ALL,), _estop),
    Action("enable", "configure", "enter closed loop", (MOTOR_OR_ALL,), lambda b, a: _motor(b, a).enable()),
    Action("clear", "configure", "clear the error flags", (MOTOR_OR_ALL,), lambda b, a: _motor(b, a).clear_error()),
    Action(
        "zero", "configure", "make the current angle 0 deg", (MOTOR,), lambda b, a: _motor(b, a).set_zero_position()
    ),
    Action(
        "save",
        "configure",
        "store the configuration in flash",
        (MOTOR_OR_ALL,),
        lambda b, a: _motor(b, a).save_config(),
    ),
    Action("reboot", "configure", "restart the motor's firmware", (MOTOR_OR_ALL,), lambda b, a: _motor(b, a).reboot()),
):
    register(_a)


def table() -> Iterator[Action]:
    """Every action, in table order (the hook for front ends that offer them all)."""
    return iter(list(_TABLE.values()))


def get(name: str) -> Action:
    """Action ``name``; a ValidationError listing the actions when there is none."""
    action = _TABLE.get(name)
    if action is None:
        raise ValidationError(f"no action {name!r}: the actions are {', '.join(_TABLE)}")
    return action


def validate(action: Action | str, args: Mapping[str, Any]) -> dict[str, Any]:
    """``args`` checked and typed for ``action`` (defaults filled in); the first bad one raises,
    naming the field, the value and its domain. Nothing is sent."""
    act = get(action) if isinstance(action, str) else action
    if not isinstance(args, Mapping):
        raise ValidationError(f"{act.name}: arguments are a mapping of names to values, got {args!r}")
    names = {a.name for a in act.args}
    unknown = [k for k in args if k not in names]
    if unknown:
        listed = ", ".join(a.name for a in act.args)
        raise ValidationError(f"{act.name}: no argument {unknown[0]!r}; its arguments are {listed}")
    out: dict[str, Any] = {}
    for a in act.args:
        if a.name in args and args[a.name] is not None:
            out[a.name] = a.check(args[a.name])
        elif a.required:
            raise ValidationError(f"{act.name}: {a.name} is missing ({a.help}, {a.domain_text()})")
        else:
            out[a.name] = a.default
    _modes(act, args, out)
    if "name" in out:
        key: str | int = int(out["name"]) if out["name"].isdigit() else out["name"]
        p = find_parameter(key)
        if p is None:
            raise ValidationError(f"name={out['name']!r}: no such parameter (see spec/parameters.csv)")
        out["name"] = p.name
        if "value" in out:
            given = args["value"]
            whole = isinstance(given, int) or (isinstance(given, str) and given.strip().lstrip("-").isdigit())
            value = int(out["value"]) if whole else out["value"]
            out["value"] = p.check(value, bool(out.get("force")))  # its own domain, named
    return out


def _modes(act: Action, args: Mapping[str, Any], out: dict[str, Any]) -> None:
    """Settle the row's ``mode`` (given; else its default, or the one mode the arguments given belong to)
    and its arguments: another mode's given is refused, its own missing takes its default (none: it is
    missing), the other modes' are None."""
    tagged = [a for a in act.args if a.modes]
    if not tagged:
        return
    choices = act.arg("mode")
    given = [a for a in tagged if args.get(a.name) is not None]
    if args.get("mode") is None:
        fits = [m for m in choices.choices if all(m in a.modes for a in given)]
        if not fits:
            named = ", ".join(f"{a.name} (mode {_either(a.modes)})" for a in given)
            raise ValidationError(f"{act.name}: {named}: the arguments of one mode only")
        out["mode"] = choices.default if choices.default in fits else fits[0]
    mode = out["mode"]
    for a in tagged:
        if mode not in a.modes:
            if a in given:
                raise ValidationError(f"{act.name}: {a.name} applies to mode {_either(a.modes)}, not {mode}")
            out[a.name] = None
        elif out[a.name] is _REQUIRED:
            raise ValidationError(f"{act.name}: {a.name} is missing ({a.help}, {a.domain_text()})")


def run(bus: Any, action: Action | str, args: Mapping[str, Any]) -> Any:
    """Validate ``args`` and carry ``action`` out on a threaded bus; returns what its operation returns."""
    act = get(action) if isinstance(action, str) else action
    return act.operation(bus, validate(act, args))


async def run_async(bus: Any, action: Action | str, args: Mapping[str, Any]) -> Any:
    """:func:`run` on an asyncio bus (or a threaded one: a result that is no awaitable is returned as is)."""
    act = get(action) if isinstance(action, str) else action
    result = act.operation(bus, validate(act, args))
    if inspect.isawaitable(result):
        return await result
    return result


def describe(action: Action | str) -> dict[str, Any]:
    """A row as JSON-ready data (what ``drempower actions --json`` prints and the dashboard builds its
    Actions panel from): name, safety, help, what a number it returns means and its unit, and each
    argument's name, kind, unit, domain, default."""
    act = get(action) if isinstance(action, str) else action
    return {
        "name": act.name,
        "safety": act.safety,
        "help": act.help,
        "result": act.result,
        "result_unit": act.result_unit,
        "args": [
            {
                "name": a.name,
                "kind": a.kind,
                "unit": a.unit,
                "low": a.low,
                "high": a.high,
                "required": a.required,
                "default": None if a.default is _REQUIRED else a.default,
                "choices": list(a.choices),
                "modes": list(a.modes),
                "help": a.help,
                "domain": a.domain_text(),
            }
            for a in act.args
        ],
    }


ENABLE_SETTLE = 0.3
"""How long (s) :func:`why_not_enabled` and :func:`why_not_cleared` give motors to get there."""
_SILENT = "did not answer the read of its state: is it on the bus?"


def _settle(
    bus: Any,
    nodes: Sequence[int],
    ask: Callable[[int], Any],
    reached: Callable[[Any], bool],
    within: float,
    stop: Callable[[], bool] | None,
) -> dict[int, Any]:
    """Ask every motor of ``nodes`` (``ask(node)``: the message, one exchange for all) again every 20 ms
    until each answer is ``reached``, ``within`` s at most or until ``stop()``; returns the last answer
    (None: none came) of each motor that did not get there."""
    waiting = list(nodes)
    deadline = time.monotonic() + within
    while True:
        answers = dict(zip(waiting, bus.request([ask(n) for n in waiting], missing_ok=True), strict=True))
        waiting = [n for n in waiting if answers[n] is None or not reached(answers[n])]
        if not waiting or time.monotonic() >= deadline or (stop is not None and stop()):
            return {n: answers[n] for n in waiting}
        time.sleep(0.02)


def why_not_enabled(
    bus: Any, nodes: Sequence[int], within: float = ENABLE_SETTLE, stop: Callable[[], bool] | None = None
) -> dict[int, str]:
    """After row ``enable`` for motors ``nodes`` on a threaded ``bus``: ``{}`` once each reads closed loop
    (their states read in one exchange, again every 20 ms, ``within`` s at most), else for each that did
    not, why not, in the words the front ends put after its name: ``"did not enter closed loop (state
    idle): its error flags are set: clear errors first, then enable again"``. ``stop()`` true ends the
    wait early. A front end that reports an enable as done asks this first: a sent enable is no closed
    loop (a motor with error flags ignores it)."""
    left = _settle(
        bus,
        nodes,
        lambda n: ReadParam(n, AXIS0_CURRENT_STATE, DataType.U32),
        lambda r: int(r.value) == AxisState.CLOSED_LOOP_CONTROL,
        within,
        stop,
    )
    why: dict[int, str] = {}
    for n, r in left.items():
        if r is None:
            why[n] = _SILENT
            continue
        try:
            flags = "its error flags are set: clear errors first" if bus.motor(n).get_state().error else None
        except DrEmpowerError:
            flags = None
        fix = flags or "see its errors"
        why[n] = f"did not enter closed loop (state {state_name(int(r.value))}): {fix}, then enable again"
    return why


def why_not_cleared(
    bus: Any, nodes: Sequence[int], within: float = ENABLE_SETTLE, stop: Callable[[], bool] | None = None
) -> dict[int, str]:
    """After row ``clear`` for motors ``nodes``: ``{}`` once no state frame of theirs has the error bit
    (read as :func:`why_not_enabled` reads), else for each that still has it, in the same kind of words:
    ``"errors remain after clearing: see its errors (an encoder error needs zeroing first)"``."""
    left = _settle(bus, nodes, FastRead, lambda st: not st.error, within, stop)
    return {
        n: _SILENT
        if st is None
        else "errors remain after clearing: see its errors (an encoder error needs zeroing first)"
        for n, st in left.items()
    }


def outcome(action: Action | str, result: Any) -> str | None:
    """What running ``action`` came to, as every front end words it after the row's name: a command
    is ``" sent"`` (it was sent, which is not "done": a motion command returns before the motor gets
    there), with the number it returned named in its unit, e.g. ``" sent (move time 1.42 s)"``; a read
    is ``": "`` and its value (numbers as :func:`~drempower.naming.number_text` shows them). None for
    a record or a list, which each front end shows in its own form (rows, JSON)."""
    act = get(action) if isinstance(action, str) else action
    if result is None:
        return " sent" if act.safety != "read" else ": none"
    if isinstance(result, (dict, list, tuple)) or hasattr(result, "_asdict") or dataclasses.is_dataclass(result):
        return None
    value = number_text(result, None) if isinstance(result, float) else str(plain(result))
    if act.result:
        value = f"{act.result} {value}"
    if act.result_unit:
        value = f"{value} {act.result_unit}"
    return f" sent ({value})" if act.safety != "read" else f": {value}"


def plain(result: Any) -> Any:
    """What an operation returned, as JSON-ready values: a record (named tuple, dataclass) a dict of
    its fields (and its ``flags`` if it has them), a tuple a list, an enum its name, numbers as they are."""
    if result is None or isinstance(result, (bool, int, float, str)):
        return result
    if isinstance(result, enum.Enum):
        return result.name.lower()
    if hasattr(result, "_asdict"):
        return {k: plain(v) for k, v in result._asdict().items()}
    if dataclasses.is_dataclass(result) and not isinstance(result, type):
        out = {f.name: plain(getattr(result, f.name)) for f in dataclasses.fields(result)}
        flags = getattr(result, "flags", None)
        if isinstance(flags, dict):
            out["flags"] = plain(flags)
        return out
    if isinstance(result, Mapping):
        return {str(k): plain(v) for k, v in result.items()}
    if isinstance(result, (list, tuple, set, frozenset)):
        return [plain(v) for v in result]
    return str(result)
