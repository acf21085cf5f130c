"""``drempower stop``, ``clear``, ``idle``, ``enable`` and ``zero``: safety and axis state."""

from __future__ import annotations

import argparse
import re
import time
from collections.abc import Callable
from typing import Any

from ..client import Bus, Motor
from ..errors import DrEmpowerError
from ..protocol.enums import AxisState
from . import _readings
from ._connect import add_connection_args, add_ids_arg, follow_up, open_from_args
from ._output import add_json_arg, emit, motors_text, report, sent

GROUP = "motion"
"""Where ``drempower --help`` lists this module's subcommands."""

_SETTLE = 1.0
"""Longest wait (s) for motors to reach the state asked for."""
_ZERO_TOLERANCE = 0.5
"""How close to 0 deg (deg) a motor must read after zeroing."""
_AT_REST = 0.5
"""The fastest a motor may turn (r/min) and still count as at rest for ``zero``."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "stop",
        help="emergency stop: motors go idle and ignore motion until clear + enable (default: all, broadcast)",
        description="Emergency stop (estop). Recover with `drempower clear IDS` then `drempower enable IDS`.",
    )
    add_ids_arg(p, all_ok=True, optional=True)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run_stop)

    commands: list[tuple[str, str, Callable[[argparse.Namespace], int]]] = [
        ("clear", "clear error flags (the motors stay idle: enable them afterwards)", run_clear),
        ("idle", "release motors (no torque; they turn freely)", run_idle),
        ("enable", "enter closed-loop control (needed after power-up errors, clear or idle)", run_enable),
    ]
    for name, help, func in commands:
        c = sub.add_parser(name, help=help, description=help[0].upper() + help[1:] + ".")
        add_ids_arg(c, all_ok=True)
        add_json_arg(c)
        add_connection_args(c)
        c.set_defaults(func=func)

    z = sub.add_parser(
        "zero",
        help="make the current position 0 deg (motors at rest)",
        description="Make each motor's current output position 0 deg; --save keeps it in flash.",
    )
    add_ids_arg(z)
    z.add_argument("--save", action="store_true", help="store the configuration in flash afterwards")
    z.add_argument("--force", action="store_true", help="zero even a motor that is moving")
    add_json_arg(z)
    add_connection_args(z)
    z.set_defaults(func=run_zero)


def run_stop(args: argparse.Namespace) -> int:
    ids: list[int] = args.ids or [0]
    with open_from_args(args) as bus:
        bus.estop(None if ids == [0] else ids)
    report(args, f"emergency stop sent to {motors_text(ids)}", sent(ids, "estop"))
    return 0


Check = Callable[[_readings.Reading], bool]


def _error(r: _readings.Reading) -> bool:
    return r.state is not None and r.state.error


def _apply(
    args: argparse.Namespace,
    action: Callable[[Motor], None],
    ok: Check,
    failure: str,
    first: Callable[[Bus], None] | None = None,
) -> int:
    """Send ``action`` to every motor, wait until ``ok`` holds for each, show the motors.

    ``failure`` (with ``{ids}`` and ``{errors}``) is the error when some motor is not ``ok`` in time.
    A broadcast (``all``) is sent only: which motors heard it is unknown. ``first``
    runs on the open bus before anything is sent (and may refuse by raising).
    """
    with open_from_args(args) as bus:
        if first is not None:
            first(bus)
        for node in args.ids:
            action(bus.motor(node))
        if args.ids == [0]:
            report(args, f"sent to {motors_text(args.ids)}", sent(args.ids, args.command))
            return 0
        readings = _settle(bus, args.ids, ok)
    emit(args, _readings.HEADERS, [r.record() for r in readings])
    bad = [r for r in readings if not ok(r)]
    if bad:
        text = failure.format(ids=",".join(str(r.id) for r in bad), errors=bad[0].error_text())
        # the commands suggested carry the user's connection options
        raise DrEmpowerError(re.sub(r"`drempower ([^`]*)`", lambda m: f"`{follow_up(args, m[1])}`", text))
    return 0


def _settle(bus: Bus, ids: list[int], ok: Check) -> list[_readings.Reading]:
    deadline = time.monotonic() + _SETTLE
    while True:
        readings = _readings.read(bus, ids)
        if all(ok(r) for r in readings) or time.monotonic() > deadline:
            return readings
        time.sleep(0.02)


def run_clear(args: argparse.Namespace) -> int:
    return _apply(
        args,
        Motor.clear_error,
        lambda r: not _error(r),
        "motor {ids}: errors remain after clearing ({errors}); encoder errors need `drempower zero {ids}` first",
    )


def run_idle(args: argparse.Namespace) -> int:
    return _apply(
        args,
        lambda m: m.set_mode(1),
        lambda r: r.axis_state == AxisState.IDLE,
        "motor {ids} did not go idle",
    )


def run_enable(args: argparse.Namespace) -> int:
    def watchdog(bus: Bus) -> None:
        if args.ids != [0]:
            _readings.warn_leftover_watchdog(bus, args.ids, args)

    return _apply(
        args,
        lambda m: m.set_mode(2),
        lambda r: r.axis_state == AxisState.CLOSED_LOOP_CONTROL and not _error(r),
        "motor {ids} did not enter closed loop ({errors}): see `drempower errors {ids}`, then `drempower clear {ids}`",
        watchdog,
    )


def run_zero(args: argparse.Namespace) -> int:
    def zero(m: Motor) -> None:
        m.set_zero_position()
        if args.save:
            m.save_config()

    def at_rest(bus: Bus) -> None:
        """Refuse (nothing sent) while a motor turns or has a move under way: its zero would be wherever it passed."""
        for r in _readings.read(bus, args.ids):
            st = r.state
            if st is not None and (abs(st.speed) > _AT_REST or not st.trajectory_done):
                doing = f"turning at {st.speed:g} r/min" if abs(st.speed) > _AT_REST else "in the middle of a move"
                raise DrEmpowerError(
                    f"motor {r.id} is {doing} (at {st.angle:.2f} deg): zero needs it at rest; "
                    "stop it first, or add --force to zero it anyway"
                )

    return _apply(
        args,
        zero,
        lambda r: r.state is not None and abs(r.state.angle) < _ZERO_TOLERANCE,
        "motor {ids} does not read 0 deg after zeroing: was it moving?",
        None if args.force else at_rest,
    )
