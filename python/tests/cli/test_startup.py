"""A command imports what it needs when it needs it: ``drempower --version`` and ``drempower state 1 --sim 1``
start without python-can, asyncio or any other command's module (bench/bench_cli.py times them)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

_PROBE = """
import json, runpy, sys
sys.argv = ["drempower", *json.loads(sys.argv[1])]
try:
    runpy.run_module("drempower", run_name="__main__")
except SystemExit as exc:
    code = exc.code
print("\\n" + json.dumps({"modules": sorted(sys.modules), "code": code}))
"""
_HEAVY = ("can", "asyncio", "serial", "numpy", "mujoco", "aiohttp", "zenoh", "importlib.metadata")


def _modules(argv: list[str]) -> tuple[set[str], int]:
    r = subprocess.run(
        [sys.executable, "-c", _PROBE, json.dumps(argv)], capture_output=True, text=True, timeout=60, check=False
    )
    out = json.loads(r.stdout.strip().splitlines()[-1])
    return set(out["modules"]), out["code"]


def _commands(modules: set[str]) -> set[str]:
    return {m for m in modules if m.startswith("drempower.cli.") and not m.startswith("drempower.cli._")}


def test_import_drempower_imports_next_to_nothing() -> None:
    r = subprocess.run(
        [sys.executable, "-c", "import drempower, sys; print(sorted(m for m in sys.modules if 'drempower' in m))"],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    assert r.stdout.strip() == str(["drempower", "drempower._lazy", "drempower.errors"])


def test_version_imports_no_client_and_no_command() -> None:
    modules, code = _modules(["--version"])
    assert code == 0
    assert not _commands(modules)
    assert not {m for m in modules if m.split(".")[0] in _HEAVY or m == "importlib.metadata"}
    assert not {m for m in modules if m.startswith(("drempower.client.", "drempower.sim", "drempower.robot"))}


@pytest.mark.parametrize(
    ("argv", "command"),
    [
        (["state", "1", "--sim", "1"], "drempower.cli.state"),
        (["get", "1", "axis0.motor.effective_current_lim", "--sim", "1"], "drempower.cli.getset"),
    ],
)
def test_a_command_imports_its_own_module_alone_and_nothing_heavy(argv: list[str], command: str) -> None:
    modules, code = _modules(argv)
    assert code == 0
    assert _commands(modules) == {command}
    assert not {m for m in modules if m.split(".")[0] in _HEAVY or m == "importlib.metadata"}
    assert "drempower.robot.robot_sync" not in modules and "drempower.sim.attach_pythoncan" not in modules


def test_help_still_lists_every_command() -> None:
    modules, code = _modules(["--help"])
    from drempower.cli._index import COMMANDS

    assert code == 0
    homes = {f"drempower.cli.{m}" for m in COMMANDS.values() if not m.startswith("(")}
    assert homes <= _commands(modules)


def test_the_command_index_is_fresh() -> None:
    from ..conftest import REPO_ROOT

    r = subprocess.run(
        [sys.executable, str(REPO_ROOT / "tools" / "gen_cli_index.py"), "--check"],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert r.returncode == 0, r.stderr
