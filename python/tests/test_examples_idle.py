"""Each example against motors an earlier program left idle: it enables them and reports true figures."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterator

import pytest

import drempower
from drempower.sim import SimBus, SimRunner, attach_socketcand

from .conftest import REPO_ROOT


@pytest.fixture
def idle_sim() -> Iterator[tuple[SimBus, list[str]]]:
    """Simulated motors 1-3 served over socketcand, left idle; the examples' connection options."""
    sim = SimBus(ids=[1, 2, 3])
    with SimRunner(sim, 1.0), attach_socketcand(sim) as server:
        opts = ["-i", "socketcand", "-c", "can0", "-o", f"host={server.host}", "-o", f"port={server.port}"]
        with drempower.open_bus("socketcand", "can0", host=server.host, port=server.port, timeout=1.0) as before:
            before.idle([1, 2, 3])  # the earlier program
            for n in (1, 2, 3):
                assert before.motor(n).read_property("axis0.current_state") == 1
        yield sim, [*opts, "--timeout", "1"]


def _run(name: str, *args: str) -> str:
    proc = subprocess.run(
        [sys.executable, str(REPO_ROOT / "examples" / name), *args], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    return proc.stdout


def test_trajectory_tracks_its_sine(idle_sim: tuple[SimBus, list[str]]) -> None:
    out = _run("trajectory_200hz.py", *idle_sim[1], "--ids", "1,2", "--seconds", "1")
    error = float(re.search(r"largest tracking error seen: ([\d.]+) deg", out).group(1))  # type: ignore[union-attr]
    assert error < 10  # an idle motor's would be the whole 30 deg amplitude


def test_impedance_spring_moves_the_motor(idle_sim: tuple[SimBus, list[str]]) -> None:
    out = _run("impedance.py", *idle_sim[1], "--ids", "1")
    moved = float(re.search(r"the spring moved the motor ([-\d.]+) deg of the 45", out).group(1))  # type: ignore[union-attr]
    assert moved > 20
    assert idle_sim[0].motors[1].position > 20


def test_sync_move_ends_at_its_targets(idle_sim: tuple[SimBus, list[str]]) -> None:
    out = _run("sync_move.py", *idle_sim[1], "--ids", "1,2,3")
    for node, target in ((1, 30.0), (2, -60.0), (3, 90.0)):
        got = float(re.search(rf"motor {node}:\s+([-\d.]+) deg", out).group(1))  # type: ignore[union-attr]
        assert got == pytest.approx(target, abs=0.5)
    back = re.search(r"back at \{(.*)\}", out).group(1)  # type: ignore[union-attr]
    assert [float(v.split(":")[1]) for v in back.split(",")] == pytest.approx([0, 0, 0], abs=0.5)


def test_single_motor_reaches_its_target(idle_sim: tuple[SimBus, list[str]]) -> None:
    out = _run("single_motor.py", *idle_sim[1])
    assert "reached 90.00 deg" in out
