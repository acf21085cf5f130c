"""Parameter writes are checked against each parameter's domain (spec/parameters.csv) before anything is sent."""

from __future__ import annotations

import dataclasses
import struct

import pytest

import drempower.compat as compat
from drempower.client import AsyncBus, Bus
from drempower.client.engine.backup import ConfigBackup
from drempower.errors import BackupFileError, FieldRangeError, ValidationError
from drempower.protocol import WriteParam, parameter, parameters
from drempower.protocol.addresses import (
    AXIS0_CONFIG_CAN_NODE_ID,
    AXIS0_CONTROLLER_CONFIG_POS_GAIN,
    AXIS0_REQUESTED_STATE,
)
from drempower.protocol.parameters import DomainError
from drempower.sim.defaults import FACTORY

from ..scripted import FakeMotors, ScriptedTransport

REFUSED = [
    ("axis0.config.can_node_id", 64, "1..63 (hard)"),
    ("axis0.config.can_node_id", 0, "1..63 (hard)"),
    ("axis0.requested_state", 3, "one of 1, 8 (soft)"),
    ("axis0.config.extra_setting.stall_current_limit", -5, ">= 0 (soft, inferred)"),
    ("axis0.controller.config.pos_gain", 1e30, "0..1000 (soft, inferred)"),
    ("can.config.baud_rate", 123456, "one of 125000, 250000, 500000, 1e+06 (hard)"),
    ("axis0.controller.config.input_filter_bandwidth", 301, "0..300 (soft)"),
    ("axis0.config.extra_setting.enable_reply_state", 2, "one of 0, 1 (hard)"),
]


