"""The position modes of the command line's moves and their options (``move``, and ``move`` on a robot's
joints): which options each mode takes, their defaults from the table of actions, and the speed and
parameter of set_angles they make."""

from __future__ import annotations

import argparse

from .. import actions as table
from ..client.engine.commands import PositionMode
from ._usage import UsageError

_MODES = {"t": PositionMode.T, "q": PositionMode.Q, "p": PositionMode.P}
_OPTIONS = {
    mode: {name: table.get("move").arg(name).default for name in names}
    for mode, names in {
        PositionMode.T: ("bandwidth",),
        PositionMode.Q: ("speed", "accel"),
        PositionMode.P: ("speed_ff", "torque_ff"),
    }.items()
}
"""The options each mode takes, with their defaults (row ``move``'s of the table of actions)."""


def _params(args: argparse.Namespace, mode: PositionMode) -> tuple[float, float]:
    """``speed`` and ``param`` of set_angles for ``mode``; the options of other modes are refused."""
    for other, options in _OPTIONS.items():
        stray = [name for name in options if other is not mode and getattr(args, name) is not None]
        if stray:
            flag = "--" + stray[0].replace("_", "-")
            raise UsageError(f"{flag} applies to mode {other.name.lower()}, not {mode.name.lower()}")
    values = [default if (v := getattr(args, name)) is None else v for name, default in _OPTIONS[mode].items()]
    return (0.0, values[0]) if mode is PositionMode.T else (values[0], values[1])


_FIELDS = {
    PositionMode.T: {"param (bandwidth)": "--bandwidth"},
    PositionMode.Q: {"speed": "--speed", "param (accel)": "--accel"},
    PositionMode.P: {"speed": "--speed-ff", "param": "--torque-ff"},
}
"""The library's field names of each mode, by the option that sets them (and ANGLES for the positions)."""
