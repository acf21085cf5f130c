"""Tuning a joint's position controller from its identified dynamics, with a step before and after.

The motor's controller is a cascade (turns at the output shaft): ``speed = pos_gain * (pos_sp - pos)``,
``torque = vel_gain * (speed_sp - speed) + integral``. For a closed-loop bandwidth ``f`` Hz:
``pos_gain = 2 pi f`` (1/s), a velocity loop 4 times faster (``vel_gain = J w_v - b`` with the inertia
``J`` and viscous friction ``b`` at the motor in turn units; the two loops then form a critically
damped pair), ``vel_integrator_gain = vel_gain * w_v / 8`` (it removes a steady load, gravity's,
without overshoot), and a T-mode input filter bandwidth of ``2 w_p``.

This module is the part without I/O; the runs (``step_response``, ``tune``) are in ``routines_async.py``
(asyncio) and ``routines_sync.py`` (threads), offered as ``joint.tune()``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from ..errors import ValidationError
from ..protocol.parameters import parameter
from .identify import Identification

__all__ = ["GAIN_NAMES", "Gains", "Step", "TuneReport", "gains_for", "step_metrics"]

GAIN_NAMES = (
    "axis0.controller.config.pos_gain",
    "axis0.controller.config.vel_gain",
    "axis0.controller.config.vel_integrator_gain",
)
_VEL_RATIO = 4.0
_SETTLE_BAND = 0.05


@dataclass
class Gains:
    """``pos_gain`` 1/s, ``vel_gain`` Nm/(turn/s), ``vel_integrator_gain`` Nm/turn; ``bandwidth``: the T-mode
    input filter's, 1/s."""

    pos_gain: float
    vel_gain: float
    vel_integrator_gain: float
    bandwidth: float


@dataclass
class Step:
    """A step response: ``rise`` (10-90 %, s), ``overshoot`` (fraction of the step), ``settling`` (s to stay
    within 5 %), ``final`` (fraction reached at the end)."""

    rise: float
    overshoot: float
    settling: float
    final: float


@dataclass
class TuneReport:
    """What tuning found: the identified model, the gains, and the step before and after."""

    joint: str
    bandwidth: float
    identified: Identification
    gains: Gains
    before: Step
    after: Step

    def as_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return asdict(self)


def gains_for(inertia: float, viscous: float, bandwidth: float, gear: float = 1.0) -> Gains:
    """The gains for a closed-loop ``bandwidth`` Hz of a joint of ``inertia`` kg m^2 and ``viscous``
    Nm s/rad at the joint, behind ``gear``; refused when a gain leaves its parameter's domain."""
    if isinstance(bandwidth, bool) or not isinstance(bandwidth, int | float) or not 0 < bandwidth <= 50:
        raise ValidationError(f"bandwidth={bandwidth!r}: expected 0 < bandwidth <= 50 Hz")
    wp = 2 * math.pi * bandwidth
    wv = _VEL_RATIO * wp
    jt = 2 * math.pi * max(inertia, 0.0) / gear**2
    bt = 2 * math.pi * max(viscous, 0.0) / gear**2
    kv = max(jt * wv - bt, 1e-3)
    out = Gains(wp, kv, kv * wv / 8, min(300.0, 2 * wp))
    for name, value in zip(GAIN_NAMES, (out.pos_gain, out.vel_gain, out.vel_integrator_gain), strict=True):
        p = parameter(name)
        if not p.in_domain(value):
            most = "" if p.maximum is None else f"; at most about {bandwidth * p.maximum / value:.2g} Hz"
            raise ValidationError(
                f"bandwidth={bandwidth:g} Hz: needs {name.rsplit('.', 1)[1]}={value:.4g} for this load, outside "
                f"its domain {p.domain_text()}{most}"
            )
    return out


def step_metrics(ts: list[float], ys: list[float]) -> Step:
    """The rise, overshoot and settling of a step response: ``ys`` the fraction of the step at ``ts`` s."""
    t10 = next((t for t, y in zip(ts, ys, strict=True) if y >= 0.1), math.inf)
    t90 = next((t for t, y in zip(ts, ys, strict=True) if y >= 0.9), math.inf)
    settling = 0.0
    for t, y in zip(ts, ys, strict=True):
        if abs(y - 1.0) > _SETTLE_BAND:
            settling = t
    if abs(ys[-1] - 1.0) > _SETTLE_BAND:
        settling = math.inf
    return Step(t90 - t10, max(0.0, max(ys) - 1.0), settling, ys[-1])
