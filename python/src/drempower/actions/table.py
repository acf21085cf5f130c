"""The table of actions: each row's operation, safety class and help; register a new one here."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Literal

from ..client.engine.commands import MAX_ANGLE, PositionMode
from ..errors import ValidationError
from ..protocol.parameters import find_parameter
from .args import (
    _POSITION_FIELDS,
    ANGLE,
    DURATION,
    ENABLE,
    FORCE,
    KD,
    KP,
    MOTOR,
    MOTOR_OR_ALL,
    PARAM,
    POSITION_ARGS,
    SPEED,
    SPEED_MODE,
    SPEED_RAMP,
    SPEED_TFF,
    STEP,
    TFF,
    TORQUE,
    TORQUE_MODE,
    TORQUE_RAMP,
    VALUE,
    VEL,
    VERIFY,
    Arg,
)

Safety = Literal["read", "configure", "motion", "stop"]
"""How an action touches a motor: reads it, changes its configuration, moves it, or stops it."""


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
