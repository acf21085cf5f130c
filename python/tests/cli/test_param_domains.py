"""``drempower set`` checks each value against the parameter's domain; --force passes soft bounds only."""

from __future__ import annotations

import pytest

from drempower.protocol import Frame
from drempower.sim import SimBus

from .conftest import Cli

STALL = "axis0.config.extra_setting.stall_current_limit"
GAIN = "axis0.controller.config.pos_gain"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((STALL, "-5"), f"{STALL}=-5.0 is outside its domain: >= 0 (soft, inferred); --force writes it anyway"),
        ((GAIN, "1e30"), f"{GAIN}=1e+30 is outside its domain: 0..1000 (soft, inferred)"),
        (("heartbeat_ms", "100000"), "can.config.heartbeat_ms=100000 is outside its domain: 0..60000"),
        (("input_filter_bandwidth", "-1"), "input_filter_bandwidth=-1.0 is outside its domain: 0..300 (soft)"),
        ((GAIN, "nan"), f"{GAIN}=nan: NaN and infinity cannot be sent"),
        ((GAIN, "-inf"), f"{GAIN}=-inf: NaN and infinity cannot be sent"),
    ],
)
def test_set_refuses_values_outside_the_domain_before_connecting(
    cli: Cli, host_frames: list[Frame], args: tuple[str, ...], message: str
) -> None:
    r = cli("set", "1", *args, "--sim", "1")
    assert r.code == 2 and message in r.err, r.err
    assert r.err.startswith("usage: drempower set ") and "Traceback" not in r.err
    assert r.err.strip().splitlines()[-1].startswith("drempower set: error: argument NAME VALUE: ")
    assert host_frames == []


def test_set_force_writes_outside_a_soft_bound(cli: Cli, sim: SimBus) -> None:
    r = cli("set", "1", STALL, "-5", "--force", "--sim", "1")
    assert r.code == 0, r.err
    assert sim.motors[1].param(STALL) == -5.0


def test_set_force_does_not_pass_a_hard_bound(cli: Cli, host_frames: list[Frame]) -> None:
    r = cli("set", "1", "can.config.protocol", "1", "controller.config.control_mode", "9", "--force", "--sim", "1")
    assert r.code == 2 and "control_mode=9 is out of range: allowed 0..4" in r.err
    assert host_frames == []
    r = cli("set", "1", "axis0.trap_traj.config.traj_mode", "3", "--force", "--sim", "1")
    assert r.code == 2 and "traj_mode=3 is out of range: allowed 1..2" in r.err
    assert host_frames == []
