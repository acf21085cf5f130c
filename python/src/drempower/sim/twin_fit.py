"""Fitting the twin to recordings of the robot: every joint's ``armature``, ``damping`` and ``frictionloss``.

The method: output-error least squares on the whole multibody model. For a guess of the parameters
(the totals at each joint, the motor's share included), every recording is replayed on the twin
(:class:`~drempower.sim.twin_replay.Replay`: the recorded commands sent to the simulated motors at
their recorded times, MuJoCo integrating the arm with its gravity and the coupling between joints),
and the differences between the twin's and the recorded position, speed and torque of every joint,
each divided by its size under the robot file's own parameters, are the residuals. scipy's
``least_squares`` (trust-region reflective, a forward-difference Jacobian) minimises their sum of
squares over the logarithms of the parameters (so they stay positive and scale alike) and the
recording's transport delay (the twin's states are compared that long before their recorded time).

Before anything is fitted each fitted joint's motion is checked: a parameter the recording does not
excite (a joint that barely moves, never reverses, or never accelerates) is refused by name. After the
fit, each parameter's relative standard error is estimated from the final Jacobian (the covariance
``s^2 (J^T J)^-1`` of the logarithms, ``s^2`` the residual variance): a parameter whose effect on the
residuals is too small against the noise, or too like another parameter's (the delay's, a neighbour's),
to be told within :data:`MAX_REL_ERROR` is refused by name rather than reported as fitted; so is one the
fit drove to its bound. ``fixed`` keeps such a parameter at the robot file's value and fits the rest.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError, ValidationError
from .twin_replay import PARAMETERS, Recording, Replay, Trace, compare, windowed

if TYPE_CHECKING:
    from ..robotfile import RobotSpec

__all__ = [
    "MAX_REL_ERROR",
    "TIMING",
    "FitResult",
    "best_delay",
    "check_excited",
    "fit_twin",
    "relative_errors",
    "timing_shifts",
    "write_fitted",
]

MIN_SPEED = 0.1
"""rad/s: a joint whose peak recorded speed is below this excites none of its parameters."""
MIN_MOVING = 0.2
"""Share of the samples a joint must move faster than :data:`MIN_SPEED`/2 for its friction loss."""
MIN_ACCEL = 0.5
"""rad/s^2: the RMS acceleration a joint needs for its armature."""
MIN_SPEED_SPREAD = 0.05
"""rad/s: the spread (standard deviation) of the moving speed a joint needs for its damping (else it
cannot be told apart from friction loss)."""
_FLOOR = {"armature": 1e-4, "damping": 1e-3, "frictionloss": 1e-3}
"""The smallest starting value of a parameter (a nominal 0 has no logarithm)."""
_SPAN = math.log(50.0)
"""The fit keeps each parameter within a factor 50 of its start."""
_DELAY_UNIT = 0.01
"""s per unit of the delay variable."""
MAX_REL_ERROR = 0.2
"""The largest uncertainty (relative) of a parameter reported as fitted: its standard error from the final
Jacobian together with how far a :data:`TIMING` error of the recording's time base would move it."""
TIMING = 0.001
"""s: the error of a recording's time base the fit allows for: the replay's step (the twin integrates 1 ms
at a time, its commands take effect on that grid, and the recorded stamps are good to about as much)."""


