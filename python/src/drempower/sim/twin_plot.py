"""A self-contained HTML page (inline SVG, no script) of a recording against its replay on the twin."""

from __future__ import annotations

import html
import math
import os
from collections.abc import Sequence
from typing import Any

from ..errors import ValidationError
from .twin_replay import Recording, Trace

__all__ = ["write_plot"]

_W, _H, _PAD = 900, 160, 40
_SIGNALS = (
    ("q", "position", "deg", 180 / math.pi),
    ("v", "speed", "deg/s", 180 / math.pi),
    ("tau", "torque", "Nm", 1.0),
)


def _path(xs: Any, ys: Any, x0: float, x1: float, y0: float, y1: float) -> str:
    sx = (_W - 2 * _PAD) / ((x1 - x0) or 1.0)
    sy = (_H - 2 * _PAD) / ((y1 - y0) or 1.0)
    return " ".join(f"{_PAD + (x - x0) * sx:.1f},{_H - _PAD - (y - y0) * sy:.1f}" for x, y in zip(xs, ys, strict=True))


def _panel(title: str, unit: str, t_rec: Any, y_rec: Any, t_sim: Any, y_sim: Any) -> str:
    lo = float(min(y_rec.min(), y_sim.min())) if len(y_rec) else 0.0
    hi = float(max(y_rec.max(), y_sim.max())) if len(y_rec) else 1.0
    x1 = float(t_sim[-1]) if len(t_sim) else 1.0
    return (
        f'<svg width="{_W}" height="{_H}" viewBox="0 0 {_W} {_H}" role="img" aria-label="{html.escape(title)}">'
        f'<rect x="{_PAD}" y="{_PAD // 2}" width="{_W - 2 * _PAD}" height="{_H - 1.5 * _PAD}" '
        'fill="none" stroke="#ccc"/>'
        f'<text x="{_PAD}" y="14" font-size="12">{html.escape(title)} ({html.escape(unit)}): '
        f"{lo:.4g} .. {hi:.4g}; 0 .. {x1:.1f} s</text>"
        f'<polyline fill="none" stroke="#1f77b4" stroke-width="1" points="{_path(t_rec, y_rec, 0.0, x1, lo, hi)}"/>'
        f'<polyline fill="none" stroke="#d62728" stroke-width="1" points="{_path(t_sim, y_sim, 0.0, x1, lo, hi)}"/>'
        "</svg>"
    )


def write_plot(
    path: str | os.PathLike[str],
    recording: Recording,
    trace: Trace,
    joints: Sequence[str],
    delay: float,
    *,
    title: str = "robot and twin",
    points: int = 1500,
) -> None:
    """Write to ``path`` a page with, per joint, position, speed and torque of the robot (blue, the
    recording) and of the twin (red, its states ``delay`` s later), each drawn with at most ``points`` points."""
    import numpy as np

    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title></head><body style='font-family:sans-serif'>",
        f"<h1 style='font-size:16px'>{html.escape(title)}</h1>",
        "<p style='font-size:12px'><span style='color:#1f77b4'>robot (recorded)</span> · "
        f"<span style='color:#d62728'>twin (replayed, shifted {1000 * delay:.0f} ms)</span></p>",
    ]
    for j in joints:
        st = recording.states[j]
        step_r = max(1, len(st["t"]) // points)
        step_s = max(1, len(trace.t) // points)
        parts.append(f"<h2 style='font-size:14px'>{html.escape(j)}</h2>")
        for key, name, unit, scale in _SIGNALS:
            parts.append(
                _panel(
                    f"{j} {name}",
                    unit,
                    st["t"][::step_r],
                    np.asarray(st[key][::step_r]) * scale,
                    trace.t[::step_s] + delay,
                    np.asarray(getattr(trace, key)[j][::step_s]) * scale,
                )
            )
    parts.append("</body></html>\n")
    try:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write("".join(parts))
    except OSError as exc:
        raise ValidationError(f"--plot {os.fspath(path)}: {exc.strerror}") from None
