"""The command line on a robot file: run-time refusals in one line without the usage block, exit 2 for bad
input and files, ``tune --amplitude``, and ``teach`` saying when it runs below its rate."""

from __future__ import annotations

from pathlib import Path

import pytest

from .conftest import Cli

ROBOT = """
[buses.arm]
interface = "sim"
clock = "{clock}"
[joints.elbow]
bus = "arm"
id = 1
limits = {{ speed = 1.0 }}
"""


def _robot(tmp_path: Path, clock: str = "virtual") -> str:
    path = tmp_path / f"arm-{clock}.toml"
    path.write_text(ROBOT.format(clock=clock))
    return str(path)


def _one_line(err: str) -> bool:
    return len(err.strip().splitlines()) == 1 and "usage:" not in err and "Traceback" not in err


def test_tune_takes_an_amplitude_so_a_joint_with_a_speed_limit_can_be_tuned(cli: Cli, tmp_path: Path) -> None:
    arm = _robot(tmp_path)
    r = cli("tune", "elbow", "--bandwidth", "1", "--robot", arm, "--yes")
    assert r.code == 2 and "beyond joint 'elbow''s speed limit 1 rad/s" in r.err and _one_line(r.err), r.err
    r = cli("tune", "elbow", "--bandwidth", "1", "--robot", arm, "--yes", "--amplitude", "0.1", "--json")
    assert r.code == 0, r.err
    assert r.records()[0]["joint"] == "elbow"


def test_play_dry_run_with_a_column_no_joint_has_is_one_line(cli: Cli, tmp_path: Path) -> None:
    arm = _robot(tmp_path)
    bad = tmp_path / "bad.csv"
    bad.write_text("t,elbw\n0,0\n1,0.1\n")
    for extra in (["--dry-run"], []):
        r = cli("play", str(bad), "--robot", arm, *extra)
        assert r.code == 2 and "column 'elbw' is no joint of" in r.err and _one_line(r.err), r.err


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["play", "{tmp}/missing.csv", "--robot", "{arm}"], "missing.csv: no such file"),
        (["state", "1", "-i", "simm", "-c", "x"], "unknown interface 'simm'"),
    ],
)
def test_bad_files_and_typos_exit_2(cli: Cli, tmp_path: Path, argv: list[str], words: str) -> None:
    arm = _robot(tmp_path)
    r = cli(*(a.format(tmp=tmp_path, arm=arm) for a in argv))
    assert r.code == 2 and words in r.err and _one_line(r.err), r.err


def test_a_model_joint_typo_exits_2(cli: Cli, tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    model = Path(__file__).resolve().parents[3] / "examples" / "robots" / "arm6.xml"
    path = tmp_path / "arm.toml"
    path.write_text(
        f'[model]\nfile = "{model.as_posix()}"\n[buses.arm]\ninterface = "sim"\n'
        '[joints.elbow]\nbus = "arm"\nid = 3\nmodel_joint = "elbw"\n'
    )
    r = cli("state", "elbow", "--robot", str(path))
    assert r.code == 2 and "model_joint='elbw' is not a joint of the model" in r.err and _one_line(r.err), r.err


def test_identify_beyond_a_limit_is_refused_in_one_line(cli: Cli, tmp_path: Path) -> None:
    r = cli("identify", "elbow", "--robot", _robot(tmp_path), "--yes")
    assert r.code == 2 and "speed limit" in r.err and _one_line(r.err), r.err


def test_teach_says_when_it_runs_below_its_rate(cli: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DREMPOWER_SIM_TIME_SCALE", "1")
    arm = _robot(tmp_path, "wall")
    r = cli("teach", "--robot", arm, "--no-compensation", "--seconds", "1.5", "--rate", "20000")
    assert r.code == 0, r.err
    assert "drempower teach: running at" in r.err and "Hz of 20000 asked" in r.err, r.err
    r = cli("teach", "--robot", arm, "--no-compensation", "--seconds", "1.5", "--rate", "20")
    assert r.code == 0 and "asked" not in r.err, r.err  # 20 Hz is kept: nothing to say
