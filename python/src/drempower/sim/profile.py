"""Point-to-point motion profiles of the Q mode: trapezoid and S-curve.

A profile has up to three phases (accelerate, cruise, decelerate) and may start
while moving. The trapezoid has constant acceleration; the S-curve's acceleration
rises linearly from 0 to its peak and back (a triangular pulse) in every speed
change. An S-curve with peak acceleration ``a`` covers the same distance in the
same time as a trapezoid with acceleration ``a/2``, so both share the planner.
Any consistent unit system works; the simulator uses output turns and seconds.
"""

from __future__ import annotations

import math

__all__ = ["Profile", "plan"]


class Profile:
    """A planned move from ``x0`` (speed ``v0``) to ``x1`` (at rest); ``duration`` s.

    ``sample(t)`` gives position, speed and acceleration ``t`` seconds after the start.
    """

    __slots__ = ("_phases", "duration", "s_curve", "x0", "x1")

    def __init__(self, x0: float, x1: float, phases: list[tuple[float, float, float, float]], s_curve: bool) -> None:
        self.x0 = x0
        self.x1 = x1
        self._phases = phases
        """(start time, duration, start speed, end speed) of each phase, start position implied."""
        self.s_curve = s_curve
        self.duration = sum(p[1] for p in phases)

    def sample(self, t: float) -> tuple[float, float, float]:
        """(position, speed, acceleration) at ``t`` s (the start before 0, the target at rest after the end)."""
        if t >= self.duration:
            return self.x1, 0.0, 0.0
        t = max(t, 0.0)
        x = self.x0
        for t0, dur, va, vb in self._phases:
            if t >= t0 + dur:
                x += (va + vb) * 0.5 * dur
                continue
            u = t - t0
            dv = vb - va
            if not self.s_curve:
                acc = dv / dur
                return x + va * u + 0.5 * acc * u * u, va + acc * u, acc
            tau = u / dur
            if tau <= 0.5:
                s, ds, big_s = 2.0 * tau * tau, 4.0 * tau, 2.0 * tau**3 / 3.0
            else:
                r = 1.0 - tau
                s, ds, big_s = 1.0 - 2.0 * r * r, 4.0 * r, tau - 0.5 + (2.0 / 3.0) * (r**3 - 0.125) + 1.0 / 12.0
            return x + va * u + dv * dur * big_s, va + dv * s, dv * ds / dur
        return self.x1, 0.0, 0.0  # pragma: no cover - float rounding at the very end


def plan(x0: float, v0: float, x1: float, vmax: float, accel: float, s_curve: bool = False) -> Profile:
    """Plan a move from ``x0`` at speed ``v0`` to rest at ``x1``, cruising at most at ``vmax`` (> 0).

    ``accel`` (> 0) is the trapezoid's acceleration, or the S-curve's peak acceleration.
    If the start speed exceeds ``vmax`` the first phase slows down to it; if the target is
    too close to stop in time the profile overshoots and comes back (as ODrive does).
    """
    a = accel * 0.5 if s_curve else accel
    dx = x1 - x0
    stop = math.copysign(v0 * v0 / (2.0 * a), v0)
    s = 1.0 if dx - stop >= 0.0 else -1.0
    vr = s * vmax
    ar = a if s * v0 <= vmax else -a
    ar *= s
    ta = (vr - v0) / ar
    td = vr / (s * a)
    dmin = 0.5 * ta * (vr + v0) + 0.5 * td * vr
    if s * dx < s * dmin and s * ar > 0.0:  # too short to reach vmax: a triangle
        vr = s * math.sqrt(max((-s * a * v0 * v0 - 2.0 * ar * s * a * dx) / (-s * a - ar), 0.0))
        ta = max(0.0, (vr - v0) / ar)
        td = max(0.0, vr / (s * a))
        tv = 0.0
    else:  # when slowing down to vmax, dmin is the stopping distance: dx < dmin only by rounding
        tv = max(0.0, (dx - dmin) / vr) if vr else 0.0
    phases: list[tuple[float, float, float, float]] = []
    t = 0.0
    for dur, va, vb in ((ta, v0, vr), (tv, vr, vr), (td, vr, 0.0)):
        if dur > 0.0:
            phases.append((t, dur, va, vb))
            t += dur
    return Profile(x0, x1, phases, s_curve)
