"""``drempower calibrate``: run a motor's calibration through the axis states inherited from ODrive.

The sequence is requested by writing ``axis0.requested_state`` (30003): 4 motor
calibration (phase resistance and inductance; the rotor stays still), 7 encoder
offset calibration (the rotor turns slowly, forward and back), 3 the full
sequence (4 then 7). The axis reports each phase in ``axis0.current_state``
(30002) and ends in IDLE, with the errors of a failed phase set.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from ..client import Bus, Motor
from ..errors import DrEmpowerError
from ..naming import state_name
from ..protocol.addresses import (
    AXIS0_CONFIG_EXTRA_SETTING_ENCODER_OFFSET_CALIBRATED,
    AXIS0_CURRENT_STATE,
    AXIS0_MOTOR_IS_CALIBRATED,
    AXIS0_REQUESTED_STATE,
)
from ..protocol.enums import AxisState
from . import _readings
from ._confirm import add_yes_arg, confirm
from ._connect import add_connection_args, follow_up, motor_id, open_from_args, positive
from ._output import Progress, add_json_arg, report
from .faults import explain

GROUP = "motion"
"""Where ``drempower --help`` lists this module's subcommands."""

SEQUENCES = {
    "full": AxisState.FULL_CALIBRATION_SEQUENCE,
    "motor": AxisState.MOTOR_CALIBRATION,
    "encoder": AxisState.ENCODER_OFFSET_CALIBRATION,
}
"""``--only`` choices and the state each requests."""
PHASE_TEXT = {
    AxisState.MOTOR_CALIBRATION: "motor calibration (phase resistance and inductance; the motor beeps)",
    AxisState.ENCODER_OFFSET_CALIBRATION: "encoder offset calibration (the shaft turns slowly, forward and back)",
    AxisState.FULL_CALIBRATION_SEQUENCE: "full calibration sequence",
}
_POLL = 0.1
_START_GRACE = 1.0
"""Seconds the motor may take to leave IDLE after the request."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "calibrate",
        help="run a motor's calibration (motor, encoder offset, or both) with progress and the result",
        description=(
            "Calibrate a motor through the axis states the firmware inherits from ODrive: motor calibration "
            "(4), then encoder offset calibration (7), during which the shaft turns; --only runs one of them. "
            "The shaft must be free to turn and unloaded. Asks for confirmation unless --yes; Ctrl-C sets the "
            "motor idle. Calibration is done at the factory: recalibrate after erase_config or a firmware update."
        ),
    )
    p.add_argument("id", type=motor_id, metavar="ID", help="the motor's id")
    p.add_argument("--only", choices=("motor", "encoder"), help="run only this phase (default: the full sequence)")
    p.add_argument("--save", action="store_true", help="store the result in flash when calibration succeeds")
    p.add_argument("--max-time", type=positive, default=90.0, metavar="S", help="give up after S seconds (default 90)")
    add_yes_arg(p)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def _state(motor: Motor) -> AxisState | int:
    value = int(motor.read_property(AXIS0_CURRENT_STATE))
    try:
        return AxisState(value)
    except ValueError:
        return value


def _follow(args: argparse.Namespace, motor: Motor, max_time: float) -> float:
    """Wait until the sequence ends in IDLE, saying each phase on stderr; the seconds it took."""
    start = time.monotonic()
    seen: list[AxisState | int] = []
    with Progress() as progress:  # a running clock on a terminal
        while True:
            state = _state(motor)
            elapsed = time.monotonic() - start
            if state != AxisState.IDLE and (not seen or seen[-1] != state):
                seen.append(state)
                text = PHASE_TEXT.get(state) if isinstance(state, AxisState) else None
                text = text or f"{state_name(int(state))}"
                if not args.json:
                    progress.clear()
                    print(f"motor {args.id}: {text}...", file=sys.stderr, flush=True)
            if state == AxisState.IDLE and (seen or elapsed > _START_GRACE):
                return elapsed
            if not args.json:
                progress.show(f"  {elapsed:.0f} s")
            _check_time(args, state, elapsed, max_time)
            time.sleep(_POLL)


def _check_time(args: argparse.Namespace, state: AxisState | int, elapsed: float, max_time: float) -> None:
    if elapsed > max_time:
        raise DrEmpowerError(
            f"motor {args.id}: calibration still running after {max_time:g} s (state "
            f"{state_name(int(state))}); it was set idle"
        )


def run(args: argparse.Namespace) -> int:
    wanted = SEQUENCES[args.only or "full"]
    what = PHASE_TEXT[wanted]
    moves = wanted != AxisState.MOTOR_CALIBRATION
    warning = "the shaft will turn, so it must be free and unloaded; " if moves else "the motor is released; "
    confirm(args, f"run {what} on motor {args.id}", warning + "a load it holds now will drop")
    with open_from_args(args) as bus:
        motor = bus.motor(args.id)
        (reading,) = _readings.read(bus, [args.id])
        if reading.state is not None and reading.state.error:
            raise DrEmpowerError(
                f"motor {args.id} reports errors ({reading.error_text()}): calibration would not start; "
                f"`{follow_up(args, f'clear {args.id}')}` first"
            )
        try:
            # axis0.requested_state: the calibration states 3/4/7 lie outside its soft domain
            motor.write_property(AXIS0_REQUESTED_STATE, int(wanted), force=True)
            seconds = _follow(args, motor, args.max_time)
        except BaseException:
            _idle(bus, args.id)
            raise
        return _result(args, motor, seconds)


def _idle(bus: Bus, node: int) -> None:
    """Stop a calibration: request IDLE (best effort: the link may be what failed)."""
    try:
        bus.motor(node).set_mode(1)
        print(f"drempower: motor {node} set to idle", file=sys.stderr)
    except DrEmpowerError:
        pass


def _result(args: argparse.Namespace, motor: Motor, seconds: float) -> int:
    errors = motor.dump_error()
    motor_ok = bool(motor.read_property(AXIS0_MOTOR_IS_CALIBRATED))
    encoder_ok = bool(motor.read_property(AXIS0_CONFIG_EXTRA_SETTING_ENCODER_OFFSET_CALIBRATED))
    record = {
        "id": args.id,
        "sequence": args.only or "full",
        "ok": not errors,
        "seconds": round(seconds, 1),
        "motor_calibrated": motor_ok,
        "encoder_offset_calibrated": encoder_ok,
        "errors": explain(errors),
        "saved": False,
    }
    if not errors and args.save:
        motor.save_config()
        record["saved"] = True
    if args.json:
        report(args, "", [record])
    elif errors:
        print(f"motor {args.id}: calibration failed after {seconds:.1f} s")
        for f in record["errors"]:
            print(f"  {f['word']}: {f['flag']}: {f['meaning']}\n    what to do: {f['action']}")
    else:
        saved = ", saved" if record["saved"] else f"; `{follow_up(args, f'save {args.id}')}` keeps it"
        print(
            f"motor {args.id}: calibration done in {seconds:.1f} s (motor calibrated: {'yes' if motor_ok else 'no'}, "
            f"encoder offset calibrated: {'yes' if encoder_ok else 'no'}){saved}; "
            f"`{follow_up(args, f'enable {args.id}')}` to use it"
        )
    if errors:
        if args.json:
            print(f"drempower: motor {args.id}: calibration failed", file=sys.stderr)
        return 1
    return 0
