"""A robot file's joint means the same in every front end: the model's range is a limit of every
motion, and no program's end drops an arm (joints that hold are held when the robot closes)."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

import drempower
from drempower.errors import MotorIdleError, SoftLimitError
from drempower.sim.motor import AxisState

ARM6 = Path(__file__).resolve().parents[3] / "examples" / "robots" / "arm6.toml"


GAINS = (
    '"axis0.controller.config.pos_gain" = 20.0\n"axis0.controller.config.vel_gain" = 0.5\n'
    '"axis0.controller.config.vel_integrator_gain" = 5.0\n'
)
"""arm6.toml's gains of its shoulder and elbow, tuned for the arm's load."""


def _file(tmp_path: Path, elbow: str = "", shoulder: str = "", clock: str = "virtual") -> Path:
    """A two-joint copy of arm6.toml (the 2:1 shoulder and the elbow) with extra keys for each joint."""
    path = tmp_path / "arm.toml"
    path.write_text(
        f'[model]\nfile = "{(ARM6.parent / "arm6.xml").as_posix()}"\n'
        f'[buses.arm]\ninterface = "sim"\nclock = "{clock}"\nbitrate = 1000000\n'
        f'[joints.shoulder]\nbus = "arm"\nid = 2\ngear = 2.0\n{shoulder}\n'
        f"[joints.shoulder.sim_params]\n{GAINS}"
        f'[joints.elbow]\nbus = "arm"\nid = 3\n{elbow}\n'
        f"[joints.elbow.sim_params]\n{GAINS}"
    )
    return path


def test_the_model_range_limits_move_joints_sync_and_async(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    path = _file(tmp_path)
    with drempower.open_robot(path) as robot, pytest.raises(SoftLimitError, match="range of model joint 'elbow'"):
        robot.move_joints({"elbow": 3.0}, speed=1.0, accel=5.0, enable=True)

    async def run() -> None:
        async with drempower.open_robot_async(path) as robot:
            with pytest.raises(SoftLimitError, match="range of model joint 'elbow'"):
                await robot.move_joints({"elbow": -3.0}, speed=1.0, accel=5.0, enable=True)
            await robot.move_joints({"elbow": 2.0}, speed=1.0, accel=5.0, enable=True)  # inside: accepted

    asyncio.run(run())


def test_the_files_narrower_limit_wins_and_a_wider_one_is_narrowed_to_the_model(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    narrow = _file(tmp_path, elbow="limits = { position = [-1.0, 1.0] }", shoulder="limits = { speed = 2.0 }")
    with drempower.open_robot(narrow) as robot:
        assert robot.limits["elbow"]["position"] == (-1.0, 1.0)
        assert robot.limits["shoulder"]["position"] == (-2.0, 2.0)  # a file's speed limit keeps the model's range
        with pytest.raises(SoftLimitError, match=r"\[joints.elbow\] limits"):
            robot.move_joints({"elbow": 1.5}, speed=1.0, accel=5.0, enable=True)
    wide = tmp_path / "wide"
    wide.mkdir()
    with drempower.open_robot(_file(wide, elbow="limits = { position = [-9.0, 9.0] }")) as robot:
        assert robot.limits["elbow"]["position"] == (-2.5, 2.5)
        with pytest.raises(SoftLimitError, match="range of model joint 'elbow'"):
            robot.move_joints({"elbow": 3.0}, speed=1.0, accel=5.0, enable=True)


def test_the_files_limits_and_the_models_range_both_hold_each_naming_its_source(tmp_path: Path) -> None:
    """A file's max_step and the model's range come from two sources: the bus holds both (the second
    source once replaced the first), each refusal naming where its limit was set."""
    pytest.importorskip("mujoco")
    path = _file(tmp_path, elbow="limits = { max_step = 0.05, speed = 2.0 }")
    with drempower.open_robot(path) as robot:
        held = robot.bus("arm").limits(3)
        assert set(held) == {"max_step", "speed", "position"}
        assert "[joints.elbow] limits" in held["max_step"].where and "[joints.elbow] limits" in held["speed"].where
        assert held["position"].where == "the range of model joint 'elbow'"
        with pytest.raises(SoftLimitError, match=r"max_step .*\[joints.elbow\] limits"):
            robot.move_joints({"elbow": 0.5}, speed=1.0, accel=5.0, enable=True)
        with pytest.raises(SoftLimitError, match="range of model joint 'elbow'"):
            robot.move_joints({"elbow": 3.0}, speed=1.0, accel=5.0, enable=True)


def _closing_states(path: Path, how: str) -> dict[int, AxisState]:
    """Each motor's axis state after a program moved both joints and ended ``how``."""
    robot = drempower.open_robot(path)
    sim = robot.buses["arm"].transport.bus  # type: ignore[attr-defined]
    try:
        robot.move_joints({"shoulder": 0.3, "elbow": 0.3}, speed=1.0, accel=5.0, enable=True)
        robot.positions_done(timeout=30)
        if how == "exception":
            with robot:
                raise RuntimeError("the program failed")
    except RuntimeError:
        pass
    finally:
        robot.close()
    sim.advance(0.5)
    return {i: m.state for i, m in sim.motors.items()}


@pytest.mark.parametrize("how", ["close", "exception"])
def test_closing_a_robot_holds_its_joints_unless_the_file_says_idle(tmp_path: Path, how: str) -> None:
    pytest.importorskip("mujoco")
    states = _closing_states(_file(tmp_path, elbow='on_timeout = "idle"'), how)
    assert states[2] == AxisState.CLOSED_LOOP_CONTROL  # the shoulder holds: the arm is not dropped
    assert states[3] == AxisState.IDLE  # the elbow's file says idle


def test_a_bare_bus_still_idles_what_it_commanded() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        bus.set_angles([1], [10.0], 10.0, 10.0, enable=True)
        sim = bus.transport.bus  # type: ignore[attr-defined]
    sim.advance(0.5)
    assert sim.motors[1].state == AxisState.IDLE


@pytest.mark.parametrize("clock", ["virtual", "wall"])
def test_a_joint_idled_right_after_a_move_refuses_the_next_move_on_either_clock(tmp_path: Path, clock: str) -> None:
    """The state read of the safety gate must not overtake the idle request (a lower CAN id wins)."""
    pytest.importorskip("mujoco")
    path = _file(tmp_path, clock=clock)
    with drempower.open_robot(path) as robot:
        robot.move_joints({"elbow": 0.5}, speed=1.0, accel=5.0, enable=True)
        robot.joint("elbow").set_mode(1)
        with pytest.raises(MotorIdleError, match="motor 3 is idle"):
            robot.set_angles({"elbow": 0.0}, 10, 10)
        robot.set_angles({"elbow": 0.0}, 10, 10, enable=True)  # enabling again: accepted
