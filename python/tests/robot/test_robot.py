"""The threaded robot over simulated buses and python-can virtual buses."""

from __future__ import annotations

import dataclasses
import math
import threading
from pathlib import Path

import pytest

import drempower
from drempower.client import Motor, MotorState
from drempower.client.engine.commands import q_move_time
from drempower.errors import BusClosedError, FieldRangeError, SoftLimitError, TransportError, ValidationError
from drempower.protocol import Preset, ReadParam, Start, SysCmd, SystemCommand, decode_command
from drempower.protocol.limits import MOTION_CMDS
from drempower.protocol.parameters import DataType
from drempower.robot import Gearing, Joint, JointSpec, Robot, open_robot
from drempower.sim import SimBus

from ..client.links import Recorder
from ..waits import eventually


def _sims(robot: Robot) -> dict[str, SimBus]:
    return {name: bus.transport.bus for name, bus in robot.buses.items()}  # type: ignore[attr-defined]


@pytest.fixture
def robot(sim_robot_file: Path) -> Robot:
    r = open_robot(sim_robot_file, sim={"time_scale": 20.0}, timeout=0.5)
    yield r  # type: ignore[misc]
    r.close()


def test_joints_are_motor_handles_on_their_buses(robot: Robot) -> None:
    elbow = robot.joint("elbow")
    assert isinstance(elbow, Joint) and isinstance(elbow, Motor)
    assert elbow.bus is robot.bus("right") and elbow.id == 1 and robot["shoulder"].bus is robot.bus("left")
    assert set(_sims(robot)["left"].motors) == {1, 2} and set(_sims(robot)["right"].motors) == {1}
    assert elbow.get_state().angle == pytest.approx(0.0, abs=0.01)
    js = elbow.get_joint_state()
    assert js.name == "elbow" and js.position == pytest.approx(0.5, abs=1e-3)  # the offset at motor 0 deg
    with pytest.raises(ValidationError, match="joint 'knee': no such joint \\(joints: shoulder, hip, elbow\\)"):
        robot.joint("knee")


def test_gearing_converts_both_ways() -> None:
    g = Gearing(JointSpec("elbow", "right", 1, gear=-2.0, offset=0.5))
    st = MotorState(1, 90.0, 60.0, 1.5, True, False, 0.0)
    js = g.joint_state(st)
    assert js.position == pytest.approx(math.radians(90) / -2 + 0.5)
    assert js.velocity == pytest.approx(2 * math.pi / -2)  # 60 r/min = 2 pi rad/s at the motor
    assert js.torque == pytest.approx(-3.0) and js.motor is st
    assert g.motor_angle(js.position) == pytest.approx(90.0)
    assert g.motor_speed(js.velocity) == pytest.approx(60.0)
    assert g.motor_torque(js.torque) == pytest.approx(1.5)
    assert g.motor_step(0.1) == pytest.approx(math.degrees(-0.2))


def test_synchronised_move_shares_one_move_time_and_reports_the_start_skew(robot: Robot) -> None:
    recs = {name: Recorder(sim) for name, sim in _sims(robot).items()}
    before = robot.bus("left").on_sent
    move = robot.set_angles({"shoulder": 90.0, "hip": 45.0, "elbow": -30.0}, speed=30.0, param=100.0)
    assert move.move_time == math.ceil(q_move_time(90.0, 30.0, 100.0) * 100) / 100
    assert set(move.starts) == {"left", "right"}
    assert move.skew == max(move.starts.values()) - min(move.starts.values()) >= 0
    for name, rec in recs.items():
        msgs = [decode_command(f.arbitration_id, f.data) for f in rec.frames]
        presets = [m for m in msgs if isinstance(m, Preset)]
        starts = [m for m in msgs if isinstance(m, Start)]
        assert presets and {p.p2 for p in presets} == {move.move_time}, name  # Q preset: target, time, accel
        assert len(starts) == 1 and msgs[-1] == starts[0], name  # the start follows the presets
    done = robot.positions_done(timeout=10)
    assert done["shoulder"].angle == pytest.approx(90.0, abs=0.1)
    assert done["hip"].angle == pytest.approx(45.0, abs=0.1)
    assert done["elbow"].angle == pytest.approx(-30.0, abs=0.1)
    assert robot.bus("left").on_sent is before


