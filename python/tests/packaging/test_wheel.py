"""The package as users get it: ``python -m build`` makes a wheel and an sdist with complete
metadata, and the wheel installed into a fresh virtual environment runs ``drempower demo``.

Nothing is fetched: the build runs without isolation (setuptools and build come from the
test environment), the fresh environment sees the test environment's packages (python-can,
pyserial) through a ``.pth`` file, and the wheel is installed with ``--no-deps --no-index``.
"""

from __future__ import annotations

import email
import json
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import venv
import zipfile
from pathlib import Path

import pytest

import drempower

PROJECT = Path(__file__).resolve().parents[2]
"""The directory of pyproject.toml."""

pytestmark = pytest.mark.timeout(600)


@pytest.fixture(scope="module")
def dist(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the project built into wheel + sdist (the build's scratch files stay in the copy)."""
    root = tmp_path_factory.mktemp("project")
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(PROJECT / name, root / name)
    shutil.copytree(PROJECT / "src", root / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    out = root / "dist"
    done = subprocess.run(
        [sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out), str(root)],
        capture_output=True,
        text=True,
        timeout=500,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    log = (done.stdout + done.stderr).lower()
    assert "deprecat" not in log, log
    assert "setuptoolsdeprecationwarning" not in log
    return out


def _metadata(dist: Path) -> email.message.Message:
    (wheel,) = dist.glob("drempower-*.whl")
    with zipfile.ZipFile(wheel) as z:
        (name,) = [n for n in z.namelist() if n.endswith(".dist-info/METADATA")]
        return email.message_from_bytes(z.read(name))


def test_wheel_metadata_is_complete(dist: Path) -> None:
    meta = _metadata(dist)
    assert meta["Name"] == "drempower"
    assert meta["Version"] == drempower.__version__
    assert meta["License-Expression"] == "MIT"
    assert "LICENSE" in meta.get_all("License-File", [])
    assert meta["Requires-Python"] == ">=3.10"
    classifiers = meta.get_all("Classifier", [])
    assert "Programming Language :: Python :: 3" in classifiers
    assert "Typing :: Typed" in classifiers
    assert not any(c.startswith("License ::") for c in classifiers)  # the SPDX expression says it
    urls = dict(u.split(", ", 1) for u in meta.get_all("Project-URL", []))
    assert {"Homepage", "Source", "Issues", "Changelog"} <= set(urls)
    assert meta["Description-Content-Type"] == "text/markdown"
    assert meta.get_payload().startswith("# drempower (Python)")  # the package readme
    requires = meta.get_all("Requires-Dist", [])
    core = [r for r in requires if "extra ==" not in r]
    backports = [r for r in core if 'python_version < "3.11"' in r]  # standard-library backports for 3.10
    assert sorted(r.split(">")[0] for r in core if r not in backports) == ["pyserial", "python-can"]
    assert [r.split(">")[0] for r in backports] == ["tomli"]


def test_sdist_holds_sources_license_and_readme(dist: Path) -> None:
    (sdist,) = dist.glob("drempower-*.tar.gz")
    with tarfile.open(sdist) as t:
        names = {n.split("/", 1)[1] for n in t.getnames() if "/" in n}
    assert {
        "pyproject.toml",
        "README.md",
        "LICENSE",
        "src/drempower/cli/__init__.py",
        "src/drempower/py.typed",
    } <= names


def test_wheel_installs_into_a_fresh_environment_and_runs_the_demo(dist: Path, tmp_path: Path) -> None:
    env = tmp_path / "venv"
    venv.create(env, with_pip=False)
    python = env / ("Scripts/python.exe" if sys.platform == "win32" else "bin/python")
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    # the test environment's packages (python-can, pyserial) without fetching them
    Path(site, "_test_env.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    (wheel,) = dist.glob("drempower-*.whl")
    pip = [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index", "--quiet"]
    done = subprocess.run([*pip, str(wheel)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    where = subprocess.run(
        [str(python), "-c", "import drempower; print(drempower.__file__)"], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert Path(where).is_relative_to(env), where  # the wheel's copy, not the checkout's
    script = env / ("Scripts/drempower.exe" if sys.platform == "win32" else "bin/drempower")
    demo = subprocess.run(
        [str(script), "demo", "--motors", "2", "--time-scale", "20", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert demo.returncode == 0, demo.stderr
    summary = json.loads(demo.stdout.strip().splitlines()[-1])
    assert summary["motors"] == [1, 2]
    assert summary["reached"] == 2
