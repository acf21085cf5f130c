"""Joint trajectories: positions over time, interpolated, time-parameterised and read from files (no I/O
beyond the files).

A :class:`Trajectory` holds knots: ``times`` (s from the start, strictly increasing from 0) and, for
each, one position per joint (rad at the joint, or deg for a bus's motors). Between knots it is a
cubic Hermite polynomial in each joint (velocities given, or those of a C2 cubic spline that starts
and ends at rest), or a quintic where accelerations are given too::

    >>> tr = Trajectory([0.0, 1.0, 2.0], [[0.0, 0.0], [0.5, -0.2], [1.0, 0.0]], joints=["a", "b"])
    >>> round(tr.sample(1.0).positions[0], 6)
    0.5

:meth:`Trajectory.from_waypoints` times a path of waypoints within per-joint speed and acceleration
limits. Files: CSV (a ``t`` column, one column per joint), JSON, and the ``sensor_msgs/JointState``
topic of an MCAP recording (:meth:`Trajectory.load`, :meth:`Trajectory.save`).
"""

from __future__ import annotations

import bisect
import csv
import json
import math
import os
import struct
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, NamedTuple

from ..errors import DrEmpowerError, ValidationError

__all__ = ["Trajectory", "Sample", "Peaks", "per_joint"]

Rows = Sequence[Sequence[float]] | Mapping[str, Sequence[float]]
"""One row per time with one value per joint, or joint name -> one value per time."""
_VEL, _ACC = ":velocity", ":acceleration"
"""CSV column suffixes of the optional velocities and accelerations (a joint name holds no ``:``)."""


class Sample(NamedTuple):
    """The trajectory at one time: per joint ``positions``, ``velocities`` (/s) and ``accelerations`` (/s^2)."""

    positions: list[float]
    velocities: list[float]
    accelerations: list[float]


class Peaks(NamedTuple):
    """The largest magnitude of each joint's velocity and acceleration over the trajectory, and its extent."""

    speed: list[float]
    accel: list[float]
    low: list[float]
    high: list[float]


MAX_VALUE = 1e6
"""The largest magnitude of a time (s), position, velocity or acceleration a trajectory takes (beyond any
motor's +-720000 deg): a spline through larger ones overflows."""
MIN_STEP = 1e-6
"""The shortest step (s) between two times of a trajectory (a spline over a shorter one divides by ~0)."""


