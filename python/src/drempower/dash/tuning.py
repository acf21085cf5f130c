"""Step-response figures: rise time, overshoot, settling time and steady-state error."""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["step_figures"]


def step_figures(
    t: Sequence[float], y: Sequence[float], base: float, target: float, settle_band: float = 0.02
) -> dict[str, float | None]:
    """Figures of a step from ``base`` to ``target`` sampled as ``y`` at times ``t`` (s from the step).

    ``rise_s``: 10 % to 90 % of the step; ``overshoot_pct``: furthest excursion past the
    target, % of the step; ``settling_s``: last time ``y`` was outside ``settle_band`` (a
    fraction of the step) around the target; ``steady_error``: target minus the mean of the
    last 10 % of the samples. A figure that the samples do not show is None.
    """
    step = target - base
    out: dict[str, float | None] = {"rise_s": None, "overshoot_pct": None, "settling_s": None, "steady_error": None}
    if not t or step == 0 or len(t) != len(y):
        return out
    frac = [(v - base) / step for v in y]
    t10 = next((tt for tt, f in zip(t, frac, strict=True) if f >= 0.1), None)
    t90 = next((tt for tt, f in zip(t, frac, strict=True) if f >= 0.9), None)
    if t10 is not None and t90 is not None:
        out["rise_s"] = t90 - t10
    out["overshoot_pct"] = max(0.0, (max(frac) - 1.0) * 100.0)
    outside = [tt for tt, f in zip(t, frac, strict=True) if abs(f - 1.0) > settle_band]
    if not outside:
        out["settling_s"] = 0.0
    elif outside[-1] < t[-1]:
        out["settling_s"] = outside[-1]
    tail = y[len(y) - max(1, len(y) // 10) :]
    out["steady_error"] = target - sum(tail) / len(tail)
    return out
