"""Identification of a joint's dynamics: a safe excitation, then a least-squares fit of

    torque = inertia * acceleration + viscous * velocity + coulomb * sign(velocity)
             + gravity_sin * sin(position) + gravity_cos * cos(position)

at the joint (Nm, rad). The excitation is a sum of three sines of position around where the joint is,
followed in impedance mode (``kp``/``kd`` at the motor) with velocity feed-forward: small amplitude,
bounded speed, inside the joint's limits (checked before anything moves); the joint is held where it
is at the end and on any error or interruption. Acceleration is the central difference of the
measured velocity; samples slower than ``min_speed`` are left out of the fit (friction near rest
is not Coulomb's law).

This module is the part without I/O; the run is ``identify`` in ``routines_async.py`` (asyncio) and
``routines_sync.py`` (threads), offered as ``joint.identify()``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from ..errors import DrEmpowerError, ValidationError
from .plan import model_ranges, robot_limits

if TYPE_CHECKING:
    from ..robotfile import RobotSpec
    from ..sim.twin import Twin

__all__ = ["Identification", "check_excitation", "excitation", "fit_dynamics", "from_samples"]

_FREQS = ((0.7, 1.0, 0.0), (1.9, 0.6, 1.0), (3.3, 0.3, 2.0))
"""(Hz, relative amplitude, phase rad) of the excitation's sines."""
_NORM = sum(a for _, a, _ in _FREQS)


@dataclass
class Identification:
    """A joint's identified dynamics at the joint: ``inertia`` kg m^2, ``viscous`` Nm s/rad, ``coulomb`` Nm,
    ``gravity`` (peak gravity torque, Nm) with ``gravity_sin``/``gravity_cos`` (Nm), ``fit`` (R^2 of the
    torque, 1 = perfect), ``samples`` used."""

    joint: str
    inertia: float
    viscous: float
    coulomb: float
    gravity: float
    gravity_sin: float
    gravity_cos: float
    fit: float
    samples: int

    def as_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return asdict(self)


def _solve(a: list[list[float]], b: list[float]) -> list[float]:
    """``a x = b`` by Gaussian elimination with partial pivoting (a small, well-posed system)."""
    n = len(b)
    m = [[*row, b[i]] for i, row in enumerate(a)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        if abs(m[p][c]) < 1e-12:
            raise DrEmpowerError("identify: the excitation did not excite every term (singular fit)")
        m[c], m[p] = m[p], m[c]
        for r in range(c + 1, n):
            f = m[r][c] / m[c][c]
            for k in range(c, n + 1):
                m[r][k] -= f * m[c][k]
    x = [0.0] * n
    for r in range(n - 1, -1, -1):
        x[r] = (m[r][n] - sum(m[r][k] * x[k] for k in range(r + 1, n))) / m[r][r]
    return x


def fit_dynamics(
    times: list[float], positions: list[float], velocities: list[float], torques: list[float], min_speed: float = 0.2
) -> tuple[list[float], float, int]:
    """Least-squares coefficients (inertia, viscous, coulomb, gravity_sin, gravity_cos), the R^2 of the fit and
    the number of samples used, from samples at the joint (s, rad, rad/s, Nm)."""
    rows: list[list[float]] = []
    ys: list[float] = []
    for k in range(1, len(times) - 1):
        v = velocities[k]
        if abs(v) < min_speed:
            continue
        acc = (velocities[k + 1] - velocities[k - 1]) / (times[k + 1] - times[k - 1])
        q = positions[k]
        rows.append([acc, v, math.copysign(1.0, v), math.sin(q), math.cos(q)])
        ys.append(torques[k])
    if len(rows) < 20:
        raise DrEmpowerError(f"identify: {len(rows)} samples above {min_speed:g} rad/s: too few to fit")
    n = 5
    ata = [[sum(r[i] * r[j] for r in rows) for j in range(n)] for i in range(n)]
    aty = [sum(r[i] * y for r, y in zip(rows, ys, strict=True)) for i in range(n)]
    # columns barely excited (gravity on a horizontal joint: sin, cos nearly constant) are regularised lightly
    for i in range(n):
        ata[i][i] += 1e-9 * (ata[i][i] + 1.0)
    coef = _solve(ata, aty)
    mean = sum(ys) / len(ys)
    res = sum((y - sum(c * x for c, x in zip(coef, r, strict=True))) ** 2 for r, y in zip(rows, ys, strict=True))
    tot = sum((y - mean) ** 2 for y in ys) or 1.0
    return coef, 1.0 - res / tot, len(rows)


def check_excitation(
    spec: RobotSpec,
    twin: Twin | None,
    joint: str,
    q0: float,
    amplitude: float,
    seconds: float,
    rate: float,
    limits: Mapping[str, Any] | None = None,
) -> None:
    """Refuse (:class:`ValidationError`) an excitation of ``amplitude`` rad around ``q0`` rad that leaves the
    joint's limits (robot file, model range, ``limits``) or its speed limit, or bad ``seconds``/``rate``."""
    for name, value, top in (("amplitude", amplitude, math.pi), ("seconds", seconds, 120.0), ("rate", rate, 2000.0)):
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= top:
            raise ValidationError(f"{name}={value!r}: expected 0 < {name} <= {top:g}")
    known = robot_limits(spec, [joint], None if twin is None else model_ranges(twin.model)).get(joint, {})
    known = {**known, **(limits or {})}
    peak_speed = amplitude / _NORM * sum(2 * math.pi * f * a for f, a, _ in _FREQS)
    rng = known.get("position")
    if rng is not None and not (rng[0] <= q0 - amplitude and q0 + amplitude <= rng[1]):
        raise ValidationError(
            f"identify: joint {joint!r} at {q0:.3f} rad +-amplitude={amplitude:g} rad leaves its limits "
            f"{rng[0]:g}..{rng[1]:g} rad; move it or lower the amplitude; nothing was sent"
        )
    speed_limit = known.get("speed")
    if speed_limit is not None and peak_speed > speed_limit:
        raise ValidationError(
            f"identify: the excitation reaches {peak_speed:.3g} rad/s, beyond joint {joint!r}'s speed limit "
            f"{speed_limit:g} rad/s; lower the amplitude; nothing was sent"
        )


def excitation(t: float, q0: float, amplitude: float, seconds: float) -> tuple[float, float]:
    """The excitation's position (rad) and velocity (rad/s) at ``t`` s: sines around ``q0``, ramped in and
    out over half a second."""
    ramp = min(1.0, t / 0.5, (seconds - t) / 0.5)
    ref = vel = 0.0
    for f, a, ph in _FREQS:
        w = 2 * math.pi * f
        ref += a * math.sin(w * t + ph) - a * math.sin(ph)
        vel += a * w * math.cos(w * t + ph)
    return q0 + amplitude / _NORM * ref * ramp, amplitude / _NORM * vel * ramp


def from_samples(
    joint: str, rate: float, ts: list[float], qs: list[float], vs: list[float], taus: list[float]
) -> Identification:
    """The identification from an excitation's samples (s, rad, rad/s, Nm), its ramps (half a second at
    ``rate`` Hz each end) left out."""
    skip = round(0.5 * rate)
    coef, fit, used = fit_dynamics(ts[skip:-skip], qs[skip:-skip], vs[skip:-skip], taus[skip:-skip])
    inertia, viscous, coulomb, gs, gc = coef
    return Identification(joint, inertia, viscous, coulomb, math.hypot(gs, gc), gs, gc, fit, used)