def test_move_joints_in_si_units_through_gear_and_offset(robot: Robot) -> None:
    move = robot.move_joints({"shoulder": 0.3, "elbow": 0.2}, speed=2.0, accel=10.0)
    with pytest.raises(FieldRangeError, match=r"param \(accel\) \(joint elbow\)=381.97"):
        robot.move_joints({"elbow": 0.0}, speed=2.0, accel=20.0)  # 20 rad/s² x gear 2 is beyond the field
    assert move.move_time is not None
    robot.positions_done(["shoulder", "elbow"], timeout=10)
    js = robot.joint_states()
    assert js["shoulder"].position == pytest.approx(0.3, abs=2e-3)
    assert js["elbow"].position == pytest.approx(0.2, abs=2e-3)
    assert js["elbow"].motor.angle == pytest.approx(math.degrees((0.2 - 0.5) * -2.0), abs=0.1)
    assert js["hip"].position == pytest.approx(0.0, abs=2e-3)


def test_nothing_is_sent_on_any_bus_when_one_value_is_invalid(robot: Robot) -> None:
    recs = {name: Recorder(sim) for name, sim in _sims(robot).items()}
    with pytest.raises(ValidationError, match="joint elbow: angle_list=nan"):
        robot.set_angles({"shoulder": 10.0, "elbow": math.nan}, speed=10.0, param=10.0)
    with pytest.raises(ValidationError, match="joint 'knee'"):
        robot.set_angles({"shoulder": 10.0, "knee": 1.0})
    with pytest.raises(FieldRangeError, match=r"param \(accel\) \(joint shoulder\)=-1"):
        robot.set_angles({"shoulder": 10.0, "elbow": 1.0}, speed=10.0, param=-1.0)
    with pytest.raises(FieldRangeError, match=r"angle_list \(motor 1\) \(joint elbow\)=1e\+40"):
        robot.set_angles({"shoulder": 10.0, "elbow": 1e40}, speed=10.0, param=10.0)
    with pytest.raises(ValidationError, match="joint shoulder: angle_list='x'"):
        robot.set_angles({"shoulder": "x", "elbow": 1.0})  # type: ignore[dict-item]
    with pytest.raises(ValidationError, match=r"position of joint elbow \(rad\)='x'"):
        robot.move_joints({"elbow": "x"}, speed=1.0, accel=1.0)  # type: ignore[dict-item]
    with pytest.raises(ValidationError, match=r"speed \(rad/s\)=nan"):
        robot.move_joints({"elbow": 0.1}, speed=math.nan, accel=1.0)
    assert all(rec.frames == [] for rec in recs.values())


def test_cycle_across_buses_returns_each_joints_state(robot: Robot) -> None:
    sh, el = robot.joint("shoulder"), robot.joint("elbow")
    states = robot.cycle({"elbow": el.make_speed(5.0), "shoulder": sh.make_angle(10.0, 0.0, 20.0, 0)})
    assert list(states) == ["elbow", "shoulder"]
    assert states["elbow"].node == 1 and states["shoulder"].node == 1
    with pytest.raises(ValidationError, match="joint 'elbow' is motor 1; the message is for 2"):
        robot.cycle({"elbow": robot.joint("hip").make_speed(1.0)})
    recs = {name: Recorder(sim) for name, sim in _sims(robot).items()}
    bad = dataclasses.replace(el.make_angle(10.0, 0.0, 20.0, 0), position=math.inf)
    with pytest.raises(FieldRangeError, match=r"position \(joint elbow\)=inf"):
        robot.cycle({"shoulder": sh.make_speed(1.0), "elbow": bad})
    with pytest.raises(ValidationError, match="joint 'shoulder': a control cycle sends commands"):
        robot.cycle({"shoulder": ReadParam(1, 31001, DataType.U32)})
    assert all(rec.frames == [] for rec in recs.values())  # nothing sent on any bus


def test_estop_reaches_every_bus_even_when_one_failed(robot: Robot) -> None:
    recs = {name: Recorder(sim) for name, sim in _sims(robot).items()}
    robot.estop()
    for rec in recs.values():
        assert [decode_command(f.arbitration_id, f.data) for f in rec.frames] == [SystemCommand(0, SysCmd.ESTOP)]
    robot.bus("left").close()
    with pytest.raises(BusClosedError):
        robot.estop(["shoulder", "elbow"])
    assert decode_command(recs["right"].frames[-1].arbitration_id, recs["right"].frames[-1].data) == SystemCommand(
        1, SysCmd.ESTOP
    )


