"""examples/twin_hand.py runs on the twin and shows the elbow's stiffness."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from .conftest import REPO_ROOT


def test_twin_hand_example_runs() -> None:
    proc = subprocess.run(
        [sys.executable, str(REPO_ROOT / "examples" / "twin_hand.py"), "--kp", "25"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    seen = re.search(r"stiffness seen at the joint: (-?[\d.]+) Nm/rad", proc.stdout)
    assert seen is not None, proc.stdout
    assert float(seen[1]) == pytest.approx(25.0, rel=0.03)
