"""Parameter reads and writes: every address, types, conversions, access, ids."""

from __future__ import annotations

import pytest

from drempower.protocol import (
    DataType,
    FastRead,
    ParamValue,
    ReadParam,
    SysCmd,
    SystemCommand,
    WriteParam,
    parameters,
)
from drempower.protocol.ids import Frame
from drempower.sim import SimBus

from .helpers import exchange, fast_read, read, write


def test_every_parameter_answers_in_its_type_with_the_request_id() -> None:
    bus = SimBus([5])
    for p in parameters():
        (answer,) = exchange(bus, ReadParam(5, p.address, p.dtype))
        assert isinstance(answer, ParamValue)
        assert (answer.node, answer.address, answer.dtype) == (5, p.address, p.dtype)
        assert isinstance(answer.value, float if p.dtype is DataType.F32 else int)


def test_read_reply_echoes_the_request_id() -> None:
    bus = SimBus([4])
    answers: list[int] = []
    bus.add_listener(lambda f: answers.append(f.arbitration_id))
    bus.send(ReadParam.of(4, "axis0.output_shaft.pos_estimate").encode())
    assert answers == [(4 << 5) | 0x1E]


def test_defaults_of_a_typical_joint() -> None:
    bus = SimBus([1])
    assert read(bus, 1, "axis0.config.extra_setting.gear_ratio") == 10.0
    assert read(bus, 1, "axis0.output_shaft.vel_limit") == pytest.approx(300.0)
    assert read(bus, 1, "axis0.output_shaft.torque_lim") == pytest.approx(12.0)
    assert read(bus, 1, "axis0.trap_traj.config.traj_mode") == 1
    assert read(bus, 1, "axis0.config.extra_setting.enable_reply_state") == 0
    assert read(bus, 1, "can.config.baud_rate") == 1_000_000
    assert read(bus, 1, "axis0.current_state") == 8
    assert read(bus, 1, "vbus_voltage") == pytest.approx(24.0)


def test_unknown_address_gets_no_reply() -> None:
    assert exchange(SimBus([1]), ReadParam(1, 12345, DataType.U32)) == []


def test_read_in_another_type_is_converted() -> None:
    bus = SimBus([1])
    (a,) = exchange(bus, ReadParam(1, 31208, DataType.U32))  # gear ratio, f32 in the table
    assert a == ParamValue(1, 31208, DataType.U32, 10)
    (b,) = exchange(bus, ReadParam(1, 31001, DataType.F32))  # node id, u32 in the table
    assert b == ParamValue(1, 31001, DataType.F32, 1.0)
    (c,) = exchange(bus, ReadParam(1, 31214, DataType.U16))  # bool as u16, as the C library reads
    assert c == ParamValue(1, 31214, DataType.U16, 0)
    write(bus, 1, "axis0.output_shaft.circular_setpoint_min", -7.9)
    (d,) = exchange(bus, ReadParam(1, 38010, DataType.U32))  # negative float as unsigned saturates
    assert d == ParamValue(1, 38010, DataType.U32, 0)
    (e,) = exchange(bus, ReadParam(1, 38010, DataType.S16))  # truncates toward zero
    assert e == ParamValue(1, 38010, DataType.S16, -7)


def test_writes_are_not_answered_and_change_ram() -> None:
    bus = SimBus([1])
    assert exchange(bus, WriteParam.of(1, "axis0.controller.config.pos_gain", 25.0)) == []
    assert read(bus, 1, "axis0.controller.config.pos_gain") == 25.0


def test_system_commands_are_not_answered() -> None:
    bus = SimBus([1])
    for op in SysCmd:
        if op < 0x08:
            assert exchange(bus, SystemCommand(1, op)) == []


def test_write_in_another_type_is_converted() -> None:
    bus = SimBus([1])
    exchange(bus, WriteParam(1, 31214, DataType.U16, 1))  # bool written as u16
    assert read(bus, 1, "axis0.config.extra_setting.enable_reply_state") == 1
    exchange(bus, WriteParam(1, 32108, DataType.U32, 30))  # f32 parameter written as u32
    assert read(bus, 1, 32108) == 30.0


