"""tune on the identified twin pendulum (a heavy load against gravity): for three bandwidths the step after
tuning has no overshoot beyond 5 % and settles within 6 / (2 pi f) s, and beats the factory gains."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import drempower
from drempower.errors import ValidationError
from drempower.motion.routines_sync import identify, step_response, tune
from drempower.motion.tune import GAIN_NAMES, gains_for

pytest.importorskip("mujoco", reason="the twin needs MuJoCo")

from ..sim.twin.conftest import model_copy, robot_file

FACTORY = (40.0, 0.06, 2.4)
"""The simulated motor's own gains (pos_gain, vel_gain, vel_integrator_gain)."""


def test_tuned_steps_meet_the_spec_and_beat_the_factory_gains(tmp_path: Path) -> None:
    model = model_copy(tmp_path, "pendulum.xml", lambda root: None)
    path = robot_file(tmp_path, model, {"swing": {"id": 1}}, clock="virtual")
    with drempower.open_robot(path) as robot:
        joint = robot.joint("swing")
        for name, value in zip(GAIN_NAMES, FACTORY, strict=True):
            joint.write_property(name, value)
        got = identify(robot, "swing")  # with the factory gains: impedance mode does not use them
        factory = step_response(robot, "swing", 0.15)
        results = {}
        for bw in (0.5, 1.0, 2.0):
            for name, value in zip(GAIN_NAMES, FACTORY, strict=True):
                joint.write_property(name, value)
            report = tune(robot, "swing", bw, identified=got)
            results[bw] = report
        with pytest.raises(ValidationError, match=r"bandwidth=8 Hz: needs vel_gain=.* at most about"):
            gains_for(got.inertia, got.viscous, 8.0)
    print(f"factory gains: {factory}")
    for bw, rep in results.items():
        print(f"{bw} Hz: gains {rep.gains}; before {rep.before}; after {rep.after}")
        assert rep.after.overshoot <= 0.05
        assert rep.after.settling <= 6 / (2 * math.pi * bw)
        assert rep.after.settling < factory.settling or factory.settling == math.inf
        assert rep.after.overshoot < factory.overshoot or factory.overshoot == 0.0


def test_drempower_tune_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from drempower.cli import main

    model = model_copy(tmp_path, "pendulum.xml", lambda root: None)
    path = robot_file(tmp_path, model, {"swing": {"id": 1}}, clock="virtual")
    assert main(["tune", "swing", "--bandwidth", "1", "--robot", str(path), "--yes", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["gains"]["pos_gain"] == pytest.approx(2 * math.pi)
    assert out["after"]["overshoot"] <= 0.05 and out["saved"] is False
    assert main(["tune", "swing", "--bandwidth", "20", "--robot", str(path), "--yes"]) == 2
    assert "at most about" in capsys.readouterr().err
