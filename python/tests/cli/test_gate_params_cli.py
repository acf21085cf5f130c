"""``drempower actions set`` of a parameter that commands motion: a parameter not meant for users needs
``--force`` (as ``drempower set`` asks), and the write passes the safety gate as the motion it is."""

from __future__ import annotations

import pytest

from drempower.sim import SimBus

from .conftest import Cli

VEL = "axis0.output_shaft.input_vel"


def test_actions_set_of_an_input_asks_force_then_passes_the_gate(cli: Cli, sim: SimBus) -> None:
    assert cli("idle", "1", "--sim", "1").code == 0
    r = cli("actions", "set", "1", VEL, "200", "--sim", "1")
    assert r.code == 2 and r.err == (
        f"drempower: error: {VEL} is not meant to be changed by users (add force to write it anyway)\n"
    ), r
    r = cli("actions", "set", "1", VEL, "200", "--force", "--sim", "1")
    assert r.code == 1 and r.err.startswith("drempower: error: motor 1 is idle (not in closed loop)"), r
    assert sim.motors[1].param(VEL) == 0
    assert cli("enable", "1", "--sim", "1").code == 0
    r = cli("actions", "set", "1", VEL, "20", "--force", "--sim", "1")
    assert r.code == 0, r
    assert sim.motors[1].param(VEL) == pytest.approx(20)