def test_read_only_and_unknown_writes_are_ignored() -> None:
    bus = SimBus([1])
    before = read(bus, 1, "vbus_voltage")
    exchange(bus, WriteParam(1, 1, DataType.F32, 3.0), WriteParam(1, 40000, DataType.U32, 1))
    assert read(bus, 1, "vbus_voltage") == before


def test_output_views_follow_the_rotor_parameters() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.output_shaft.vel_limit", 120.0)  # r/min at the output
    assert read(bus, 1, "axis0.controller.config.vel_limit") == pytest.approx(20.0)  # rotor turn/s at 10:1
    write(bus, 1, "axis0.config.extra_setting.gear_ratio", 50.0)
    assert read(bus, 1, "axis0.output_shaft.vel_limit") == pytest.approx(24.0)
    write(bus, 1, "axis0.output_shaft.torque_lim", 30.0)
    assert read(bus, 1, "axis0.motor.config.torque_lim") == pytest.approx(0.6)


def test_invalid_gear_ratio_and_bitrate_are_ignored() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.config.extra_setting.gear_ratio", 0.0)
    write(bus, 1, "can.config.baud_rate", 123456)
    assert read(bus, 1, "axis0.config.extra_setting.gear_ratio") == 10.0
    assert read(bus, 1, "can.config.baud_rate") == 1_000_000


def test_new_node_id_takes_effect_at_once() -> None:
    bus = SimBus([1, 2])
    write(bus, 1, "axis0.config.can_node_id", 9)
    assert exchange(bus, ReadParam.of(1, 31001)) == []
    assert read(bus, 9, "axis0.config.can_node_id") == 9
    assert bus.motors[1].node_id == 9
    for bad in (0, 64):
        exchange(bus, WriteParam(9, 31001, DataType.U32, bad))
    assert bus.motors[1].node_id == 9


def test_broadcast_read_is_answered_by_every_motor_with_its_own_id() -> None:
    bus = SimBus([1, 2, 3])
    answers = exchange(bus, ReadParam.of(0, "axis0.config.can_node_id"))
    assert [(a.node, a.value) for a in answers] == [(1, 1), (2, 2), (3, 3)]  # type: ignore[union-attr]
    assert [s.node for s in exchange(bus, FastRead(0))] == [1, 2, 3]
    assert fast_read(bus, 2).node == 2


def test_input_parameters_act_as_passthrough_commands() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.output_shaft.input_pos", 45.0)
    bus.advance(1.0)
    assert bus.motors[1].position == pytest.approx(45.0, abs=0.1)
    assert read(bus, 1, "axis0.output_shaft.input_pos") == pytest.approx(45.0)
    write(bus, 1, "axis0.output_shaft.input_vel", 30.0)
    bus.advance(0.5)
    assert bus.motors[1].speed == pytest.approx(30.0, abs=0.1)
    assert read(bus, 1, "axis0.controller.config.control_mode") == 2


def test_malformed_frames_are_ignored() -> None:
    bus = SimBus([1])
    answers: list[Frame] = []
    bus.add_listener(answers.append)
    bus.send(Frame(0x03E, bytes(4)))  # short read
    bus.send(Frame(0x03C, bytes(6) + b"\x03\x00"))  # velocity mode 3
    bus.send(Frame(0x03E, bytes(8), is_remote=True))
    bus.send(Frame(0x03E, bytes(8), is_extended=True))
    assert answers == []


def test_float_reads_saturate_to_the_float32_range() -> None:
    bus = SimBus([1])
    bus.motors[1].set_param("axis0.config.extra_setting.circular_setpoint_max", 3.0e38)  # rotor turns
    assert read(bus, 1, "axis0.output_shaft.circular_setpoint_max") == pytest.approx(3.4028234663852886e38)
