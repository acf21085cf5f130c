"""Identification of a joint's dynamics: a safe excitation, then a least-squares fit of

    torque = inertia * acceleration + viscous * velocity + coulomb * sign(velocity)
             + gravity_sin * sin(position) + gravity_cos * cos(position)

at the joint (Nm, rad). The excitation is a sum of three sines of position around where the joint is,
followed in impedance mode (``kp``/``kd`` at the motor) with velocity feed-forward: small amplitude,
bounded speed, inside the joint's limits (checked before anything moves); the joint is held where it
is at the end and on any error or interruption. Acceleration is the central difference of the
measured velocity; samples slower than ``min_speed`` are left out of the fit (friction near rest
is not Coulomb's law).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from ..client.commands import PositionMode
from ..client.effects import sleep
from ..errors import DrEmpowerError, ValidationError
from .plan import model_ranges, robot_limits

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["Identification", "identify", "fit_dynamics"]

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


def identify(
    robot: Robot,
    joint: str,
    *,
    amplitude: float = 0.3,
    seconds: float = 6.0,
    rate: float = 200.0,
    kp: float = 5.0,
    kd: float = 0.2,
    max_torque: float | None = None,
    limits: Mapping[str, Any] | None = None,
) -> Identification:
    """Excite joint ``joint`` of ``robot`` around where it is (``amplitude`` rad peak, for ``seconds`` s,
    ``rate`` Hz) and fit its dynamics; see the module's docstring. The excitation is checked against the
    joint's limits (robot file, model range, ``limits``) before anything moves; a torque above
    ``max_torque`` Nm at the joint, or a tracking error above twice the amplitude, stops it."""
    for name, value, top in (("amplitude", amplitude, math.pi), ("seconds", seconds, 120.0), ("rate", rate, 2000.0)):
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value <= top:
            raise ValidationError(f"{name}={value!r}: expected 0 < {name} <= {top:g}")
    j = robot.joint(joint)
    bus = robot.bus(robot.spec.joints[joint].bus)
    twin = robot.twin
    known = robot_limits(robot.spec, [joint], None if twin is None else model_ranges(twin.model)).get(joint, {})
    known = {**known, **(limits or {})}
    q0 = j.get_joint_state().position
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
    g = j.gearing
    ts: list[float] = []
    qs: list[float] = []
    vs: list[float] = []
    taus: list[float] = []
    period = 1.0 / rate
    ok = False
    try:
        t0 = bus.core.now()
        for k in range(round(seconds * rate)):
            t = k * period
            ramp = min(1.0, t / 0.5, (seconds - t) / 0.5)  # half a second in and out
            ref = vel = 0.0
            for f, a, ph in _FREQS:
                w = 2 * math.pi * f
                ref += a * math.sin(w * t + ph) - a * math.sin(ph)
                vel += a * w * math.cos(w * t + ph)
            ref = q0 + amplitude / _NORM * ref * ramp
            vel = amplitude / _NORM * vel * ramp
            j.impedance_control(g.motor_angle(ref), g.motor_speed(vel), 0.0, kp, kd)
            st = j.get_joint_state()
            if abs(st.position - ref) > 2 * amplitude or (max_torque is not None and abs(st.torque) > max_torque):
                raise DrEmpowerError(
                    f"identify: joint {joint!r} stopped at {st.position:.3f} rad, torque {st.torque:.3g} Nm: "
                    "it does not follow the excitation (blocked, or max_torque reached)"
                )
            ts.append(st.timestamp)
            qs.append(st.position)
            vs.append(st.velocity)
            taus.append(st.torque)
            wait = t0 + (k + 1) * period - bus.core.now()
            if wait > 0:
                bus.run(sleep(wait))
        ok = True
    finally:
        st_last = j.state
        at = st_last.angle if st_last is not None else g.motor_angle(q0)
        if ok:
            j.set_angle(g.motor_angle(q0), 0.0, 20.0, PositionMode.T)  # back where it was
        else:
            bus.core.send_many([j.make_angle(at, 0.0, 20.0, PositionMode.T)])  # hold where it is
    skip = round(0.5 * rate)
    coef, fit, used = fit_dynamics(ts[skip:-skip], qs[skip:-skip], vs[skip:-skip], taus[skip:-skip])
    inertia, viscous, coulomb, gs, gc = coef
    return Identification(joint, inertia, viscous, coulomb, math.hypot(gs, gc), gs, gc, fit, used)