@dataclass
class FitResult:
    """What :func:`fit_twin` found: per joint the fitted and nominal ``armature``, ``damping``,
    ``frictionloss``; the RMS position error (deg) per joint with both; the transport ``delay`` (s);
    the replays run, and the time taken (s, wall and CPU)."""

    joints: dict[str, dict[str, float]]
    nominal: dict[str, dict[str, float]]
    uncertainty: dict[str, dict[str, float]]
    """Per joint and fitted parameter: its relative uncertainty (0.05 = 5 %): the standard error (1 sigma)
    and the ``timing`` shift together (root sum of squares)."""
    timing: dict[str, dict[str, float]]
    """Per joint and fitted parameter: how much (relative) it moves per :data:`TIMING` of error in the
    recording's time base (the fitted delay moved, the other parameters fitted again)."""
    rms_deg: dict[str, float]
    rms_deg_nominal: dict[str, float]
    delay: float
    evaluations: int
    seconds: float
    cpu_seconds: float
    recordings: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """The JSON form (``joints``, ``rms_deg``, ...)."""
        return {
            "joints": self.joints,
            "rms_deg": self.rms_deg,
            "rms_deg_nominal": self.rms_deg_nominal,
            "nominal": self.nominal,
            "uncertainty": self.uncertainty,
            "timing": self.timing,
            "delay_s": self.delay,
            "evaluations": self.evaluations,
            "seconds": self.seconds,
            "cpu_seconds": self.cpu_seconds,
            "recordings": self.recordings,
        }


def check_excited(recording: Recording, joint: str) -> None:
    """Refuse (:class:`ValidationError`, one line naming the joint and the parameter) a recording in
    which ``joint``'s motion cannot tell its armature, damping or friction loss."""
    import numpy as np

    st = recording.states[joint]
    t, v = st["t"], st["v"]
    where = f"{recording.path}: joint {joint!r}"
    peak = float(np.max(np.abs(v))) if len(v) else 0.0
    if peak < MIN_SPEED:
        raise ValidationError(
            f"{where}: the recording does not excite its frictionloss (peak speed {peak:.3g} rad/s, needs "
            f">= {MIN_SPEED:g}); record an excitation (drempower play --excite) or leave it out with --joints"
        )
    moving = np.abs(v) > MIN_SPEED / 2
    if moving.mean() < MIN_MOVING or not (np.any(v > MIN_SPEED / 2) and np.any(v < -MIN_SPEED / 2)):
        raise ValidationError(
            f"{where}: the recording does not excite its frictionloss (moving {100 * moving.mean():.0f} % of the "
            f"time, both ways needed, >= {100 * MIN_MOVING:.0f} %); record an excitation or leave it out with --joints"
        )
    spread = float(np.std(np.abs(v[moving])))
    if spread < MIN_SPEED_SPREAD:
        raise ValidationError(
            f"{where}: the recording does not excite its damping (the moving speed varies by {spread:.3g} rad/s, "
            f"needs >= {MIN_SPEED_SPREAD:g}); record an excitation or leave it out with --joints"
        )
    # the acceleration over 20 ms windows: the derivative of the speed, smoothed against sensor noise
    grid = np.arange(t[0], t[-1], 0.02)
    acc = np.diff(np.interp(grid, t, v)) / 0.02 if len(grid) > 2 else np.zeros(1)
    rms = float(np.sqrt(np.mean(acc * acc)))
    if rms < MIN_ACCEL:
        raise ValidationError(
            f"{where}: the recording does not excite its armature (RMS acceleration {rms:.3g} rad/s^2, needs "
            f">= {MIN_ACCEL:g}); record an excitation or leave it out with --joints"
        )


def _residuals(
    np: Any, rec: Recording, trace: Trace, joints: Sequence[str], delay: float, scale: dict[tuple[str, str], float]
) -> Any:
    out = []
    for j in joints:
        for key in ("q", "v", "tau"):
            r, sim = windowed(rec, trace, j, key, delay)
            out.append((sim - r) / scale[(j, key)] / math.sqrt(max(1, len(r))))
    return np.concatenate(out)