def test_a_closed_robot_refuses_work(sim_robot_file: Path) -> None:
    robot = open_robot(sim_robot_file, sim={"time_scale": 20.0})
    robot.close()
    robot.close()  # idempotent
    assert robot.closed and all(b.closed for b in robot.buses.values())
    with pytest.raises(BusClosedError, match=r"robot .* is closed"):
        robot.get_states()
    with pytest.raises(BusClosedError):
        robot.estop()


def test_positions_done_times_out_naming_the_moving_joint(robot: Robot) -> None:
    robot.joint("elbow").set_angle(3000.0, 10.0, 10.0, 1)  # minutes of travel in Q mode
    with pytest.raises(drempower.TimeoutError, match="still moving") as info:
        robot.positions_done(["elbow", "shoulder"], timeout=0.2)
    notes = getattr(info.value, "__notes__", ["(on bus 'right')"])
    assert "(on bus 'right')" in notes


def test_a_bus_that_cannot_open_is_named_and_the_others_are_closed(tmp_path: Path) -> None:
    path = tmp_path / "r.toml"
    path.write_text(
        "[buses.ok]\ninterface='sim'\n[buses.gone]\ninterface='adapter'\nchannel='"
        + str(tmp_path / "no-such-port")
        + "'\n[joints.a]\nbus='ok'\nid=1\n[joints.b]\nbus='gone'\nid=1\n"
    )
    before = {t.name for t in threading.enumerate()}
    with pytest.raises(TransportError, match=r"\[buses.gone\]: cannot open vendor USB-CAN adapter"):
        open_robot(path)
    after = {t.name for t in threading.enumerate() if t.is_alive()}
    assert not {n for n in after - before if n.startswith("drempower rx")}


def test_virtual_buses_with_attached_simulators(virtual_robot: tuple[Path, dict[str, SimBus]]) -> None:
    path, sims = virtual_robot
    with open_robot(path, stop_on_close=False) as robot:
        assert robot.bus("left").transport.description.startswith("python-can")
        move = robot.set_angles({"a": 20.0, "b": -40.0}, speed=60.0, param=300.0)
        assert move.move_time == math.ceil(q_move_time(40.0, 60.0, 300.0) * 100) / 100 and move.skew >= 0
        done = robot.positions_done(timeout=10)
        assert done["a"].angle == pytest.approx(20.0, abs=0.1) and done["b"].angle == pytest.approx(-40.0, abs=0.1)
        assert sims["left"].motors[1].position == pytest.approx(20.0, abs=0.1)
        assert robot.joint_states(["b"])["b"].position == pytest.approx(math.radians(-40.0) / 10, abs=1e-3)
        robot.estop()
    # the simulators take the estop frames on threads of their own
    assert eventually(lambda: sims["left"].motors[1].axis_error and sims["right"].motors[3].axis_error)


def test_a_cycle_sends_nothing_on_any_bus_when_one_buss_gate_refuses(robot: Robot) -> None:
    """The soft limit of a joint on one bus refuses the whole cycle before the other bus sends its part."""
    sh, el = robot.joint("shoulder"), robot.joint("elbow")
    for name, bus in robot.buses.items():
        bus.enable(sorted(_sims(robot)[name].motors))
    robot.bus("right").set_limits(1, position=(-30.0, 30.0))  # the elbow's motor, in motor degrees
    recs = {name: Recorder(sim) for name, sim in _sims(robot).items()}
    with pytest.raises(SoftLimitError, match="motor 1: position 45 deg is beyond its soft limit"):
        robot.cycle({"shoulder": sh.make_angle(10.0, 0.0, 20.0, 0), "elbow": el.make_angle(45.0, 0.0, 20.0, 0)})
    motion = set(MOTION_CMDS)
    assert not [f for rec in recs.values() for f in rec.frames if f.arbitration_id & 0x1F in motion]
    states = robot.cycle({"shoulder": sh.make_angle(10.0, 0.0, 20.0, 0), "elbow": el.make_angle(20.0, 0.0, 20.0, 0)})
    assert set(states) == {"shoulder", "elbow"}
