"""One home for the protocol's limits: node ids, command sets, the bounds of speed and torque."""

from __future__ import annotations

import pytest

import drempower
from drempower.client.engine import session
from drempower.client.engine.commands import make_speed, make_speeds, make_torque, make_torques
from drempower.errors import FieldRangeError
from drempower.protocol import limits
from drempower.protocol.ids import Cmd, Frame
from drempower.protocol.messages import S16_MAX, S16_MIN
from drempower.transports import zenoh_wire


def test_one_definition_of_the_motion_commands() -> None:
    assert session.MOTION_CMDS is limits.MOTION_CMDS
    assert zenoh_wire.MOTION_CMDS is limits.MOTION_CMDS  # the remote clients' driven motors
    assert {0x0C, 0x19, 0x1A, 0x1B, 0x1C, 0x1D} == limits.MOTION_CMDS
    assert Cmd.READ not in limits.MOTION_CMDS and Cmd.WRITE not in limits.MOTION_CMDS
    assert set(range(0x10, 0x16)) == limits.START_SYS_CMDS


def test_the_s16_range_is_defined_once() -> None:
    assert (S16_MIN, S16_MAX) == (limits.S16_MIN, limits.S16_MAX) == limits.SPEED_RANGE == limits.TORQUE_RANGE


@pytest.mark.parametrize("node", [0, 64, -1, True, 1.0, "1", None])
def test_check_motor_refuses_what_is_no_motor(node: object) -> None:
    with pytest.raises(FieldRangeError, match=r"^id=.* is out of range: allowed 1\.\.63 \(motor ids are 1\.\.63"):
        limits.check_motor(node)


def test_check_motor_takes_every_motor_id() -> None:
    assert [limits.check_motor(i) for i in limits.MOTOR_IDS] == list(range(1, 64))


@pytest.mark.parametrize(
    ("call", "field", "value"),
    [
        (lambda: make_speed(1, -1e30), "speed", -1e30),
        (lambda: make_speed(1, 327.69), "speed", 327.69),
        (lambda: make_torque(1, 3e38), "torque", 3e38),
        (lambda: make_torque(1, -327.7, 5, 6), "torque", -327.7),
        (lambda: make_speeds([1, 2], [10, 400]), "speed_list (motor 2)", 400),
        (lambda: make_torques([1, 2], [-1e9, 1]), "torque_list (motor 1)", -1e9),
    ],
)
def test_speed_and_torque_beyond_the_s16_range_are_refused(call, field: str, value: float) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(FieldRangeError) as info:
        call()
    err = info.value
    assert (err.field, err.value, err.low, err.high) == (field, value, -327.68, 327.67)
    assert f"{field}={value!r} is out of range: allowed -327.68..327.67" in str(err)


def test_the_range_edges_are_sent() -> None:
    assert make_speed(1, 327.67).speed == 327.67
    assert make_torque(1, -327.68).torque == -327.68


def test_nothing_is_sent_for_a_huge_torque_or_speed() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as bus:
        simbus = bus.transport.bus  # type: ignore[attr-defined]
        sent: list[Frame] = []
        send = simbus.send

        def recording(frame: Frame, origin: object = None) -> None:
            sent.append(frame)
            send(frame, origin)

        simbus.send = recording
        with pytest.raises(FieldRangeError, match=r"torque=3e\+38 is out of range"):
            bus.motor(1).set_torque(3e38)
        with pytest.raises(FieldRangeError, match=r"speed=-1e\+30 is out of range"):
            bus.motor(1).set_speed(-1e30)
        assert sent == []
