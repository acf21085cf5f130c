"""``lerobot-teleoperate`` with a DrEmpower leader arm driving a DrEmpower follower arm: both twins of the
example arm, each behind its own USB-CAN adapter pty, LeRobot in its own process (its plugin discovery
finds both types). A hand pushes the leader (it is in teach mode: gravity-compensated, no stiffness);
the follower ends where the leader is."""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest

pytest.importorskip("lerobot", reason="LeRobot is not installed here: make test-lerobot runs these")

from .conftest import JOINTS, TIMEOUT, Running, idle_on_timeout, lerobot_command, lerobot_env, served_arms

SECONDS = 6.0
"""The teleoperation's length (--teleop_time_s)."""
TOLERANCE = 0.5
"""deg: how far the follower may end from the leader, every joint."""
PUSHES = {"base_yaw": 1.0, "elbow": 1.0, "wrist_pitch": 0.3}
"""Nm on the leader's joints for 0.2 s, :data:`STEADY` s after teleoperation started."""
STEADY = 1.0
"""How long (s) teleoperation runs before the push: the leader's teach mode keeps its rate by then. Pushed
during a stall of the first iterations (some 0.3 s with no teach cycle, on a loaded machine) the elbow
swings to its end stop, past the range the follower accepts."""


@pytest.mark.timeout(240)
def test_the_leader_drives_the_follower(tmp_path: Path) -> None:
    with served_arms(tmp_path, ("leader", "follower")) as arms:
        leader, follower = arms["leader"], arms["follower"]
        run = Running(
            [
                lerobot_command("lerobot-teleoperate"),
                "--robot.type=drempower",
                f"--robot.timeout={TIMEOUT}",
                f"--robot.robot_file={follower.robot_file}",
                "--robot.id=follower",
                "--teleop.type=drempower_leader",
                f"--teleop.timeout={TIMEOUT}",
                f"--teleop.robot_file={leader.robot_file}",
                "--teleop.id=leader",
                "--fps=30",
                f"--teleop_time_s={SECONDS}",
            ],
            lerobot_env(tmp_path),
        )
        started = run.wait_for("Teleop loop time", 120)
        time.sleep(STEADY)  # the loop's first iterations (LeRobot's and the arms' first calls) can stall it
        start = leader.degrees()
        for joint, torque in PUSHES.items():
            leader.twin.push_joint(joint, torque=torque, duration=0.2)
        time.sleep(max(0.0, started + SECONDS - 1.0 - time.monotonic()))  # 1 s before the loop ends
        led, followed = leader.degrees(), follower.degrees()
        run.finish(120)
        led_after, followed_after = leader.degrees(), follower.degrees()
    moved = {j: led[j] - start[j] for j in JOINTS}
    error = {j: followed[j] - led[j] for j in JOINTS}
    print("leader moved (deg): " + ", ".join(f"{j} {moved[j]:+.2f}" for j in JOINTS))
    print("follower - leader (deg): " + ", ".join(f"{j} {error[j]:+.3f}" for j in JOINTS))
    assert all(abs(moved[j]) > 5.0 for j in PUSHES), moved  # the hand moved the leader
    assert max(abs(e) for e in error.values()) < TOLERANCE, error
    # disconnected, both arms are left in their safe state (on_timeout "hold": speed 0 in closed loop)
    drift = {
        arm: max(abs(after[j] - before[j]) for j in JOINTS)
        for arm, before, after in (("leader", led, led_after), ("follower", followed, followed_after))
    }
    print(
        "largest drift from 1 s before the end to after the exit (deg): "
        + ", ".join(f"{a} {d:.3f}" for a, d in drift.items())
    )
    assert max(drift.values()) < 3.0, drift


@pytest.mark.timeout(240)
def test_sigterm_leaves_both_arms_as_their_on_timeout_says(tmp_path: Path) -> None:
    """Stopped by SIGTERM (systemd, docker), LeRobot's process still disconnects both arms: their joints
    hold, and the one whose robot file says ``on_timeout = "idle"`` is released."""
    from drempower import open_robot

    with served_arms(tmp_path, ("leader", "follower")) as arms:
        for arm in arms.values():
            idle_on_timeout(arm.robot_file, "wrist_roll")
        run = Running(
            [
                lerobot_command("lerobot-teleoperate"),
                "--robot.type=drempower",
                f"--robot.timeout={TIMEOUT}",
                f"--robot.robot_file={arms['follower'].robot_file}",
                "--teleop.type=drempower_leader",
                f"--teleop.timeout={TIMEOUT}",
                f"--teleop.robot_file={arms['leader'].robot_file}",
                "--fps=30",
                "--teleop_time_s=60",
            ],
            lerobot_env(tmp_path),
        )
        run.wait_for("Teleop loop time", 120)
        time.sleep(1.0)
        run.proc.send_signal(signal.SIGTERM)
        run.finish(60, returncode=128 + signal.SIGTERM)
        states = {}
        for name, arm in arms.items():
            with open_robot(arm.robot_file, stop_on_close=False, timeout=TIMEOUT) as check:
                states[name] = {j: check.joint(j).read_property("axis0.current_state") for j in JOINTS}
    expected = {j: (1 if j == "wrist_roll" else 8) for j in JOINTS}  # 1 idle, 8 closed loop
    assert states == {"leader": expected, "follower": expected}
