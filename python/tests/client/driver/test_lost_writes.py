"""A parameter write lost on the bus gets no reply: with ``retries`` a verified write that reads back
different is written and read again (write_property, write_verified, restore)."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

import drempower
from drempower.sim import Faults, SimBus

from ..links import Recorder, link, lose

WRITE = 0x1F
POS_GAIN = "axis0.controller.config.pos_gain"


def _pos_gain(sim: SimBus, node: int) -> float:
    return float(sim.motors[node].param(POS_GAIN))


def test_a_lost_verified_write_is_written_again() -> None:
    sim = SimBus(ids=[1])
    gone = lose(sim, lambda f: f.arbitration_id == 1 << 5 | WRITE)
    with link("inprocess", sim, timeout=0.2, retries=1) as bus:
        bus.motor(1).write_property(POS_GAIN, 42, verify=True)
    assert len(gone) == 1 and _pos_gain(sim, 1) == 42


def test_without_retries_a_lost_write_fails_its_verification() -> None:
    sim = SimBus(ids=[1])
    lose(sim, lambda f: f.arbitration_id == 1 << 5 | WRITE)
    error = pytest.raises(drempower.VerifyError, match=r"motor 1: axis0.controller.config.pos_gain reads .* 42")
    with link("inprocess", sim, timeout=0.2) as bus, error:
        bus.motor(1).write_property(POS_GAIN, 42, verify=True)


def test_write_verified_writes_again_only_what_reads_wrong() -> None:
    sim = SimBus(ids=[1])
    seen = itertools.count(1)
    gone = lose(sim, lambda f: f.arbitration_id == 1 << 5 | WRITE and next(seen) == 2)
    rec = Recorder(sim)  # sees every frame the client sends, the lost one too
    with link("inprocess", sim, timeout=0.2, retries=2) as bus:
        bus.motor(1).set_angle_range(-90, 90)
    writes = [f for f in rec.frames if f.arbitration_id == 1 << 5 | WRITE]
    assert len(gone) == 1 and gone[0] == writes[1]
    assert len(writes) == 4 and writes[3] == writes[1]  # three writes, then the lost second one again


def test_retries_end_with_the_verify_error() -> None:
    sim = SimBus(ids=[1])
    lose(sim, lambda f: f.arbitration_id == 1 << 5 | WRITE, count=99)
    with link("inprocess", sim, timeout=0.2, retries=2) as bus, pytest.raises(drempower.VerifyError, match="pos_gain"):
        bus.motor(1).write_property(POS_GAIN, 42, verify=True)


def test_restore_writes_a_lost_write_again(tmp_path: Path) -> None:
    sim = SimBus(ids=[1])
    path = tmp_path / "m1.json"
    with link("inprocess", sim, timeout=0.2, retries=2) as bus:
        bus.motor(1).backup().save(path)
        sim.motors[1].set_param(POS_GAIN, 7.0)
        gone = lose(sim, lambda f: f.arbitration_id == 1 << 5 | WRITE)
        report = bus.motor(1).restore(path)
    assert len(gone) == 1 and not report.failed and _pos_gain(sim, 1) != 7.0


def test_restore_without_retries_reports_the_lost_write(tmp_path: Path) -> None:
    sim = SimBus(ids=[1])
    path = tmp_path / "m1.json"
    with link("inprocess", sim, timeout=0.2) as bus:
        bus.motor(1).backup().save(path)
        sim.motors[1].set_param(POS_GAIN, 7.0)
        lose(sim, lambda f: f.arbitration_id == 1 << 5 | WRITE)
        report = bus.motor(1).restore(path)
    assert [name for name, _ in report.failed] == [POS_GAIN] and _pos_gain(sim, 1) == 7.0


@pytest.mark.parametrize("seed", [3, 4, 5, 6])
def test_verified_writes_on_a_lossy_bus(seed: int) -> None:
    sim = SimBus(ids=[1], faults=Faults(drop_rate=0.1), seed=seed)
    with link("inprocess", sim, timeout=0.05, retries=6) as bus:
        for value in range(30, 50):
            bus.motor(1).write_property(POS_GAIN, value, verify=True)
            assert _pos_gain(sim, 1) == value