def fit_twin(
    spec: RobotSpec,
    recordings: Sequence[Recording],
    joints: Sequence[str] | None = None,
    *,
    delay: float | None = None,
    fixed: Sequence[str] = (),
    max_evaluations: int = 40,
    max_rel_error: float = MAX_REL_ERROR,
    progress: Any = None,
) -> FitResult:
    """Fit ``joints`` (default: every joint of the recordings' buses) of the robot ``spec`` to
    ``recordings`` (see the module docstring). ``delay``: the transport delay (s) if known, else fitted.
    ``fixed``: parameters (``"JOINT.PARAMETER"``) kept at the robot file's values. A parameter whose
    relative standard error exceeds ``max_rel_error`` is refused (:class:`ValidationError` naming the
    joint and the parameter). ``progress(evaluations, cost)`` is called after each replay. Needs the
    ``fit`` extra (scipy)."""
    try:
        import numpy as np
        from scipy.optimize import least_squares
    except ImportError:
        raise ConfigError("twin fit needs the fit extra: pip install 'drempower[fit]' (scipy)") from None
    if not recordings:
        raise ValidationError("no recording to fit to")
    started, cpu = time.monotonic(), time.process_time()
    replays = [Replay(spec, rec) for rec in recordings]
    every = replays[0].joints
    names = list(every) if joints is None else list(joints)
    for j in names:
        if j not in every:
            raise ValidationError(f"joint {j!r}: not a joint of the recording ({', '.join(every)})")
    if not names:
        raise ValidationError("joints: none to fit")
    kept = set()
    for item in fixed:
        joint, _, param = item.partition(".")
        if joint not in names or param not in PARAMETERS:
            raise ValidationError(
                f"fixed {item!r}: expected JOINT.PARAMETER of a fitted joint ({', '.join(names)}) and one of "
                f"{', '.join(PARAMETERS)}"
            )
        kept.add((joint, param))
    if not 0 < max_rel_error < math.inf:
        raise ValidationError(f"max_rel_error={max_rel_error!r}: expected a relative error > 0, e.g. 0.05")
    free = [(j, p) for j in names for p in PARAMETERS if (j, p) not in kept]
    if not free:
        raise ValidationError("fixed: every parameter is fixed: nothing to fit")
    for rec in recordings:
        for j in names:
            check_excited(rec, j)
    nominal = replays[0].nominal
    start = {j: {p: max(nominal[j][p], _FLOOR[p]) for p in PARAMETERS} for j in names}
    fit_delay = delay is None
    cache: dict[tuple[float, ...], list[Trace]] = {}
    evaluations = 0

    def physical(x: Any) -> dict[str, dict[str, float]]:
        out = {j: {p: nominal[j][p] for p in PARAMETERS} for j in names}
        for i, (j, p) in enumerate(free):
            out[j][p] = start[j][p] * math.exp(float(x[i]))
        return out

    def traces(params: dict[str, dict[str, float]]) -> list[Trace]:
        nonlocal evaluations
        key = tuple(v for j in names for v in params[j].values())
        got = cache.get(key)
        if got is None:
            got = [rp.run(params) for rp in replays]
            evaluations += 1
            cache.clear()
            cache[key] = got
        return got

    # each signal's size under the nominal parameters (at the best delay of a coarse search) weighs it
    base = [rp.run(None) for rp in replays]
    d0 = delay if delay is not None else best_delay(recordings, base, every)
    scale: dict[tuple[str, str], float] = {}
    for j in every:
        scale.update(_sizes(np, recordings, base, j, d0))

    def fun(x: Any) -> Any:
        params = physical(x)
        d = float(x[-1]) * _DELAY_UNIT if fit_delay else float(d0)
        trs = traces(params)
        res = np.concatenate(
            [_residuals(np, rec, tr, every, d, scale) for rec, tr in zip(recordings, trs, strict=True)]
        )
        if progress is not None:
            progress(evaluations, float(res @ res))
        return res

    n = len(free)
    x0 = np.zeros(n + (1 if fit_delay else 0))
    lo = np.full_like(x0, -_SPAN)
    hi = np.full_like(x0, _SPAN)
    if fit_delay:
        x0[-1] = d0 / _DELAY_UNIT
        lo[-1], hi[-1] = 0.0, 0.1 / _DELAY_UNIT
    sol = least_squares(
        fun,
        x0,
        bounds=(lo, hi),
        diff_step=0.02,
        x_scale="jac",
        max_nfev=max_evaluations,
        method="trf",
        ftol=1e-4,
        xtol=1e-4,
        gtol=1e-6,
    )
    fitted = physical(sol.x)
    d_fit = float(sol.x[-1]) * _DELAY_UNIT if fit_delay else float(d0)
    se = relative_errors(np, sol.jac, sol.fun)
    shift = timing_shifts(np, sol.jac) * (TIMING / _DELAY_UNIT) if fit_delay else np.zeros(len(sol.x))
    rel = np.sqrt(se * se + shift * shift)
    uncertainty: dict[str, dict[str, float]] = {j: {} for j in names}
    timing: dict[str, dict[str, float]] = {j: {} for j in names}
    for i, (j, p) in enumerate(free):
        uncertainty[j][p] = float(rel[i])
        timing[j][p] = float(shift[i])
    refused = _refused(sol.x, rel, free, max_rel_error)
    if refused:
        i, (j, p) = refused[0]
        paths = ", ".join(rec.path for rec in recordings)
        why = (
            f"the fit ran to its bound, {fitted[j][p]:.3g}, a factor 50 from {start[j][p]:.3g}"
            if math.isfinite(rel[i]) and rel[i] <= max_rel_error
            else (
                f"uncertain by {100 * rel[i]:.0f} %: standard error {100 * se[i]:.0f} %, {100 * abs(shift[i]):.0f} % "
                f"per ms of timing error; needs <= {100 * max_rel_error:g} %"
            )
        )
        also = "".join(f"; also {jj}'s {pp} ({100 * rel[k]:.0f} %)" for k, (jj, pp) in refused[1:])
        raise ValidationError(
            f"{paths}: joint {j!r}: the recording does not excite its {p} enough to fit it ({why}{also}); record "
            "an excitation that moves it more (drempower play --excite with a lower --kd) or keep the robot "
            f"file's value with --fixed {','.join(f'{jj}.{pp}' for _, (jj, pp) in refused)}"
        )
    final = traces(fitted)
    rms = _rms(recordings, final, every, d_fit)
    rms_nominal = _rms(recordings, base, every, d_fit)
    return FitResult(
        {j: fitted[j] for j in names},
        {j: nominal[j] for j in names},
        uncertainty,
        timing,
        rms,
        rms_nominal,
        d_fit,
        evaluations,
        time.monotonic() - started,
        time.process_time() - cpu,
        [rec.path for rec in recordings],
    )