def _finite(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValidationError(f"{what}={value!r}: expected a finite number")
    if abs(value) > MAX_VALUE:
        raise ValidationError(f"{what}={value!r}: beyond +-{MAX_VALUE:g}")
    return float(value)


def _joint_names(joints: Iterable[str] | None, n: int, what: str) -> tuple[str, ...]:
    if joints is None:
        return tuple(f"joint{i + 1}" for i in range(n))
    if isinstance(joints, str):
        raise ValidationError(f"joints={joints!r}: expected a list of names")
    names = tuple(str(j) for j in joints)
    if len(names) != n:
        raise ValidationError(f"joints: {len(names)} names for {n} values per row of {what}")
    if len(set(names)) != len(names):
        raise ValidationError(f"joints={list(names)!r}: a joint is named twice")
    return names


def _rows(values: Rows, joints: Iterable[str] | None, n: int, what: str) -> tuple[tuple[str, ...], list[list[float]]]:
    """``values`` as ``n`` rows, and the joint names (from a mapping's keys, else ``joints``)."""
    if isinstance(values, Mapping):
        names = tuple(values) if joints is None else tuple(joints)
        missing = [j for j in names if j not in values]
        if missing:
            raise ValidationError(f"{what}: no values for joint {missing[0]!r} (given: {', '.join(values)})")
        cols: list[Sequence[float]] = [values[j] for j in names]
        for j, col in zip(names, cols, strict=True):
            if isinstance(col, str | bytes) or len(col) != n:
                got = "text" if isinstance(col, str | bytes) else f"{len(col)} values"
                raise ValidationError(f"{what}[{j!r}]: {got} for {n} times")
        rows = [[_finite(c[k], f"{what}[{j!r}][{k}]") for j, c in zip(names, cols, strict=True)] for k in range(n)]
        return names, rows
    given: object = values
    if isinstance(given, str | bytes) or not isinstance(given, Sequence) or len(given) != n:
        got = "text" if isinstance(given, str | bytes) else f"{len(values)} rows"
        raise ValidationError(f"{what}: {got} for {n} times (one row per time)")
    out: list[list[float]] = []
    width = None
    for k, row in enumerate(values):
        if isinstance(row, int | float):
            row = [row]
        if width is None:
            width = len(row)
            if width == 0:
                raise ValidationError(f"{what}[0]: an empty row: give one value per joint")
        if len(row) != width:
            raise ValidationError(f"{what}[{k}]: {len(row)} values, but row 0 has {width} (one per joint)")
        out.append([_finite(v, f"{what}[{k}][{i}]") for i, v in enumerate(row)])
    return _joint_names(joints, width or 0, what), out


def per_joint(value: float | Sequence[float] | Mapping[str, float], joints: Sequence[str], what: str) -> list[float]:
    """A limit given for all joints (a number), per joint in order, or by name, as one value per joint (> 0)."""
    if isinstance(value, Mapping):
        missing = [j for j in joints if j not in value]
        if missing:
            raise ValidationError(f"{what}: no value for joint {missing[0]!r}")
        vals = [value[j] for j in joints]
    elif isinstance(value, int | float):
        vals = [value] * len(joints)
    else:
        vals = list(value)
        if len(vals) != len(joints):
            raise ValidationError(f"{what}: {len(vals)} values for {len(joints)} joints")
    out = []
    for j, v in zip(joints, vals, strict=True):
        x = _finite(v, f"{what}[{j!r}]")
        if x <= 0:
            raise ValidationError(f"{what}[{j!r}]={v!r}: expected > 0")
        out.append(x)
    return out


def _per_joint_any(
    value: float | Sequence[float] | Mapping[str, float], joints: Sequence[str], what: str
) -> list[float]:
    """One finite value per joint from a number, a sequence in joint order, or a mapping by name."""
    if isinstance(value, Mapping):
        missing = [j for j in joints if j not in value]
        if missing:
            raise ValidationError(f"{what}: no value for joint {missing[0]!r}")
        vals = [value[j] for j in joints]
    elif isinstance(value, int | float):
        vals = [value] * len(joints)
    else:
        vals = list(value)
        if len(vals) != len(joints):
            raise ValidationError(f"{what}: {len(vals)} values for {len(joints)} joints")
    return [_finite(v, f"{what}[{j!r}]") for j, v in zip(joints, vals, strict=True)]


def _spline_velocities(t: list[float], p: list[float]) -> list[float]:
    """Knot velocities of the C2 cubic spline through ``(t, p)`` with zero velocity at both ends."""
    n = len(t)
    v = [0.0] * n
    if n < 3:
        return v
    # interior rows: h[i] v[i-1] + 2 (h[i-1] + h[i]) v[i] + h[i-1] v[i+1] = rhs (Thomas algorithm)
    h = [t[i + 1] - t[i] for i in range(n - 1)]
    a, b, c, d = [], [], [], []
    for i in range(1, n - 1):
        a.append(h[i])
        b.append(2 * (h[i - 1] + h[i]))
        c.append(h[i - 1])
        d.append(3 * (h[i] * (p[i] - p[i - 1]) / h[i - 1] + h[i - 1] * (p[i + 1] - p[i]) / h[i]))
    m = len(b)
    for i in range(1, m):
        w = a[i] / b[i - 1]
        b[i] -= w * c[i - 1]
        d[i] -= w * d[i - 1]
    x = [0.0] * m
    x[-1] = d[-1] / b[-1]
    for i in range(m - 2, -1, -1):
        x[i] = (d[i] - c[i] * x[i + 1]) / b[i]
    v[1 : n - 1] = x
    return v


def _cubic(h: float, p0: float, p1: float, v0: float, v1: float, s: float) -> tuple[float, float, float]:
    """Cubic Hermite on a segment of ``h`` s at ``s`` s into it: position, velocity, acceleration."""
    dp = p1 - p0
    c2 = (3 * dp - (2 * v0 + v1) * h) / (h * h)
    c3 = (-2 * dp + (v0 + v1) * h) / (h * h * h)
    return p0 + s * (v0 + s * (c2 + s * c3)), v0 + s * (2 * c2 + 3 * c3 * s), 2 * c2 + 6 * c3 * s


def _quintic(
    h: float, p0: float, p1: float, v0: float, v1: float, a0: float, a1: float, s: float
) -> tuple[float, float, float]:
    """Quintic Hermite on a segment of ``h`` s at ``s`` s into it: position, velocity, acceleration."""
    dp = p1 - p0 - v0 * h - a0 * h * h / 2
    dv = v1 - v0 - a0 * h
    da = a1 - a0
    h2, h3 = h * h, h * h * h
    c3 = (10 * dp - 4 * dv * h + da * h2 / 2) / h3
    c4 = (-15 * dp + 7 * dv * h - da * h2) / (h3 * h)
    c5 = (6 * dp - 3 * dv * h + da * h2 / 2) / (h3 * h2)
    pos = p0 + s * (v0 + s * (a0 / 2 + s * (c3 + s * (c4 + s * c5))))
    vel = v0 + s * (a0 + s * (3 * c3 + s * (4 * c4 + s * 5 * c5)))
    acc = a0 + s * (6 * c3 + s * (12 * c4 + s * 20 * c5))
    return pos, vel, acc


class Trajectory:
    """Positions of several joints over time, interpolated between knots.

    ``times``: s from the start, strictly increasing from 0 (at least two). ``positions``: one row per
    time, one value per joint, or a mapping joint -> one value per time. ``velocities`` (/s) and
    ``accelerations`` (/s^2), if given, have the same shape; with accelerations the segments are
    quintic, else cubic. ``joints``: the names, in the order of the rows (default: a mapping's keys,
    else ``joint1``, ``joint2``...). Positions are in the units of whoever follows it: rad at a
    robot's joints, deg for a bus's motors.
    """

    __slots__ = ("accelerations", "joints", "positions", "times", "velocities")

    def __init__(
        self,
        times: Sequence[float],
        positions: Rows,
        velocities: Rows | None = None,
        accelerations: Rows | None = None,
        *,
        joints: Iterable[str] | None = None,
    ) -> None:
        if isinstance(times, str | bytes) or not isinstance(times, Sequence):
            raise ValidationError(f"times={times!r}: expected a sequence of s from 0")
        t = [_finite(x, f"times[{k}]") for k, x in enumerate(times)]
        if len(t) < 2:
            raise ValidationError(f"times: {len(t)} value(s): a trajectory needs at least 2 times")
        if t[0] != 0.0:
            raise ValidationError(f"times[0]={t[0]!r}: a trajectory starts at 0 s")
        for k in range(1, len(t)):
            if not t[k] > t[k - 1]:
                raise ValidationError(f"times[{k}]={t[k]!r}: must be above times[{k - 1}]={t[k - 1]!r} (increasing)")
            if t[k] - t[k - 1] < MIN_STEP:
                step = t[k] - t[k - 1]
                raise ValidationError(
                    f"times[{k}]={t[k]!r}: {step:g} s after times[{k - 1}]; the shortest step is {MIN_STEP:g} s"
                )
        names, pos = _rows(positions, joints, len(t), "positions")
        self.times: list[float] = t
        """Knot times (s from the start)."""
        self.joints: tuple[str, ...] = names
        """The joints' names, in the order of the rows."""
        self.positions: list[list[float]] = pos
        """One row per knot, one position per joint."""
        vel = None if velocities is None else _rows(velocities, names, len(t), "velocities")[1]
        acc = None if accelerations is None else _rows(accelerations, names, len(t), "accelerations")[1]
        for what, rows in (("velocities", vel), ("accelerations", acc)):
            if rows is not None and len(rows[0]) != len(names):
                raise ValidationError(f"{what}: {len(rows[0])} values per row for {len(names)} joints")
        if vel is None:
            cols = [_spline_velocities(t, [row[j] for row in pos]) for j in range(len(names))]
            vel = [[cols[j][k] for j in range(len(names))] for k in range(len(t))]
        self.velocities: list[list[float]] = vel
        """Knot velocities (given, or the spline's)."""
        self.accelerations: list[list[float]] | None = acc
        """Knot accelerations, when given (the segments are then quintic)."""

    # ------------------------------------------------------------------ evaluation

    @property
    def duration(self) -> float:
        """The time of the last knot (s)."""
        return self.times[-1]

    def sample(self, t: float) -> Sample:
        """Positions, velocities and accelerations at ``t`` s (held at the ends outside 0..duration)."""
        times = self.times
        held = t < 0.0 or t > times[-1]
        t = min(max(t, 0.0), times[-1])
        k = min(bisect.bisect_right(times, t) - 1, len(times) - 2)
        s, h = t - times[k], times[k + 1] - times[k]
        p0, p1 = self.positions[k], self.positions[k + 1]
        v0, v1 = self.velocities[k], self.velocities[k + 1]
        acc = self.accelerations
        out: tuple[list[float], list[float], list[float]] = ([], [], [])
        for j in range(len(self.joints)):
            if acc is None:
                r = _cubic(h, p0[j], p1[j], v0[j], v1[j], s)
            else:
                r = _quintic(h, p0[j], p1[j], v0[j], v1[j], acc[k][j], acc[k + 1][j], s)
            out[0].append(r[0])
            out[1].append(r[1])
            out[2].append(r[2])
        if held:
            zeros = [0.0] * len(out[0])
            return Sample(out[0], zeros, list(zeros))
        return Sample(*out)

    def peaks(self, step: float = 0.001) -> Peaks:
        """Each joint's largest speed and acceleration magnitude and its position extent, sampled every
        ``step`` s and at every knot."""
        n = len(self.joints)
        speed, accel = [0.0] * n, [0.0] * n
        low, high = [math.inf] * n, [-math.inf] * n
        count = max(1, math.ceil(self.duration / step))
        grid = sorted({*(self.duration * i / count for i in range(count + 1)), *self.times})
        for t in grid:
            s = self.sample(t)
            for j in range(n):
                speed[j] = max(speed[j], abs(s.velocities[j]))
                accel[j] = max(accel[j], abs(s.accelerations[j]))
                low[j] = min(low[j], s.positions[j])
                high[j] = max(high[j], s.positions[j])
        return Peaks(speed, accel, low, high)

    def scaled(self, speed: float) -> Trajectory:
        """The same path ``speed`` times as fast (``speed`` > 0; 0.5: twice as long)."""
        k = _finite(speed, "speed")
        if k <= 0:
            raise ValidationError(f"speed={speed!r}: expected > 0 (1 = as recorded, 0.5 = half as fast)")
        acc = None if self.accelerations is None else [[a * k * k for a in row] for row in self.accelerations]
        return Trajectory(
            [t / k for t in self.times],
            self.positions,
            [[v * k for v in row] for row in self.velocities],
            acc,
            joints=self.joints,
        )

    def select(self, joints: Sequence[str]) -> Trajectory:
        """The trajectory of ``joints`` (a subset, in that order)."""
        missing = [j for j in joints if j not in self.joints]
        if missing:
            raise ValidationError(f"joint {missing[0]!r}: not in the trajectory ({', '.join(self.joints)})")
        idx = [self.joints.index(j) for j in joints]

        def pick(rows: list[list[float]]) -> list[list[float]]:
            return [[row[i] for i in idx] for row in rows]

        acc = None if self.accelerations is None else pick(self.accelerations)
        return Trajectory(self.times, pick(self.positions), pick(self.velocities), acc, joints=joints)

    def __repr__(self) -> str:
        kind = "quintic" if self.accelerations is not None else "cubic"
        return f"<Trajectory {len(self.times)} knots, {self.duration:g} s, {kind}; joints {', '.join(self.joints)}>"

    # ------------------------------------------------------------------ excitation

    @classmethod
    def excitation(
        cls,
        joints: Sequence[str],
        seconds: float = 20.0,
        *,
        centre: float | Sequence[float] | Mapping[str, float] = 0.0,
        amplitude: float | Sequence[float] | Mapping[str, float] = 0.3,
        ramp: float = 1.0,
        limits: Mapping[str, Mapping[str, Any]] | None = None,
    ) -> Trajectory:
        """A safe excitation of ``joints`` for ``seconds`` s, for a recording to fit a twin to: per joint a
        multi-sine of four frequencies (different for each joint) around ``centre`` (rad) within
        +-``amplitude`` (rad), ramped in and out over ``ramp`` s, so it starts and ends at rest at the
        centre (see :mod:`drempower.motion.excitation`). ``centre`` and ``amplitude``: one value for all
        joints, one per joint in order, or by name. Refused (:class:`ValidationError`, naming the joint)
        when it would leave ``limits[joint]["position"]`` (low, high rad) or exceed
        ``limits[joint]["speed"]`` (rad/s), as :func:`drempower.motion.plan.robot_limits` gives them."""
        from .excitation import excitation_knots

        if isinstance(joints, str) or not joints:
            raise ValidationError(f"joints={joints!r}: expected a list of joint names")
        names = _joint_names(joints, len(joints), "joints")
        centres = _per_joint_any(centre, names, "centre")
        amps = per_joint(amplitude, names, "amplitude")
        t, p, v, a = excitation_knots(names, centres, amps, seconds, ramp=ramp, limits=limits)
        return cls(t, p, v, a, joints=names)

    # ------------------------------------------------------------------ time parameterisation

    @classmethod
    def from_waypoints(
        cls,
        waypoints: Rows,
        *,
        max_speed: float | Sequence[float] | Mapping[str, float],
        max_accel: float | Sequence[float] | Mapping[str, float],
        joints: Iterable[str] | None = None,
    ) -> Trajectory:
        """A trajectory through ``waypoints`` (rows of positions, or joint -> positions), stopping at each.

        Each segment is a synchronised trapezoid: every joint accelerates, cruises and decelerates in
        the same phases, the segment as short as the joints' ``max_speed`` (/s) and ``max_accel``
        (/s^2) allow (one value for all joints, one per joint, or by name). The result is exact: its
        knots are the phase boundaries, with their velocities.
        """
        if isinstance(waypoints, Mapping):
            first = next(iter(waypoints.values()), ())
            n = len(first) if isinstance(first, Sequence) else 0
        else:
            given: object = waypoints
            n = len(given) if isinstance(given, Sequence) and not isinstance(given, str) else 0
        if n < 2:
            raise ValidationError(f"waypoints: {n} given: a path needs at least 2")
        names, rows = _rows(waypoints, joints, n, "waypoints")
        vmax = per_joint(max_speed, names, "max_speed")
        amax = per_joint(max_accel, names, "max_accel")
        times, pos, vel = [0.0], [rows[0]], [[0.0] * len(names)]
        for k in range(1, n):
            p0, p1 = rows[k - 1], rows[k]
            d = [b - a for a, b in zip(p0, p1, strict=True)]
            c1 = max(abs(x) / v for x, v in zip(d, vmax, strict=True))
            c2 = max(abs(x) / a for x, a in zip(d, amax, strict=True))
            if c2 == 0.0:
                continue  # the same waypoint again
            # minimise T = c + ta with c >= c1 (speed), c * ta >= c2 (accel), ta <= c: c = T - ta
            if math.sqrt(c2) >= c1:
                c = ta = math.sqrt(c2)
            else:
                c, ta = c1, c2 / c1
            t0 = times[-1]
            peak = [x / c for x in d]
            if c - ta > 1e-12:
                for tk, frac in ((ta, ta / (2 * c)), (c, 1 - ta / (2 * c))):
                    times.append(t0 + tk)
                    pos.append([a + frac * x for a, x in zip(p0, d, strict=True)])
                    vel.append(list(peak))
            else:
                times.append(t0 + ta)
                pos.append([a + x / 2 for a, x in zip(p0, d, strict=True)])
                vel.append(list(peak))
            times.append(t0 + c + ta)
            pos.append(list(p1))
            vel.append([0.0] * len(names))
        if len(times) < 2:
            raise ValidationError("waypoints: every waypoint is the same: nothing to move")
        return cls(times, pos, vel, joints=names)

    # ------------------------------------------------------------------ files

    @classmethod
    def load(cls, path: str | os.PathLike[str], *, topic: str = "/joint_states") -> Trajectory:
        """Read a trajectory from ``path``: ``.csv``, ``.json`` or ``.mcap`` (its JointState ``topic``)."""
        p = os.fspath(path)
        ext = os.path.splitext(p)[1].lower()
        if ext not in (".csv", ".json", ".mcap"):
            raise ValidationError(f"{p}: unknown trajectory file type {ext or '(none)'!r}: .csv, .json or .mcap")
        if not os.path.isfile(p):
            raise ValidationError(f"cannot read {p}: no such file")  # the user's to fix: exit 2
        try:
            if ext == ".csv":
                return _read_csv(p)
            if ext == ".json":
                return _read_json(p)
            return _read_mcap(p, topic)
        except ValidationError as exc:
            raise ValidationError(f"{p}: {exc}") from None

    def save(self, path: str | os.PathLike[str], *, topic: str = "/joint_states") -> None:
        """Write the knots to ``path``: ``.csv``, ``.json`` or ``.mcap`` (JointState messages on ``topic``)."""
        p = os.fspath(path)
        ext = os.path.splitext(p)[1].lower()
        try:
            if ext == ".csv":
                _write_csv(self, p)
            elif ext == ".json":
                with open(p, "w", encoding="utf-8") as f:
                    json.dump(self.as_dict(), f, indent=1)
                    f.write("\n")
            elif ext == ".mcap":
                _write_mcap(self, p, topic)
            else:
                raise ValidationError(f"{p}: unknown trajectory file type {ext or '(none)'!r}: .csv, .json or .mcap")
        except OSError as exc:
            raise DrEmpowerError(f"cannot write {p}: {exc.strerror or exc}") from None

    def as_dict(self) -> dict[str, Any]:
        """The JSON form: ``joints``, ``t``, ``positions`` (rows), ``velocities``, ``accelerations`` if given."""
        out: dict[str, Any] = {
            "joints": list(self.joints),
            "t": self.times,
            "positions": self.positions,
            "velocities": self.velocities,
        }
        if self.accelerations is not None:
            out["accelerations"] = self.accelerations
        return out


def _write_csv(tr: Trajectory, path: str) -> None:
    head = ["t", *tr.joints, *(j + _VEL for j in tr.joints)]
    if tr.accelerations is not None:
        head += [j + _ACC for j in tr.joints]
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(head)
        for k, t in enumerate(tr.times):
            row = [t, *tr.positions[k], *tr.velocities[k]]
            if tr.accelerations is not None:
                row += tr.accelerations[k]
            w.writerow([repr(float(x)) for x in row])


def _read_csv(path: str) -> Trajectory:
    with open(path, newline="", encoding="utf-8-sig") as f:  # a byte-order mark (a spreadsheet's) is no header
        rows = list(csv.reader(f))
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        raise ValidationError("empty file: expected a header with a 't' column and one column per joint")
    head = [c.strip() for c in rows[0]]
    if "t" not in head:
        raise ValidationError(f"header {','.join(head)!r}: no 't' column (times in s from 0)")
    joints = [c for c in head if c != "t" and ":" not in c]
    if not joints:
        raise ValidationError("header: no joint column besides 't'")
    cols: dict[str, list[float]] = {c: [] for c in head}
    for line, r in enumerate(rows[1:], start=2):
        if len(r) != len(head):
            raise ValidationError(f"line {line}: {len(r)} values for {len(head)} columns")
        for c, x in zip(head, r, strict=True):
            try:
                cols[c].append(float(x))
            except ValueError:
                raise ValidationError(f"line {line}: {c}={x!r}: expected a number") from None
    vel = {j: cols[j + _VEL] for j in joints if j + _VEL in cols}
    acc = {j: cols[j + _ACC] for j in joints if j + _ACC in cols}
    return Trajectory(
        cols["t"],
        {j: cols[j] for j in joints},
        vel if len(vel) == len(joints) else None,
        acc if len(acc) == len(joints) else None,
        joints=joints,
    )


def _read_json(path: str) -> Trajectory:
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except json.JSONDecodeError as exc:
        raise ValidationError(f"not valid JSON: {exc}") from None
    if not isinstance(data, Mapping) or "t" not in data or "positions" not in data:
        raise ValidationError("expected an object with 't' (s) and 'positions' (rows), and 'joints' (names)")
    return Trajectory(
        data["t"], data["positions"], data.get("velocities"), data.get("accelerations"), joints=data.get("joints")
    )


def _write_mcap(tr: Trajectory, path: str, topic: str) -> None:
    from ..records import missing_extra
    from ..records.ros2_types import DEFINITIONS, JOINT_STATE

    try:
        from mcap_ros2.writer import Writer
    except ImportError:
        raise missing_extra("mcap-ros2-support") from None
    with open(path, "wb") as fh:
        writer = Writer(fh)
        schema = writer.register_msgdef(JOINT_STATE, DEFINITIONS[JOINT_STATE])
        for k, t in enumerate(tr.times):
            ns = round(t * 1e9)
            stamp = {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}
            msg = {
                "header": {"stamp": stamp, "frame_id": ""},
                "name": list(tr.joints),
                "position": tr.positions[k],
                "velocity": tr.velocities[k],
                "effort": [],
            }
            writer.write_message(topic, schema, msg, log_time=ns, publish_time=ns)
        writer.finish()  # type: ignore[no-untyped-call]


def _read_mcap(path: str, topic: str) -> Trajectory:
    """The JointState messages of ``topic``; joints sampled at the times of the first joint (others
    interpolated linearly when a recording stamps each joint apart), from its first time on."""
    from ..records import missing_extra

    try:
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory
    except ImportError:
        raise missing_extra("mcap-ros2-support") from None
    series: dict[str, tuple[list[float], list[float], list[float]]] = {}
    from mcap.exceptions import McapError

    with open(path, "rb") as fh:
        try:
            reader = make_reader(fh, decoder_factories=[DecoderFactory()])
            decoded = list(reader.iter_decoded_messages(topics=[topic]))
        except (McapError, ValueError, struct.error) as exc:
            why = str(exc) or "it ends early"
            raise ValidationError(f"not a readable MCAP file ({type(exc).__name__}: {why})") from None
        for _, _, message, msg in decoded:
            t = message.log_time / 1e9
            for i, name in enumerate(msg.name):
                ts, ps, vs = series.setdefault(name, ([], [], []))
                if ts and t <= ts[-1]:
                    continue
                ts.append(t)
                ps.append(float(msg.position[i]))
                vs.append(float(msg.velocity[i]) if i < len(msg.velocity) else math.nan)
    if not series:
        raise ValidationError(f"no JointState message on topic {topic!r}")
    joints = list(series)
    start = max(s[0][0] for s in series.values())
    end = min(s[0][-1] for s in series.values())
    grid = [t for t in series[joints[0]][0] if start <= t <= end]
    if len(grid) < 2:
        raise ValidationError(f"topic {topic!r}: the joints' recordings share fewer than 2 times")
    pos = {j: _resample(series[j][0], series[j][1], grid) for j in joints}
    vel = {j: _resample(series[j][0], series[j][2], grid) for j in joints}
    has_vel = all(math.isfinite(v) for vs in vel.values() for v in vs)
    return Trajectory([t - grid[0] for t in grid], pos, vel if has_vel else None, joints=joints)


def _resample(ts: list[float], xs: list[float], grid: list[float]) -> list[float]:
    out = []
    for t in grid:
        k = bisect.bisect_left(ts, t)
        if k < len(ts) and ts[k] == t:
            out.append(xs[k])
        else:
            t0, t1 = ts[k - 1], ts[k]
            out.append(xs[k - 1] + (xs[k] - xs[k - 1]) * (t - t0) / (t1 - t0))
    return out