@pytest.mark.parametrize(("name", "value", "domain"), REFUSED)
def test_a_value_outside_the_domain_is_refused_before_sending(name: str, value: float, domain: str) -> None:
    t = ScriptedTransport(FakeMotors([1]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus, pytest.raises(DomainError) as info:
        bus.motor(1).write_property(name, value)
    assert t.sent == []
    assert str(info.value).startswith(f"{name}={value!r} is outside its domain: {domain}")
    assert info.value.field == name and info.value.value == value
    assert isinstance(info.value, FieldRangeError)  # callers catching the range error see it too


def test_force_writes_outside_a_soft_bound_as_given() -> None:
    t = ScriptedTransport(FakeMotors([1]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        m = bus.motor(1)
        m.write_property("axis0.controller.config.pos_gain", 1e30, force=True)
        m.write_property(AXIS0_REQUESTED_STATE, 3, force=True)  # a calibration state
    assert [(f.arbitration_id, f.data.hex()) for f in t.sent] == [
        (0x03F, struct.pack("<HHf", AXIS0_CONTROLLER_CONFIG_POS_GAIN, 0, 1e30).hex()),
        (0x03F, "3375030003000000"),
    ]


@pytest.mark.parametrize(
    ("name", "value", "error"),
    [
        ("axis0.config.can_node_id", 64, DomainError),  # hard: the id field has 6 bits
        ("can.config.baud_rate", 123456, DomainError),
        ("axis0.requested_state", 12, FieldRangeError),  # not an AxisState at all
        ("axis0.controller.config.pos_gain", 1e39, FieldRangeError),  # beyond float32
        ("axis0.controller.config.pos_gain", float("nan"), ValidationError),
        ("axis0.controller.config.pos_gain", [1], ValidationError),
        ("axis0.controller.config.pos_gain", "1", ValidationError),
    ],
)
def test_force_never_passes_a_hard_bound_or_the_wire_range(name: str, value: object, error: type[Exception]) -> None:
    t = ScriptedTransport(FakeMotors([1]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus, pytest.raises(error, match=name.split(".")[-1]):
        bus.motor(1).write_property(name, value, force=True)  # type: ignore[arg-type]
    assert t.sent == []


async def test_the_async_api_checks_the_same_domains() -> None:
    t = ScriptedTransport(FakeMotors([1]))
    async with AsyncBus(t, timeout=0.25, stop_on_close=False) as bus:
        with pytest.raises(DomainError, match=r"can_node_id=64 is outside its domain: 1\.\.63"):
            await bus.motor(1).write_property(AXIS0_CONFIG_CAN_NODE_ID, 64)
        assert t.sent == []
        await bus.motor(1).write_property("axis0.config.extra_setting.stall_current_limit", -5, force=True)
    assert [f.data.hex() for f in t.sent] == [struct.pack("<HHf", 31209, 0, -5).hex()]


def test_compat_write_property_is_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    t = ScriptedTransport(FakeMotors([1]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        monkeypatch.setattr(compat, "_m", bus.motor)
        with pytest.raises(DomainError, match="stall_current_limit=-5"):
            compat.write_property(1, "axis0.config.extra_setting.stall_current_limit", -5)
        compat.write_property(1, "axis0.config.extra_setting.stall_current_limit", 5)
    assert len(t.sent) == 1


def test_restore_refuses_a_value_outside_its_domain(motors: FakeMotors) -> None:
    t = ScriptedTransport(motors)
    motors.params[1][32108] = 40.0
    motors.params[1][31209] = 10.0
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        good = bus.motor(1).backup()
        records = [
            dataclasses.replace(r, value=1e30) if r.address == 32108 else r
            for r in good.parameters
            if r.address in (32108, 31209)
        ]
        bad = ConfigBackup(node=1, created=good.created, parameters=records)
        t.sent.clear()
        with pytest.raises(BackupFileError) as info:
            bus.motor(1).restore(bad)
    assert [(name, why.split(":")[0]) for name, why in info.value.problems] == [
        ("axis0.controller.config.pos_gain", "axis0.controller.config.pos_gain=1e+30 is outside its domain")
    ]
    assert not t.sent  # refused before any frame


def test_writes_build_only_from_checked_values() -> None:
    assert WriteParam.of(1, "axis0.config.can_node_id", 63).value == 63
    assert WriteParam.of(1, "axis0.config.extra_setting.enable_reply_state", True).value == 1
    with pytest.raises(DomainError):
        WriteParam.of(1, "axis0.config.can_node_id", 64, force=True)
    assert WriteParam.of(1, "axis0.controller.config.pos_gain", 2000, force=True).value == 2000.0


def test_every_writable_parameter_has_a_domain_source_and_the_factory_values_lie_inside() -> None:
    """The simulator's factory configuration is writable as it is, so a backup of a fresh motor restores."""
    for name, value in FACTORY.items():
        p = parameter(name)
        assert p.check(value) == value, name
    for p in parameters():
        if p.is_bool and p.writable:
            assert p.allowed == (0, 1) and p.hard, p.name
        if not p.writable:
            assert not p.has_domain, p.name
    hard = {p.name for p in parameters() if p.hard}
    assert {"axis0.config.can_node_id", "can.config.baud_rate", "config.uart_baudrate"} <= hard
    assert "axis0.controller.config.pos_gain" not in hard
    assert parameter("axis0.controller.config.pos_gain").inferred
    assert not parameter("axis0.config.can_node_id").inferred


def test_raw_writes_sent_with_send_are_checked_too() -> None:
    from drempower.protocol import DataType

    t = ScriptedTransport(FakeMotors([1]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        with pytest.raises(DomainError, match="can_node_id=64"):
            bus.send(WriteParam(1, AXIS0_CONFIG_CAN_NODE_ID, DataType.U32, 64))
        with pytest.raises(DomainError, match="pos_gain=-1"):
            bus.send_many([WriteParam(1, 31209, DataType.F32, 1.0), WriteParam(1, 32108, DataType.F32, -1.0)])
        assert t.sent == []
        bus.send(WriteParam(1, 40000, DataType.U32, 7))  # an address outside the table goes as given
    assert len(t.sent) == 1


async def test_raw_writes_are_checked_in_the_async_api() -> None:
    from drempower.protocol import DataType

    t = ScriptedTransport(FakeMotors([1]))
    async with AsyncBus(t, timeout=0.25, stop_on_close=False) as bus:
        with pytest.raises(DomainError, match="requested_state=3"):
            await bus.send(WriteParam(1, AXIS0_REQUESTED_STATE, DataType.U32, 3))
        with pytest.raises(DomainError):
            await bus.send_many([WriteParam(1, AXIS0_CONFIG_CAN_NODE_ID, DataType.U32, 0)])
    assert t.sent == []
