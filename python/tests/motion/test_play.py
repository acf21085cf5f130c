"""``drempower play``: a dry run prints the duration and the limits met; a file beyond a limit is exit 2 with
one line; a short path on simulated motors is followed and reported."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drempower.cli import main
from drempower.motion import Trajectory

from ..conftest import REPO_ROOT

ARM = REPO_ROOT / "examples" / "robots" / "arm6.toml"
JOINTS = ("base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll")


def _arm_file(tmp: Path, elbow: float = -0.4) -> Path:
    path = tmp / "arm.csv"
    goal = [0.5, 0.3, elbow, 0.6, 0.4, -0.6]
    Trajectory.from_waypoints([[0.0] * 6, goal, [0.0] * 6], max_speed=1.0, max_accel=3.0, joints=JOINTS).save(path)
    return path


def test_dry_run_prints_the_duration_and_the_limits_met(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("mujoco")
    path = _arm_file(tmp_path)
    assert main(["play", str(path), "--robot", str(ARM), "--dry-run", "--speed", "0.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["duration_s"] == pytest.approx(2 * 1.8666666, rel=1e-5)  # --speed 0.5: twice as long
    elbow = next(j for j in out["joints"] if j["joint"] == "elbow")
    assert elbow["low"] == pytest.approx(-0.4) and elbow["limits"] == "position -2.5..2.5"
    assert elbow["peak_speed"] == pytest.approx(0.667 / 2, rel=1e-3)
    assert main(["play", str(path), "--robot", str(ARM), "--dry-run"]) == 0
    text = capsys.readouterr().out
    assert "6 joints, 1.867 s at 200 Hz" in text and "the range of model joint 'shoulder'" in text


def test_beyond_a_limit_or_the_bus_is_exit_2_with_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("mujoco")
    path = _arm_file(tmp_path, elbow=-2.7)
    assert main(["play", str(path), "--robot", str(ARM)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "joint 'elbow'" in err and "outside its limits -2.5..2.5 rad" in err and "nothing was sent" in err
    ok = _arm_file(tmp_path)
    assert main(["play", str(ok), "--robot", str(ARM), "--rate", "2000", "--dry-run"]) == 2
    assert "at most" in capsys.readouterr().err
    assert main(["play", str(ok), "--sim", "1,2"]) == 2  # joint names without --robot
    assert "give --robot FILE, or --ids" in capsys.readouterr().err
    missing = tmp_path / "none.csv"
    assert main(["play", str(missing), "--sim", "1"]) == 2  # a file the user names: bad input
    assert "no such file" in capsys.readouterr().err


def test_play_on_simulated_motors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "m.json"
    Trajectory.from_waypoints({"1": [0.0, 20.0], "2": [0.0, -10.0]}, max_speed=30.0, max_accel=120.0).save(path)
    assert main(["play", str(path), "--sim", "1,2", "--rate", "100", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["stopped"] is None and report["cycles"] > 10
    assert 0.0 < max(report["max_error"].values()) < 10.0  # real time on a loaded host: the lag varies
