"""The twin's interfaces: the hand from outside, determinism, buses sharing one twin, the robot file's keys."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest

import drempower
from drempower.client.engine.effects import sleep
from drempower.errors import ConfigError, ValidationError
from drempower.robot import load_robot
from drempower.sim import SimBus
from drempower.sim.twin import couple_robot, twin_of

from .conftest import PENDULUM_GAINS, ROBOTS, robot_file

_ARM = ("base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll")


def test_a_push_on_a_body_turns_the_joint_for_its_duration(tmp_path: Path) -> None:
    path = robot_file(tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1, "friction": "model"}})
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        joint = robot.joint("swing")
        joint.set_mode(1)
        twin.push(body="arm", force=(-5.0, 0.0, 0.0), duration=0.2)  # 1.25 Nm about +y at the centre of mass
        assert len(twin.pushes) == 1
        robot.bus("can0").run(sleep(0.1))
        assert joint.get_joint_state().velocity > 0.1
        robot.bus("can0").run(sleep(0.15))
        assert twin.pushes == []
        assert joint.get_joint_state().position > math.radians(1.0)


def test_the_hand_refuses_what_it_cannot_do(tmp_path: Path) -> None:
    path = robot_file(tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1}})
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        with pytest.raises(ValidationError, match=r"body='hand'.*\(stand, arm\)"):
            twin.push(body="hand", force=(1, 0, 0))
        with pytest.raises(ValidationError, match=r"force=\(1, 0\): expected 3 finite numbers"):
            twin.push(body="arm", force=(1, 0))
        with pytest.raises(ValidationError, match=r"duration=0: expected a positive"):
            twin.push(body="arm", force=(1, 0, 0), duration=0)
        with pytest.raises(ValidationError, match=r"joint='elbow': not a hinge of the model \(swing\)"):
            twin.push_joint("elbow", torque=1.0)
        with pytest.raises(ValidationError, match=r"torque=nan"):
            twin.push_joint("swing", torque=math.nan)
        assert twin.pushes == []


def _trace(path: Path) -> list[tuple[float, ...]]:
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        bus = robot.bus("arm")
        robot.joint("shoulder").set_position(0.8)
        robot.joint("elbow").set_position(-0.5)
        out: list[tuple[float, ...]] = []
        for step in range(100):
            if step == 30:
                twin.push(body="forearm", force=(0.0, 8.0, 0.0), duration=0.3)
            bus.run(sleep(0.02))
            for st in robot.get_states().values():
                out.append((st.angle, st.speed, st.torque, st.timestamp))
        return out


def test_the_same_run_gives_the_same_trace() -> None:
    """On the virtual clock the twin is deterministic: two runs, identical states, bit for bit."""
    path = ROBOTS / "arm6_payload.toml"
    first, second = _trace(path), _trace(path)
    assert first == second
    assert max(abs(s[0]) for s in first) > 30.0  # it moved (deg)


def test_buses_of_one_robot_share_one_twin(tmp_path: Path) -> None:
    joints: dict[str, dict[str, object]] = {
        name: {"id": i % 3 + 1, "bus": "a" if i < 3 else "b"} for i, name in enumerate(_ARM)
    }
    path = robot_file(tmp_path, ROBOTS / "arm6.xml", joints, bus="a")
    text = path.read_text().replace("[joints.", '[buses.b]\ninterface = "sim"\n\n[joints.', 1)
    path.write_text(text)
    spec = load_robot(path)
    buses = {"a": SimBus([1, 2, 3]), "b": SimBus([1, 2, 3])}
    twin = couple_robot(spec, buses)
    assert twin is not None and twin_of(buses["a"]) is twin and twin_of(buses["b"]) is twin
    twin.set_joint("wrist_pitch", 0.5)
    assert buses["b"].motors[2].position == pytest.approx(math.degrees(0.5))
    buses["b"].advance(0.5)  # only bus b's clock passes: the twin follows it, bus a's motors see it
    assert twin.time == pytest.approx(0.499)
    assert buses["a"].motors[1].drive.pos == pytest.approx(twin.joint_position("base_yaw") / (2 * math.pi))
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        shared = robot.twin
        assert shared is not None
        sims = [getattr(b.transport, "bus", None) for b in robot.buses.values()]
        assert [twin_of(s) for s in sims if s is not None] == [shared, shared]


@pytest.mark.parametrize(
    ("model", "joint", "error"),
    [
        ('file = "nowhere.xml"', "", r"\[model\]: file='nowhere.xml': no such file"),
        ('file = "pendulum.xml"\nscale = 2', "", r"\[model\]: unknown key 'scale'"),
        ('file = "pendulum.xml"', 'friction = "none"', r"friction='none': one of 'motor', 'model'"),
        ('file = "pendulum.xml"', 'sim_params = {"pos_gain" = 1}', r"sim_params: 'pos_gain' is not a parameter"),
        ('file = "pendulum.xml"', 'sim_params = {"axis0.controller.config.pos_gain" = "x"}', r"expected a finite"),
    ],
)
def test_robot_file_model_keys_are_checked(tmp_path: Path, model: str, joint: str, error: str) -> None:
    (tmp_path / "pendulum.xml").write_text((ROBOTS / "pendulum.xml").read_text())
    path = tmp_path / "r.toml"
    path.write_text(f'[model]\n{model}\n[buses.a]\ninterface = "sim"\n[joints.swing]\nbus = "a"\nid = 1\n{joint}\n')
    with pytest.raises(ConfigError, match=error):
        load_robot(path)


def test_a_joint_missing_from_the_model_is_named(tmp_path: Path) -> None:
    path = robot_file(tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1, "model_joint": "hinge"}})
    with pytest.raises(ConfigError, match=r"joint 'swing': model_joint='hinge' is not a joint of the model \(swing\)"):
        drempower.open_robot(path, sim={"clock": "virtual"})


def test_sim_params_are_the_motors_starting_configuration(tmp_path: Path) -> None:
    path = robot_file(tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1, "sim_params": PENDULUM_GAINS}})
    with drempower.open_bus("sim", robot=path, clock="virtual") as bus:
        motor = bus.motor(1)
        assert motor.read_property("axis0.controller.config.pos_gain") == pytest.approx(10.0)
        motor.reboot()
        bus.run(sleep(1.0))
        assert motor.read_property("axis0.controller.config.pos_gain") == pytest.approx(10.0)


def test_the_twin_runner_keeps_the_buses_in_lockstep(tmp_path: Path) -> None:
    from drempower.sim.twin import TwinRunner

    joints = {name: {"id": i % 3 + 1, "bus": "a" if i < 3 else "b"} for i, name in enumerate(_ARM)}
    path = robot_file(tmp_path, ROBOTS / "arm6.xml", joints, bus="a")
    path.write_text(path.read_text().replace("[joints.", '[buses.b]\ninterface = "sim"\n\n[joints.', 1))
    buses = {"a": SimBus([1, 2, 3]), "b": SimBus([1, 2, 3])}
    twin = couple_robot(load_robot(path), buses)
    assert twin is not None
    gaps: list[float] = []
    with TwinRunner(buses.values(), time_scale=2.0):
        deadline = time.monotonic() + 5.0
        while buses["b"].now < 0.3 and time.monotonic() < deadline:
            with buses["a"].lock, buses["b"].lock:  # between two rounds' bus advances
                gaps.append(abs(buses["a"].now - buses["b"].now))
            time.sleep(0.001)
    assert len(gaps) > 10 and max(gaps) <= 0.001 + 1e-9  # never a step apart
    assert buses["a"].now >= 0.3 and buses["b"].now >= 0.3
    assert abs(buses["a"].now - buses["b"].now) <= 0.001 + 1e-9
    assert twin.time == pytest.approx(min(buses["a"].now, buses["b"].now) - 0.001, abs=0.0011)
    assert buses["a"].on_activity is None and buses["b"].on_activity is None


@pytest.mark.parametrize(("gear", "offset"), [(1.0, 0.0), (-2.0, 0.3)])
def test_the_joint_reads_the_model_angle_through_gear_and_offset(tmp_path: Path, gear: float, offset: float) -> None:
    path = robot_file(tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1, "gear": gear, "offset": offset}})
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        joint = robot.joint("swing")
        joint.set_mode(1)
        for q in (0.0, 0.7, -1.2):
            twin.set_joint("swing", q, velocity=0.5)
            st = joint.get_joint_state()
            assert st.position == pytest.approx(q, abs=1e-6)
            assert st.velocity == pytest.approx(0.5, abs=0.002)  # the state frame carries 0.01 r/min
            assert st.motor.angle == pytest.approx(math.degrees((q - offset) * gear), abs=1e-4)


def test_motors_hold_the_models_starting_pose(tmp_path: Path) -> None:
    """A motor in closed loop from power-up holds where the model starts, whatever the joint's offset."""
    joints = {"swing": {"id": 1, "gear": -2.0, "offset": 0.3, "sim_params": PENDULUM_GAINS}}
    path = robot_file(tmp_path, ROBOTS / "pendulum.xml", joints)
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        robot.bus("can0").run(sleep(1.0))
        st = robot.joint("swing").get_joint_state()
    assert st.position == pytest.approx(0.0, abs=1e-3)
    assert abs(st.velocity) < 1e-3


