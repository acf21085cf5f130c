"""``python -m drempower`` as a separate process: exit codes and one-line errors."""

from __future__ import annotations

import os
import subprocess
import sys

from drempower.cli._connect import TIME_SCALE_ENV

from .conftest import TIME_SCALE


def drempower(*argv: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, TIME_SCALE_ENV: str(TIME_SCALE)}
    return subprocess.run(
        [sys.executable, "-m", "drempower", *argv], capture_output=True, text=True, timeout=60, env=env
    )


def test_demo_exits_0() -> None:
    p = drempower("demo")
    assert p.returncode == 0, p.stderr
    assert "targets reached: 3/3" in p.stdout


def test_a_silent_motor_exits_1_with_one_line() -> None:
    p = drempower("move", "9", "90", "--sim", "1", "--timeout", "0.25")
    assert p.returncode == 1
    assert p.stdout == ""
    assert p.stderr == "drempower: error: motor 9: no answer to a fast read (get_state) within 0.25 s\n"


def test_a_silent_motor_of_a_read_gets_a_row_and_exit_1() -> None:
    p = drempower("state", "9", "--sim", "1", "--timeout", "0.25")
    assert p.returncode == 1
    assert p.stdout.splitlines()[1].split() == ["9", "-", "-", "-", "-", "-", "-", "no", "answer"]
    assert p.stderr == "drempower: no answer from motor 9\n"


def test_usage_errors_exit_2() -> None:
    p = drempower("move", "1")
    assert p.returncode == 2 and "the following arguments are required: ANGLES" in p.stderr
    p = drempower("move", "1,2", "90,1,2", "--sim", "1,2")
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.startswith("usage: drempower move ")
    assert p.stderr.endswith("drempower move: error: 2 motors but 3 angle values: give one for all or one each\n")
