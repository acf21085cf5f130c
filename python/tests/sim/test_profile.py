"""The Q-mode profile planner: end points, limits, continuity, and the host library's move times."""

from __future__ import annotations

import math

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from drempower.sim.behaviour import target_time_profile
from drempower.sim.profile import plan

positions = st.floats(-100.0, 100.0)
speeds = st.floats(0.1, 50.0)
accels = st.floats(0.5, 500.0)


@given(positions, st.floats(-20.0, 20.0), positions, speeds, accels, st.booleans())
@example(0.0, 1.75, 1.75, 0.1, 1.75, True)  # stops exactly on target from above vmax
def test_profile_ends_at_rest_on_target_and_is_continuous(
    x0: float, v0: float, x1: float, vmax: float, accel: float, s_curve: bool
) -> None:
    p = plan(x0, v0, x1, vmax, accel, s_curve)
    assert p.sample(0.0)[0] == pytest.approx(x0, abs=1e-9)
    assert p.sample(0.0)[1] == pytest.approx(v0, abs=1e-9)
    end = p.sample(p.duration - 1e-9)
    assert end[0] == pytest.approx(x1, abs=1e-6)
    assert end[1] == pytest.approx(0.0, abs=1e-5)
    assert p.sample(p.duration + 1.0) == (x1, 0.0, 0.0)
    n = 200
    prev = p.sample(0.0)
    for k in range(1, n + 1):
        cur = p.sample(p.duration * k / n)
        dt = p.duration / n
        assert abs(cur[0] - prev[0]) <= (max(abs(v0), vmax) + 1e-6) * dt * 1.0001 + 1e-9
        assert abs(cur[2]) <= accel * 1.0001 + 1e-9
        prev = cur


@given(st.floats(0.1, 1000.0), st.floats(0.5, 200.0), st.floats(1.0, 300.0), st.booleans())
def test_move_time_matches_the_host_library(d: float, v: float, a: float, s_curve: bool) -> None:
    """PROTOCOL.md 3.4.3, in deg, r/min and (r/min)/s: 1 r/min = 6 deg/s."""
    if s_curve:
        t = 4 * math.sqrt(a * d / 12) / a if d <= 12 * v * v / a else d / (6 * v) + 2 * v / a
    else:
        t = 2 * math.sqrt(d / (6 * a)) if d <= 6 * v * v / a else v / a + d / (6 * v)
    p = plan(0.0, 0.0, d, 6 * v, 6 * a, s_curve)
    assert p.duration == pytest.approx(t, rel=1e-9)


@given(st.floats(0.1, 500.0), st.floats(0.1, 20.0), st.floats(0.1, 500.0))
def test_target_time_profile_finishes_in_time(d: float, time: float, a: float) -> None:
    v, used = target_time_profile(d, time, a)
    assert used >= a
    assert plan(0.0, 0.0, d, v, used).duration == pytest.approx(time, rel=1e-6)


def test_triangle_when_too_short_to_cruise() -> None:
    p = plan(0.0, 0.0, 1.0, 100.0, 4.0)
    assert p.duration == pytest.approx(1.0)
    assert max(p.sample(t / 100)[1] for t in range(101)) == pytest.approx(2.0, rel=1e-2)


def test_start_faster_than_allowed_slows_down_first() -> None:
    p = plan(0.0, 10.0, 100.0, 5.0, 10.0)
    assert p.sample(0.25)[1] == pytest.approx(7.5)
    assert p.sample(1.0)[1] == pytest.approx(5.0)
