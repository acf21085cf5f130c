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

import itertools
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from ..errors import DrEmpowerError, IdentificationError, ValidationError
from .plan import model_ranges, robot_limits

if TYPE_CHECKING:
    from ..robotfile import RobotSpec
    from ..sim.twin import Twin

__all__ = [
    "Identification",
    "IdentificationError",
    "check_excitation",
    "excitation",
    "fit_dynamics",
    "from_samples",
]

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


MIN_FIT = 0.95
"""Lowest R^2 of the torque fit an identification is given with (a quiet run gets above 0.99)."""
MAX_INERTIA_ERROR = 0.1
"""Largest standard error of the inertia, relative to it, an identification is given with."""
MIN_SAMPLES = 0.7
"""Smallest share of the samples asked that must arrive on time (within 2.5 periods of the one before)."""
LATE = 2.5
"""A sample more than this many periods after the one before counts as late (the host fell behind)."""


def fit_dynamics(
    times: list[float],
    positions: list[float],
    velocities: list[float],
    torques: list[float],
    min_speed: float = 0.2,
    max_gap: float | None = None,
) -> tuple[list[float], float, int, list[float]]:
    """Least-squares coefficients (inertia, viscous, coulomb, gravity_sin, gravity_cos), the R^2 of the fit,
    the number of samples used and the standard error of each coefficient, from samples at the joint (s,
    rad, rad/s, Nm). A sample next to a gap longer than ``max_gap`` s is left out (its acceleration, a
    difference across the gap, would not be that of its moment)."""
    rows: list[list[float]] = []
    ys: list[float] = []
    for k in range(1, len(times) - 1):
        v = velocities[k]
        if abs(v) < min_speed:
            continue
        dt = times[k + 1] - times[k - 1]
        if dt <= 0 or (max_gap is not None and max(times[k + 1] - times[k], times[k] - times[k - 1]) > max_gap):
            continue
        acc = (velocities[k + 1] - velocities[k - 1]) / dt
        q = positions[k]
        rows.append([acc, v, math.copysign(1.0, v), math.sin(q), math.cos(q)])
        ys.append(torques[k])
    if len(rows) < 20:
        raise IdentificationError(f"identify: {len(rows)} samples above {min_speed:g} rad/s: too few to fit")
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
    sigma2 = res / max(1, len(rows) - n)
    errors = [math.sqrt(max(0.0, sigma2 * _solve(ata, [float(i == j) for j in range(n)])[i])) for i in range(n)]
    return coef, 1.0 - res / tot, len(rows), errors


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
    joint: str,
    rate: float,
    ts: list[float],
    qs: list[float],
    vs: list[float],
    taus: list[float],
    seconds: float | None = None,
) -> Identification:
    """The identification from an excitation's samples (s, rad, rad/s, Nm; ``ts`` each state frame's own
    time), its ramps (the first and last half second) left out. Raises :class:`IdentificationError` when
    fewer than :data:`MIN_SAMPLES` of the samples asked (``seconds`` s at ``rate`` Hz) arrived on time, or
    the fit is poor (R^2 below :data:`MIN_FIT`, the inertia's standard error above :data:`MAX_INERTIA_ERROR`)."""
    if len(ts) < 3:
        raise IdentificationError(f"identify: {len(ts)} samples: too few to fit")
    start, end = ts[0] + 0.5, ts[-1] - 0.5
    keep = [k for k, t in enumerate(ts) if start <= t <= end]
    ts, qs, vs, taus = ([x[k] for k in keep] for x in (ts, qs, vs, taus))
    period = 1.0 / rate
    asked = max(1, round(((seconds if seconds is not None else (end - start) + 1.0) - 1.0) * rate))
    on_time = sum(1 for a, b in itertools.pairwise(ts) if 0 < b - a <= LATE * period)
    if on_time < MIN_SAMPLES * asked:
        raise IdentificationError(
            f"identify: refused: {asked - on_time} of {asked} samples missed or late (the host could not keep "
            f"{rate:g} Hz): run it on a quieter host, or lower --rate; nothing was reported"
        )
    coef, fit, used, errors = fit_dynamics(ts, qs, vs, taus, max_gap=LATE * period)
    inertia, viscous, coulomb, gs, gc = coef
    spread = errors[0] / abs(inertia) if inertia else math.inf
    if fit < MIN_FIT or not spread <= MAX_INERTIA_ERROR:
        raise IdentificationError(
            f"identify: refused: a poor fit (R^2 {fit:.3f}, inertia {inertia:.3g} kg m^2 +-{100 * spread:.0f} %; "
            f"needs R^2 >= {MIN_FIT:g} and +-{100 * MAX_INERTIA_ERROR:.0f} %): a blocked or loaded joint, or a busy "
            "host; try a larger --amplitude or a quieter host; nothing was reported"
        )
    return Identification(joint, inertia, viscous, coulomb, math.hypot(gs, gc), gs, gc, fit, used)
