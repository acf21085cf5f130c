"""Teach mode on the twin arm: with gravity compensation it drifts less than 1 deg in 5 s at three poses;
without, it falls. The path taught comes back as a trajectory, and drempower teach records it. On a
virtual clock, teach mode on a thread keeps its rate while another thread lets time pass."""

from __future__ import annotations

import math
import threading
from pathlib import Path

import pytest

import drempower
from drempower.client.engine.effects import sleep
from drempower.motion import Trajectory
from drempower.motion.routines_sync import teach

from ..conftest import REPO_ROOT

pytest.importorskip("mujoco", reason="gravity compensation needs MuJoCo")

ARM = REPO_ROOT / "examples" / "robots" / "arm6.toml"
JOINTS = ("base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll")
POSES = ((0.0, 0.6, 0.9, 0.0, 0.5, 0.0), (0.8, -0.4, 1.2, 1.0, -0.6, 1.5), (0.3, 1.0, -0.8, 0.5, 0.3, 0.0))


def _drift(pose: tuple[float, ...], compensate: bool) -> list[float]:
    with drempower.open_robot(ARM, sim={"clock": "virtual"}) as robot:
        robot.move_joints(dict(zip(JOINTS, pose, strict=True)), speed=1.0, accel=3.0)
        robot.positions_done(timeout=20)
        robot.bus("arm").run(sleep(1.0))
        tr = teach(robot, 5.0, compensate=compensate)
    assert tr.duration == pytest.approx(5.0, abs=0.02)
    return [math.degrees(abs(a - b)) for a, b in zip(tr.positions[-1], tr.positions[0], strict=True)]


@pytest.mark.parametrize("pose", POSES)
def test_held_in_teach_mode_it_stays_and_without_compensation_it_falls(pose: tuple[float, ...]) -> None:
    held = _drift(pose, True)
    fell = _drift(pose, False)
    print(f"pose {pose}: drift with compensation {max(held):.3f} deg, without {max(fell):.1f} deg")
    assert max(held) < 1.0
    assert max(fell) > 10.0


def test_on_a_thread_it_keeps_its_rate_while_another_thread_lets_time_pass() -> None:
    """As the LeRobot leader runs it: teach mode on a thread of its own, the caller letting 2 s pass on the
    same virtual clock. Every cycle comes one period after the last (none is skipped while the other
    thread's wait lets time pass)."""
    with drempower.open_robot(ARM, sim={"clock": "virtual"}) as robot:
        first, stop = threading.Event(), threading.Event()
        got: list[Trajectory] = []

        def seen(t: float, positions: object) -> None:
            first.set()

        taught = threading.Thread(target=lambda: got.append(teach(robot, None, on_state=seen, stop=stop.is_set)))
        taught.start()
        try:
            assert first.wait(10)
            start = robot.bus("arm").now()
            robot.bus("arm").run(sleep(2.0))
            assert robot.bus("arm").now() - start >= 2.0
        finally:
            stop.set()
            taught.join(10)
    (path,) = got
    gaps = [b - a for a, b in zip(path.times, path.times[1:], strict=False)]
    assert path.duration >= 2.0
    assert max(gaps) == pytest.approx(0.01, abs=1e-6)  # 100 cycles per s, on time


def test_drempower_teach_records_the_path(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from drempower.cli import main

    robot = tmp_path / "arm.toml"
    robot.write_text(
        ARM.read_text()
        .replace('interface = "sim"', 'interface = "sim"\nclock = "virtual"')
        .replace('file = "arm6.xml"', f'file = "{ARM.parent / "arm6.xml"}"')
    )
    out = tmp_path / "path.csv"
    assert main(["teach", "--robot", str(robot), "--seconds", "1", "--record", str(out)]) == 0
    tr = Trajectory.load(out)
    assert tr.joints == JOINTS and tr.duration == pytest.approx(1.0, abs=0.05)
    assert "recorded" in capsys.readouterr().out


def test_model_feed_forward_in_impedance_mode() -> None:
    """Soft impedance (kp 10 Nm/rad) on the arm out of its upright pose: the model's gravity torques cut the
    tracking error, its full inverse dynamics cut it further."""
    worst = {}
    for ff in (None, "gravity", "inverse"):
        with drempower.open_robot(ARM, sim={"clock": "virtual"}) as robot:
            robot.move_joints(dict(zip(JOINTS, POSES[0], strict=True)), speed=1.0, accel=3.0)
            robot.positions_done(timeout=20)
            st = robot.joint_states()
            start = [st[j].position for j in JOINTS]
            goal = [s + d for s, d in zip(start, (0.5, 0.3, -0.4, 0.6, 0.4, -0.6), strict=True)]
            tr = Trajectory.from_waypoints([start, goal, start], max_speed=1.0, max_accel=3.0, joints=JOINTS)
            rep = robot.follow(tr, mode="impedance", kp=10.0, kd=0.5, feedforward=ff, start_tolerance=0.2)
        worst[ff] = max(rep.max_error.values())
    print("largest tracking error, rad: " + ", ".join(f"{k or 'none'} {v:.4f}" for k, v in worst.items()))
    assert worst["gravity"] < 0.6 * worst[None]
    assert worst["inverse"] < 0.5 * worst["gravity"]
