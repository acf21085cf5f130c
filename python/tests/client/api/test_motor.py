"""Single-motor methods: settings, queries, validation."""

from __future__ import annotations

import pytest

import drempower
from drempower.client import AxisMode, Bus, IdTakenError, NoMotorError, VerifyError
from drempower.protocol import SysCmd, SystemCommand, WriteParam

from ..scripted import FakeMotors, ScriptedTransport


def test_set_id_checks_the_new_id_then_saves(bus: Bus, scripted: ScriptedTransport) -> None:
    m = bus.motor(3).set_id(9, timeout=0.1)  # id 9 is free: its read waits the whole timeout
    assert m.id == 9 and m.get_id() == 9
    assert SystemCommand(9, SysCmd.SAVE_CONFIG) in scripted.commands()


def test_set_id_lost_write_saves_nothing(motors: FakeMotors) -> None:
    def lose_writes(f: object) -> list[object]:
        return [] if f.arbitration_id & 0x1F == 0x1F else motors(f)  # type: ignore[attr-defined]

    t = ScriptedTransport(lose_writes, virtual=True)  # type: ignore[arg-type]
    with Bus(t, timeout=0.1, stop_on_close=False) as bus, pytest.raises(NoMotorError, match="new id 9"):
        bus.motor(3).set_id(9)
    assert not any(isinstance(c, SystemCommand) for c in t.commands())


def test_settings_validate_and_verify(bus: Bus, motors: FakeMotors, scripted: ScriptedTransport) -> None:
    m = bus.motor(1)
    for bad in (
        lambda: m.set_can_baud_rate(300000),
        lambda: m.set_uart_baud_rate(1200),
        lambda: m.set_mode(3),
        lambda: m.set_traj_mode(0),
        lambda: m.set_GPIO_mode("pwm", 1),
        lambda: m.set_GPIO_mode("step_dir", 2000),
        lambda: m.set_angle_range(10, -10),
        lambda: m.write_property("vbus_voltage", 1),  # read-only
        lambda: m.write_property("no.such.thing", 1),
        lambda: m.write_property("axis0.config.can_node_id", -1),
        lambda: m.set_angle(0, 0, 0, 0),  # T bandwidth 0
        lambda: m.set_angle(0, 0, 10, 1),  # Q speed 0
        lambda: m.set_speed(10, 400, 2),
        lambda: m.set_torque(1, 0, 3),
        lambda: m.impedance_control(0, 0, 0, -1, 0),
        lambda: m.step_angle(10, 1, 1, 7),
    ):
        with pytest.raises(drempower.ValidationError):
            bad()
    assert scripted.sent == []
    m.set_can_baud_rate(500000)
    assert motors.params[1][21001] == 500000
    m.set_mode(AxisMode.IDLE)
    assert motors.params[1][30003] == 1
    m.write_property("axis0.output_shaft.vel_limit", 123.25, verify=True)
    assert m.read_property(38012) == 123.25


def test_write_verify_detects_a_refused_write(motors: FakeMotors) -> None:
    def refuse(f: object) -> list[object]:
        if f.arbitration_id & 0x1F == 0x1F:  # type: ignore[attr-defined]
            return []
        return motors(f)  # type: ignore[arg-type]

    with (
        Bus(ScriptedTransport(refuse), timeout=0.02, stop_on_close=False) as bus,  # type: ignore[arg-type]
        pytest.raises(VerifyError, match=r"axis0\.output_shaft\.vel_limit"),
    ):
        bus.motor(1).write_property("axis0.output_shaft.vel_limit", 5, verify=True)


def test_set_angle_range(bus: Bus, motors: FakeMotors) -> None:
    motors.positions[1] = 50.0
    with pytest.raises(drempower.ValidationError, match=r"50\.00 deg"):
        bus.motor(1).set_angle_range(-10, 10)
    bus.motor(1).set_angle_range(-90, 90)
    assert (motors.params[1][38010], motors.params[1][38011], motors.params[1][31202]) == (-90.0, 90.0, 1)


