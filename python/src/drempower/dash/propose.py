"""The Tuning view's "Propose gains": the same tune as ``drempower tune``, written only on confirmation.

:func:`propose` identifies the joint (it moves: the page asks first), computes ``pos_gain``, ``vel_gain``,
``vel_integrator_gain`` and the T-mode filter bandwidth for the asked closed-loop bandwidth and steps the
joint with its present gains; nothing is written. :func:`apply` writes the proposal (each gain through the
hub's parameter write: checked against its domain, its value before kept for the session) and steps the
joint again: the figures before and after. Over one bus a motor is a joint of gear 1 (rad at its output).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from ..errors import ValidationError
from ..motion.identify import Identification
from ..motion.routines_sync import identify, step_response
from ..motion.tune import GAIN_NAMES, Gains, Step, gains_for

if TYPE_CHECKING:
    from ..robot import Robot
    from .hub import Hub

__all__ = ["Proposal", "apply", "propose"]

_STEP = 0.15
"""The verification step (rad at the joint)."""


@dataclass
class Proposal:
    """A proposal for hub key ``key``: the joint, the asked ``bandwidth`` Hz, what was identified, the gains
    and the step with the present gains."""

    key: int
    joint: str
    bandwidth: float
    identified: Identification
    gains: Gains
    before: Step
    step: float

    def as_dict(self) -> dict[str, Any]:
        """What the page shows."""
        return {
            "id": self.key,
            "joint": self.joint,
            "bandwidth": self.bandwidth,
            "identified": self.identified.as_dict(),
            "gains": asdict(self.gains),
            "before": _step(self.before),
        }


def _step(s: Step) -> dict[str, float | None]:
    """A step's figures for JSON (an infinite time, never reached, is None)."""
    return {k: (None if v == float("inf") else v) for k, v in asdict(s).items()}


@contextmanager
def _robot_of(hub: Hub, key: int) -> Iterator[tuple[Robot, str]]:
    """The hub's robot and the joint of ``key``; over one bus, a robot of that one motor on the hub's bus
    (its bus stays open afterwards)."""
    if hub.robot is not None:
        joint = hub.joints.get(key)
        if joint is None:
            raise ValidationError(f"{hub.label(key)}: not a joint of the robot file: tuning needs its gear")
        yield hub.robot, joint["joint"]
        return
    from ..robot import Robot
    from ..robot.config import BusSpec, JointSpec, RobotSpec

    bus = hub.bus
    name = f"motor_{key}"
    spec = RobotSpec({"bus": BusSpec("bus", "sim")}, {name: JointSpec(name, "bus", key)}, "dashboard")
    before = bus.on_sent
    robot = Robot(spec, {"bus": bus})
    try:
        yield robot, name
    finally:
        robot._shutdown()
        bus.on_sent = before


def _bandwidth(args: dict[str, Any]) -> float:
    value = args.get("bandwidth")
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= 50:
        raise ValidationError(f"bandwidth={value!r}: expected 0 < bandwidth <= 50 Hz")
    return float(value)


def propose(hub: Hub, who: str, args: dict[str, Any], proposals: dict[int, Proposal]) -> dict[str, Any]:
    """Identify motor ``args["id"]``, compute the gains for ``args["bandwidth"]`` Hz and step it with its
    present gains; keeps the proposal in ``proposals`` and writes nothing."""
    key = hub.key(args)
    bandwidth = _bandwidth(args)
    hub._control(who, f"{hub.label(key)} propose gains for {bandwidth:g} Hz (identify, then a step)")
    hub.require_enabled([key])
    hub.commanded.add(key)  # moved from the page: idled with the others when the dashboard ends
    with _robot_of(hub, key) as (robot, joint):
        got = identify(robot, joint)
        gains = gains_for(got.inertia, got.viscous, bandwidth, robot.spec.joints[joint].gear)
        before = step_response(robot, joint, _STEP)
    proposal = Proposal(key, joint, bandwidth, got, gains, before, _STEP)
    proposals[key] = proposal
    return proposal.as_dict()


def apply(hub: Hub, who: str, args: dict[str, Any], proposals: dict[int, Proposal]) -> dict[str, Any]:
    """Write the proposal for motor ``args["id"]`` (the one made for ``args["bandwidth"]``) and step it
    again; the proposal with ``after``."""
    key = hub.key(args)
    proposal = proposals.get(key)
    if proposal is None or proposal.bandwidth != _bandwidth(args):
        raise ValidationError(f"{hub.label(key)}: no proposal for this bandwidth: propose gains first")
    g = proposal.gains
    for name, value in zip(GAIN_NAMES, (g.pos_gain, g.vel_gain, g.vel_integrator_gain), strict=True):
        hub.do_write_param(who, key, name, value)
    hub.require_enabled([key])
    hub.commanded.add(key)
    with _robot_of(hub, key) as (robot, joint):
        after = step_response(robot, joint, proposal.step)
    del proposals[key]
    return {**proposal.as_dict(), "after": _step(after), "written": list(GAIN_NAMES)}
