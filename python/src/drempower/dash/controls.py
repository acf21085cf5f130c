"""The page's controls as rows of :mod:`drempower.actions`: its buttons, position modes, jog, step,
velocity, torque and impedance, with the page's fields renamed to the row's arguments."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .. import actions

__all__ = ["PAGE_CONTROLS", "PAGE_PARAM", "PAGE_ROWS", "page_row"]

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


def page_row(args: dict[str, Any], bandwidth: Callable[[], float]) -> tuple[str, dict[str, Any]]:
    """The row of the page's control ``args["action"]`` (one of :data:`PAGE_CONTROLS`) and its arguments,
    in the page's units; ``bandwidth()`` reads the motor's T-mode filter bandwidth (1/s) for a step without one."""
    action = str(args.get("action"))
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
        row_args["bandwidth"] = bandwidth()
    return row, row_args
