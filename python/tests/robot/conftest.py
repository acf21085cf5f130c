"""Robot files for the tests: simulated buses, or python-can virtual channels with simulators attached."""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest

from drempower.sim import SimBus, SimRunner, attach_python_can

SIM_ROBOT = """
[buses.left]
interface = "sim"
[buses.right]
interface = "sim"
[joints.shoulder]
bus = "left"
id = 1
[joints.hip]
bus = "left"
id = 2
[joints.elbow]
bus = "right"
id = 1
gear = -2.0
offset = 0.5
"""

_channels = itertools.count()


@pytest.fixture
def sim_robot_file(tmp_path: Path) -> Path:
    path = tmp_path / "robot.toml"
    path.write_text(SIM_ROBOT)
    return path


@pytest.fixture
def virtual_robot(tmp_path: Path) -> Iterator[tuple[Path, dict[str, SimBus]]]:
    """A robot file of two python-can virtual buses, each with a simulator (20x real time) attached."""
    names = {bus: f"drempower-robot-{bus}-{next(_channels)}-{id(tmp_path)}" for bus in ("left", "right")}
    path = tmp_path / "virtual.toml"
    path.write_text(
        f"""
[buses.left]
interface = "virtual"
channel = "{names["left"]}"
timeout = 0.5
[buses.right]
interface = "virtual"
channel = "{names["right"]}"
timeout = 0.5
[joints.a]
bus = "left"
id = 1
[joints.b]
bus = "right"
id = 3
gear = 10
"""
    )
    sims = {"left": SimBus(ids=[1]), "right": SimBus(ids=[3])}
    with ExitStack() as stack:
        for bus, sim in sims.items():
            stack.callback(SimRunner(sim, 20.0).start().stop)
            stack.callback(attach_python_can(sim, channel=names[bus]).close)
        yield path, sims
