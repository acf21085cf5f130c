"""The examples run against the simulator."""

from __future__ import annotations

import subprocess
import sys

import pytest

from ..conftest import REPO_ROOT

EXAMPLES = {
    "single_motor.py": ["--time-scale", "10"],
    "sync_move.py": ["--time-scale", "10"],
    "trajectory_200hz.py": ["--seconds", "0.2"],
    "impedance.py": [],
    "scan_backup.py": [],
    "robot.py": ["--time-scale", "10"],
}


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_example_runs(name: str, tmp_path: object) -> None:
    args = [sys.executable, str(REPO_ROOT / "examples" / name), *EXAMPLES[name]]
    if name == "scan_backup.py":
        args += ["--out", str(tmp_path)]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout
