#!/usr/bin/env python3
"""Draw docs/img/motion-follow.svg: the twin arm following a 2 s, 6-joint trajectory (T mode, 200 Hz,
virtual clock), reference and measured positions of three joints, and the tracking error; and
docs/img/motion-tune.svg: the twin pendulum's 0.15 rad step with the factory gains and tuned for 1 Hz.

Usage: ``python3 tools/plot_follow.py [OUT_DIR]``. Needs MuJoCo (the ``physics`` extra). The SVG is
written by hand (no plotting library): polylines on a grid, a few hundred points per line.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python" / "src"))

import drempower  # noqa: E402
from drempower.motion import Trajectory  # noqa: E402

ARM = ROOT / "examples" / "robots" / "arm6.toml"
JOINTS = ("base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll")
SHOWN = (("base_yaw", "#1f77b4"), ("shoulder", "#d62728"), ("elbow", "#2ca02c"))
W, H, PAD = 640, 420, 48


def run() -> tuple[list[tuple[float, list[float], list[float]]], float]:
    with drempower.open_robot(ARM, sim={"clock": "virtual"}) as robot:
        st = robot.joint_states()
        start = [st[j].position for j in JOINTS]
        goal = [s + d for s, d in zip(start, (0.5, 0.3, -0.4, 0.6, 0.4, -0.6), strict=True)]
        tr = Trajectory.from_waypoints([start, goal, start], max_speed=1.0, max_accel=3.0, joints=JOINTS)
        report = robot.follow(tr.scaled(tr.duration / 2.0), rate=200.0, trace=True)
    assert report.trace is not None
    return report.trace, max(report.max_error.values())


def _poly(points: list[tuple[float, float]], colour: str, dash: str = "") -> str:
    d = " ".join(f"{x:.1f},{y:.1f}" for x, y in points)
    extra = f' stroke-dasharray="{dash}"' if dash else ""
    return f'<polyline fill="none" stroke="{colour}" stroke-width="1.5"{extra} points="{d}"/>'


def svg(trace: list[tuple[float, list[float], list[float]]], worst: float) -> str:
    top_h = (H - 3 * PAD) * 0.68
    bot_y = PAD * 2 + top_h
    bot_h = H - bot_y - PAD
    t_end = trace[-1][0]
    idx = [JOINTS.index(n) for n, _ in SHOWN]
    lo = min(min(r[j], m[j]) for _, r, m in trace for j in idx)
    hi = max(max(r[j], m[j]) for _, r, m in trace for j in idx)
    emax = max(abs(r[j] - m[j]) for _, r, m in trace for j in idx) * 1.1

    def x(t: float) -> float:
        return PAD + (W - 2 * PAD) * t / t_end

    def y(v: float) -> float:
        return PAD + top_h * (hi - v) / (hi - lo)

    def ye(e: float) -> float:
        return bot_y + bot_h * (1 - e / emax)

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" '
        'font-family="sans-serif" font-size="11">',
        f'<rect width="{W}" height="{H}" fill="white"/>',
        f'<text x="{PAD}" y="20" font-size="13">Twin arm, 6 joints, T mode at 200 Hz: reference (dashed) and '
        f"measured; largest error {worst:.4f} rad</text>",
    ]
    for y0, h in ((PAD, top_h), (bot_y, bot_h)):
        out.append(f'<rect x="{PAD}" y="{y0:.1f}" width="{W - 2 * PAD}" height="{h:.1f}" fill="none" stroke="#999"/>')
    for k in range(5):
        t = t_end * k / 4
        out.append(f'<text x="{x(t):.1f}" y="{H - PAD + 14}" text-anchor="middle">{t:.1f} s</text>')
    for v in (lo, (lo + hi) / 2, hi):
        out.append(f'<text x="{PAD - 4}" y="{y(v) + 4:.1f}" text-anchor="end">{v:.2f}</text>')
    out.append(f'<text x="{PAD - 4}" y="{ye(emax) + 10:.1f}" text-anchor="end">{emax:.3f}</text>')
    out.append(f'<text x="{PAD - 4}" y="{ye(0) + 4:.1f}" text-anchor="end">0</text>')
    out.append(f'<text x="{PAD + 4}" y="{bot_y + 12:.1f}">tracking error (rad)</text>')
    out.append(f'<text x="{PAD + 4}" y="{PAD + 12}">position (rad)</text>')
    step = max(1, len(trace) // 200)
    rows = [*trace[::step], trace[-1]]
    for k, (name, colour) in enumerate(SHOWN):
        j = JOINTS.index(name)
        out.append(_poly([(x(t), y(r[j])) for t, r, _ in rows], colour, "4 3"))
        out.append(_poly([(x(t), y(m[j])) for t, _, m in rows], colour))
        out.append(_poly([(x(t), ye(abs(r[j] - m[j]))) for t, r, m in rows], colour))
        out.append(f'<text x="{W - PAD - 80}" y="{PAD + 14 + 14 * k}" fill="{colour}">{name}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def steps() -> tuple[list[tuple[float, float]], list[tuple[float, float]], str]:
    """The pendulum's step with the factory gains and tuned for 1 Hz (virtual clock)."""
    import tempfile

    from drempower.motion.routines_sync import identify, step_response, tune
    from drempower.motion.tune import GAIN_NAMES

    with tempfile.TemporaryDirectory() as tmp:
        robot_file = Path(tmp) / "pendulum.toml"
        text = (ROOT / "examples" / "robots" / "pendulum.toml").read_text()
        text = text.replace('file = "pendulum.xml"', f'file = "{ROOT / "examples" / "robots" / "pendulum.xml"}"')
        robot_file.write_text(text.replace('interface = "sim"', 'interface = "sim"\nclock = "virtual"'))
        with drempower.open_robot(robot_file) as robot:
            joint = robot.joint("swing")
            for name, value in zip(GAIN_NAMES, (40.0, 0.06, 2.4), strict=True):
                joint.write_property(name, value)
            got = identify(robot, "swing")
            before: list[tuple[float, float]] = []
            after: list[tuple[float, float]] = []
            step_response(robot, "swing", 0.15, trace=before)
            report = tune(robot, "swing", 1.0, identified=got)
            step_response(robot, "swing", 0.15, trace=after)
    g = report.gains
    gains = f"pos_gain {g.pos_gain:.3g}, vel_gain {g.vel_gain:.3g}, vel_integrator_gain {g.vel_integrator_gain:.3g}"
    return before, after, gains


