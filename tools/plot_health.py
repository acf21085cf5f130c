#!/usr/bin/env python3
"""Draw docs/img/health.svg: the twin pendulum held level for 15 simulated minutes, twice.

Without a supervisor the winding heats to the firmware's 95 degC, the effective
current limit derates, the arm sags to where the derated torque holds it. With the
supervisor (``on_overheat = "idle"``) the joint is warned about at 80 degC and
released at 90 degC, before the firmware derates or trips (100 degC), and cools.

Usage: ``python3 tools/plot_health.py [OUT_DIR]``. Needs MuJoCo (the ``physics`` extra); about a
minute of CPU (two runs of 900 s on the virtual clock). The SVG is written by hand (no plotting
library): polylines on a grid.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python" / "src"))

import drempower  # noqa: E402
from drempower.client.engine.effects import sleep  # noqa: E402
from drempower.client.engine.supervisor import HealthPolicy  # noqa: E402

PENDULUM = ROOT / "examples" / "robots" / "pendulum.toml"
SECONDS, STEP = 900.0, 2.0
W, H, PAD = 700, 460, 56
Row = tuple[float, float, float, float]
"""time s, winding degC, effective limit A, joint angle deg."""


def run(supervised: bool) -> tuple[list[Row], list[tuple[float, str]]]:
    rows: list[Row] = []
    marks: list[tuple[float, str]] = []
    with drempower.open_robot(PENDULUM, sim={"clock": "virtual"}) as robot:
        joint = robot.joint("swing")
        bus = robot.bus("can0")
        joint.set_position(math.radians(90.0))
        policy = HealthPolicy(period=STEP, on_overheat="idle")
        t = 0.0
        while t <= SECONDS:
            if supervised:
                for e in robot.supervise(policy):
                    if e.kind in ("hot", "overheat"):
                        marks.append((t, f"{e.kind}: {e.action}"))
            h = joint.health()
            rows.append((t, h.motor_temp_c, h.current_limit_a, math.degrees(joint.get_joint_state().position)))
            bus.run(sleep(STEP))
            t += STEP
    return rows, marks


def svg(free: list[Row], watched: list[Row], marks: list[tuple[float, str]]) -> str:
    top_h = (H - 3 * PAD) * 0.62
    bot_y = PAD * 2 + top_h
    bot_h = H - bot_y - PAD
    t_lo, t_hi = 20.0, 105.0

    def x(t: float) -> float:
        return PAD + (W - 2 * PAD) * t / SECONDS

    def yt(v: float) -> float:
        return PAD + top_h * (t_hi - v) / (t_hi - t_lo)

    def yl(v: float) -> float:
        return bot_y + bot_h * (16.0 - v) / 16.0

    def poly(pts: list[tuple[float, float]], colour: str, dash: str = "") -> str:
        d = " ".join(f"{a:.1f},{b:.1f}" for a, b in pts)
        extra = f' stroke-dasharray="{dash}"' if dash else ""
        return f'<polyline fill="none" stroke="{colour}" stroke-width="1.6"{extra} points="{d}"/>'

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" '
        'font-family="sans-serif" font-size="11">',
        f'<rect width="{W}" height="{H}" fill="white"/>',
        f'<text x="{PAD}" y="20" font-size="13">Twin pendulum held level (4.9 Nm): winding temperature and '
        "effective current limit</text>",
    ]
    for v, label, colour in ((80, "warn 80", "#999"), (90, "act 90", "#999"), (95, "derate 95", "#e08000"),
                             (100, "trip 100", "#c00")):  # fmt: skip
        out.append(f'<line x1="{PAD}" x2="{W - PAD}" y1="{yt(v):.1f}" y2="{yt(v):.1f}" stroke="{colour}" '
                   'stroke-dasharray="3,3"/>')  # fmt: skip
        nudge = {90: 10, 95: 5, 100: 0}.get(v, 4)
        out.append(f'<text x="{W - PAD + 3}" y="{yt(v) + nudge:.1f}" fill="{colour}">{label}</text>')
    for v in (20, 40, 60, 80, 100):
        out.append(f'<text x="{PAD - 6}" y="{yt(v) + 4:.1f}" text-anchor="end">{v}</text>')
    for v in (0, 5, 10, 15):
        out.append(f'<text x="{PAD - 6}" y="{yl(v) + 4:.1f}" text-anchor="end">{v}</text>')
    for t in range(0, int(SECONDS) + 1, 150):
        out.append(f'<text x="{x(t):.1f}" y="{H - PAD + 16}" text-anchor="middle">{t}</text>')
    out += [
        f'<rect x="{PAD}" y="{PAD}" width="{W - 2 * PAD}" height="{top_h:.1f}" fill="none" stroke="#333"/>',
        f'<rect x="{PAD}" y="{bot_y:.1f}" width="{W - 2 * PAD}" height="{bot_h:.1f}" fill="none" stroke="#333"/>',
        f'<text x="{PAD + 4}" y="{PAD - 6}">winding / degC</text>',
        f'<text x="{PAD + 4}" y="{bot_y - 6:.1f}">effective current limit / A</text>',
        f'<text x="{W / 2:.0f}" y="{H - 12}" text-anchor="middle">simulated time / s</text>',
        poly([(x(r[0]), yt(r[1])) for r in free], "#d62728"),
        poly([(x(r[0]), yt(r[1])) for r in watched], "#1f77b4"),
        poly([(x(r[0]), yl(r[2])) for r in free], "#d62728"),
        poly([(x(r[0]), yl(r[2])) for r in watched], "#1f77b4", "5,3"),
    ]
    for t, label in marks:
        out.append(f'<line x1="{x(t):.1f}" x2="{x(t):.1f}" y1="{PAD}" y2="{PAD + top_h:.1f}" stroke="#1f77b4" '
                   'stroke-width="0.6"/>')  # fmt: skip
        out.append(f'<text x="{x(t) - 4:.1f}" y="{yt(50):.1f}" fill="#1f77b4" text-anchor="end">{label}</text>')
    sag = free[-1][3]
    out += [
        f'<text x="{x(400):.1f}" y="{yt(31):.1f}" fill="#d62728">no supervisor: derated from 95 degC, '
        f"the arm sagged to {sag:.0f} deg</text>",
        f'<text x="{x(400):.1f}" y="{yt(25):.1f}" fill="#1f77b4">on_overheat = "idle": warned at 80, '
        "released at 90 degC</text>",
        "</svg>",
    ]
    return "\n".join(out) + "\n"


def main() -> None:
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img"
    free, _ = run(False)
    watched, marks = run(True)
    target = folder / "health.svg"
    target.write_text(svg(free, watched, marks), encoding="utf-8")
    peak = max(r[1] for r in watched)
    print(
        f"wrote {target}: unsupervised peak {max(r[1] for r in free):.1f} degC, lowest limit "
        f"{min(r[2] for r in free):.2f} A, final angle {free[-1][3]:.1f} deg; supervised peak {peak:.1f} degC, "
        f"events {marks}"
    )


if __name__ == "__main__":
    main()
