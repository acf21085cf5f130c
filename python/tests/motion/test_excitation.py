"""``Trajectory.excitation`` and ``drempower play --excite``: a multi-sine per joint that starts and ends at
rest at the centre, stays within the amplitude and under its speed bound, differs from joint to joint, and is
refused (naming the joint) when it would leave a joint's limits."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from drempower.cli import main
from drempower.errors import ValidationError
from drempower.motion import Trajectory
from drempower.motion.excitation import frequencies, peak_speed

from ..conftest import REPO_ROOT

ARM = REPO_ROOT / "examples" / "robots" / "arm6.toml"


def test_it_starts_and_ends_at_rest_at_the_centre_and_stays_within_the_amplitude() -> None:
    tr = Trajectory.excitation(["a", "b", "c"], 12.0, centre={"a": 0.5, "b": -1.0, "c": 0.0}, amplitude=[0.3, 0.2, 0.1])
    assert tr.duration == pytest.approx(12.0)
    for t in (0.0, 12.0):
        s = tr.sample(t)
        assert s.positions == pytest.approx([0.5, -1.0, 0.0], abs=1e-12)
        assert s.velocities == pytest.approx([0.0] * 3, abs=1e-12)
    peaks = tr.peaks(0.002)
    for j, (c, a) in enumerate(((0.5, 0.3), (-1.0, 0.2), (0.0, 0.1))):
        assert c - a <= peaks.low[j] and peaks.high[j] <= c + a
        assert peaks.high[j] - peaks.low[j] > a  # it does move: most of the band is used
        assert peaks.speed[j] <= peak_speed(j, a, 1.0)
    # the joints' sines differ, so their motions are not alike
    assert not set(frequencies(0)) & set(frequencies(1))
    xs = [tr.sample(k * 0.01) for k in range(1200)]
    va = [s.velocities[0] for s in xs]
    vb = [s.velocities[1] for s in xs]
    corr = sum(x * y for x, y in zip(va, vb, strict=True)) / math.sqrt(sum(x * x for x in va) * sum(y * y for y in vb))
    assert abs(corr) < 0.3


def test_leaving_a_limit_or_a_speed_limit_is_refused_naming_the_joint() -> None:
    with pytest.raises(
        ValidationError, match=r"joint 'b' at 1\.900 rad \+-amplitude=0\.3 rad leaves its limits -2\.\.2"
    ):
        Trajectory.excitation(["a", "b"], 10.0, centre=[0.0, 1.9], limits={"b": {"position": (-2.0, 2.0)}})
    with pytest.raises(ValidationError, match=r"joint 'a' would reach .* beyond its speed limit 0\.5 rad/s"):
        Trajectory.excitation(["a"], 10.0, amplitude=0.3, limits={"a": {"speed": 0.5}})
    with pytest.raises(ValidationError, match="amplitude"):
        Trajectory.excitation(["a"], 10.0, amplitude=-1.0)
    with pytest.raises(ValidationError, match="ramp"):
        Trajectory.excitation(["a"], 1.0, ramp=1.0)


def test_play_excite_dry_run_and_refusal(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("mujoco")
    assert main(["play", "--excite", "20", "--robot", str(ARM), "--dry-run", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["duration_s"] == pytest.approx(20.0)
    for row in out["joints"]:
        assert -0.3 <= row["low"] < -0.2 and 0.2 < row["high"] <= 0.3
    assert main(["play", "--excite", "20", "--amplitude", "2.2", "--robot", str(ARM), "--dry-run"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) <= 1 + 12 and "joint 'shoulder'" in err[-1] and "leaves its limits -2..2 rad" in err[-1]
    assert main(["play", "--excite", "5", "--sim", "1", "--dry-run"]) == 2
    assert "--excite needs --robot FILE" in capsys.readouterr().err
    assert main(["play", "--robot", str(ARM), "--dry-run"]) == 2
    assert "give a trajectory FILE or --excite S" in capsys.readouterr().err
