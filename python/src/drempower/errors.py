"""Every error drempower raises, in one tree.

Catch :class:`DrEmpowerError` to catch them all; each also derives from the
builtin a caller would expect (``ValueError`` for bad input, ``OSError`` for a
device, ``TimeoutError`` for a silent motor)::

    DrEmpowerError (Exception)
    ├── ProtocolError (ValueError)             a frame or byte stream that breaks the protocol
    ├── ValidationError (ValueError)           a value or option that cannot be used; nothing was sent
    │   ├── FieldRangeError                    a number outside the range its field holds
    │   │   ├── DomainError                    a value outside a parameter's domain (spec/parameters.csv)
    │   │   └── SoftLimitError                 a value beyond a soft limit (set_limits, a robot file)
    │   ├── MotionParameterError               a parameter write commanding motion the soft limits cannot check
    │   ├── ConfigError                        a robot file that cannot be used
    │   ├── BackupFileError                    a backup document that cannot be restored
    │   └── TransportOptionError               (also a TransportError) an option a transport cannot use
    ├── TransportError (OSError)               a bus that cannot be opened, a device that failed
    ├── TimeoutError (builtins.TimeoutError)   a motor that did not answer in time
    ├── BusClosedError                         the bus is closed or its receive loop stopped
    ├── BusStoppedError                        an estop dropped a start still waiting for its presets
    ├── MotorFaultError                        a motor reported an error while a call waited on it
    ├── MotorIdleError                         a motion command to a motor not in closed loop; nothing was sent
    ├── MoveError                              a position move did not end at its target
    │   ├── MoveFaultError                     (also a MotorFaultError) the motor reported an error
    │   └── MoveTimeoutError                   (also a TimeoutError) the move was not over in time
    ├── FollowError                            a trajectory stopped early (a tracking error above max_error)
    ├── IdentificationError                    an identification refused: samples missed or late, a poor fit
    ├── VerifyError                            a read-back differs from what was written
    │   ├── IdTakenError                       set_id: another motor already answers at the new id
    │   └── NoMotorError                       set_id: no motor answers where one was expected
    ├── SavedConfigError                       a simulated motor's saved configuration cannot be loaded
    └── UsageError                             a command line that cannot work (the CLI exits 2)

The older import paths (``drempower.client.errors``,
``drempower.transports.errors``, ``drempower.cli._usage``) name the same
classes.
"""

from __future__ import annotations

import builtins
import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .protocol.parameters import Parameter

__all__ = [
    "DrEmpowerError",
    "ProtocolError",
    "ValidationError",
    "FieldRangeError",
    "DomainError",
    "ConfigError",
    "TransportError",
    "TransportOptionError",
    "TimeoutError",
    "BusClosedError",
    "BusStoppedError",
    "MotorFaultError",
    "MotionParameterError",
    "MotorIdleError",
    "FollowError",
    "IdentificationError",
    "SoftLimitError",
    "VerifyError",
    "IdTakenError",
    "NoMotorError",
    "MoveError",
    "MoveFaultError",
    "MoveTimeoutError",
    "UsageError",
    "SavedConfigError",
    "BackupFileError",
]


class DrEmpowerError(Exception):
    """Base class of every error raised by drempower."""


class ProtocolError(DrEmpowerError, ValueError):
    """A frame or byte stream that does not follow the DrEmpower protocol."""


class ValidationError(DrEmpowerError, ValueError):
    """A value that cannot be put on the wire or an option that cannot be used (bad type, NaN, unknown name...)."""


class FieldRangeError(ValidationError):
    """A numeric field outside the range its wire encoding can hold.

    ``field`` names the field, ``value`` is what was given and ``low``/``high``
    bound the allowed range (inclusive).
    """

    def __init__(self, field: str, value: object, low: float, high: float, detail: str = "") -> None:
        self.field = field
        self.value = value
        self.low = low
        self.high = high
        extra = f" ({detail})" if detail else ""
        super().__init__(f"{field}={value!r} is out of range: allowed {low:g}..{high:g}{extra}")


class ConfigError(ValidationError):
    """A robot description (TOML file) that cannot be used; the message names the file, the entry and the key."""


class TransportError(DrEmpowerError, OSError):
    """A bus that cannot be opened, or a device that failed while in use.

    The message says what was tried (interface, channel or serial port) and why
    it failed.
    """


class TransportOptionError(ValidationError, TransportError):
    """An option a transport cannot use (a bit rate the adapter does not set, a serial rate that is not a
    number, a negative wait): the bus was not opened and nothing was sent. A :class:`ValidationError` (the
    CLI's exit 2: a user's mistake) and a :class:`TransportError` (opening the bus failed)."""


def motors(nodes: Sequence[int]) -> str:
    """``"motor 3"``, ``"motors 1, 2"``; node 0 reads "broadcast"."""
    names = ["broadcast" if n == 0 else str(n) for n in nodes]
    return ("motor " if len(names) == 1 else "motors ") + ", ".join(names)