def test_gpio_modes(bus: Bus, motors: FakeMotors, scripted: ScriptedTransport) -> None:
    m = bus.motor(2)
    assert m.get_GPIO_mode().mode == "off"
    m.set_GPIO_mode("step_dir", 512)
    g = m.get_GPIO_mode()
    assert (g.mode, g.enable_uart, g.enable_step_dir, g.param) == ("step_dir", False, True, 512.0)
    system = [c for c in scripted.commands() if isinstance(c, SystemCommand)]
    assert system == [SystemCommand(2, SysCmd.SAVE_CONFIG), SystemCommand(2, SysCmd.REBOOT)]
    m.set_GPIO_mode("tx_rx", 57600)
    assert m.get_GPIO_mode().param == 57600


def test_queries(bus: Bus, motors: FakeMotors) -> None:
    motors.params[1].update({1: 24.0, 33206: -1.5, 30001: 0x4002, 34001: 0x800})
    m = bus.motor(1)
    assert m.get_volcur() == (24.0, -1.5)
    report = m.dump_error()
    assert report
    assert report.flags == {
        "axis0.error": ["DC_BUS_UNDER_VOLTAGE", "ESTOP_REQUESTED"],
        "axis0.encoder.error": ["EDR_BATTERY_LOW"],
    }
    assert "ESTOP_REQUESTED" in str(report)
    assert not bus.motor(2).dump_error()


def test_enable_reply_state_is_remembered(bus: Bus, motors: FakeMotors) -> None:
    bus.motor(1).enable_reply_state()
    assert motors.params[1][31214] == 1 and bus.reply_state[1] is True


def test_system_commands(bus: Bus, scripted: ScriptedTransport) -> None:
    m = bus.motor(4)
    m.clear_error()
    m.save_config()
    m.reboot()
    m.init_config()
    m.erase_config()
    m.set_zero_position()
    m.estop()
    ops = [c.op for c in scripted.commands() if isinstance(c, SystemCommand)]
    assert ops == [
        SysCmd.CLEAR_ERRORS,
        SysCmd.SAVE_CONFIG,
        SysCmd.REBOOT,
        SysCmd.INIT_CONFIG,
        SysCmd.ERASE_CONFIG,
        SysCmd.SET_ZERO_POSITION,
        SysCmd.ESTOP,
    ]
    assert all(isinstance(c, (SystemCommand, WriteParam)) for c in scripted.commands())


def test_remembered_parameters_follow_every_write_and_reset(bus: Bus) -> None:
    core = bus._core.session.known
    bus.send(WriteParam.of(1, "axis0.trap_traj.config.traj_mode", 2))  # however it is sent
    assert core.traj_mode == {1: 2}
    bus.motor(2).get_traj_mode()
    bus.motor(2).enable_reply_state(True)
    assert core.traj_mode == {1: 2, 2: 1} and core.reply_state == {2: True}
    bus.motor(1).reboot()
    assert core.traj_mode == {2: 1}
    bus.motor(0).write_property("axis0.trap_traj.config.traj_mode", 2)  # every motor: values unknown now
    assert core.traj_mode == {} and core.reply_state == {2: True}
    bus.send(SystemCommand(0, SysCmd.INIT_CONFIG))
    assert core.reply_state == {}


def test_set_id_never_makes_two_motors_share_an_id() -> None:
    from drempower.sim import SimBus

    from ..links import Recorder, link

    sim = SimBus(ids=[1, 2])
    rec = Recorder(sim)
    with link("inprocess", sim, timeout=0.1) as bus:
        with pytest.raises(IdTakenError, match="id 1 is already taken"):
            bus.motor(2).set_id(1)
        with pytest.raises(NoMotorError, match="no motor answers at id 3"):
            bus.motor(3).set_id(5)
        assert not any(f.arbitration_id & 0x1F == 0x1F for f in rec.frames)  # nothing written
        bus.motor(2).set_id(7)
        assert [m.id for m in bus.scan()] == [1, 7]
