"""The simulated buses of a robot whose file names a physics model: one twin behind all of them.

:func:`open_options` gives the :func:`~drempower.open_bus` arguments of every bus of a
robot, as :func:`~drempower.robot.config.bus_options` does; when the file names a
model, its ``sim`` buses are made here, coupled to one
:class:`~drempower.sim.twin.Twin`, and handed to ``open_bus`` ready made.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import Any

from ..errors import ConfigError
from .config import RobotSpec, bus_options

__all__ = ["open_options", "simulated_buses"]

_TRANSPORT_KEYS = frozenset(("interface", "timeout", "retries", "stop_on_close", "start", "time_scale", "clock"))
"""The ``open_bus`` arguments of a sim bus that are not the simulated bus's own."""


def open_options(spec: RobotSpec, overrides: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The ``open_bus`` arguments of every bus of ``spec`` by name (see :func:`bus_options`);
    the sim buses of a robot with a model come with their ``bus``, coupled to one twin. Several
    such buses on wall time run on one clock (a :class:`~drempower.sim.twin.TwinRunner` that ends
    once every bus is closed)."""
    opts = {name: bus_options(spec, name, overrides) for name in spec.buses}
    sims = {name: kw for name, kw in opts.items() if kw["interface"] == "sim"}
    if spec.model is None or not sims:
        return opts
    buses = simulated_buses(
        spec, {name: {k: v for k, v in kw.items() if k not in _TRANSPORT_KEYS} for name, kw in sims.items()}
    )
    for name, kw in sims.items():
        if name in buses:
            opts[name] = {**{k: v for k, v in kw.items() if k in _TRANSPORT_KEYS}, "bus": buses[name]}
    wall = [name for name in buses if opts[name].get("clock", "wall") == "wall"]
    scale = {opts[name].get("time_scale", 1.0) for name in wall}
    if len(wall) > 1 and len(scale) == 1 and 0 not in scale:
        from ..sim.twin import TwinRunner

        for name in wall:  # one clock for the buses of one twin, instead of a runner each
            opts[name]["time_scale"] = 0
        TwinRunner([buses[name] for name in wall], scale.pop(), while_attached=True).start()
    return opts


_SPEC_KEYS = frozenset(("robot", "robot_bus", "motors"))
"""What :meth:`RobotSpec.open_options` adds to a sim bus's own options."""


def simulated_buses(spec: RobotSpec, options: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """A :class:`~drempower.sim.SimBus` for each bus name in ``options`` (its SimBus arguments), with the
    motors of its joints, all coupled to the twin of ``spec``'s model. Without MuJoCo: a warning, and
    an empty dict (the buses then simulate each motor's own mechanics)."""
    from ..sim import SimBus
    from ..sim.twin import couple_robot

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