def _refused(x: Any, rel: Any, free: Sequence[tuple[str, str]], top: float) -> list[tuple[int, tuple[str, str]]]:
    """The fitted parameters (index, (joint, parameter)) not told well enough: relative error beyond
    ``top``, or at the fit's bound; the worst first."""
    out = [(i, jp) for i, jp in enumerate(free) if not float(rel[i]) <= top or abs(float(x[i])) > _SPAN - 1e-3]
    return sorted(out, key=lambda item: -float(rel[item[0]]) if math.isfinite(rel[item[0]]) else -math.inf)


def timing_shifts(np: Any, jac: Any) -> Any:
    """Per variable: how much it moves per unit of the last one (the delay) when that is moved and the others
    are fitted again, from the Jacobian ``jac`` at the optimum: ``cov[i, last] / cov[last, last]`` of
    ``(J^T J)^-1`` (a regression of each variable on the delay; 0 for the delay itself is not returned:
    its own entry is 1). Large for a parameter that the delay mimics (a light joint's damping)."""
    j = np.asarray(jac, dtype=float)
    norms = np.linalg.norm(j, axis=0)
    if norms[-1] == 0:
        return np.zeros(j.shape[1])
    safe = np.where(norms > 0, norms, 1.0)
    cov = np.linalg.pinv((j / safe).T @ (j / safe)) / np.outer(safe, safe)
    return cov[:, -1] / cov[-1, -1]


