"""The twin's interfaces: the hand from outside, determinism, buses sharing one twin, the robot file's keys."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import drempower
from drempower.client.effects import sleep
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
