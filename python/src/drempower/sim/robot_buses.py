"""The simulated buses of a robot file: one :class:`~drempower.sim.SimBus` per bus, coupled to one twin of
its physics model (:func:`~drempower.sim.twin.couple_robot`).

The ``sim`` transport (``open_bus("sim", robot=...)``) and the robot layer make a robot's buses here.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any

from ..errors import ConfigError
from ..robotfile import RobotSpec
from .bus import SimBus
from .twin import couple_robot

__all__ = ["simulated_buses"]

_SPEC_KEYS = frozenset(("robot", "robot_bus", "motors"))
"""What a robot's :func:`~drempower.robotfile.bus_options` adds to a sim bus's own options."""


def simulated_buses(spec: RobotSpec, options: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """A :class:`~drempower.sim.SimBus` for each bus name in ``options`` (its SimBus arguments), with the
    motors of its joints, all coupled to the twin of ``spec``'s model. Without MuJoCo: a warning, and
    an empty dict (the buses then simulate each motor's own mechanics)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        warnings.warn(
            f"{spec.source}: the model is not simulated (MuJoCo is not installed): "
            "pip install 'drempower[physics]'; the motors move on their own",
            stacklevel=3,
        )
        return {}
    buses: dict[str, SimBus] = {}
    for name, given in options.items():
        kw = {k: v for k, v in given.items() if k not in _SPEC_KEYS}
        ids = sorted(j.id for j in spec.joints_on(name))
        try:
            buses[name] = SimBus(ids, **kw)
        except TypeError as exc:
            raise ConfigError(f"{spec.source}: [buses.{name}]: {exc}") from None
    couple_robot(spec, buses)
    return buses