def relative_errors(np: Any, jac: Any, residuals: Any) -> Any:
    """Each variable's standard error (1 sigma) from the Jacobian ``jac`` of ``residuals`` at the optimum:
    the square roots of the diagonal of ``s^2 (J^T J)^-1``, ``s^2`` the residuals' variance (sum of
    squares over the degrees of freedom), times ``(1 + rho) / (1 - rho)`` for residuals that follow each
    other (``rho`` their correlation with the next: what the model leaves out is slow, and n such
    residuals tell less than n independent ones). For a logarithm, its relative error; inf for a
    variable the residuals do not depend on, or depend on only as some others together do."""
    j = np.asarray(jac, dtype=float)
    r = np.asarray(residuals, dtype=float)
    m, n = j.shape
    s2 = float(r @ r) / max(1, m - n)
    if m > 2 and s2 > 0:
        rho = min(max(float(r[1:] @ r[:-1]) / float(r @ r), 0.0), 0.99)
        s2 *= (1 + rho) / (1 - rho)
    norms = np.linalg.norm(j, axis=0)
    out = np.full(n, np.inf)
    live = norms > 0
    if not live.any():
        return out
    js = j[:, live] / norms[live]  # unit columns: the conditioning is of the directions, not the scales
    _u, sv, vt = np.linalg.svd(js, full_matrices=False)
    tiny = sv <= sv[0] * 1e-10
    inv = np.where(tiny, 0.0, 1.0 / np.where(tiny, 1.0, sv) ** 2)
    cov = (vt.T * inv) @ vt * s2
    se = np.sqrt(np.diag(cov)) / norms[live]
    degenerate = np.abs(vt[tiny]).max(axis=0) > 1e-6 if tiny.any() else np.zeros(len(se), dtype=bool)
    se[degenerate] = np.inf
    out[live] = se
    return out


def _sizes(
    np: Any, recordings: Sequence[Recording], traces: Sequence[Trace], j: str, delay: float
) -> dict[tuple[str, str], float]:
    """Each of joint ``j``'s signals' RMS residual under ``traces`` (a floor keeps a perfect one finite)."""
    floors = {"q": math.radians(0.01), "v": math.radians(0.5), "tau": 0.005}
    out = {}
    for key in ("q", "v", "tau"):
        e = np.concatenate(
            [np.subtract(*windowed(rec, tr, j, key, delay)) for rec, tr in zip(recordings, traces, strict=True)]
        )
        out[(j, key)] = max(float(np.sqrt(np.mean(e * e))) if len(e) else 0.0, floors[key])
    return out


def best_delay(recordings: Sequence[Recording], traces: Sequence[Trace], joints: Sequence[str]) -> float:
    """The transport delay (s, 0..30 ms by 1 ms) that makes ``traces`` closest to the recorded positions."""
    best, best_err = 0.0, math.inf
    for k in range(31):
        d = k * 0.001
        err = sum(
            compare(rec, tr, joints, d)[j]["rms_deg"] ** 2
            for rec, tr in zip(recordings, traces, strict=True)
            for j in joints
        )
        if err < best_err:
            best, best_err = d, err
    return best


def _rms(
    recordings: Sequence[Recording], traces: Sequence[Trace], joints: Sequence[str], delay: float
) -> dict[str, float]:
    """Per joint the RMS position error (deg) over all ``recordings``."""
    total: dict[str, list[float]] = {j: [0.0, 0.0] for j in joints}
    for rec, tr in zip(recordings, traces, strict=True):
        for j, row in compare(rec, tr, joints, delay).items():
            total[j][0] += row["rms_deg"] ** 2 * row["windows"]
            total[j][1] += row["windows"]
    return {j: math.sqrt(s / n) if n else math.nan for j, (s, n) in total.items()}


