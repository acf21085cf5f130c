"""A joint's soft limits from one place: the robot file's ``limits`` and the model's joint range.

Every front end that opens a robot file's bus (the robot API, each CLI subcommand with
``--robot``, the dashboard, the bridge, the LeRobot plugins) gives the bus these limits, so a
command beyond one is refused with the same :class:`~drempower.errors.SoftLimitError` words
everywhere. The model's joint range is a position limit unless the file's ``position`` is narrower.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from ..robotfile import JointLimit, ModelRange, RobotSpec, joint_limits, model_range_of
from .joint import Gearing

__all__ = ["JointLimit", "ModelRange", "apply_limits", "joint_limits", "limit_bus", "model_range_of", "twin_model"]


def apply_limits(
    bus: Any, spec: RobotSpec, names: Iterable[str], model_range: ModelRange | None
) -> dict[str, JointLimit]:
    """Give ``bus`` the soft limits (motor units, through each joint's gear) of the joints ``names``
    (all on that bus); returns the limits at each joint."""
    out: dict[str, JointLimit] = {}
    for name in names:
        js = spec.joints[name]
        lim = joint_limits(spec, name, model_range)
        out[name] = lim
        if not lim:
            continue
        motor = Gearing(js).motor_limits(lim)
        for n, key in enumerate(sorted(set(lim.where.values()))):  # one call per source: each limit names its own
            part = {k: v for k, v in motor.items() if lim.where.get(k) == key}
            bus.set_limits(js.id, where=key, replace=n == 0, **part)
    return out


def twin_model(bus: Any) -> Any:
    """The physics model (``mujoco.MjModel``) of the twin a simulated bus drives, or None."""
    sim = getattr(getattr(bus, "transport", None), "bus", None)
    if sim is None:
        return None
    from ..sim.twin import twin_of

    twin = twin_of(sim)
    return None if twin is None else twin.model


def limit_bus(bus: Any, spec: RobotSpec, name: str) -> dict[str, JointLimit]:
    """Give the open bus ``name`` of ``spec`` its joints' soft limits (as :class:`~drempower.robot.Robot`
    does): for a front end that opens one bus of a robot file by itself."""
    ranges = model_range_of(spec, twin_model(bus))
    return apply_limits(bus, spec, [j.name for j in spec.joints_on(name)], ranges)
