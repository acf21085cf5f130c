"""Generated files are up to date with their sources."""

from __future__ import annotations

import subprocess
import sys

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


def test_staleness_is_detected(tmp_path: object) -> None:
    target = REPO_ROOT / "python" / "src" / "drempower" / "protocol" / "_parameter_table.py"
    original = target.read_bytes()
    try:
        target.write_bytes(original + b"# edited by hand\n")
        r = _check("generate.py")
        assert r.returncode == 1
        assert "_parameter_table.py" in r.stderr
    finally:
        target.write_bytes(original)