def write_fitted(
    spec: RobotSpec, fitted: dict[str, dict[str, float]], out: str | os.PathLike[str]
) -> tuple[Path, Path]:
    """Write the robot file ``out`` (TOML) and beside it a copy of the model (``<out stem>.xml``) whose
    joints have the ``fitted`` totals; the fitted joints get ``friction = "model"`` (the motor's share
    is in the fitted values). Returns both paths."""
    import xml.etree.ElementTree as ET

    if spec.model is None:
        raise ConfigError(f"{spec.source}: no [model]: nothing to write the fit into")
    target = Path(out)
    if target.suffix != ".toml":
        raise ValidationError(f"--write {out}: expected a robot file name ending in .toml")
    model_out = target.with_suffix(".xml")
    src = Path(spec.model.file)
    try:
        tree = ET.parse(src)
    except (OSError, ET.ParseError) as exc:
        raise ConfigError(f"model {src}: {exc} (the fit is written into a copy of an MJCF model)") from None
    root = tree.getroot()
    for inc in root.iter("include"):  # keep includes working from the copy's folder
        inc.set("file", str((src.parent / inc.get("file", "")).resolve()))
    for comp in root.iter("compiler"):
        for attr in ("meshdir", "texturedir", "assetdir"):
            if comp.get(attr) is not None:
                comp.set(attr, str((src.parent / comp.get(attr, "")).resolve()))
    elems = {j.get("name"): j for j in root.iter("joint") if j.get("name")}
    for joint, values in fitted.items():
        mj = spec.joints[joint].model_joint or joint
        el = elems.get(mj)
        if el is None:
            raise ConfigError(f"model {src}: no <joint name={mj!r}>")
        for p in PARAMETERS:
            el.set(p, f"{values[p]:.6g}")
    target.parent.mkdir(parents=True, exist_ok=True)
    tree.write(model_out, encoding="unicode", xml_declaration=False)
    target.write_text(_robot_text(spec, fitted, model_out.name), encoding="utf-8")
    return target, model_out


def _robot_text(spec: RobotSpec, fitted: dict[str, dict[str, float]], model: str) -> str:
    """The robot file ``spec`` as TOML, with ``model`` as its model and the fitted joints' friction "model"."""
    import json

    def value(v: Any) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, int | float):
            return repr(v)
        if isinstance(v, list | tuple):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return json.dumps(str(v))

    def key(k: str) -> str:
        return k if k.replace("_", "").replace("-", "").isalnum() else json.dumps(k)

    lines = [
        f"# The twin of {Path(spec.source).name}, fitted to recordings by drempower twin fit:",
        "# the model copy has each fitted joint's armature, damping and frictionloss (the motor's share included).",
        "[model]",
        f"file = {value(model)}",
    ]
    if spec.model is not None and spec.model.on_divergence is not None:
        lines.append(f"on_divergence = {value(spec.model.on_divergence)}")
    for b in spec.buses.values():
        lines += ["", f"[buses.{key(b.name)}]", f"interface = {value(b.interface)}"]
        lines += [f"{key(k)} = {value(v)}" for k, v in b.options.items()]
    for j in spec.joints.values():
        lines += ["", f"[joints.{key(j.name)}]", f"bus = {value(j.bus)}", f"id = {j.id}"]
        if j.gear != 1.0:
            lines.append(f"gear = {j.gear!r}")
        if j.offset != 0.0:
            lines.append(f"offset = {j.offset!r}")
        if j.model_joint:
            lines.append(f"model_joint = {value(j.model_joint)}")
        friction = "model" if j.name in fitted else j.friction
        if friction != "motor":
            lines.append(f"friction = {value(friction)}")
        if j.on_timeout != "hold":
            lines.append(f"on_timeout = {value(j.on_timeout)}")
        for k in ("on_overheat", "on_divergence"):
            if getattr(j, k) is not None:
                lines.append(f"{k} = {value(getattr(j, k))}")
        if j.limits:
            lines.append(f"[joints.{key(j.name)}.limits]")
            lines += [f"{key(k)} = {value(v)}" for k, v in j.limits.items()]
        if j.sim_params:
            lines.append(f"[joints.{key(j.name)}.sim_params]")
            lines += [f"{key(k)} = {value(v)}" for k, v in j.sim_params.items()]
        if j.identified and j.name not in fitted:
            lines.append(f"[joints.{key(j.name)}.identified]")
            lines += [f"{key(k)} = {value(v)}" for k, v in j.identified.items()]
    return "\n".join(lines) + "\n"
