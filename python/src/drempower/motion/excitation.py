"""A safe excitation for identifying a robot's joints: a multi-sine per joint, within every joint's limits.

Each joint follows ``centre + amplitude * e(t) * sum_k a_k sin(2 pi f_k t + phi_k) / sum_k a_k``: four
sines whose frequencies differ from joint to joint (so that the joints' motions are uncorrelated and
a fit can tell their parameters apart), Schroeder phases (a low crest factor), and an envelope
``e(t)`` that rises from 0 to 1 over ``ramp`` s at the start and falls back at the end, so the
trajectory starts and ends at rest at the centre. The excursion never exceeds ``amplitude``; the
speed never exceeds the bound :func:`peak_speed` gives. Both are checked against the limits before
a :class:`~drempower.motion.trajectory.Trajectory` is made.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import ValidationError

__all__ = ["BASE_FREQUENCIES", "RELATIVE_AMPLITUDES", "excitation_knots", "frequencies", "peak_speed"]

BASE_FREQUENCIES = (0.23, 0.53, 0.97, 1.51)
"""The first joint's sine frequencies (Hz); joint ``j`` uses them times ``1 + 0.13 j``."""
RELATIVE_AMPLITUDES = (1.0, 0.6, 0.35, 0.2)
"""The sines' relative amplitudes (the slow ones move most: accelerations stay moderate)."""
_NORM = sum(RELATIVE_AMPLITUDES)


def frequencies(index: int) -> list[float]:
    """The sine frequencies (Hz) of the ``index``-th joint (0-based)."""
    return [f * (1.0 + 0.13 * (index % 8)) for f in BASE_FREQUENCIES]


def _phases() -> list[float]:
    n = len(BASE_FREQUENCIES)
    return [-math.pi * k * (k + 1) / n for k in range(n)]


def peak_speed(index: int, amplitude: float, ramp: float) -> float:
    """A bound (rad/s) on the speed of the ``index``-th joint's excitation of ``amplitude`` rad with an
    envelope ramp of ``ramp`` s."""
    sines = sum(a * 2 * math.pi * f for a, f in zip(RELATIVE_AMPLITUDES, frequencies(index), strict=True))
    return amplitude / _NORM * sines + amplitude * math.pi / (2 * ramp)


def _value(t: float, seconds: float, ramp: float, freqs: list[float], phases: list[float]) -> tuple[float, ...]:
    """The unit excitation (excursion / amplitude) at ``t``: position, velocity, acceleration."""
    s = v = a = 0.0
    for amp, f, ph in zip(RELATIVE_AMPLITUDES, freqs, phases, strict=True):
        w = 2 * math.pi * f
        s += amp * math.sin(w * t + ph)
        v += amp * w * math.cos(w * t + ph)
        a -= amp * w * w * math.sin(w * t + ph)
    s, v, a = s / _NORM, v / _NORM, a / _NORM
    # the envelope: 0.5 - 0.5 cos over the ramps, 1 between
    if t < ramp:
        x, sign = t, 1.0
    elif t > seconds - ramp:
        x, sign = seconds - t, -1.0
    else:
        return s, v, a
    k = math.pi / ramp
    e, de, dde = 0.5 - 0.5 * math.cos(k * x), 0.5 * k * math.sin(k * x) * sign, 0.5 * k * k * math.cos(k * x)
    return e * s, de * s + e * v, dde * s + 2 * de * v + e * a


def excitation_knots(
    joints: Sequence[str],
    centre: Sequence[float],
    amplitude: Sequence[float],
    seconds: float,
    *,
    ramp: float = 1.0,
    step: float = 0.01,
    limits: Mapping[str, Mapping[str, Any]] | None = None,
) -> tuple[list[float], list[list[float]], list[list[float]], list[list[float]]]:
    """Knot times, positions, velocities and accelerations of the excitation (see the module docstring);
    raises :class:`ValidationError` naming the joint when it would leave ``limits[joint]['position']``
    (rad, low..high) or exceed ``limits[joint]['speed']`` (rad/s)."""
    if isinstance(seconds, bool) or not isinstance(seconds, int | float) or not 0 < seconds <= 3600:
        raise ValidationError(f"seconds={seconds!r}: expected 0 < seconds <= 3600")
    if isinstance(ramp, bool) or not isinstance(ramp, int | float) or not 0 < ramp <= seconds / 2:
        raise ValidationError(f"ramp={ramp!r}: expected 0 < ramp <= seconds / 2 = {seconds / 2:g} s")
    for j, (name, a) in enumerate(zip(joints, amplitude, strict=True)):
        c = centre[j]
        if not math.isfinite(c):
            raise ValidationError(f"centre[{name!r}]={c!r}: expected a finite number of rad")
        if not 0 <= a <= math.pi:
            raise ValidationError(f"amplitude[{name!r}]={a!r}: expected 0 <= amplitude <= pi rad")
        lim = (limits or {}).get(name, {})
        rng = lim.get("position")
        if rng is not None and not (rng[0] <= c - a and c + a <= rng[1]):
            raise ValidationError(
                f"excitation: joint {name!r} at {c:.3f} rad +-amplitude={a:g} rad leaves its limits "
                f"{rng[0]:g}..{rng[1]:g} rad; move it or lower the amplitude"
            )
        top = lim.get("speed")
        peak = peak_speed(j, a, ramp)
        if top is not None and peak > top:
            raise ValidationError(
                f"excitation: joint {name!r} would reach {peak:.3g} rad/s, beyond its speed limit {top:g} rad/s; "
                f"lower the amplitude"
            )
    n = max(2, math.ceil(seconds / step) + 1)
    times = [seconds * k / (n - 1) for k in range(n)]
    phases = _phases()
    freqs = [frequencies(j) for j in range(len(joints))]
    pos: list[list[float]] = []
    vel: list[list[float]] = []
    acc: list[list[float]] = []
    for t in times:
        unit = [_value(t, seconds, ramp, freqs[j], phases) for j in range(len(joints))]
        pos.append([centre[j] + amplitude[j] * r[0] for j, r in enumerate(unit)])
        vel.append([amplitude[j] * r[1] for j, r in enumerate(unit)])
        acc.append([amplitude[j] * r[2] for j, r in enumerate(unit)])
    for rest in (vel[0], vel[-1], acc[0], acc[-1]):  # exactly at rest at both ends
        rest[:] = [0.0] * len(rest)
    return times, pos, vel, acc
