"""A twin served by ``drempower sim --robot`` (its own runner) answers with the state of the moment, as the
plain simulator does: no 20 ms staircase in a trace read at a high rate (the dashboard's Tuning view)."""

from __future__ import annotations

import itertools
import time
from pathlib import Path

import pytest

import drempower
from drempower.robot.config import load_robot
from drempower.sim import SimBus
from drempower.sim.twin import TwinRunner, couple_robot

pytest.importorskip("mujoco", reason="the twin needs MuJoCo")

ARM6 = Path(__file__).resolve().parents[4] / "examples" / "robots" / "arm6.toml"


def test_a_served_twin_answers_with_the_state_of_the_moment() -> None:
    spec = load_robot(ARM6)
    buses = {name: SimBus(sorted(j.id for j in spec.joints_on(name)), bitrate=1_000_000) for name in spec.buses}
    assert couple_robot(spec, buses) is not None
    (sim,) = buses.values()
    with TwinRunner(buses.values()), drempower.open_bus("sim", bus=sim, time_scale=0, stop_on_close=False) as bus:
        m = bus.motor(1)  # base_yaw: no gravity on it
        m.set_speed(30.0, enable=True)
        time.sleep(0.2)
        reads: list[tuple[float, float]] = []
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            reads.append((time.monotonic(), m.get_state().angle))
            time.sleep(0.002)
        m.set_mode(1)
    # between two reads 2 ms or more apart the joint (at 30 r/min: 0.18 deg/ms) has moved
    spaced = [(a, b) for a, b in itertools.pairwise(reads) if b[0] - a[0] >= 0.002]
    same = sum(1 for a, b in spaced if b[1] == a[1])
    assert len(spaced) > 20
    assert same <= 0.1 * len(spaced), f"{same} of {len(spaced)} reads repeat the one before: a staircase"