def test_without_mujoco_the_plain_simulator_runs_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import sys

    from drempower.cli import main

    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco now raises ImportError
    path = robot_file(tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1}})
    with pytest.warns(
        UserWarning, match=r"not simulated \(MuJoCo is not installed\): pip install 'drempower\[physics\]'"
    ):
        robot = drempower.open_robot(path, sim={"clock": "virtual"})
    with robot:
        assert robot.twin is None
        assert robot.joint("swing").get_state().angle == 0.0
    assert main(["sim", "--robot", str(path), "--duration", "0.1"]) == 2  # a missing extra, as every command says it
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'drempower[physics]'" in err


def test_open_robot_runs_a_twins_buses_on_one_clock_until_closed(tmp_path: Path) -> None:
    import threading

    joints = {name: {"id": i % 3 + 1, "bus": "a" if i < 3 else "b"} for i, name in enumerate(_ARM)}
    path = robot_file(tmp_path, ROBOTS / "arm6.xml", joints, bus="a")
    path.write_text(path.read_text().replace("[joints.", '[buses.b]\ninterface = "sim"\n\n[joints.', 1))
    with drempower.open_robot(path, timeout=1.0) as robot:
        sims = [robot.bus(name).transport.bus for name in ("a", "b")]
        robot.joint("wrist_pitch").set_position(0.3)
        gaps = []
        deadline = time.monotonic() + 10.0
        while sims[1].now < 0.5 and time.monotonic() < deadline:
            with sims[0].lock, sims[1].lock:
                gaps.append(abs(sims[0].now - sims[1].now))
            time.sleep(0.005)
        assert max(gaps) <= 0.001 + 1e-9
        assert robot.joint("wrist_pitch").get_joint_state().position == pytest.approx(0.3, abs=0.05)
    deadline = time.monotonic() + 5.0
    while any(t.name == "drempower-twin" for t in threading.enumerate()) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert not any(t.name == "drempower-twin" for t in threading.enumerate())
    assert sims[0].on_activity is None and sims[1].on_activity is None


