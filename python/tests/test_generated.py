"""Generated files are up to date with their sources."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from .conftest import REPO_ROOT


def _check(script: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(REPO_ROOT / "tools" / script), "--check"], capture_output=True, text=True, check=False
    )


def test_parameter_code_is_fresh() -> None:
    r = _check("generate.py")
    assert r.returncode == 0, r.stderr


def test_vectors_are_fresh() -> None:
    r = _check("gen_vectors.py")
    assert r.returncode == 0, r.stderr


def test_staleness_is_detected(tmp_path: Path) -> None:
    """A hand edit of a generated file fails the check (run on a copy, not on the working tree)."""
    parts = [
        Path("tools/generate.py"),
        Path("spec/parameters.csv"),
        Path("python/src/drempower/protocol/_parameter_table.py"),
        Path("c/include/drempower/dre_params.h"),
    ]
    for rel in parts:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(REPO_ROOT / rel, tmp_path / rel)
    script = [sys.executable, str(tmp_path / "tools" / "generate.py"), "--check"]
    assert subprocess.run(script, capture_output=True, text=True, check=False).returncode == 0
    target = tmp_path / parts[2]
    target.write_text(target.read_text() + "# edited by hand\n")
    r = subprocess.run(script, capture_output=True, text=True, check=False)
    assert r.returncode == 1
    assert "_parameter_table.py" in r.stderr