class TimeoutError(DrEmpowerError, builtins.TimeoutError):
    """A motor did not answer a request in time.

    ``nodes`` lists the silent motors, ``request`` names what was asked and
    ``timeout`` is the time waited (s). Also an instance of the builtin
    :class:`TimeoutError`.
    """

    def __init__(self, nodes: Sequence[int], request: str, timeout: float, message: str | None = None) -> None:
        self.nodes = tuple(nodes)
        self.request = request
        self.timeout = timeout
        if message is None:
            message = f"{motors(nodes)}: no answer to {request} within {timeout:g} s"
        super().__init__(message)


class BusClosedError(DrEmpowerError):
    """The bus was closed, or its receive loop stopped because the device failed."""


class BusStoppedError(DrEmpowerError):
    """An emergency stop on the bus dropped a start that was waiting for its presets to be on the wire."""


class MotorFaultError(DrEmpowerError):
    """A motor reported an error (the E bit of its state) while a call waited on it.

    ``node`` is the motor, ``flags`` maps each error word that is set to its
    flag names (empty when the words could not be read).
    """

    def __init__(self, node: int, doing: str, flags: dict[str, list[str]]) -> None:
        self.node = node
        self.flags = flags
        named = "; ".join(f"{word}: {', '.join(names)}" for word, names in flags.items()) or "error words unread"
        super().__init__(f"motor {node} reported an error {doing} ({named})")


class MotorIdleError(DrEmpowerError):
    """A motion command to motors that are not in closed loop was refused; nothing was sent.

    ``nodes`` are the motors, ``states`` their axis states (``axis0.current_state``,
    1 = idle; None when they were only known not to be enabled). The message names the fix.
    """

    def __init__(self, nodes: Sequence[int], states: Sequence[int | None] = (), fix: str | None = None) -> None:
        """``fix``: how to enable them in the caller's terms (a front end's button or command line);
        by default the API's and the CLI's."""
        from .protocol.enums import AxisState

        self.nodes = tuple(nodes)
        self.states = tuple(states) or (None,) * len(self.nodes)
        names = set()
        for st in self.states:
            try:
                names.add("idle" if st is None else AxisState(st).name.lower())
            except ValueError:
                names.add(f"in axis state {st}")
        what = " / ".join(sorted(names))
        ids = ",".join(map(str, self.nodes))
        verb = "is" if len(self.nodes) == 1 else "are"
        it = "it" if len(self.nodes) == 1 else "them"
        handle = "motor.enable()" if len(self.nodes) == 1 else "bus.enable([...])"
        if fix is None:
            fix = f"({handle}, drempower enable {ids}) or pass enable=True"
        super().__init__(f"{motors(self.nodes)} {verb} {what} (not in closed loop): enable {it} first {fix}")


class SoftLimitError(FieldRangeError):
    """A command beyond a soft limit (position range, speed, torque, acceleration, largest step).

    ``node`` is the motor, ``limit`` the limit's name, ``field``/``value``/``low``/``high`` as in
    :class:`FieldRangeError` (motor units: deg, r/min, Nm, (r/min)/s) and ``where`` says where the
    limit was set (``bus.set_limits(...)``, or the robot file and joint).
    """

    def __init__(self, node: int, limit: str, value: float, low: float, high: float, unit: str, where: str) -> None:
        super().__init__(limit, value, low, high)
        self.node = node
        self.limit = limit
        self.where = where
        self.args = (
            f"motor {node}: {limit} {value:g} {unit} is beyond its soft limit {low:g}..{high:g} {unit} "
            f"(set by {where})",
        )


class MotionParameterError(ValidationError):
    """A parameter write that commands motion the soft limits cannot vouch for (a rotor-side input, a
    mode, step/dir, a calibration state) was refused on a motor with soft limits; nothing was sent.

    ``node`` is the motor, ``name`` the parameter, ``where`` where the motor's limits were set.
    """

    def __init__(self, node: int, name: str, value: float, kind: str, where: str) -> None:
        super().__init__(
            f"motor {node}: writing {name}={value:g} ({kind}) commands motion its soft limits (set by {where}) "
            "cannot check: use the motion commands (set_angle, set_speed, set_torque) or the output shaft's input_*"
        )
        self.node = node
        self.name = name
        self.where = where


class VerifyError(DrEmpowerError):
    """A value read back after writing it differs from what was written (the write was lost or refused)."""


class IdTakenError(VerifyError):
    """The id asked for is already answered by another motor; nothing was changed (C: ``DRE_E_ID_TAKEN``)."""


class NoMotorError(VerifyError):
    """No motor answered where one was expected (C: ``DRE_E_NO_MOTOR``); the message says what was left unchanged."""


class UsageError(DrEmpowerError):
    """A command line that cannot work as given; reported like argparse's own errors (exit 2)."""