def test_the_motor_replaces_the_models_own_actuator_of_its_joint(tmp_path: Path) -> None:
    """A model from elsewhere often has position servos of its own: on a coupled joint only the motor acts."""
    import xml.etree.ElementTree as ET

    from .conftest import model_copy

    def servo(root: ET.Element) -> None:
        act = ET.SubElement(root, "actuator")
        ET.SubElement(act, "position", name="servo", joint="swing", kp="500")

    model = model_copy(tmp_path, "pendulum.xml", servo)
    path = robot_file(tmp_path, model, {"swing": {"id": 1, "friction": "model"}})
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        assert [twin.model.actuator(i).name for i in range(twin.model.nu)] == ["drempower:swing"]


def test_pushes_are_bounded_alone_and_together(tmp_path: Path) -> None:
    """The API holds the hand to the bounds the dashboard shows (PUSH_LIMITS): one push, and all the pushes
    acting on one body or joint together (300 pushes of 200 Nm no longer add up to 60000 Nm)."""
    from drempower.sim.twin import PUSH_LIMITS

    path = robot_file(tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1}})
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        with pytest.raises(ValidationError, match=r"force \(1e\+300, 0.0, 0.0\) N: beyond \+-1000 N"):
            twin.push(body="arm", force=(1e300, 0, 0))
        top = PUSH_LIMITS["torque"]
        twin.push_joint("swing", torque=top, duration=5.0)
        with pytest.raises(ValidationError, match=r"with the pushes acting on it: beyond \+-200 Nm"):
            twin.push_joint("swing", torque=top, duration=5.0)
        with pytest.raises(ValidationError, match="a push lasts at most 10 s"):
            twin.push_joint("swing", torque=1.0, duration=60.0)
        assert len(twin.pushes) == 1
        twin.push_joint("swing", torque=-top, duration=5.0)  # the other way: within the bound together
        assert len(twin.pushes) == 2


def test_a_model_with_nan_is_refused_naming_the_file_and_the_field(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from .conftest import model_copy

    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning about the NaN to MUJOCO_LOG.TXT here

    def nan_axis(root: Any) -> None:
        for j in root.iter("joint"):
            j.set("axis", "0 nan 0")

    model = model_copy(tmp_path, "pendulum.xml", nan_axis)
    path = robot_file(tmp_path, model, {"swing": {"id": 1}})
    with pytest.raises(ConfigError, match=r"jnt_axis \(joint 'swing'\) holds nan: expected finite numbers"):
        drempower.open_robot(path, sim={"clock": "virtual"})