def step_svg(before: list[tuple[float, float]], after: list[tuple[float, float]], gains: str) -> str:
    t_end = max(before[-1][0], after[-1][0])
    values = [v for _, v in before + after]
    lo, hi = min(0.0, *values), max(1.2, *values)

    def x(t: float) -> float:
        return PAD + (W - 2 * PAD) * t / t_end

    def y(v: float) -> float:
        return PAD + (H - 2 * PAD) * (hi - v) / (hi - lo)

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" '
        'font-family="sans-serif" font-size="11">',
        f'<rect width="{W}" height="{H}" fill="white"/>',
        f'<text x="{PAD}" y="20" font-size="13">Twin pendulum (2 kg at 0.25 m), a 0.15 rad step: factory gains '
        "and tuned for 1 Hz</text>",
        f'<rect x="{PAD}" y="{PAD}" width="{W - 2 * PAD}" height="{H - 2 * PAD}" fill="none" stroke="#999"/>',
        f'<line x1="{PAD}" x2="{W - PAD}" y1="{y(1.0):.1f}" y2="{y(1.0):.1f}" stroke="#bbb" stroke-dasharray="4 3"/>',
    ]
    for k in range(4):
        t = t_end * k / 3
        out.append(f'<text x="{x(t):.1f}" y="{H - PAD + 14}" text-anchor="middle">{t:.1f} s</text>')
    for v in (lo, 0.0, 1.0, hi):
        out.append(f'<text x="{PAD - 4}" y="{y(v) + 4:.1f}" text-anchor="end">{v:.1f}</text>')
    lines = ((before, "#d62728", "factory gains", 0), (after, "#1f77b4", "tuned: " + gains, 1))
    for rows, colour, label, k in lines:
        step = max(1, len(rows) // 300)
        out.append(_poly([(x(t), y(v)) for t, v in rows[::step]], colour))
        out.append(f'<text x="{PAD + 8}" y="{PAD + 16 + 14 * k}" fill="{colour}">{label}</text>')
    out.append(f'<text x="{PAD + 8}" y="{H - PAD - 8}">fraction of the step</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main() -> None:
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img"
    target = folder / "motion-follow.svg"
    trace, worst = run()
    target.write_text(svg(trace, worst), encoding="utf-8")
    print(f"wrote {target}; largest error {worst:.4f} rad ({math.degrees(worst):.2f} deg)")
    before, after, gains = steps()
    target = folder / "motion-tune.svg"
    target.write_text(step_svg(before, after, gains), encoding="utf-8")
    print(f"wrote {target}")


if __name__ == "__main__":
    main()
