"""The Tuning view's "Propose gains" at the hub: identify, the gains for an asked bandwidth and a step with
the present gains, nothing written; on confirmation the gains written and a step after."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import drempower
from drempower.dash import Hub
from drempower.errors import ValidationError
from drempower.motion.tune import GAIN_NAMES

FACTORY = (40.0, 0.06, 2.4)
"""The simulated motor's own gains (pos_gain, vel_gain, vel_integrator_gain)."""


def _gains(hub: Hub, key: int) -> list[float]:
    return [float(hub.motor(key).read_property(n)) for n in GAIN_NAMES]


def test_propose_on_the_twin_pendulum_then_write_on_confirmation(tmp_path: Path) -> None:
    pytest.importorskip("mujoco", reason="the twin needs MuJoCo")
    from ..sim.twin.conftest import model_copy, robot_file

    model = model_copy(tmp_path, "pendulum.xml", lambda root: None)
    path = robot_file(tmp_path, model, {"swing": {"id": 1}}, clock="virtual")
    with drempower.open_robot(path) as robot:
        hub = Hub(robot)
        try:
            assert _gains(hub, 1) == pytest.approx(FACTORY)
            proposal = hub.do_propose("test", {"id": 1, "bandwidth": 1.0})
            assert _gains(hub, 1) == pytest.approx(FACTORY)  # a proposal writes nothing
            with pytest.raises(ValidationError, match="no proposal for this bandwidth"):
                hub.do_apply_gains("test", {"id": 1, "bandwidth": 2.0})
            assert _gains(hub, 1) == pytest.approx(FACTORY)
            done = hub.do_apply_gains("test", {"id": 1, "bandwidth": 1.0})
            written = _gains(hub, 1)
            with pytest.raises(ValidationError, match="propose gains first"):  # a proposal is written once
                hub.do_apply_gains("test", {"id": 1, "bandwidth": 1.0})
        finally:
            hub.close()
    g = proposal["gains"]
    print(f"proposed {g}; before {proposal['before']}; after {done['after']}")
    assert proposal["joint"] == "swing" and g["pos_gain"] == pytest.approx(2 * math.pi)
    assert proposal["identified"]["inertia"] == pytest.approx(2.0 * 0.25 * 0.25 + 0.0417, rel=0.25)
    assert written == pytest.approx([g["pos_gain"], g["vel_gain"], g["vel_integrator_gain"]], rel=1e-5)
    before, after = done["before"], done["after"]
    assert after["overshoot"] <= 0.05 and after["settling"] is not None
    assert after["settling"] <= 6 / (2 * math.pi)
    assert before["settling"] is None or after["settling"] < before["settling"]  # the factory gains: never settle


def test_propose_over_one_bus_and_its_refusals() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as bus:
        hub = Hub(bus)
        try:
            with pytest.raises(ValidationError, match="bandwidth=0: expected 0 < bandwidth <= 50 Hz"):
                hub.do_propose("test", {"id": 1, "bandwidth": 0})
            proposal = hub.do_propose("test", {"id": 1, "bandwidth": 2.0})
            assert proposal["joint"] == "motor_1" and proposal["gains"]["pos_gain"] == pytest.approx(4 * math.pi)
            assert proposal["before"]["final"] == pytest.approx(1.0, abs=0.05)
            assert _gains(hub, 1) == pytest.approx(FACTORY)
        finally:
            hub.close()
        read_only = Hub(bus, read_only=True)
        try:
            with pytest.raises(ValidationError, match="read-only"):
                read_only.do_propose("test", {"id": 1, "bandwidth": 1.0})
        finally:
            read_only.close()
