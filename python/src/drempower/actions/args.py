"""The arguments of the actions: kinds, units and domains, checked the same way for every front end."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

from ..client.engine.commands import MAX_ANGLE, MAX_BANDWIDTH, PositionMode
from ..errors import FieldRangeError, ValidationError
from ..protocol.enums import TorqueMode, VelocityMode
from ..protocol.limits import MAX_NODE, MIN_MOTOR, S16_MAX, SPEED_RANGE, TORQUE_RANGE
from ..protocol.parameters import find_parameter

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
