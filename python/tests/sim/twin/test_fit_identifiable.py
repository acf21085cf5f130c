"""The twin fit's identifiability check: each parameter's relative standard error from the final Jacobian,
and how far an error of the recording's timing moves it (the delay's column of the same Jacobian)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drempower.sim.twin_fit import relative_errors, timing_shifts


def test_standard_errors_of_a_linear_model_match_the_textbook() -> None:
    rng = np.random.default_rng(1)
    m = 4000
    t = np.linspace(0.0, 1.0, m)
    jac = np.column_stack([np.ones(m), t, np.sin(7 * t)])  # residual = jac @ x - data
    noise = rng.normal(0.0, 0.1, m)
    truth = np.array([1.0, 2.0, 3.0])
    data = jac @ truth + noise
    x, *_ = np.linalg.lstsq(jac, data, rcond=None)
    residuals = jac @ x - data
    se = relative_errors(np, jac, residuals)
    textbook = np.sqrt(np.diag(np.linalg.inv(jac.T @ jac)) * float(residuals @ residuals) / (m - 3))
    assert se == pytest.approx(textbook, rel=1e-9)
    # the scatter of the estimates over many noises is what the standard error says
    fits = [np.linalg.lstsq(jac, jac @ truth + rng.normal(0.0, 0.1, m), rcond=None)[0] for _ in range(300)]
    assert np.std(fits, axis=0) == pytest.approx(se, rel=0.15)


def test_residuals_that_follow_each_other_widen_the_error_as_much_as_they_widen_the_scatter() -> None:
    rng = np.random.default_rng(2)
    m = 4000
    t = np.linspace(0.0, 1.0, m)
    jac = np.column_stack([np.ones(m), np.sin(3 * t), np.cos(11 * t)])

    def slow_noise() -> np.ndarray:  # each residual 0.9 of the one before: what a slow model error leaves
        e = rng.normal(0.0, 0.1, m)
        for i in range(1, m):
            e[i] += 0.9 * e[i - 1]
        return e

    fits = [np.linalg.lstsq(jac, slow_noise(), rcond=None)[0] for _ in range(200)]
    noise = slow_noise()
    x = np.linalg.lstsq(jac, noise, rcond=None)[0]
    se = relative_errors(np, jac, jac @ x - noise)
    white = np.sqrt(np.diag(np.linalg.inv(jac.T @ jac)) * float((jac @ x - noise) @ (jac @ x - noise)) / (m - 3))
    assert np.all(se > 3 * white)  # sqrt(1.9 / 0.1) = 4.4 times
    assert se == pytest.approx(np.std(fits, axis=0), rel=0.35)


def test_a_parameter_the_residuals_cannot_tell_has_an_infinite_error() -> None:
    m = 500
    t = np.linspace(0.0, 1.0, m)
    r = np.full(m, 0.01)
    unused = np.column_stack([t, np.zeros(m)])  # the second parameter changes nothing
    assert np.isinf(relative_errors(np, unused, r)).tolist() == [False, True]
    twins = np.column_stack([t, 2 * t, np.cos(t)])  # two parameters with the same effect: only their sum is told
    se = relative_errors(np, twins, r)
    assert math.isinf(se[0]) and math.isinf(se[1]) and math.isfinite(se[2])
    nearly = np.column_stack([t, t + 1e-4 * np.sin(9 * t)])  # nearly alike: told, but poorly
    apart = np.column_stack([t, np.sin(9 * t)])
    assert relative_errors(np, nearly, r)[1] > 1000 * relative_errors(np, apart, r)[1]


def test_the_shift_per_delay_is_what_refitting_with_the_delay_moved_gives() -> None:
    rng = np.random.default_rng(3)
    m = 3000
    t = np.linspace(0.0, 1.0, m)
    delay = np.sin(5 * t)
    jac = np.column_stack([np.cos(2 * t), 0.8 * delay + 0.2 * np.cos(17 * t), np.ones(m), delay])
    shift = timing_shifts(np, jac)
    data = jac @ np.array([1.0, 2.0, 3.0, 4.0]) + rng.normal(0.0, 0.01, m)
    best = np.linalg.lstsq(jac, data, rcond=None)[0]

    def refit(d: float) -> np.ndarray:  # the delay held at ``d``, the rest fitted again
        return np.linalg.lstsq(jac[:, :3], data - jac[:, 3] * d, rcond=None)[0]

    assert refit(best[3]) == pytest.approx(best[:3], rel=1e-9)
    assert (refit(best[3] + 0.1) - best[:3]) / 0.1 == pytest.approx(shift[:3], rel=1e-6, abs=1e-9)
    assert shift[3] == pytest.approx(1.0)
    assert abs(shift[1]) > 3 * abs(shift[0])  # the column most like the delay's moves most with it