def _flags_text(flags: dict[str, list[str]]) -> str:
    return "; ".join(f"{word}: {', '.join(names)}" for word, names in flags.items()) or "no error flags"


class MoveError(DrEmpowerError):
    """A position move did not end at its target (angle limits, stall, estop, a fault or a timeout).

    ``node`` is the motor, ``target`` the commanded angle (deg), ``position`` the
    angle it reported last (deg, None when it never answered), ``flags`` its
    decoded error words (empty when none is set or they could not be read) and
    ``reason`` says what went wrong. :class:`MoveFaultError` (the motor
    reported an error) and :class:`MoveTimeoutError` (still moving when the wait
    ended) are the two kinds that are also :class:`MotorFaultError` and
    :class:`TimeoutError`.
    """

    def __init__(
        self,
        node: int,
        target: float | None,
        position: float | None,
        flags: dict[str, list[str]],
        reason: str,
    ) -> None:
        self.node = node
        self.target = target
        self.position = position
        self.flags = flags
        self.reason = reason
        goal = "unknown" if target is None else f"{target:.2f} deg"
        where = "unknown" if position is None else f"{position:.2f} deg"
        DrEmpowerError.__init__(self, f"motor {node}: {reason}: target {goal}, reached {where} ({_flags_text(flags)})")


class MoveFaultError(MoveError, MotorFaultError):
    """The motor reported an error (E bit) while a wait for its move was running."""

    def __init__(
        self, node: int, target: float | None, position: float | None, flags: dict[str, list[str]], reason: str
    ) -> None:
        MoveError.__init__(self, node, target, position, flags, reason)


class MoveTimeoutError(MoveError, TimeoutError):
    """The motors had not finished their moves when the wait's ``timeout`` (s) ended.

    ``node``, ``target``, ``position`` and ``flags`` describe the first motor
    still moving, ``nodes`` names every one, and ``others`` holds a
    :class:`MoveError` (target, position, flags, reason) for each of the rest;
    the message names them all.
    """

    def __init__(
        self,
        node: int,
        target: float | None,
        position: float | None,
        flags: dict[str, list[str]],
        reason: str,
        timeout: float,
        nodes: Sequence[int] = (),
        others: Sequence[MoveError] = (),
    ) -> None:
        self.nodes = tuple(nodes) or (node,)
        self.others = tuple(others)
        self.request = "wait_position_done"
        self.timeout = timeout
        MoveError.__init__(self, node, target, position, flags, reason)
        if self.others:
            DrEmpowerError.__init__(self, "; ".join([str(self), *map(str, self.others)]))


class SavedConfigError(DrEmpowerError):
    """A saved configuration file of a simulated motor that cannot be loaded; names the file and a way out."""

    def __init__(self, path: os.PathLike[str] | str, problems: list[str]) -> None:
        self.path = path
        self.problems = problems
        super().__init__(
            f"saved configuration {os.fspath(path)}: {'; '.join(problems)} "
            "(delete the file, or use another --config-dir, to start from the factory configuration)"
        )


class BackupFileError(ValidationError):
    """A backup document that cannot be restored: ``problems`` lists (parameter, reason) per bad record."""

    def __init__(self, reason: str, problems: Sequence[tuple[str, str]] = ()) -> None:
        self.reason = reason
        self.problems = list(problems)
        if problems:
            n = len(problems)
            listed = "; ".join(f"{name}: {why}" for name, why in problems)
            reason = f"{reason + ': ' if reason else ''}{n} malformed record{'s' if n > 1 else ''}: {listed}"
        super().__init__(reason)


class DomainError(FieldRangeError):
    """A value outside a parameter's domain (``spec/parameters.csv``).

    ``parameter`` is the :class:`Parameter`; ``hard`` says whether ``force=True``
    could write it anyway (it cannot when hard).
    """

    def __init__(self, p: Parameter, value: object) -> None:
        low = p.minimum if p.minimum is not None else (min(p.allowed) if p.allowed else float("-inf"))
        high = p.maximum if p.maximum is not None else (max(p.allowed) if p.allowed else float("inf"))
        super().__init__(p.name, value, low, high)
        self.parameter = p
        self.hard = p.hard
        hint = "" if p.hard else "; force=True writes it anyway"
        self.args = (f"{p.name}={value!r} is outside its domain: {p.domain_text()}{hint}",)


class IdentificationError(DrEmpowerError):
    """An identification refused (samples a busy host missed or got late, a poor fit): nothing is reported
    rather than a parameter far off (the CLI exits 1)."""


class FollowError(DrEmpowerError):
    """A trajectory stopped early (a tracking error above ``max_error``): the joints were stopped;
    ``report`` (a :class:`~drempower.motion.plan.FollowReport`: the motion layer's, so typed Any in this
    bottom layer) says how far it got."""

    def __init__(self, message: str, report: Any) -> None:
        super().__init__(message)
        self.report = report
