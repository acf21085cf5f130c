"""The examples run against the simulator."""

from __future__ import annotations

import subprocess
import sys

import pytest

from .conftest import REPO_ROOT

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


def test_examples_take_the_python_can_options_of_the_command(tmp_path: object) -> None:
    """``-o host=... -o port=...`` reach a socketcand server, as with ``drempower``; ``-b 1M`` and ``--retries``."""
    from drempower.sim import SimBus, SimRunner, attach_socketcand

    bus = SimBus(ids=[1])
    with SimRunner(bus, 10.0), attach_socketcand(bus) as server:
        args = [sys.executable, str(REPO_ROOT / "examples" / "single_motor.py"), "-i", "socketcand", "-c", "can0"]
        args += ["-o", f"host={server.host}", "-o", f"port={server.port}", "--timeout", "2", "--retries", "1"]
        proc = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "reached 90.00 deg" in proc.stdout
    bad = subprocess.run([*args[:2], "-o", "nokey"], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "'nokey': expected KEY=VALUE" in bad.stderr
