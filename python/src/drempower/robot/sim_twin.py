"""The simulated buses of a robot whose file names a physics model: one twin behind all of them.

:func:`open_options` gives the :func:`~drempower.open_bus` arguments of every bus of a
robot, as :func:`~drempower.robotfile.bus_options` does; when the file names a
model, its ``sim`` buses are made here, coupled to one
:class:`~drempower.sim.twin.Twin` (:func:`~drempower.sim.robot_buses.simulated_buses`), and handed
to ``open_bus`` ready made.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..robotfile import RobotSpec, bus_options

__all__ = ["open_options"]

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
    from ..sim.robot_buses import simulated_buses  # the simulator loads only for a robot with a model

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
